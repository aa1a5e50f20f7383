"""client_record.py -- the recorder's calls of the Python client (client.Client has them): start,
stop, list, read, delete recordings, and download their files or exports to disk
(docs/recorder.md, docs/irpctl.md "record").

    c.record_start("run-7", ["SIG.sample", {"path": "SIG.wave[0]", "unit": "V"}], duration_s=60)
    c.record_download("run-7", "run-7.mcap")          # a .zip when it has several files
    c.record_export("run-7", "run-7.parquet", "parquet")
"""

from __future__ import annotations

import os
from pathlib import Path
from urllib.parse import quote


class RecordCalls:
    """Mixed into client.Client: uses its request, get and download."""

    def record_start(
        self,
        name: str,
        variables: list,
        decimation: int = 1,
        duration_s: float | None = None,
        max_bytes: int | None = None,
    ) -> dict:
        """Starts a recording of `variables` (paths, or {"path", "unit"}); the recording."""
        stop = {k: v for k, v in (("duration_s", duration_s), ("max_bytes", max_bytes)) if v is not None}
        body = {"name": name, "variables": variables, "decimation": decimation, "stop": stop}
        return self.request("POST", "/recordings", json=body, timeout=max(self.timeout, 30))

    def record_stop(self, name: str) -> dict:
        return self.request("POST", f"/recordings/{quote(name, safe='')}/stop", timeout=max(self.timeout, 30))

    def recordings(self) -> dict:
        """Every recording and capture, the quota and its use, the trace channels per owner."""
        return self.get("/recordings")

    def recording(self, name: str) -> dict:
        return self.get(f"/recordings/{quote(name, safe='')}")

    def record_delete(self, name: str) -> None:
        self.request("DELETE", f"/recordings/{quote(name, safe='')}")

    def record_download(self, name: str, target: str | os.PathLike | None = None, part: int | None = None) -> Path:
        """The recording's files to `target` (a file, or a folder for the name the agent gives);
        the file written: a .zip (`target` with that suffix) when the recording has several files."""
        params = {"part": part} if part is not None else None
        return self.download(f"/recordings/{quote(name, safe='')}/download", params, target, f"{name}.mcap")

    def record_export(self, name: str, target: str | os.PathLike | None = None, format: str = "csv") -> Path:
        """The recording's rows as CSV or Parquet to `target`; the file written."""
        params = {"format": format}
        return self.download(f"/recordings/{quote(name, safe='')}/export", params, target, f"{name}.{format}")

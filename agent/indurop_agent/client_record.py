"""client_record.py -- the recorder's calls of the Python client (client.Client has them): start,
stop, list, read, delete recordings, and download their files or exports to disk
(docs/recorder.md, docs/irpctl.md "record").

    c.record_start("run-7", ["SIG.sample", {"path": "SIG.wave[0]", "unit": "V"}], duration_s=60)
    c.record_download("run-7", "run-7.mcap")          # a .zip when it has several files
    c.record_export("run-7", "run-7.parquet", "parquet")
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from urllib.parse import quote

import httpx

LONG_TIMEOUT_S = 600.0  # an export of a long recording is made while it is sent


class RecordCalls:
    """Mixed into client.Client: uses its request, get, url and _http."""

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
        return self._save(f"/recordings/{quote(name, safe='')}/download", params, target, f"{name}.mcap")

    def record_export(self, name: str, target: str | os.PathLike | None = None, format: str = "csv") -> Path:
        """The recording's rows as CSV or Parquet to `target`; the file written."""
        params = {"format": format}
        return self._save(f"/recordings/{quote(name, safe='')}/export", params, target, f"{name}.{format}")

    def _save(self, path: str, params, target, default: str) -> Path:
        from .client import ApiError, _detail  # client.py imports this module

        try:
            with self._http.stream("GET", path, params=params, timeout=httpx.Timeout(LONG_TIMEOUT_S)) as r:
                if r.status_code >= 400:
                    r.read()
                    raise ApiError(r.status_code, _detail(r))
                named = re.search(r'filename="?([^";]+)"?', r.headers.get("content-disposition", ""))
                name = os.path.basename(named.group(1)) if named else default
                out = Path(target) if target is not None else Path(name)
                if out.is_dir():
                    out = out / name
                elif Path(name).suffix != out.suffix and Path(name).suffix == ".zip":
                    out = out.with_suffix(".zip")  # several files came: not an .mcap, whatever it was to be called
                partial = out.with_name(out.name + ".part")
                with open(partial, "wb") as f:
                    for chunk in r.iter_bytes(1 << 20):
                        f.write(chunk)
                os.replace(partial, out)
                return out
        except httpx.HTTPError as e:
            raise ApiError(0, f"the download from {self.url} broke: {e}") from e

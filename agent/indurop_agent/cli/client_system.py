"""client_system.py -- the System page's calls of the Python client (client.Client has them): the
figures, restarts, logs (read and followed), backup download and restore, the TLS certificate's
upload, and the set store's prune.  docs/administration.md says what each does."""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from pathlib import Path

import httpx

from .client_errors import ApiError, detail

# A restore or a backup of a large store, or irpd's restart, takes longer than one ordinary call.
LONG_TIMEOUT_S = 600.0  # a backup, a restore, an export of a long recording: made while sent


class SystemCalls:
    """Mixed into client.Client: uses its request, get, url, timeout and _http."""

    def system(self) -> dict:
        """Versions, uptimes, the data folder's disk use, the TLS certificate, the log sources."""
        return self.get("/system")

    def restart(self, what: str) -> dict:
        """Restarts "irpd" (onto the active set, safe outputs first; answers once it runs again) or
        "agent" (answers 202 at once; the agent is back a few seconds later)."""
        if what not in ("irpd", "agent"):
            raise ValueError(f"restart what? irpd or agent, not {what!r}")
        return self.request("POST", f"/system/restart/{what}", timeout=max(self.timeout, 120))

    def logs(self, log: str, lines: int = 200, grep: str | None = None, since: str | None = None) -> dict:
        """The last `lines` lines of irpd's or the agent's log that hold `grep` (any case), from
        `since` (ISO 8601) on: {"log", "source", "lines": [{"time", "message", ...}], "truncated"}."""
        return self.get(f"/system/logs/{log}", lines=lines, grep=grep, since=since)

    def follow_logs(
        self, log: str, lines: int = 50, grep: str | None = None, since: str | None = None
    ) -> Iterator[dict]:
        """The log live: the last `lines` matching lines, then each new one, until the caller stops."""
        params = {k: v for k, v in (("lines", lines), ("grep", grep), ("since", since)) if v is not None}
        try:
            with self._http.stream(
                "GET", f"/system/logs/{log}/follow", params=params, timeout=httpx.Timeout(self.timeout, read=None)
            ) as r:
                if r.status_code >= 400:
                    r.read()
                    raise ApiError(r.status_code, detail(r))
                for raw in r.iter_lines():
                    if raw.strip():
                        yield json.loads(raw)
        except httpx.HTTPError as e:
            raise ApiError(0, f"the log stream from {self.url} broke: {e}") from e

    def backup(self, target: str | os.PathLike | None = None, with_secrets: bool = False) -> Path:
        """Downloads a backup to `target` (a file, or a folder for the name the agent gives; default
        the current folder); returns the file written."""
        params = {"with_secrets": "true"} if with_secrets else None
        return self.download("/system/backup", params, target, "indurop-backup.tar.gz", "backup download")

    def restore(self, archive: str | os.PathLike, dry_run: bool = False) -> dict:
        """Sends a backup: with dry_run what it would replace; else it is staged and the agent
        restarts to apply it.  The plan (sets added, active set, tokens, users, files, warnings)."""
        size = os.path.getsize(archive)
        with open(archive, "rb") as f:
            return self.request(
                "POST",
                "/system/restore",
                params={"dry_run": "true" if dry_run else "false"},
                content=f,
                headers={"Content-Type": "application/gzip", "Content-Length": str(size)},
                timeout=LONG_TIMEOUT_S,
            )

    def upload_tls(self, certificate: str | os.PathLike, key: str | os.PathLike) -> dict:
        """Replaces the agent's TLS certificate and key (PEM files) after checking them."""
        body = {"certificate": Path(certificate).read_text(), "key": Path(key).read_text()}
        return self.request("POST", "/system/tls", json=body)

    def prune_sets(self, keep_last: int, dry_run: bool = False) -> dict:
        """Deletes the sets that are not active, not the rollback target and not among the newest
        `keep_last`, and the files only they used; dry_run says what would go."""
        return self.request(
            "POST", "/sets/prune", json={"keep_last": keep_last, "dry_run": dry_run}, timeout=max(self.timeout, 120)
        )

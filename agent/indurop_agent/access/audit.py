"""audit.py -- the audit log, <data-dir>/audit.jsonl: one JSON object per line for every mutation
(and every refused one), appended with O_APPEND and fsync'ed before the answer goes out.

A line: {"time", "who": {"id", "name", "role"}, "client", "action", "target", "result": "ok" |
"error", "status" (the HTTP status), "detail" (what went wrong), plus what the action adds, e.g.
"files": {path: sha256} for an upload}.  Everything a client sent is stored as JSON data, never
put into a format string or a log line unescaped.
"""

from __future__ import annotations

import json
import os
import threading
from collections import deque
from pathlib import Path

from .auth import now_iso

ACTIONS = (
    "upload",
    "activate",
    "rollback",
    "restore",
    "patch_module",
    "write_variable",
    "robot_joints",
    "program_edit",
    "token_create",
    "token_revoke",
    "lockout",
    "sign_in",
    "sign_out",
    "user_add",
    "user_change",
    "user_password",
    "alarm_ack",
    "alarm_ack_all",
    "alarm_shelve",
    "alarm_unshelve",
    # the System page (docs/administration.md)
    "irpd_restart",
    "agent_restart",
    "backup",
    "restore_backup",
    "restore_applied",
    "tls_upload",
    "sets_prune",
    # refused requests that are no mutation's own (refusals.py: rate-limited)
    "refused",
    "refusals_suppressed",
)


class AuditLog:
    def __init__(self, path: Path):
        self.path = path
        self._lock = threading.Lock()

    def write(
        self, action: str, *, who: dict | None, client: str | None, target: str | None, result: str = "ok", **extra
    ) -> dict:
        """Appends one line and returns it.  `extra` holds JSON-able details (status, detail, hashes)."""
        entry = {
            "time": now_iso(),
            "who": who,
            "client": client,
            "action": action,
            "target": target,
            "result": result,
            **extra,
        }
        line = (json.dumps(entry, ensure_ascii=True, default=str) + "\n").encode()
        with self._lock:
            fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o600)
            try:
                os.write(fd, line)
                os.fsync(fd)
            finally:
                os.close(fd)
        return entry

    def tail(self, limit: int) -> list[dict]:
        """The last `limit` entries, oldest first (a line that does not parse is shown as such)."""
        if limit <= 0 or not self.path.exists():
            return []
        with open(self.path, "rb") as f:
            lines = deque(f, maxlen=limit)
        out = []
        for raw in lines:
            try:
                out.append(json.loads(raw))
            except ValueError:
                out.append({"result": "unreadable", "line": raw.decode("utf-8", "replace")})
        return out

"""info.py -- the figures of GET /system: the agent's and irpd's versions and uptimes, the data
folder's disk use (each file counted once: a set's tree shares its inodes with the blobs) and
the free space of its file system, the TLS certificate served."""

from __future__ import annotations

import os
import platform
import shutil
import time
from pathlib import Path

from .. import __version__
from ..access.auth import now_iso
from ..irpd.client import IrpdClient, IrpdRefused, IrpdUnavailable
from . import tls
from .logs import sources

STARTED_WALL = now_iso()
STARTED_MONOTONIC = time.monotonic()
STATUS_TIMEOUT_S = 1.0
MAX_FILES_WALKED = 500_000  # a data folder with more is reported as counted so far


def disk_use(data_dir: Path) -> dict:
    """Bytes the data folder takes on disk (allocated blocks, each inode once), by top-level entry,
    and its file system's size and free space."""
    seen: set[tuple[int, int]] = set()
    parts: dict[str, int] = {}
    walked = 0
    complete = True

    def size_of(path: str) -> int:
        nonlocal walked, complete
        total = 0
        stack = [path]
        while stack:
            current = stack.pop()
            try:
                st = os.lstat(current)
            except OSError:
                continue
            walked += 1
            if walked > MAX_FILES_WALKED:
                complete = False
                return total
            key = (st.st_dev, st.st_ino)
            if key not in seen:
                seen.add(key)
                total += st.st_blocks * 512
            if os.path.isdir(current) and not os.path.islink(current):
                try:
                    stack.extend(e.path for e in os.scandir(current))
                except OSError:
                    pass
        return total

    try:
        entries = sorted(os.scandir(data_dir), key=lambda e: e.name)
    except OSError:
        entries = []
    # the blobs first, so that the sets' hard links to them are counted under blobs
    for e in sorted(entries, key=lambda e: e.name != "blobs"):
        parts[e.name] = size_of(e.path)
    usage = shutil.disk_usage(data_dir)
    return {
        "path": str(data_dir),
        "used_bytes": sum(parts.values()),
        "parts": [{"name": name, "bytes": parts[name]} for name in sorted(parts, key=lambda n: -parts[n])],
        "complete": complete,
        "filesystem_bytes": usage.total,
        "free_bytes": usage.free,
    }


def irpd_info(irpd: IrpdClient) -> dict:
    try:
        status = irpd.request("status", timeout=STATUS_TIMEOUT_S) or {}
    except (IrpdUnavailable, IrpdRefused) as e:
        return {"reachable": False, "detail": str(e), "version": None, "pid": None, "uptime_s": None, "set_id": None}
    return {
        "reachable": True,
        "detail": None,
        "version": (irpd.hello or {}).get("irpd"),
        "protocol": (irpd.hello or {}).get("version"),
        "pid": status.get("pid"),
        "uptime_s": (status.get("uptime_ns") or 0) / 1e9,
        "set_id": status.get("set_id"),
        "running": status.get("running"),
    }


def tls_info(settings) -> dict | None:
    """The certificate the agent serves (None on plain HTTP); an unreadable one says why."""
    if settings.tls_cert is None:
        return None
    try:
        described = tls.describe(tls.read_certificate(settings.tls_cert))
    except tls.CertificateError as e:
        return {"path": str(settings.tls_cert), "error": str(e)}
    return {"path": str(settings.tls_cert), "error": None, **described}


def gather(state) -> dict:
    """Everything GET /system answers (models.SystemInfo)."""
    settings = state.settings
    logs = sources(settings)
    return {
        "agent": {
            "version": __version__,
            "pid": os.getpid(),
            "started": STARTED_WALL,
            "uptime_s": time.monotonic() - STARTED_MONOTONIC,
            "python": platform.python_version(),
            "supervisor": state.agent_restart.supervisor,
            "scheme": "https" if settings.tls_cert else "http",
            "host": settings.host,
            "port": settings.port,
        },
        "irpd": irpd_info(state.irpd),
        "data": disk_use(settings.data_dir),
        "tls": tls_info(settings),
        "logs": {name: (source.describe() if source else None) for name, source in logs.items()},
        "restore_pending": (settings.data_dir / "restore-pending").is_dir(),
    }

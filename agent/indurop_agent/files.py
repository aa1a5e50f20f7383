"""files.py -- how the agent writes its own files in the data folder (tokens, users, sessions, the
active set, a set's manifest, the TLS pair): a temporary file beside the target with the final
mode, written and fsync'ed, renamed over the target, and the folder fsync'ed, so that a crash
leaves the old file or the new one, never half of either."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path


def fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_atomically(path: Path, data: bytes | str, mode: int = 0o600) -> None:
    """Replaces `path` with `data` (text is written as UTF-8), its mode `mode`."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")  # mode 0600 until fchmod
    try:
        os.fchmod(fd, mode)
        with os.fdopen(fd, "wb") as f:
            f.write(data.encode() if isinstance(data, str) else data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    fsync_dir(path.parent)


def write_json(path: Path, value, mode: int = 0o600) -> None:
    """Replaces `path` with `value` as indented JSON."""
    write_atomically(path, json.dumps(value, indent=1), mode)

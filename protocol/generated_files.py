"""generated_files.py -- what every generator of protocol/ does with the files it makes: writes the
ones that changed, or with --check writes nothing and names the stale ones with the command that
regenerates them.  Used by protocol/generate.py, protocol/shm/generate.py and
protocol/stream/generate.py."""

from __future__ import annotations

import sys
from pathlib import Path


def stale(files: dict[Path, str]) -> list[Path]:
    """The files (absolute paths) whose text on disk is not `files[path]`, or that do not exist."""
    return [p for p, text in files.items() if not p.exists() or p.read_text() != text]


def write_or_check(files: dict[Path, str], check: bool, command: str, root: Path) -> int:
    """With `check`: prints each stale file with `command` and returns 1 if any is stale, else 0.
    Without: writes the stale ones (making their folders) and returns 0."""
    changed = stale(files)
    if check:
        for p in changed:
            print(f"{p.relative_to(root)} is stale: run `{command}`", file=sys.stderr)
        return 1 if changed else 0
    for p in changed:
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(files[p])
        print(f"wrote {p.relative_to(root)}")
    return 0

"""variables.py -- read-only access to irpd's shared-variable segment (<indurop/segment.h>).

The agent maps /dev/shm/<name> read-only and takes the layout from the segment itself.  A value
is read as libindurop reads it: the sequence of its variable's lock before and after the copy,
retried while a writer is inside (odd) or came between; the agent never takes a lock, so it can
never make an RT writer wait.

An online change publishes a new layout into the same segment (docs/shared-variables.md, "Layouts
that evolve"): every read first compares the header's layout_seq with the one the layout was
taken at, and takes the new one (hash, text) consistently when it moved.  A segment replaced by a
restarted irpd is a new file: `replaced()` tells, and the caller maps the new one.
"""

from __future__ import annotations

import json
import os
import struct
from pathlib import Path

from .shm_layout import LayoutError, segment

# Every offset from irpd's description of the segment (shm_layout.py).
LAYOUT = segment("variables")
HEADER = LAYOUT.header
LOCK = LAYOUT.struct("indurop_var_lock")
HASH_CHARS = LAYOUT.constant("layout_hash_chars")
LAYOUT_HASH = HEADER.offset("layout_hash")
# (struct format, offset) of the fields read on every refresh and every value read.
LAYOUT_SEQ = HEADER.format("layout_seq"), HEADER.offset("layout_seq")
LAYOUT_OFFSET = HEADER.format("layout_offset"), HEADER.offset("layout_offset")
LAYOUT_SIZE = HEADER.format("layout_size"), HEADER.offset("layout_size")
LOCK_SEQ = LOCK.format("seq"), LOCK.offset("seq")
FORMATS = {
    ("float", 4): "<f",
    ("float", 8): "<d",
    ("signed", 1): "<b",
    ("signed", 2): "<h",
    ("signed", 4): "<i",
    ("signed", 8): "<q",
    ("unsigned", 1): "<B",
    ("unsigned", 2): "<H",
    ("unsigned", 4): "<I",
    ("unsigned", 8): "<Q",
    ("bool", 1): "<?",
    ("char", 1): "<b",
}


class VariableError(Exception):
    """A path that is not a leaf of the layout, or a segment that is not there."""


class Segment:
    def __init__(self, name: str):
        self.path = Path("/dev/shm") / name.lstrip("/")
        try:
            self.mm, self.inode = LAYOUT.open(name)
        except LayoutError as e:
            raise VariableError(str(e)) from e
        self.locks = HEADER.read(self.mm, "locks_offset")
        self.lock_size = HEADER.read(self.mm, "lock_size")
        self.data = HEADER.read(self.mm, "data_offset")
        self.seq = None
        self.refresh()

    def refresh(self) -> bool:
        """Takes the layout published last, if it is not the one held; True when it changed."""
        seq = self._field(LAYOUT_SEQ)
        if seq == self.seq:
            return False
        for _ in range(100000):
            seq = self._field(LAYOUT_SEQ)
            if seq & 1:
                continue
            layout_offset, layout_size = self._field(LAYOUT_OFFSET), self._field(LAYOUT_SIZE)
            hash_ = self.mm[LAYOUT_HASH : LAYOUT_HASH + HASH_CHARS]
            text = self.mm[layout_offset : layout_offset + layout_size]
            if self._field(LAYOUT_SEQ) == seq:
                break
        else:
            raise VariableError("the shared-variable layout is being published continuously; try again")
        self.hash, self.text = hash_.decode(), bytes(text)
        self.layout = json.loads(self.text)
        self.leaves = {leaf["path"]: leaf for leaf in self.layout["leaves"]}
        self.scalars = self.layout.get("scalars", {})
        self.seq = seq
        return True

    def _field(self, where: tuple[str, int], base: int = 0) -> int:
        return struct.unpack_from(where[0], self.mm, base + where[1])[0]

    def replaced(self) -> bool:
        """Whether /dev/shm holds another segment under this name now (irpd restarted)."""
        try:
            return os.stat(self.path).st_ino != self.inode
        except OSError:
            return True

    def close(self) -> None:
        self.mm.close()

    def read(self, path: str):
        self.refresh()
        leaf = self.leaves.get(path)
        if leaf is None:
            raise VariableError(f"no variable '{path}' in layout {self.hash[:12]}…; GET /api/v1/variables lists them")
        kind = self.scalars.get(leaf["type"], {}).get("kind", "unsigned")
        fmt = FORMATS.get((kind, leaf["size"]))
        if fmt is None:
            raise VariableError(f"'{path}' is a {leaf['type']}, which the agent cannot decode")
        lock = self.locks + leaf["lock"] * self.lock_size
        at = self.data + leaf["offset"]
        for _ in range(10000):
            before = self._field(LOCK_SEQ, lock)
            if before & 1:
                continue
            raw = self.mm[at : at + leaf["size"]]
            after = self._field(LOCK_SEQ, lock)
            if after == before:
                return struct.unpack(fmt, raw)[0]
        raise VariableError(f"'{path}' is being written continuously; try again")

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
import mmap
import os
import struct
from pathlib import Path

MAGIC = 0x3153524156505249  # "IRPVARS1"
# Offsets of the header fields, pinned by static_asserts in segment.h and shared.h.
LAYOUT_HASH, LOCKS_OFFSET, LOCK_SIZE, LAYOUT_OFFSET, LAYOUT_SIZE, DATA_OFFSET = 16, 96, 108, 112, 120, 128
LAYOUT_SEQ = 152
SEQ_IN_LOCK = 40
FORMATS = {("float", 4): "<f", ("float", 8): "<d", ("signed", 1): "<b", ("signed", 2): "<h", ("signed", 4): "<i",
           ("signed", 8): "<q", ("unsigned", 1): "<B", ("unsigned", 2): "<H", ("unsigned", 4): "<I",
           ("unsigned", 8): "<Q", ("bool", 1): "<?", ("char", 1): "<b"}


class VariableError(Exception):
    """A path that is not a leaf of the layout, or a segment that is not there."""


class Segment:
    def __init__(self, name: str):
        path = Path("/dev/shm") / name.lstrip("/")
        self.path = path
        try:
            with open(path, "rb") as f:
                self.inode = os.fstat(f.fileno()).st_ino
                self.mm = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
        except OSError as e:
            raise VariableError(f"shared variables {name}: {e}") from e
        if struct.unpack_from("<Q", self.mm, 0)[0] != MAGIC:
            raise VariableError(f"{name} is not an indurop variable segment")
        self.locks, = struct.unpack_from("<Q", self.mm, LOCKS_OFFSET)
        self.lock_size, = struct.unpack_from("<I", self.mm, LOCK_SIZE)
        self.data, = struct.unpack_from("<Q", self.mm, DATA_OFFSET)
        self.seq = None
        self.refresh()

    def refresh(self) -> bool:
        """Takes the layout published last, if it is not the one held; True when it changed."""
        seq, = struct.unpack_from("<I", self.mm, LAYOUT_SEQ)
        if seq == self.seq:
            return False
        for _ in range(100000):
            seq, = struct.unpack_from("<I", self.mm, LAYOUT_SEQ)
            if seq & 1:
                continue
            layout_offset, layout_size = struct.unpack_from("<QQ", self.mm, LAYOUT_OFFSET)
            hash_ = self.mm[LAYOUT_HASH:LAYOUT_HASH + 64]
            text = self.mm[layout_offset:layout_offset + layout_size]
            if struct.unpack_from("<I", self.mm, LAYOUT_SEQ)[0] == seq:
                break
        else:
            raise VariableError("the shared-variable layout is being published continuously; try again")
        self.hash, self.text = hash_.decode(), bytes(text)
        self.layout = json.loads(self.text)
        self.leaves = {leaf["path"]: leaf for leaf in self.layout["leaves"]}
        self.scalars = self.layout.get("scalars", {})
        self.seq = seq
        return True

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
            raise VariableError(f"no variable '{path}' in layout {self.hash[:12]}…; "
                                f"GET /api/v1/variables lists them")
        kind = self.scalars.get(leaf["type"], {}).get("kind", "unsigned")
        fmt = FORMATS.get((kind, leaf["size"]))
        if fmt is None:
            raise VariableError(f"'{path}' is a {leaf['type']}, which the agent cannot decode")
        seq_at = self.locks + leaf["lock"] * self.lock_size + SEQ_IN_LOCK
        at = self.data + leaf["offset"]
        for _ in range(10000):
            before, = struct.unpack_from("<I", self.mm, seq_at)
            if before & 1:
                continue
            raw = self.mm[at:at + leaf["size"]]
            after, = struct.unpack_from("<I", self.mm, seq_at)
            if after == before:
                return struct.unpack(fmt, raw)[0]
        raise VariableError(f"'{path}' is being written continuously; try again")

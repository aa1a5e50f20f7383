"""variables.py -- read-only access to irpd's shared-variable segment (<indurop/segment.h>).

The agent maps /dev/shm/<name> read-only and takes the layout from the segment itself.  A value
is read as libindurop reads it: the sequence of its variable's lock before and after the copy,
retried while a writer is inside (odd) or came between; the agent never takes a lock, so it can
never make an RT writer wait.
"""
from __future__ import annotations

import json
import mmap
import struct
from pathlib import Path

MAGIC = 0x3153524156505249  # "IRPVARS1"
# Offsets of the header fields, pinned by static_asserts in segment.h and shared.h.
LAYOUT_HASH, LOCKS_OFFSET, LOCK_SIZE, LAYOUT_OFFSET, LAYOUT_SIZE, DATA_OFFSET = 16, 96, 108, 112, 120, 128
SEQ_IN_LOCK = 40
FORMATS = {("float", 4): "<f", ("float", 8): "<d", ("signed", 1): "<b", ("signed", 2): "<h", ("signed", 4): "<i",
           ("signed", 8): "<q", ("unsigned", 1): "<B", ("unsigned", 2): "<H", ("unsigned", 4): "<I",
           ("unsigned", 8): "<Q", ("bool", 1): "<?", ("char", 1): "<b"}


class VariableError(Exception):
    """A path that is not a leaf of the layout, or a segment that is not there."""


class Segment:
    def __init__(self, name: str):
        path = Path("/dev/shm") / name.lstrip("/")
        try:
            with open(path, "rb") as f:
                self.mm = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
        except OSError as e:
            raise VariableError(f"shared variables {name}: {e}") from e
        if struct.unpack_from("<Q", self.mm, 0)[0] != MAGIC:
            raise VariableError(f"{name} is not an indurop variable segment")
        self.hash = self.mm[LAYOUT_HASH:LAYOUT_HASH + 64].decode()
        self.locks, = struct.unpack_from("<Q", self.mm, LOCKS_OFFSET)
        self.lock_size, = struct.unpack_from("<I", self.mm, LOCK_SIZE)
        layout_offset, layout_size, self.data = struct.unpack_from("<QQQ", self.mm, LAYOUT_OFFSET)
        self.layout = json.loads(self.mm[layout_offset:layout_offset + layout_size])
        self.leaves = {leaf["path"]: leaf for leaf in self.layout["leaves"]}
        self.scalars = self.layout.get("scalars", {})

    def close(self) -> None:
        self.mm.close()

    def read(self, path: str):
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

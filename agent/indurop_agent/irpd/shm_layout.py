"""shm_layout.py -- the layouts of irpd's shared-memory segments, as irpd describes them.

irpd describes every struct it lays out in shared memory field by field: offset, size, type and
meaning, taken from the compiler (`irpd --print-shm-layout`, docs/shared-memory.md).
shm_layout.json next to this file is that description; a test fails when it is stale and names
`ninja -C build shm-layout`, which rewrites it.  The agent's readers (variables.py, trace.py) take
every offset, size and constant from here and write none down.

Every segment opens the same way: magic (u64), version (u32), header_size (u32).
`SegmentLayout.open` maps one read-only and checks all three against the description; `Mapped`
holds such a mapping for the readers of segments that writers change under them (trace, alarms).
"""

from __future__ import annotations

import json
import mmap
import os
import struct
from functools import cache
from pathlib import Path

DESCRIPTION = Path(__file__).with_name("shm_layout.json")
FORMAT = 1  # the description's own format that this module reads
SCALARS = {
    "u8": "B",
    "u16": "H",
    "u32": "I",
    "u64": "Q",
    "i8": "b",
    "i16": "h",
    "i32": "i",
    "i64": "q",
    "f32": "f",
    "f64": "d",
}


class LayoutError(Exception):
    """A segment that is not there, or not the segment the description describes."""


class StructLayout:
    """One struct: its size and its fields ({"offset", "size", "type", ["count"], "meaning"})."""

    def __init__(self, name: str, entry: dict):
        self.name = name
        self.size: int = entry["size"]
        self.fields: dict[str, dict] = entry["fields"]
        self._read: dict[str, tuple[struct.Struct, int, bool]] = {}  # field -> (format, offset, is an array)

    def field(self, name: str) -> dict:
        try:
            return self.fields[name]
        except KeyError:
            raise LayoutError(
                f"{self.name} has no field '{name}' in {DESCRIPTION}; it lists {', '.join(self.fields)}"
            ) from None

    def offset(self, name: str) -> int:
        return self.field(name)["offset"]

    def format(self, name: str) -> str:
        """The struct format of a scalar field ("<Q"), or of a whole array of scalars ("<64Q")."""
        f = self.field(name)
        code = SCALARS.get(f["type"])
        if code is None:
            raise LayoutError(f"{self.name}.{name} is a {f['type']}, not a number")
        return f"<{f['count']}{code}" if "count" in f else f"<{code}"

    def read(self, buf, name: str, base: int = 0):
        """A scalar field (or an array of scalars, as a tuple) of the struct that starts at `base` in `buf`."""
        how = self._read.get(name)
        if how is None:
            how = self._read[name] = struct.Struct(self.format(name)), self.offset(name), "count" in self.field(name)
        values = how[0].unpack_from(buf, base + how[1])
        return values if how[2] else values[0]

    def text(self, buf, name: str, base: int = 0) -> str:
        """A char[] field, up to its first NUL."""
        f = self.field(name)
        at = base + f["offset"]
        return bytes(buf[at : at + f["size"]]).split(b"\0", 1)[0].decode("utf-8", "replace")


class SegmentLayout:
    """One segment: its magic and version, its structs, constants and enums."""

    def __init__(self, name: str, entry: dict):
        self.name = name
        self.entry = entry
        self.magic: int = entry["magic"]
        self.magic_text: str = entry["magic_text"]
        self.version: int = entry["version"]
        self.structs = {n: StructLayout(n, s) for n, s in entry["structs"].items()}
        self.header = self.structs[entry["header"]]

    def struct(self, name: str) -> StructLayout:
        try:
            return self.structs[name]
        except KeyError:
            raise LayoutError(f"the {self.name} segment has no struct '{name}' in {DESCRIPTION}") from None

    def constant(self, name: str) -> int:
        return self.entry["constants"][name]["value"]

    def enum(self, name: str) -> dict[str, int]:
        """{value's name: number}."""
        return {k: v["value"] for k, v in self.entry["enums"][name]["values"].items()}

    def shm_name(self, instance: str) -> str:
        return self.entry["shm"].replace("<instance>", instance)

    def open(self, name: str) -> tuple[mmap.mmap, int]:
        """Maps /dev/shm/<name> read-only and checks that it is this segment, in this version;
        returns the mapping and the file's inode (a restarted irpd makes a new file)."""
        path = Path("/dev/shm") / name.lstrip("/")
        try:
            with open(path, "rb") as f:
                inode = os.fstat(f.fileno()).st_ino
                mm = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
        except (OSError, ValueError) as e:
            raise LayoutError(f"{self.name} segment {name}: {e}") from e
        try:
            self.check(mm, name)
        except LayoutError:
            mm.close()
            raise
        return mm, inode

    def check(self, buf, name: str) -> None:
        """Raises LayoutError unless `buf` starts with this segment's magic, version and header size."""
        h = self.header
        if len(buf) < h.size or h.read(buf, "magic") != self.magic:
            raise LayoutError(f"{name} is not an indurop {self.name} segment (no {self.magic_text} at its start)")
        version = h.read(buf, "version")
        if version != self.version:
            raise LayoutError(
                f"{name} is {self.name} segment version {version}; this agent reads version "
                f"{self.version}: run the agent that came with this irpd"
            )
        size = h.read(buf, "header_size")
        if size != h.size:
            raise LayoutError(
                f"{name} has a {size}-byte {h.name}; this agent's description ({DESCRIPTION.name}) "
                f"says {h.size}: run the agent that came with this irpd"
            )


@cache
def description(path: Path = DESCRIPTION) -> dict:
    try:
        d = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise LayoutError(f"the shared-memory description {path}: {e}; `ninja -C build shm-layout` rewrites it") from e
    if d.get("format") != FORMAT or d.get("byte_order") != "little":
        raise LayoutError(
            f"{path} is description format {d.get('format')!r} ({d.get('byte_order')}-endian); "
            f"this agent reads format {FORMAT}, little-endian"
        )
    return d


def segment(name: str, path: Path = DESCRIPTION) -> SegmentLayout:
    """ "variables", "stats", "trace" or "control"."""
    segments = description(path)["segments"]
    if name not in segments:
        raise LayoutError(f"no segment '{name}' in {path}; it describes {', '.join(segments)}")
    return SegmentLayout(name, segments[name])


class Mapped:
    """A segment mapped read-only: the words its writers change, read as one aligned 8-byte load
    each (memoryview item access copies the whole word at once, unlike struct's '<Q', which goes
    byte by byte), and whether /dev/shm still holds it (a restarted irpd makes a new file)."""

    def __init__(self, layout: SegmentLayout, name: str):
        self.name = name
        self.path = Path("/dev/shm") / name.lstrip("/")
        self.mm, self.inode = layout.open(name)
        self._u64 = memoryview(self.mm).cast("Q")

    def close(self) -> None:
        self._u64.release()
        self.mm.close()

    def _word(self, offset: int) -> int:
        return self._u64[offset // 8]

    def replaced(self) -> bool:
        """True when /dev/shm no longer holds this segment (irpd stopped or restarted)."""
        try:
            return os.stat(self.path).st_ino != self.inode
        except OSError:
            return True

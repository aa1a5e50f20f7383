"""variables.py -- read-only access to irpd's shared-variable segment (<indurop/segment.h>).

The agent maps /dev/shm/<name> read-only and takes the layout from the segment itself.  A value
is read as libindurop reads it: the sequence of its variable's lock before and after the copy,
retried while a writer is inside (odd) or came between; the agent never takes a lock, so it can
never make an RT writer wait.  A group's path (a namespace, a struct, an array or one of its
elements) names every leaf under it (`select`); the leaves of one variable are copied together,
so that they come from one write (`values`).

An online change publishes a new layout into the same segment (docs/shared-variables.md, "Layouts
that evolve"): every read first compares the header's layout_seq with the one the layout was
taken at, and takes the new one (hash, text) consistently when it moved.  A segment replaced by a
restarted irpd is a new file: `replaced()` tells, and the caller maps the new one.
"""

from __future__ import annotations

import difflib
import json
import os
import struct
import time
from collections import OrderedDict
from pathlib import Path

from .read_plan import Plan, compile_plan
from .shm_layout import LayoutError, segment

# A variable's copy: tries without a pause, then tried between sleeps for up to COPY_WAIT_S (_copy).
COPY_SPINS = 1000
COPY_WAIT_S = 1.0

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
PLANS_KEPT = 64  # read plans kept for the layout held (one per list of paths read: a watch list, an editor's view)


# The scalar kinds irpd's trace rings sample (rtcore/src/trace/trace_rings.cpp: traceType): a char
# is read as a number from the segment but not traced.
TRACED_KINDS = ("signed", "unsigned", "float", "bool")


def number_problem(path: str, leaves: dict, scalars: dict, *, traced: bool = False, unknown=None) -> str | None:
    """Why `path` is not a number of the layout the agent reads -- with `traced`, one irpd's trace
    rings sample -- or None when it is: no such variable (`unknown(path)` says it, e.g.
    Segment.unknown with the nearest names), a struct or an array (up to three of its members named),
    or another type.  `leaves` and `scalars`: the layout's, as Segment has them."""
    leaf = leaves.get(path)
    if leaf is None:
        under = [p for p in leaves if p.startswith((path + ".", path + "["))] if path else []
        if not under:
            if unknown is not None:
                return unknown(path)
            return f"no variable '{path}' in the running layout (GET /api/v1/variables lists them)"
        names = ", ".join(f"'{p}'" for p in under[:3]) + (", ..." if len(under) > 3 else "")
        return f"'{path}' is a struct or an array, not a scalar: name one of its {len(under)} members ({names})"
    kind = scalars.get(leaf["type"], {}).get("kind", "unsigned")
    if (kind, leaf["size"]) not in FORMATS or (traced and kind not in TRACED_KINDS):
        return f"'{path}' is a {leaf['type']}, not a number {'irpd can trace' if traced else 'the agent can read'}"
    return None


def type_text(type_: str, iec_type: str | None = None) -> str:
    """A variable's type as indurop shows it everywhere (Variables page, Scope, OPC UA, recordings,
    DDS): a Structured Text variable's IEC 61131-3 type beside its C++ one, "TIME (int64_t)"
    (layout.json's `iec_type`, written by stc), a .glb variable's C++ type alone, "short"."""
    return f"{iec_type} ({type_})" if iec_type else type_


def shown(entries: list[dict]) -> list[dict]:
    """The layout's variables or leaves a user sees: all but a compiler's own ones (layout.json's
    `"internal": true`, e.g. stc's `Main._stc_init`), which irpd lays out and keeps across an online
    change like any other, but which the Variables API and page, OPC UA, DDS and the recorder leave out."""
    return [e for e in entries if not e.get("internal")]


class VariableError(Exception):
    """A path that names no leaf and no group of the layout, or a segment that is not there."""


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
        self.leaves = {leaf["path"]: leaf for leaf in shown(self.layout["leaves"])}  # what users may name
        self.scalars = self.layout.get("scalars", {})
        self._names: list[str] | None = None  # every leaf and group path, for unknown()
        self._groups: dict[str, list[dict]] | None = None  # every group path -> its leaves, for group()
        self._plans: OrderedDict[tuple[str, ...], Plan] = OrderedDict()  # read_many's, by the paths asked
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
        """The value of the leaf `path`."""
        self.refresh()
        leaf = self.leaves.get(path)
        if leaf is None:
            raise VariableError(self.unknown(path))
        return self.values([leaf])[0]

    def read_many(self, paths: list[str]) -> tuple[list[tuple[dict, object]], list[dict]]:
        """The leaves `paths` name, read in one pass (the leaves of one variable from one write):
        ([(leaf, value)] in the order asked, [{path, message}] for a path that names no leaf -- an
        unknown path with the nearest names, a group with the count of its leaves).  The paths are
        resolved once per layout (a plan kept for the next read of the same paths), and the pass is
        made again when a new layout was published during it."""
        key = tuple(paths)
        for _ in range(100):
            self.refresh()
            # the layout's sequence first: refresh() (another thread's too) sets it last, so the plans
            # and leaves taken after it are of that layout or a newer one, which the check below sees
            seq, plans = self.seq, self._plans
            plan = plans.get(key)
            if plan is None:
                plan = plans[key] = self._plan(key)
                if len(plans) > PLANS_KEPT:
                    plans.popitem(last=False)
            values = plan.read(self.mm)
            if values is None:  # a writer met in every pass, or leaves not planned: one lock at a time
                values = self.values(plan.leaves)
            if self._field(LAYOUT_SEQ) == seq:
                return list(zip(plan.leaves, values)), list(plan.errors)
        raise VariableError("the shared-variable layout is being published continuously; try again")

    def _plan(self, paths: tuple[str, ...]) -> Plan:
        found, formats, errors = [], [], []
        for path in paths:
            leaf = self.leaves.get(path)
            if leaf is not None:
                fmt = self._format(leaf)
                if fmt is None:
                    message = f"'{path}' is a {leaf['type']}, which the agent cannot decode"
                    errors.append({"path": path, "message": message})
                else:
                    found.append(leaf)
                    formats.append(fmt)
                continue
            count = len(self.group(path))
            message = (
                f"'{path}' is a group of {count} leaves, not a leaf: name its members (GET /api/v1/variables/{path} "
                "lists them)"
                if count
                else self.unknown(path)
            )
            errors.append({"path": path, "message": message})
        where = {"data": self.data, "locks": self.locks, "lock_size": self.lock_size, "seq": LOCK_SEQ}
        return compile_plan(found, formats, errors, where)

    def group(self, path: str) -> list[dict]:
        """The leaves under the group `path` (a namespace, a struct, an array or one of its
        elements), in layout order; [] when it names no group."""
        if self._groups is None:
            groups: dict[str, list[dict]] = {}
            for p, leaf in self.leaves.items():  # every group a leaf is under: its path up to each '.' and '['
                for i, c in enumerate(p):
                    if c in ".[":
                        groups.setdefault(p[:i], []).append(leaf)
            self._groups = groups
        return self._groups.get(path, []) if path else []

    def select(self, path: str) -> list[dict]:
        """The layout's leaves that `path` names: the leaf itself, or for a group (a namespace, a
        struct, an array or one of its elements) every leaf under it, in layout order."""
        self.refresh()
        leaf = self.leaves.get(path)
        if leaf is not None:
            return [leaf]
        found = self.group(path)
        if not found:
            raise VariableError(self.unknown(path))
        return list(found)

    def unknown(self, path: str) -> str:
        """What to say about a path that names no leaf and no group: the nearest names it has."""
        if self._names is None:
            self.group("")
            self._names = sorted({*self.leaves, *self._groups})
        near = difflib.get_close_matches(path, self._names, n=3, cutoff=0.75)
        near.sort(key=lambda n: (-difflib.SequenceMatcher(None, path, n).ratio(), n))  # the nearest first
        names = [repr(n) for n in near]
        listed = f"{', '.join(names[:-1])} or {names[-1]}" if len(names) > 1 else "".join(names)
        hint = f"; did you mean {listed}?" if near else ";"
        return (
            f"no variable '{path}' (neither a leaf nor a group) in layout {self.hash[:12]}…{hint} "
            "GET /api/v1/variables lists the leaves"
        )

    def values(self, leaves: list[dict]) -> list:
        """The values of `leaves` (entries of the layout held): the leaves of one variable (one lock)
        are copied together, between two equal reads of the lock's sequence, so that they are of
        the same write."""
        formats = []
        for leaf in leaves:
            fmt = self._format(leaf)
            if fmt is None:
                raise VariableError(f"'{leaf['path']}' is a {leaf['type']}, which the agent cannot decode")
            formats.append(fmt)
        by_lock: dict[int, list[int]] = {}
        for i, leaf in enumerate(leaves):
            by_lock.setdefault(leaf["lock"], []).append(i)
        out: list = [None] * len(leaves)
        for lock, which in by_lock.items():
            lo = min(leaves[i]["offset"] for i in which)
            hi = max(leaves[i]["offset"] + leaves[i]["size"] for i in which)
            raw = self._copy(lock, lo, hi, leaves[which[0]]["path"])
            for i in which:
                out[i] = struct.unpack_from(formats[i], raw, leaves[i]["offset"] - lo)[0]
        return out

    def _format(self, leaf: dict) -> str | None:
        """The struct format a leaf is decoded with, or None for a type the agent cannot decode."""
        kind = self.scalars.get(leaf["type"], {}).get("kind", "unsigned")
        return FORMATS.get((kind, leaf["size"]))

    def _copy(self, lock_index: int, lo: int, hi: int, path: str) -> bytes:
        """The data bytes [lo, hi) of one variable, as one writer left them.  A writer holds a variable
        for as long as its write, or, for the variables of an ST program run in place, its run (the
        sequence odd meanwhile: docs/st-runtime.md, "In place"), which a loaded machine can preempt
        for milliseconds: after COPY_SPINS tries the reader sleeps between tries, for up to
        COPY_WAIT_S."""
        lock = self.locks + lock_index * self.lock_size
        deadline, pause = None, 0.00005
        while True:
            for _ in range(COPY_SPINS):
                before = self._field(LOCK_SEQ, lock)
                if before & 1:
                    continue
                raw = self.mm[self.data + lo : self.data + hi]
                after = self._field(LOCK_SEQ, lock)
                if after == before:
                    return raw
            now = time.monotonic()
            deadline = deadline or now + COPY_WAIT_S
            if now >= deadline:
                raise VariableError(f"'{path}' was being written for {COPY_WAIT_S:g} s without a pause; try again")
            time.sleep(pause)
            pause = min(pause * 2, 0.005)

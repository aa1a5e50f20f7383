# evolve.py -- glbc --previous: lays a layout out against the one that runs now.  Variables with
# the same path and type_id keep their offset and lock; new and changed ("moved") ones go first-fit
# into space that neither the previous layout nor any layout of its lineage uses, so running
# modules keep their variables and removed variables leave holes that are not reused.  A changed
# variable whose value can be kept is "converted": convert.py plans the copies irpd runs at the swap.

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from typing import Any

from .convert import NotConvertible, Shape, plan, shape_in, shape_of
from .emit_layout import FORMAT, VERSION, type_id
from .errors import GlbError
from .layout import CACHE_LINE, Layout, StructType, Variable, round_up

MAX_LINEAGE = 16  # earlier layouts a layout.json remembers; the oldest is dropped
GIVE = "give the layout.json that runs now (irpctl layout -o layout.json)"
OLDER = "written by an older glbc; compile the running set's .glb files again without --previous"
RESTART = "holes of removed variables count until the next irpd restart (then compile without --previous)"


@dataclass(frozen=True)
class Placed:
    """A top-level variable of an earlier layout: where it is and what its bytes mean."""

    path: str
    type_id: str
    offset: int
    size: int
    lock: int
    lock_group: str | None = None

    def entry(self) -> dict[str, Any]:
        group = {"lock_group": self.lock_group} if self.lock_group is not None else {}
        return {
            "path": self.path,
            "type_id": self.type_id,
            "offset": self.offset,
            "size": self.size,
            "lock": self.lock,
        } | group


@dataclass
class Previous:
    """The layout.json given to --previous."""

    file: str
    hash: str
    variables: list[Placed]
    lineage: list[tuple[str, list[Placed]]]  # (hash, variables), newest first
    types: dict[str, Any]  # its "types" and each variable's "type" and "dims": what converting reads
    typed: dict[str, tuple[str, list[int]]]
    iec: dict[str, str]  # the IEC type of a variable declared by stc, by path

    def shape(self, path: str) -> tuple[Shape, list[int], str]:
        """A variable's shape, dimensions and spelled type; NotConvertible when the file does not
        describe it."""
        try:
            name, dims = self.typed[path]
            return shape_in(self.types, name), [int(d) for d in dims], spelled(name, dims)
        except (KeyError, TypeError, ValueError, AttributeError, RecursionError):
            raise NotConvertible(f"{path}: the previous layout does not describe its type") from None


def spelled(type_name: str, dims: list[int]) -> str:
    """A variable's type as the reports show it: `int16_t`, `a.s_t[4][2]`."""
    return type_name + "".join(f"[{d}]" for d in dims)


# -- reading the previous layout --------------------------------------------------------------------


def _fail(file: str, message: str) -> GlbError:
    return GlbError(message, file=file)


def _hash(file: str, value: Any, what: str) -> str:
    if not isinstance(value, str) or not re.fullmatch(r"[0-9a-f]{64}", value):
        raise _fail(file, f'{what} has no "hash" of 64 hex digits: not a layout glbc wrote; {GIVE}')
    return value


def _variables(file: str, value: Any, what: str) -> list[Placed]:
    if not isinstance(value, list):
        raise _fail(file, f'{what} has no "variables" list: not a layout glbc wrote; {GIVE}')
    out = []
    for i, v in enumerate(value):
        path = v.get("path") if isinstance(v, dict) else None
        if not isinstance(path, str):
            raise _fail(file, f'variable {i} of {what} has no "path": not a layout glbc wrote; {GIVE}')
        for key in ("offset", "size", "lock"):
            x = v.get(key)
            if not isinstance(x, int) or isinstance(x, bool) or x < 0 or (key == "size" and x == 0):
                raise _fail(file, f'variable {path} of {what} has no valid "{key}": not a layout glbc wrote; {GIVE}')
        tid = v.get("type_id")
        if not isinstance(tid, str) or not re.fullmatch(r"[0-9a-f]{16}", tid):
            raise _fail(file, f'variable {path} of {what} has no "type_id": {OLDER}')
        group = v.get("lock_group")
        if group is not None and not isinstance(group, str):
            raise _fail(file, f'variable {path} of {what} has a "lock_group" that is not a string: {OLDER}')
        out.append(Placed(path, tid, v["offset"], v["size"], v["lock"], group))
    return out


def read_previous(file: str) -> Previous:
    """Reads and checks the layout.json given to --previous; GlbError naming the file otherwise."""
    try:
        with open(file, "rb") as f:
            data = f.read()
    except OSError as e:
        raise _fail(file, f"cannot read the previous layout: {e.strerror or e}; {GIVE}") from None
    try:
        doc = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as e:
        raise _fail(file, f"the previous layout is not JSON ({e}); {GIVE}") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise _fail(file, f'not an indurop layout ("format" is not "{FORMAT}"); {GIVE}')
    if type(doc.get("version")) is not int or doc["version"] != VERSION:
        raise _fail(
            file,
            f"layout version {json.dumps(doc.get('version'))}; this glbc reads version {VERSION}: "
            f"compile the running set's .glb files with the glbc that wrote it",
        )
    layout_hash = _hash(file, doc.get("hash"), "the layout")
    variables = _variables(file, doc.get("variables"), "the layout")
    lineage = doc.get("lineage", [])  # a layout with no variables from an older glbc has none
    if not isinstance(lineage, list):
        raise _fail(file, f'"lineage" is not a list: not a layout glbc wrote; {GIVE}')
    earlier = []
    for k, entry in enumerate(lineage):
        what = f"lineage entry {k}"
        if not isinstance(entry, dict):
            raise _fail(file, f"{what} is not an object: not a layout glbc wrote; {GIVE}")
        earlier.append((_hash(file, entry.get("hash"), what), _variables(file, entry.get("variables"), what)))
    types = doc.get("types") if isinstance(doc.get("types"), dict) else {}
    typed = {v["path"]: (v.get("type"), v.get("dims", [])) for v in doc["variables"]}
    iec = {v["path"]: v["iec_type"] for v in doc["variables"] if isinstance(v.get("iec_type"), str)}
    return Previous(file, layout_hash, variables, earlier, types, typed, iec)


# -- placing ------------------------------------------------------------------------------------------


def _gaps(kept: list[Placed]) -> list[list[int | None]]:
    """The free space between the cache lines that `kept` uses: [start, end) pairs in order, the last
    one open-ended (end None)."""
    gaps: list[list[int | None]] = []
    at = 0
    for start, end in sorted(
        (p.offset // CACHE_LINE * CACHE_LINE, round_up(p.offset + p.size, CACHE_LINE)) for p in kept
    ):
        if start > at:
            gaps.append([at, start])
        at = max(at, end)
    gaps.append([at, None])
    return gaps


def _first_fit(gaps: list[list[int | None]], size: int) -> int:
    need = round_up(size, CACHE_LINE)
    for i, (start, end) in enumerate(gaps):
        if end is None or end - start >= need:
            if end is not None and end - start == need:
                del gaps[i]
            else:
                gaps[i][0] = start + need
            return start
    raise AssertionError("the last gap is open-ended")


def _too_large(prev: Previous, placed: list[Variable], kept_end: int, max_size: int) -> GlbError:
    over = [v for v in placed if round_up(v.offset + v.size, CACHE_LINE) > max_size]
    if over:
        v = over[0]
        return GlbError(
            f"segment over its limit: variable '{v.name}' ({v.size} bytes) goes to offset {v.offset}, the "
            f"first space the running layout and its lineage leave free, and ends at byte "
            f"{round_up(v.offset + v.size, CACHE_LINE)}, over --max-size {max_size}; {RESTART}",
            v.loc,
        )
    return _fail(
        prev.file,
        f"segment over its limit: the variables and holes this layout keeps end at byte "
        f"{kept_end}, over --max-size {max_size}; {RESTART}",
    )


def place(layout: Layout, prev: Previous, max_size: int) -> None:
    """Re-lays `layout` out against `prev`: offsets, locks, data_size, lock_count, lineage, changes."""
    kept = prev.variables + [p for _, variables in prev.lineage for p in variables]
    before = {p.path: p for p in prev.variables}
    gaps = _gaps(kept)
    used_locks = {p.lock for p in kept}
    # A lock group keeps its lock: a variable that joins it (new or moved) takes the lock its
    # variables have in the running layout, or the one the first of them gets here.
    group_locks: dict[str, int] = {}
    for p in prev.variables:
        if p.lock_group is not None:
            group_locks.setdefault(p.lock_group, p.lock)
    next_lock = 0
    placed: list[Variable] = []
    for v in layout.variables:
        old = before.get(v.path)
        if old is not None and old.type_id == type_id(v):
            v.offset, v.lock = old.offset, old.lock
        else:
            placed.append(v)
    for run in _runs(layout.variables, placed):
        base = run[0].offset // CACHE_LINE * CACHE_LINE  # build() placed them from here
        start = _first_fit(gaps, run[-1].offset + run[-1].size - base)
        for v in run:
            v.offset = start + v.offset - base
    for v in placed:
        if v.lock_group is not None and v.lock_group in group_locks:
            v.lock = group_locks[v.lock_group]
            continue
        while next_lock in used_locks:
            next_lock += 1
        v.lock = next_lock
        used_locks.add(next_lock)
        if v.lock_group is not None:
            group_locks[v.lock_group] = v.lock
    kept_end = round_up(max((p.offset + p.size for p in kept), default=0), CACHE_LINE)
    layout.data_size = max([kept_end] + [round_up(v.offset + v.size, CACHE_LINE) for v in layout.variables])
    layout.lock_count = 1 + max(used_locks | {v.lock for v in layout.variables}, default=-1)
    if layout.data_size > max_size:
        raise _too_large(prev, placed, kept_end, max_size)

    now = {v.path for v in layout.variables}
    added = [v.path for v in placed if v.path not in before]
    moved, converted = [], []
    for v in placed:
        if v.path in before:
            entry = {"path": v.path, "from": before[v.path].offset, "to": v.offset}
            try:
                shape, dims, was = prev.shape(v.path)
                copies = plan(v.path, shape, dims, entry["from"], shape_of(v.type), v.dims, v.offset)
                converted.append(entry | {"from_type": was, "to_type": spelled(_name(v), v.dims)} | copies)
            except NotConvertible as e:
                moved.append(entry | _types(prev, v) | {"reason": str(e)})
    removed = [p.path for p in prev.variables if p.path not in now]
    layout.changes = {
        "previous": prev.hash,
        "added": added,
        "removed": removed,
        "moved": moved,
        "converted": converted,
    }
    layout.lineage = [
        {"hash": h, "variables": [p.entry() for p in variables]}
        for h, variables in [(prev.hash, prev.variables)] + prev.lineage
    ][:MAX_LINEAGE]


def _runs(variables: list[Variable], placed: list[Variable]) -> list[list[Variable]]:
    """The variables to place (new or changed), in runs that keep build()'s offsets between them: a
    packed variable that follows a packed one to place goes with it (build() packed it right after),
    so a program's new variables stay packed; every other one is a run of its own."""
    to_place = {id(v) for v in placed}
    runs: list[list[Variable]] = []
    joins = False
    for v in variables:
        if id(v) not in to_place:
            joins = False
            continue
        if v.packed and joins:
            runs[-1].append(v)
        else:
            runs.append([v])
        joins = v.packed
    return runs


def _types(prev: Previous, v: Variable) -> dict[str, str]:
    """A moved variable's types before and after, as the dry run names them: the IEC type of a
    variable stc declared (`INT`), else the spelled C++ one (`int16_t`, `a.s_t[4]`)."""
    name, dims = prev.typed.get(v.path, ("?", []))
    dims = [d for d in dims if isinstance(d, int)] if isinstance(dims, list) else []
    return {
        "from_type": spelled(prev.iec.get(v.path) or str(name), dims),
        "to_type": spelled(v.iec_type or _name(v), v.dims),
    }


def _name(v: Variable) -> str:
    return v.type.qualname if isinstance(v.type, StructType) else v.type.name


def summary(changes: dict[str, Any]) -> str:
    """The line glbc prints to stderr: `glbc: against layout 5356ab12cd34…: 1 added, 0 removed, 0 moved,
    1 converted`, then one line per moved variable saying why its value is not kept."""
    lines = [
        f"glbc: against layout {changes['previous'][:12]}…: {len(changes['added'])} added, "
        f"{len(changes['removed'])} removed, {len(changes['moved'])} moved, {len(changes['converted'])} converted"
    ]
    lines += [
        f"glbc: not convertible without loss, only a managed restart of irpd runs this layout: {m['reason']}"
        for m in changes["moved"]
    ]
    return "\n".join(lines)

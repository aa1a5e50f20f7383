"""sharing.py -- dds.json's `export` and `imports` (docs/dds.md "Controllers sharing variables"):
read from the parsed file, and checked against the writers and the layout.

An export names a variable of this set that other controllers may import: a scalar, or an array
of scalars (every element, in order).  An import names a variable another controller exports (by
the controller's name and the path) and the variables of this set the bridge writes for it: the
value, the staleness flag, and optionally the age and the source's stamp.  Every variable an
import writes has the bridge as its only writer: a module's `<writes>`, a subscription or another
import on it is refused naming both.  Every refusal is a BridgeFileError naming the file, the line
and what to fix; the agent's upload, the bridge and the agent's import alarms use it.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ..irpd.variables import shown, type_text
from .bridge_schema import SCHEMA

DEFAULT_RATE_HZ = 100.0
DEFAULT_TIMEOUT_MS = 250.0
_INDEX = re.compile(r"(\[\d+\])+")
CONTROLLER = re.compile(SCHEMA["$defs"]["controller"]["pattern"])  # a name imports can name


class SharingError(ValueError):
    """A refusal where no file name is at hand (the bridge adds dds.json's)."""

    def __init__(self, message: str, line: int | None = None):
        super().__init__(message)
        self.line = line


@dataclass(frozen=True)
class Export:
    variable: str  # a scalar, or an array of scalars
    rate_hz: float = DEFAULT_RATE_HZ  # at most one sample per basic period
    line: int | None = None


@dataclass(frozen=True)
class Import:
    source: str  # the exporting controller's name (dds.json's "from")
    path: str  # the variable's path in the exporter's layout
    variable: str  # this set's variable that receives the value
    stale: str  # 1 (true) while the import is stale and `variable` holds the fallback
    age_us: str | None = None  # the value's age when written, in microseconds
    stamp_ns: str | None = None  # the value's due time on this controller's CLOCK_MONOTONIC
    rate_hz: float = DEFAULT_RATE_HZ  # writes a second at most
    timeout_ms: float = DEFAULT_TIMEOUT_MS  # stale after this long without a sample
    fallback: float | bool | tuple = 0  # written while stale: one value, or one per element
    line: int | None = None

    @property
    def key(self) -> str:
        """How the diagnostics and the logs name it: <controller>:<path>."""
        return f"{self.source}:{self.path}"

    @property
    def written(self) -> tuple[str, ...]:
        """Every variable the bridge writes for this import."""
        return tuple(v for v in (self.variable, self.stale, self.age_us, self.stamp_ns) if v)


def parse(doc: dict, error) -> tuple[tuple[Export, ...], tuple[Import, ...]]:
    """dds.json's `export` and `imports` (already checked against the schema); `error(message,
    line)` makes the BridgeFileError to raise.  Refuses an export named twice and a variable two
    imports would write."""
    exports, seen = [], {}
    for e in doc.get("export", []):
        x = Export(e["variable"], float(e.get("rate_hz", DEFAULT_RATE_HZ)), getattr(e, "line", None))
        if x.variable in seen:
            raise error(f"export: {x.variable} is exported twice (also line {seen[x.variable]})", x.line)
        seen[x.variable] = x.line
        exports.append(x)
    imports, writes = [], {}
    for i in doc.get("imports", []):
        imp = Import(
            source=i["from"],
            path=i["path"],
            variable=i["variable"],
            stale=i["stale"],
            age_us=i.get("age_us"),
            stamp_ns=i.get("stamp_ns"),
            rate_hz=float(i.get("rate_hz", DEFAULT_RATE_HZ)),
            timeout_ms=float(i.get("timeout_ms", DEFAULT_TIMEOUT_MS)),
            fallback=tuple(i["fallback"]) if isinstance(i.get("fallback"), list) else i.get("fallback", 0),
            line=getattr(i, "line", None),
        )
        for v in imp.written:
            for other_var, other in writes.items():
                if overlaps(v, other_var):
                    same = (
                        " (twice in one import)"
                        if other is imp
                        else f" and the import of {other.key} (line {other.line})"
                    )
                    raise error(
                        f"{v} would have two writers: the import of {imp.key}{same}; one writer per variable", imp.line
                    )
            writes[v] = imp
        imports.append(imp)
    return tuple(exports), tuple(imports)


def overlaps(a: str, b: str) -> bool:
    """Whether two paths name a common leaf: the same path, or one inside the other (a struct's
    member, an array's element)."""
    if len(a) > len(b):
        a, b = b, a
    return a == b or (b.startswith(a) and b[len(a)] in ".[")


def check_writers(imports: tuple[Import, ...], subscribed: dict, module_writes: dict[str, list[str]], error) -> None:
    """No variable an import writes is written by a subscription (`subscribed`: variable -> its
    Mapping) or declared by a module as one it writes (module.xml <writes>)."""
    for imp in imports:
        for v in imp.written:
            for var, m in subscribed.items():
                if overlaps(v, var):
                    raise error(
                        f"{v} would have two writers: the subscription to {m.topic} (line {m.line}) and the import "
                        f"of {imp.key}; drop one of them",
                        imp.line,
                    )
            for module, paths in module_writes.items():
                for w in paths:
                    if overlaps(v, w):
                        raise error(
                            f"{v} would have two writers: module {module} (module.xml <writes>{w}</writes>) and the "
                            f"import of {imp.key}; drop one of them",
                            imp.line,
                        )


# ---- the layout ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Shape:
    """A variable as the bridge reads or writes it: its scalar leaves in order and their type."""

    leaves: tuple[str, ...]
    type: str  # "float64", "int16", "bool", ... (element_type of the layout's scalar)
    array: bool

    @property
    def name(self) -> str:
        """As the samples carry it: "float64", "float32[4]"."""
        return f"{self.type}[{len(self.leaves)}]" if self.array else self.type


def element_type(kind: str, size: int) -> str:
    """A layout scalar (its kind and size) as the samples name it."""
    if kind == "bool":
        return "bool"
    if kind == "float":
        return f"float{8 * size}"
    if kind in ("signed", "char"):
        return f"int{8 * size}"
    return f"uint{8 * size}"


def shape(layout: dict, path: str) -> Shape | None:
    """The scalar leaf `path`, or the array of scalars `path` (its elements in layout order, of
    one scalar type); None for anything else (no such variable, a struct, an array of structs)."""
    scalars = layout.get("scalars", {})
    every = shown(layout.get("leaves", []))  # a compiler's own variables are no one's to share
    leaves = [leaf for leaf in every if leaf["path"] == path]
    array = not leaves
    if array:
        leaves = [
            leaf for leaf in every if leaf["path"].startswith(path + "[") and _INDEX.fullmatch(leaf["path"], len(path))
        ]
    if not leaves or len({leaf["type"] for leaf in leaves}) != 1 or leaves[0]["type"] not in scalars:
        return None
    s = scalars[leaves[0]["type"]]
    return Shape(tuple(leaf["path"] for leaf in leaves), element_type(s["kind"], s["size"]), array)


def described(path: str, leaves: list[dict], array: bool = False) -> str:
    """A mapped or exported variable as the bridge's USER_DATA names it: its path and its type as the
    web UI shows it (irpd/variables.py's type_text: `Main.count DINT (int32_t)`, a .glb variable's
    `double`); an array of scalars (its layout leaves) with its elements' range (`SHARE.vec[0..3]
    float`); the path alone without a leaf (not in the layout)."""
    if not leaves:
        return path
    where = f"{path}[0..{len(leaves) - 1}]" if array else path
    return f"{where} {type_text(leaves[0]['type'], leaves[0].get('iec_type'))}"


def user_data(described: list[str]) -> str:
    """The USER_DATA of a writer or reader of variables, in ROS 2's `key=value;` form (as rmw puts
    its typehash there; ROS 2 ignores keys it does not know)."""
    return f"indurop.variables={', '.join(described)};"


_RANGES = {
    f"{s}int{b}": ((-(1 << (b - 1)), (1 << (b - 1)) - 1) if s == "" else (0, (1 << b) - 1))
    for s in ("", "u")
    for b in (8, 16, 32, 64)
}


def fits(type_: str, value) -> bool:
    """Whether `value` (a JSON number or boolean) is a value of the element type."""
    if type_ == "bool":
        return isinstance(value, bool) or value in (0, 1)
    if isinstance(value, bool):
        return False
    if type_.startswith("float"):
        return isinstance(value, (int, float)) and math.isfinite(value)
    low, high = _RANGES[type_]
    if not (isinstance(value, int) or (isinstance(value, float) and value.is_integer())):
        return False
    return low <= value <= high


def max_value(type_: str) -> float:
    """The largest value of an element type (the age is held at it rather than refused)."""
    return _RANGES[type_][1] if type_ in _RANGES else math.inf


def check_layout(exports: tuple[Export, ...], imports: tuple[Import, ...], layout: dict, error) -> None:
    """Every export and every import's variables against the layout (layout.json): the variables
    exist, with types that can hold what the bridge writes, and the fallback fits the variable."""
    for x in exports:
        if shape(layout, x.variable) is None:
            raise error(f"export: no scalar variable or array of scalars {x.variable} in the layout", x.line)
    for imp in imports:
        local = shape(layout, imp.variable)
        if local is None:
            raise error(
                f"the import of {imp.key}: no scalar variable or array of scalars {imp.variable} in the layout",
                imp.line,
            )
        wanted = {
            imp.stale: ("the staleness flag", lambda t: t == "bool" or "int" in t, "a bool (or an integer)"),
            imp.age_us: ("the age", lambda t: t != "bool", "an integer or a float (microseconds)"),
            imp.stamp_ns: ("the stamp", lambda t: t in ("int64", "uint64"), "an int64_t or a uint64_t (nanoseconds)"),
        }
        for v, (what, ok, expected) in wanted.items():
            if v is None:
                continue
            s = shape(layout, v)
            if s is None or s.array:
                raise error(f"the import of {imp.key}: {what} {v} is not a scalar variable of the layout", imp.line)
            if not ok(s.type):
                raise error(f"the import of {imp.key}: {what} {v} is a {s.type}; it must be {expected}", imp.line)
        check_fallback(imp, local, error)


def check_fallback(imp: Import, local: Shape, error) -> None:
    values = imp.fallback if isinstance(imp.fallback, tuple) else None
    if values is not None and (not local.array or len(values) != len(local.leaves)):
        raise error(
            f"the import of {imp.key}: the fallback has {len(values)} values; {imp.variable} has "
            f"{len(local.leaves) if local.array else 'one'} (give one value for every element, or a list as long)",
            imp.line,
        )
    for v in values or (imp.fallback,):
        if not fits(local.type, v):
            raise error(f"the import of {imp.key}: the fallback {v!r} is not a {local.type} ({imp.variable})", imp.line)


def fallback_values(imp: Import, local: Shape) -> list:
    """The fallback, one value per element, as irpd's `write` takes it (checked: check_fallback)."""
    values = list(imp.fallback) if isinstance(imp.fallback, tuple) else [imp.fallback] * len(local.leaves)
    return [as_written(local.type, v) for v in values]


def as_written(type_: str, value):
    """A number (a traced double, a JSON value) as irpd's `write` takes it for the element type:
    an integer for the integer types, true or false for bool; anything else is left as it is
    (irpd refuses it, naming it)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return value
    if type_ == "bool":
        return bool(value) if value in (0, 1) else value
    if type_.startswith("float") or not math.isfinite(value) or not float(value).is_integer():
        return value
    return int(value)

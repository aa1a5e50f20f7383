"""values.py -- the shared variables as OPC UA values: the layout's scalar types as built-in types,
the tree of objects and variables the layout makes (structs and namespaces as objects, arrays of
scalars as array variables), and their values read from irpd's variable segment with the agent's
own reader (variables.Segment: never a lock, never a wait on an RT writer)."""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from datetime import UTC, datetime

from asyncua import ua

from ..irpd.variables import Segment, VariableError, shown, type_text

# (kind, size) of the layout's scalar types (layout.json "scalars") -> OPC UA built-in type.
VARIANTS = {
    ("bool", 1): ua.VariantType.Boolean,
    ("char", 1): ua.VariantType.SByte,
    ("signed", 1): ua.VariantType.SByte,
    ("signed", 2): ua.VariantType.Int16,
    ("signed", 4): ua.VariantType.Int32,
    ("signed", 8): ua.VariantType.Int64,
    ("unsigned", 1): ua.VariantType.Byte,
    ("unsigned", 2): ua.VariantType.UInt16,
    ("unsigned", 4): ua.VariantType.UInt32,
    ("unsigned", 8): ua.VariantType.UInt64,
    ("float", 4): ua.VariantType.Float,
    ("float", 8): ua.VariantType.Double,
}
INTEGERS = {
    ua.VariantType.SByte: (-(1 << 7), (1 << 7) - 1),
    ua.VariantType.Int16: (-(1 << 15), (1 << 15) - 1),
    ua.VariantType.Int32: (-(1 << 31), (1 << 31) - 1),
    ua.VariantType.Int64: (-(1 << 63), (1 << 63) - 1),
    ua.VariantType.Byte: (0, (1 << 8) - 1),
    ua.VariantType.UInt16: (0, (1 << 16) - 1),
    ua.VariantType.UInt32: (0, (1 << 32) - 1),
    ua.VariantType.UInt64: (0, (1 << 64) - 1),
}


@dataclass(frozen=True)
class Obj:
    """An object node: a namespace, a struct, an array of structs or one of its elements."""

    path: str  # its NodeId's string, e.g. PLC_ROBOT.AXIS_IN[0]
    parent: str  # its parent's path; "" = the Objects folder
    name: str  # its browse name

    @property
    def signature(self) -> tuple:
        return ("object",)


@dataclass(frozen=True)
class Var:
    """A variable node: a scalar leaf, or an array of scalars (ValueRank = len(dims))."""

    path: str
    parent: str
    name: str
    type: str  # the layout's type name (uint32_t, double, short, ...)
    variant: ua.VariantType
    dims: tuple[int, ...]  # () for a scalar
    leaves: tuple[str, ...]  # the layout's leaf paths, row-major
    iec_type: str | None = None  # a Structured Text variable's IEC 61131-3 type (layout.json's iec_type)

    @property
    def signature(self) -> tuple:
        return ("variable", self.type, self.variant, self.dims, self.iec_type)

    @property
    def description(self) -> str:
        """The node's Description: its types and path ("TIME (int64_t) Main.t.ET", "short PLC_ROBOT.I0")."""
        return f"{type_text(self.type, self.iec_type)} {self.path}"


def element_suffixes(dims: tuple[int, ...]) -> list[str]:
    """The element suffixes "[0][0]", "[0][1]", ... of an array of these dimensions, row-major."""
    out = [""]
    for d in dims:
        out = [s + f"[{i}]" for s in out for i in range(d)]
    return out


def index_range(text: str, length: int) -> range | None:
    """An IndexRange of a 1-D array of `length` ("3", "2:4"); None when it is not one of it."""
    try:
        if ":" in text:
            a, b = (int(x) for x in text.split(":"))
            return range(a, b + 1) if 0 <= a < b < length else None
        a = int(text)
        return range(a, a + 1) if 0 <= a < length else None
    except ValueError:
        return None


def narrowed(var: Var, picked: range | None) -> Var:
    """The elements `picked` of a 1-D array variable as a variable of their own (one: a scalar)."""
    if picked is None:
        return var
    dims = () if len(picked) == 1 else (len(picked),)
    return dataclasses.replace(var, dims=dims, leaves=tuple(var.leaves[i] for i in picked))


def variant_of(layout: dict, type_name: str) -> ua.VariantType | None:
    scalar = layout.get("scalars", {}).get(type_name)
    return VARIANTS.get((scalar["kind"], scalar["size"])) if scalar else None


def tree(layout: dict) -> dict[str, Obj | Var]:
    """Every node the layout makes, parents before their children, by path."""
    nodes: dict[str, Obj | Var] = {}
    types = layout.get("types", {})

    def parent_objects(path: str) -> None:
        parts = path.split(".")
        for i in range(1, len(parts) + 1):
            p = ".".join(parts[:i])
            if p not in nodes:
                nodes[p] = Obj(p, ".".join(parts[: i - 1]), parts[i - 1])

    def add(path: str, parent: str, name: str, type_name: str, dims: tuple[int, ...], iec: str | None) -> None:
        variant = variant_of(layout, type_name)
        if variant is not None:
            leaves = tuple(path + s for s in element_suffixes(dims))
            nodes[path] = Var(path, parent, name, type_name, variant, dims, leaves, iec)
            return
        struct = types.get(type_name)
        if struct is None:
            return  # a type the layout does not describe: nothing to show
        nodes[path] = Obj(path, parent, name)
        if dims:
            for s in element_suffixes(dims):
                nodes[path + s] = Obj(path + s, path, s)
                for f in struct["fields"]:
                    add(
                        f"{path}{s}.{f['name']}",
                        path + s,
                        f["name"],
                        f["type"],
                        tuple(f.get("dims") or ()),
                        f.get("iec_type"),
                    )
        else:
            for f in struct["fields"]:
                add(f"{path}.{f['name']}", path, f["name"], f["type"], tuple(f.get("dims") or ()), f.get("iec_type"))

    for v in shown(layout.get("variables", [])):
        namespace = v.get("namespace") or ""
        if namespace:
            parent_objects(namespace)
        add(v["path"], namespace, v["name"], v["type"], tuple(v.get("dims") or ()), v.get("iec_type"))
    return nodes


def typed(variant: ua.VariantType, value):
    """A value read from the segment, or a trace ring's double, as the built-in type holds it."""
    if variant == ua.VariantType.Boolean:
        return bool(value)
    if variant in INTEGERS:
        if isinstance(value, float):
            if math.isnan(value):
                return None
            value = int(value)
        return value
    return float(value)


def shaped(values: list, dims: tuple[int, ...]):
    """A flat row-major list as nested lists of `dims` (a 1-D array stays flat)."""
    if len(dims) <= 1:
        return values
    step = len(values) // dims[0]
    return [shaped(values[i * step : (i + 1) * step], dims[1:]) for i in range(dims[0])]


def variant(var: Var, values: list) -> ua.Variant:
    typed_values = [typed(var.variant, v) for v in values]
    if not var.dims:
        return ua.Variant(typed_values[0], var.variant)
    if len(var.dims) == 1:
        return ua.Variant(typed_values, var.variant)
    return ua.Variant(typed_values, var.variant, Dimensions=list(var.dims))


def clock_offset_ns() -> int:
    """CLOCK_REALTIME - CLOCK_MONOTONIC now, from the closest of five pairs of readings: a thread
    preempted between two readings would make it milliseconds wrong.  NTP slews both clocks alike,
    so it changes only when the wall clock is stepped."""
    best = (1 << 62, 0)
    for _ in range(5):
        a = time.monotonic_ns()
        w = time.time_ns()
        b = time.monotonic_ns()
        best = min(best, (b - a, w - (a + b) // 2))
    return best[1]


def wall(ns: int | None = None) -> datetime:
    return datetime.fromtimestamp((time.time_ns() if ns is None else ns) / 1e9, UTC)


class Variables:
    """irpd's variable segment, mapped when irpd names it (status) and mapped again when irpd
    restarts; reads of variables as DataValues."""

    def __init__(self) -> None:
        self.segment: Segment | None = None
        self.name: str | None = None

    def follow(self, name: str | None) -> bool:
        """Maps the segment irpd names now (None: it has none); True when the mapping changed."""
        if self.segment is not None and (name != self.name or self.segment.replaced()):
            self.segment.close()
            self.segment, self.name = None, None
        if name is None or self.segment is not None:
            return False
        try:
            self.segment = Segment(name)
        except (VariableError, OSError):
            return False
        self.name = name
        return True

    def layout(self) -> dict | None:
        if self.segment is None:
            return None
        self.segment.refresh()
        return self.segment.layout

    def read(self, leaves: list[str]) -> list:
        """The values of these leaf paths (one consistent copy per variable); VariableError."""
        if self.segment is None or self.segment.replaced():
            raise VariableError("irpd's shared-variable segment is not mapped")
        self.segment.refresh()
        return self.segment.values([self.segment.leaves[p] for p in leaves])

    def data_value(self, var: Var) -> ua.DataValue:
        """A read of a variable: its value now, or a bad status saying why not."""
        now = wall()
        try:
            values = self.read(list(var.leaves))
        except KeyError:
            return ua.DataValue(StatusCode=ua.StatusCode(ua.StatusCodes.BadNodeIdUnknown), ServerTimestamp=now)
        except VariableError:
            return ua.DataValue(StatusCode=ua.StatusCode(ua.StatusCodes.BadNoCommunication), ServerTimestamp=now)
        return ua.DataValue(variant(var, values), SourceTimestamp=now, ServerTimestamp=now)

# convert.py -- the one place of the rules that say whether a retyped variable keeps its value at an
# online change (glbc --previous), and the plan of scalar copies irpd runs at the swap.
#
#   scalars   converted when the new type holds every value of the old one (LOSSLESS below);
#   structs   field by field by name: kept fields converted recursively, new fields start at zero,
#             removed fields are dropped (and listed);
#   arrays    element by element over the common index range: new elements start at zero, the
#             elements beyond a shrunk array are dropped (and listed).
#
# Anything else (narrowing, float to integer, a scalar becoming a struct, another number of array
# dimensions...) is not converted: the variable "moves" and the reason says why; irpd runs such a
# layout only by a managed restart (docs/hot-reload.md "Converted variables").
# docs/glbc.md "Converted variables" is the table of these rules.

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .layout import StructType, Type
from .scalars import SCALARS, Scalar

# The mantissa bits of the floating types: an integer of at most that many value bits is exact.
_MANTISSA = {4: 24, 8: 53}


def lossless(a: Scalar, b: Scalar) -> bool:
    """Whether every value of scalar type `a` is a value of `b` (IEC's widening conversions)."""
    if (a.kind, a.size) == (b.kind, b.size):
        return True  # the same representation under another name (short, int16_t)
    if a.kind == "bool" or b.kind == "bool":
        return False
    if a.kind == "float":
        return b.kind == "float" and b.size >= a.size
    bits = a.size * 8 - (a.kind == "signed")  # value bits of the integer
    if b.kind == "float":
        return bits <= _MANTISSA[b.size]
    if a.kind == b.kind:
        return b.size >= a.size
    return a.kind == "unsigned" and b.kind == "signed" and b.size > a.size


def code(s: Scalar) -> str:
    """A scalar's kind and size as a copy names it: s2 (int16_t), u4, f8 (double), b1 (bool)."""
    return f"{s.kind[0]}{s.size}"


@dataclass(frozen=True)
class Shape:
    """What a value's bytes are, from either side: a scalar, or a struct's fields with their offsets."""

    scalar: Scalar | None
    size: int
    fields: tuple[tuple[str, Shape, tuple[int, ...], int], ...] = ()  # (name, shape, dims, offset)


def shape_of(t: Type) -> Shape:
    """The shape of a type of the layout being compiled."""
    if isinstance(t, StructType):
        return Shape(None, t.size, tuple((f.name, shape_of(f.type), tuple(f.dims), f.offset) for f in t.fields))
    return Shape(t, t.size)


def shape_in(types: dict[str, Any], name: str) -> Shape:
    """The shape of type `name` of a layout.json's `types` (the previous layout); KeyError, TypeError
    or ValueError when the document does not describe it."""
    if name in SCALARS:
        return Shape(SCALARS[name], SCALARS[name].size)
    t = types[name]
    fields = tuple(
        (str(f["name"]), shape_in(types, f["type"]), tuple(int(d) for d in f["dims"]), int(f["offset"]))
        for f in t["fields"]
    )
    return Shape(None, int(t["size"]), fields)


class NotConvertible(Exception):
    """Why a variable's value cannot be carried over (its path and what changed)."""


def _describe(s: Shape) -> str:
    return s.scalar.name if s.scalar else "a struct"


class _Plan:
    def __init__(self) -> None:
        self.copies: list[dict[str, Any]] = []
        self.dropped: list[str] = []

    def value(
        self, path: str, old: Shape, old_dims: tuple[int, ...], at: int, new: Shape, new_dims: tuple[int, ...], to: int
    ):
        if len(old_dims) != len(new_dims):
            raise NotConvertible(f"{path}: {len(old_dims)} array dimensions become {len(new_dims)}")
        if old_dims:
            self.array(path, old, old_dims, at, new, new_dims, to)
        elif old.scalar and new.scalar:
            if not lossless(old.scalar, new.scalar):
                raise NotConvertible(f"{path}: {old.scalar.name} to {new.scalar.name} may lose values")
            self.copies.append({"from": at, "to": to, "from_type": code(old.scalar), "to_type": code(new.scalar),
                                "count": 1, "from_stride": 0, "to_stride": 0})  # fmt: skip
        elif old.scalar or new.scalar:
            raise NotConvertible(f"{path}: {_describe(old)} becomes {_describe(new)}")
        else:
            self.struct(path, old, at, new, to)

    def struct(self, path: str, old: Shape, at: int, new: Shape, to: int) -> None:
        before = {name: (s, dims, offset) for name, s, dims, offset in old.fields}
        now = {name for name, _, _, _ in new.fields}
        for name, s, dims, offset in new.fields:
            if name in before:  # a new field starts at zero
                o, o_dims, o_offset = before[name]
                self.value(f"{path}.{name}", o, o_dims, at + o_offset, s, dims, to + offset)
        self.dropped += [f"{path}.{name}" for name, _, _, _ in old.fields if name not in now]

    def array(
        self, path: str, old: Shape, old_dims: tuple[int, ...], at: int, new: Shape, new_dims: tuple[int, ...], to: int
    ):
        old_stride, new_stride = old.size, new.size
        for d in old_dims[1:]:
            old_stride *= d
        for d in new_dims[1:]:
            new_stride *= d
        common = min(old_dims[0], new_dims[0])
        if old_dims[0] > new_dims[0]:
            self.dropped.append(f"{path}[{new_dims[0]}..{old_dims[0] - 1}]")
        # Element 0's copies, repeated over the common range: one copy with a count when they are
        # single values, else element by element (arrays of arrays).
        element = _Plan()
        element.value(f"{path}[*]", old, old_dims[1:], at, new, new_dims[1:], to)
        self.dropped += element.dropped
        if all(c["count"] == 1 for c in element.copies):
            for c in element.copies:
                self.copies.append(c | {"count": common, "from_stride": old_stride, "to_stride": new_stride})
            return
        for i in range(common):
            for c in element.copies:
                self.copies.append(c | {"from": c["from"] + i * old_stride, "to": c["to"] + i * new_stride})


def plan(
    path: str, old: Shape, old_dims: list[int], at: int, new: Shape, new_dims: list[int], to: int
) -> dict[str, Any]:
    """The copies that carry a retyped variable's value from offset `at` (its old place) to `to`, and
    what is dropped; NotConvertible with the reason when its value cannot be kept."""
    p = _Plan()
    p.value(path, old, tuple(old_dims), at, new, tuple(new_dims), to)
    return {"dropped": p.dropped, "copies": p.copies}

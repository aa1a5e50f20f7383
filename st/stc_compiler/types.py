# types.py -- the IEC 61131-3 types as the checker and the code generators see them: elementary types
# (with their C++ / glbc scalar), STRING[n], ARRAY, STRUCT, enumerations, subranges, FB instances,
# the generic families (ANY_NUM, ...) and the implicit conversions the standard allows.

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


class Type:
    name: str

    def __str__(self) -> str:
        return self.name


@dataclass(eq=False)
class Elementary(Type):
    """kind: bool, bit, int (signed), uint, real, time, date, tod, dt; cpp: the C++ / glbc scalar."""

    name: str
    kind: str
    bits: int
    cpp: str

    def __repr__(self) -> str:
        return self.name


def _elementary() -> dict[str, Elementary]:
    rows = [
        ("BOOL", "bool", 1, "bool"),
        ("BYTE", "bit", 8, "uint8_t"),
        ("WORD", "bit", 16, "uint16_t"),
        ("DWORD", "bit", 32, "uint32_t"),
        ("LWORD", "bit", 64, "uint64_t"),
        ("SINT", "int", 8, "int8_t"),
        ("INT", "int", 16, "int16_t"),
        ("DINT", "int", 32, "int32_t"),
        ("LINT", "int", 64, "int64_t"),
        ("USINT", "uint", 8, "uint8_t"),
        ("UINT", "uint", 16, "uint16_t"),
        ("UDINT", "uint", 32, "uint32_t"),
        ("ULINT", "uint", 64, "uint64_t"),
        ("REAL", "real", 32, "float"),
        ("LREAL", "real", 64, "double"),
        # durations and points in time: int64_t nanoseconds (docs/st.md, "Types")
        ("TIME", "time", 64, "int64_t"),
        ("LTIME", "time", 64, "int64_t"),
        ("DATE", "date", 64, "int64_t"),
        ("LDATE", "date", 64, "int64_t"),
        ("TOD", "tod", 64, "int64_t"),
        ("LTOD", "tod", 64, "int64_t"),
        ("DT", "dt", 64, "int64_t"),
        ("LDT", "dt", 64, "int64_t"),
    ]
    return {name: Elementary(name, kind, bits, cpp) for name, kind, bits, cpp in rows}


ELEMENTARY = _elementary()
ALIASES = {"TIME_OF_DAY": "TOD", "DATE_AND_TIME": "DT", "LTIME_OF_DAY": "LTOD", "LDATE_AND_TIME": "LDT"}
BOOL, INT, DINT, LINT, REAL, LREAL = (ELEMENTARY[n] for n in ("BOOL", "INT", "DINT", "LINT", "REAL", "LREAL"))
TIME, LTIME = ELEMENTARY["TIME"], ELEMENTARY["LTIME"]
DEFAULT_STRING_LENGTH = 80
MAX_STRING_LENGTH = 65535


@dataclass(eq=False)
class StringType(Type):
    length: int
    wide: bool = False

    @property
    def name(self) -> str:  # type: ignore[override]
        base = "WSTRING" if self.wide else "STRING"
        return base if self.length == DEFAULT_STRING_LENGTH else f"{base}[{self.length}]"


STRING = StringType(DEFAULT_STRING_LENGTH)
WSTRING = StringType(DEFAULT_STRING_LENGTH, True)


@dataclass(eq=False)
class ArrayType(Type):
    dims: list[tuple[int, int]]
    element: Type
    element_init: Any = None  # the initial value of its elements' derived type (TYPE X : INT := 5)

    @property
    def name(self) -> str:  # type: ignore[override]
        ranges = ", ".join(f"{lo}..{hi}" for lo, hi in self.dims)
        return f"ARRAY[{ranges}] OF {self.element}"


@dataclass(eq=False)
class StructType(Type):
    name: str
    members: dict[str, Any] = field(default_factory=dict)  # upper-case name -> tree.VarDecl, in order


@dataclass(eq=False)
class EnumType(Type):
    name: str
    values: dict[str, Any] = field(default_factory=dict)  # upper-case name -> tree.EnumValue
    cpp: str = "int16_t"


@dataclass(eq=False)
class SubrangeType(Type):
    name: str
    base: Elementary
    low: int
    high: int


@dataclass(eq=False)
class FbType(Type):
    """The type of an FB instance: its FUNCTION_BLOCK (tree.Pou)."""

    pou: Any

    @property
    def name(self) -> str:  # type: ignore[override]
        return self.pou.name


@dataclass(eq=False)
class LiteralType(Type):
    """An untyped numeric literal (`5`, `1.5`) before its context gives it a type: it fits any
    integer, bit string or real type that holds its value (int), or any real type (real)."""

    kind: str  # int or real
    value: Any  # the value when constant; None for an untyped call such as MAX(1, 70000)
    # The smallest and largest literal the expression is made of (MAX(1, 70000): 1 and 70000): every
    # one must fit the type the context gives (IEC types each literal operand by its context).
    low: Any = None
    high: Any = None

    def __post_init__(self) -> None:
        self.low = self.value if self.low is None else self.low
        self.high = self.value if self.high is None else self.high

    @property
    def name(self) -> str:  # type: ignore[override]
        return "an integer literal" if self.kind == "int" else "a real literal"

    def misfit(self, t: Type) -> Any:
        """The first of its literals that does not fit t, or None when all fit."""
        return next((v for v in (self.low, self.high) if v is not None and not fits(t, v)), None)

    def default(self) -> Elementary:
        if self.kind == "real":
            return LREAL
        return DINT if self.misfit(DINT) is None else LINT


def literal_span(a: LiteralType, b: LiteralType) -> LiteralType:
    """The untyped literal type of an expression of both (an integer one only if both are)."""
    kind = "real" if "real" in (a.kind, b.kind) else "int"
    lows = [v for v in (a.low, b.low) if v is not None]
    highs = [v for v in (a.high, b.high) if v is not None]
    return LiteralType(kind, None, min(lows) if lows else None, max(highs) if highs else None)


def base(t: Type) -> Type:
    """A subrange's base type; every other type itself."""
    return t.base if isinstance(t, SubrangeType) else t


def kind(t: Type) -> str | None:
    t = base(t)
    if isinstance(t, Elementary):
        return t.kind
    if isinstance(t, StringType):
        return "string"
    if isinstance(t, LiteralType):
        return "lit_" + t.kind
    return None


def value_range(t: Elementary) -> tuple[int, int]:
    if t.kind in ("uint", "bit"):
        return 0, (1 << t.bits) - 1
    if t.kind == "int":
        return -(1 << (t.bits - 1)), (1 << (t.bits - 1)) - 1
    if t.kind == "bool":
        return 0, 1
    return -(1 << 63), (1 << 63) - 1


def fits(t: Type, value: int) -> bool:
    t = base(t)
    if isinstance(t, SubrangeType):
        return t.low <= value <= t.high
    if isinstance(t, Elementary):
        lo, hi = value_range(t)
        return lo <= value <= hi
    return False


# ---- generic families (IEC 61131-3 3rd ed., figure 5) -----------------------------------------

GENERIC = {
    "ANY": {"bool", "bit", "int", "uint", "real", "time", "date", "tod", "dt", "string", "derived"},
    "ANY_ELEMENTARY": {"bool", "bit", "int", "uint", "real", "time", "date", "tod", "dt", "string"},
    "ANY_MAGNITUDE": {"int", "uint", "real", "time"},
    "ANY_NUM": {"int", "uint", "real"},
    "ANY_REAL": {"real"},
    "ANY_INT": {"int", "uint"},
    "ANY_SIGNED": {"int"},
    "ANY_UNSIGNED": {"uint"},
    "ANY_BIT": {"bool", "bit"},
    "ANY_STRING": {"string"},
    "ANY_DATE": {"date", "tod", "dt"},
    "ANY_DURATION": {"time"},
}


def in_family(t: Type, family: str) -> bool:
    kinds = GENERIC[family]
    k = kind(t)
    if k == "lit_int":
        return bool(kinds & {"int", "uint", "real", "bit"})
    if k == "lit_real":
        return "real" in kinds
    if k is None:
        return "derived" in kinds and isinstance(base(t), (EnumType, StructType, ArrayType))
    return k in kinds


# ---- implicit conversions (IEC 61131-3 3rd ed., table 11): widening only ----------------------

_WIDENS_TO = {
    "SINT": "INT DINT LINT REAL LREAL",
    "INT": "DINT LINT REAL LREAL",
    "DINT": "LINT LREAL",
    "USINT": "UINT UDINT ULINT INT DINT LINT REAL LREAL",
    "UINT": "UDINT ULINT DINT LINT REAL LREAL",
    "UDINT": "ULINT LINT LREAL",
    "REAL": "LREAL",
    "BYTE": "WORD DWORD LWORD",
    "WORD": "DWORD LWORD",
    "DWORD": "LWORD",
    "TIME": "LTIME",
    "DATE": "LDATE",
    "TOD": "LTOD",
    "DT": "LDT",
}
WIDENS_TO = {k: frozenset(v.split()) for k, v in _WIDENS_TO.items()}


def same(a: Type, b: Type) -> bool:
    a, b = base(a), base(b)
    if a is b:
        return True
    if isinstance(a, StringType) and isinstance(b, StringType):
        return a.wide == b.wide
    if isinstance(a, ArrayType) and isinstance(b, ArrayType):
        sizes = [hi - lo for lo, hi in a.dims] == [hi - lo for lo, hi in b.dims]
        return sizes and same(a.element, b.element)
    return False


def converts(src: Type, dst: Type) -> bool:
    """Whether a value of `src` may be stored in `dst` with no conversion written (widening only)."""
    if same(src, dst):
        return True
    s, d = base(src), base(dst)
    if isinstance(s, LiteralType):
        if not isinstance(d, Elementary):
            return False
        if s.kind == "real":
            return d.kind == "real"
        if d.kind == "real":
            return True
        return d.kind in ("int", "uint", "bit") and s.misfit(dst) is None
    if isinstance(s, Elementary) and isinstance(d, Elementary):
        return d.name in WIDENS_TO.get(s.name, ())
    return False


def common(a: Type, b: Type) -> Type | None:
    """The type both convert to implicitly (the wider one), or None."""
    if isinstance(base(a), LiteralType) and isinstance(base(b), LiteralType):
        return literal_span(base(a), base(b))
    if converts(a, b):
        return base(b) if not isinstance(base(a), LiteralType) or not isinstance(b, SubrangeType) else b.base
    if converts(b, a):
        return base(a)
    return None


def concrete(t: Type) -> Type:
    """A literal's default type where nothing else gives it one."""
    return t.default() if isinstance(t, LiteralType) else t

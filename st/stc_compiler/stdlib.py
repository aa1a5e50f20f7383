# stdlib.py -- the standard functions of IEC 61131-3 (3rd ed.) as one table: name, parameters (name and
# type: an elementary type, a generic family, or a type variable `T` bound by the call) and result.
# check.py types calls with it; the code generator maps each entry to the runtime (st/runtime).

from __future__ import annotations

from dataclasses import dataclass

from .types import ELEMENTARY


@dataclass(frozen=True)
class Param:
    name: str
    type: str  # "INT", "ANY_INT", "T" (bound by the call; then `family` restricts it)
    family: str = "ANY"


@dataclass(frozen=True)
class Function:
    """`extensible`: the last parameter repeats (IN1, IN2, IN3, ...; at least len(params) given)."""

    name: str
    params: tuple[Param, ...]
    result: str  # a type name, "T", or a generic family (e.g. TRUNC's ANY_INT resolves to DINT)
    extensible: bool = False
    kind: str = "function"  # function, conversion, operator (ADD...), intrinsic


def _p(spec: str) -> tuple[Param, ...]:
    """'IN:T:ANY_NUM, N:ANY_INT' -> Params."""
    out = []
    for part in filter(None, (s.strip() for s in spec.split(","))):
        name, typ, *family = part.split(":")
        out.append(Param(name, typ, family[0] if family else "ANY"))
    return tuple(out)


FUNCTIONS: dict[str, Function] = {}


def _add(name: str, params: str, result: str, extensible: bool = False, kind: str = "function") -> None:
    FUNCTIONS[name] = Function(name, _p(params), result, extensible, kind)


# numeric
_add("ABS", "IN:T:ANY_NUM", "T")
for _name in ("SQRT", "LN", "LOG", "EXP", "SIN", "COS", "TAN", "ASIN", "ACOS", "ATAN"):
    _add(_name, "IN:T:ANY_REAL", "T")
_add("EXPT", "IN1:T:ANY_REAL, IN2:ANY_NUM", "T")
# arithmetic as functions
_add("ADD", "IN1:T:ANY_MAGNITUDE, IN2:T:ANY_MAGNITUDE", "T", extensible=True, kind="operator")
_add("MUL", "IN1:T:ANY_NUM, IN2:T:ANY_NUM", "T", extensible=True, kind="operator")
_add("SUB", "IN1:T:ANY_MAGNITUDE, IN2:T:ANY_MAGNITUDE", "T", kind="operator")
_add("DIV", "IN1:T:ANY_NUM, IN2:T:ANY_NUM", "T", kind="operator")
_add("MOD", "IN1:T:ANY_INT, IN2:T:ANY_INT", "T", kind="operator")
_add("MOVE", "IN:T:ANY", "T", kind="operator")
# bit strings
for _name in ("SHL", "SHR", "ROL", "ROR"):
    _add(_name, "IN:T:ANY_BIT, N:ANY_INT", "T")
for _name in ("AND", "OR", "XOR"):
    _add(_name, "IN1:T:ANY_BIT, IN2:T:ANY_BIT", "T", extensible=True, kind="operator")
_add("NOT", "IN:T:ANY_BIT", "T", kind="operator")
# selection
_add("SEL", "G:BOOL, IN0:T:ANY, IN1:T:ANY", "T")
_add("MAX", "IN1:T:ANY_ELEMENTARY, IN2:T:ANY_ELEMENTARY", "T", extensible=True)
_add("MIN", "IN1:T:ANY_ELEMENTARY, IN2:T:ANY_ELEMENTARY", "T", extensible=True)
_add("LIMIT", "MN:T:ANY_ELEMENTARY, IN:T:ANY_ELEMENTARY, MX:T:ANY_ELEMENTARY", "T")
_add("MUX", "K:ANY_INT, IN0:T:ANY, IN1:T:ANY", "T", extensible=True)
# comparison
for _name in ("GT", "GE", "EQ", "LE", "LT", "NE"):
    _add(_name, "IN1:T:ANY_ELEMENTARY, IN2:T:ANY_ELEMENTARY", "BOOL", kind="operator")
# strings (positions and lengths are 1-based INTs, as IEC says)
_add("LEN", "IN:STRING", "INT")
_add("LEFT", "IN:STRING, L:ANY_INT", "STRING")
_add("RIGHT", "IN:STRING, L:ANY_INT", "STRING")
_add("MID", "IN:STRING, L:ANY_INT, P:ANY_INT", "STRING")
_add("CONCAT", "IN1:STRING, IN2:STRING", "STRING", extensible=True)
_add("INSERT", "IN1:STRING, IN2:STRING, P:ANY_INT", "STRING")
_add("DELETE", "IN:STRING, L:ANY_INT, P:ANY_INT", "STRING")
_add("REPLACE", "IN1:STRING, IN2:STRING, L:ANY_INT, P:ANY_INT", "STRING")
_add("FIND", "IN1:STRING, IN2:STRING", "INT")
# truncation: TRUNC gives a DINT (as CODESYS); REAL_TRUNC_INT etc. name their result
_add("TRUNC", "IN:ANY_REAL", "DINT", kind="conversion")

# The runtime's one intrinsic: the due time of the running period, irp::cycle().planned_ns
# (rtcore/include/indurop/indurop.h), as LTIME; st/lib/standard.st's timers run on it.
CYCLE_TIME = "__CYCLE_TIME_NS"
_add(CYCLE_TIME, "", "LTIME", kind="intrinsic")

# ---- conversions *_TO_* ------------------------------------------------------------------------

_NUMERIC = ["SINT", "INT", "DINT", "LINT", "USINT", "UINT", "UDINT", "ULINT", "REAL", "LREAL"]
_BITS = ["BOOL", "BYTE", "WORD", "DWORD", "LWORD"]
_TIMES = ["TIME", "LTIME"]
_DATES = ["DATE", "LDATE", "TOD", "LTOD", "DT", "LDT"]
_STRINGS = ["STRING", "WSTRING"]
_SPELLINGS = {"TOD": ["TOD", "TIME_OF_DAY"], "DT": ["DT", "DATE_AND_TIME"], "LTOD": ["LTOD"], "LDT": ["LDT"]}


def _conversion_pairs() -> list[tuple[str, str]]:
    """Every pair the standard's table 22 has (and CODESYS's numeric <-> TIME/DATE ones, docs/st.md)."""
    pairs = []
    plain = _NUMERIC + _BITS + _TIMES + _STRINGS
    for a in plain:
        for b in plain:
            if a != b:
                pairs.append((a, b))
    for d in _DATES:  # points in time: to and from integers and strings, and between their own kinds
        for other in _NUMERIC[:8] + _BITS[1:] + _STRINGS:
            pairs += [(d, other), (other, d)]
    pairs += [("DT", "DATE"), ("DT", "TOD"), ("LDT", "LDATE"), ("LDT", "LTOD"), ("LDT", "DT"), ("DT", "LDT")]
    pairs += [("LDATE", "DATE"), ("DATE", "LDATE"), ("LTOD", "TOD"), ("TOD", "LTOD"), ("LDT", "DATE"), ("LDT", "TOD")]
    return pairs


for _src, _dst in _conversion_pairs():
    for _s in _SPELLINGS.get(_src, [_src]):
        for _d in _SPELLINGS.get(_dst, [_dst]):
            _add(f"{_s}_TO_{_d}", f"IN:{_src}", _dst, kind="conversion")
for _src in ("REAL", "LREAL"):
    for _dst in _NUMERIC[:8]:
        _add(f"{_src}_TRUNC_{_dst}", f"IN:{_src}", _dst, kind="conversion")
for _dst in _NUMERIC + _BITS + _TIMES + _STRINGS:  # 3rd edition's generic TO_INT(x), ...
    _add(f"TO_{_dst}", "IN:ANY_ELEMENTARY", _dst, kind="conversion")

assert all(t in ELEMENTARY or t in ("STRING", "WSTRING") for t in _NUMERIC + _BITS + _TIMES + _DATES)


def conversion(src: str, dst: str) -> str | None:
    """The name of the function that converts src to dst, if the table has one."""
    name = f"{src}_TO_{dst}"
    return name if name in FUNCTIONS else None


def lookup(name: str) -> Function | None:
    return FUNCTIONS.get(name.upper())


def described() -> list[dict]:
    """The table as data, by name: {name, kind, result, params [{name, type}], extensible}, a generic
    parameter's type its family (the web UI's generated st_language.ts and the agent's symbols)."""
    return [
        {
            "name": f.name,
            "kind": f.kind,
            "result": f.result,
            "params": [{"name": p.name, "type": p.family if p.type == "T" else p.type} for p in f.params],
            "extensible": f.extensible,
        }
        for f in sorted(FUNCTIONS.values(), key=lambda f: f.name)
    ]

# literals.py -- the values of ST literals as the grammar's terminals spell them: integers in any base,
# reals, strings with $-escapes, durations (ns), dates, times of day and date-and-times (ns).

from __future__ import annotations

import datetime
import re

from lark import Token, Tree

from . import tree as t
from .errors import Place

NS = {
    "d": 86_400_000_000_000,
    "h": 3_600_000_000_000,
    "m": 60_000_000_000,
    "s": 1_000_000_000,
    "ms": 1_000_000,
    "us": 1_000,
    "ns": 1,
}
_DURATION_PART = re.compile(r"([0-9][0-9_]*(?:\.[0-9_]+)?)(ms|us|ns|d|h|m|s)", re.IGNORECASE)
_ESCAPES = {"$": "$", "'": "'", '"': '"', "L": "\n", "N": "\n", "P": "\f", "R": "\r", "T": "\t"}
_EPOCH = datetime.datetime(1970, 1, 1)


def integer(text: str) -> int:
    text = text.replace("_", "")
    if "#" in text:
        base, digits = text.split("#", 1)
        return int(digits, int(base))
    return int(text)


def real(text: str) -> float:
    return float(text.replace("_", ""))


def string(text: str, wide: bool) -> str:
    """The value of '...' or "..." with its $-escapes ($$, $', $L, $N, $P, $R, $T, $hh or $hhhh)."""
    body = text[1:-1]
    out: list[str] = []
    i = 0
    hex_len = 4 if wide else 2
    while i < len(body):
        ch = body[i]
        if ch != "$":
            out.append(ch)
            i += 1
            continue
        nxt = body[i + 1 : i + 2]
        if nxt.upper() in _ESCAPES:
            out.append(_ESCAPES[nxt.upper()])
            i += 2
            continue
        code = body[i + 1 : i + 1 + hex_len]
        if len(code) == hex_len and re.fullmatch(r"[0-9A-Fa-f]+", code):
            out.append(chr(int(code, 16)))
            i += 1 + hex_len
            continue
        raise ValueError(f"'${nxt}' is not a string escape; write $$ for a dollar, or one of $' $L $N $P $R $T $hh")
    return "".join(out)


def duration(text: str) -> tuple[str, int]:
    """`T#1s200ms`, `TIME#-5ms`, `LTIME#1.5h` -> ('TIME' or 'LTIME', nanoseconds)."""
    prefix, body = text.split("#", 1)
    kind = "LTIME" if prefix.upper() in ("LTIME", "LT") else "TIME"
    sign = -1 if body.startswith("-") else 1
    body = body.lstrip("+-")
    total = 0.0
    pos = 0
    for m in _DURATION_PART.finditer(body):
        if m.start() != pos:
            break
        total += float(m.group(1).replace("_", "")) * NS[m.group(2).lower()]
        pos = m.end()
        if pos < len(body) and body[pos] == "_":
            pos += 1
    if pos != len(body) or not body:
        raise ValueError(f"'{text}' is not a duration; write e.g. T#1s200ms (units d, h, m, s, ms, us, ns)")
    return kind, sign * round(total)


def _clock(text: str) -> int:
    parts = text.split(":")
    hours, minutes = int(parts[0]), int(parts[1])
    seconds = float(parts[2]) if len(parts) > 2 else 0.0
    if hours > 23 or minutes > 59 or seconds >= 60:
        raise ValueError(f"'{text}' is not a time of day; hours 0..23, minutes and seconds 0..59")
    return hours * NS["h"] + minutes * NS["m"] + round(seconds * NS["s"])


def _date(text: str) -> int:
    y, m, d = (int(x) for x in text.split("-"))
    try:
        day = datetime.datetime(y, m, d)
    except ValueError:
        raise ValueError(f"'{text}' is not a date; write YYYY-MM-DD") from None
    return (day - _EPOCH) // datetime.timedelta(microseconds=1) * 1000


def point_in_time(text: str) -> tuple[str, str, int]:
    """D#, TOD#, DT# literals -> (kind, type name, nanoseconds)."""
    prefix, body = text.split("#", 1)
    p = prefix.upper()
    if p in ("D", "DATE", "LD", "LDATE"):
        return "date", ("LDATE" if p.startswith("L") else "DATE"), _date(body)
    if p in ("TOD", "TIME_OF_DAY", "LTOD", "LTIME_OF_DAY"):
        return "tod", ("LTOD" if p.startswith("L") else "TOD"), _clock(body)
    date, clock = body.rsplit("-", 1) if body.count("-") >= 3 else (body, "0:0")
    return "dt", ("LDT" if p.startswith("L") else "DT"), _date(date) + _clock(clock)


def build(place: Place, node: Tree) -> t.Literal:
    """A literal rule of st.lark -> a Literal; ValueError with the fix when the text is no value."""
    kind = node.data
    if kind == "typed_lit":
        prefix, value = node.children
        lit = _plain(place, value)
        lit.prefix = str(prefix)
        lit.text = f"{prefix}#{lit.text}"
        return lit
    return _plain(place, node.children[0] if kind != "time_lit" else node.children[0], kind)


def _plain(place: Place, node, rule: str | None = None) -> t.Literal:
    if isinstance(node, Tree):  # signed_number
        sign, number = node.children
        lit = _plain(place, number)
        if str(sign) == "-":
            lit.value = -lit.value
        lit.text = f"{sign}{lit.text}"
        return lit
    tok: Token = node
    text = str(tok)
    typ = tok.type
    if typ in ("INTEGER", "BASED_INTEGER"):
        return t.Literal(place, "int", integer(text), text)
    if typ == "REAL_NUMBER":
        return t.Literal(place, "real", real(text), text)
    if typ in ("TRUE", "FALSE"):
        return t.Literal(place, "bool", typ == "TRUE", text)
    if typ == "STRING_LITERAL":
        return t.Literal(place, "string", string(text, False), text)
    if typ == "WSTRING_LITERAL":
        return t.Literal(place, "wstring", string(text, True), text)
    if typ == "DURATION":
        type_name, ns = duration(text)
        return t.Literal(place, "duration", ns, text, type_name)
    if typ in ("DATE_LITERAL", "TOD_LITERAL", "DT_LITERAL"):
        kind, type_name, ns = point_in_time(text)
        return t.Literal(place, kind, ns, text, type_name)
    if typ == "IDENT":  # Color#Red
        return t.Literal(place, "enum", text, text)
    raise ValueError(f"'{text}' is not a literal")  # pragma: no cover (grammar and builder agree)

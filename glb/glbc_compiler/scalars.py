# scalars.py -- the scalar types a .glb may declare, as g++ lays them out on x86-64 Linux (LP64),
# and how a sequence of C type words (`unsigned long int`) maps to one of them.

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Scalar:
    """A scalar type: its C++ spelling (used in the header and layout.json), size, alignment and
    kind (signed, unsigned, float or bool: what a decoder needs to read it)."""

    name: str
    size: int
    align: int
    kind: str


def _table() -> dict[str, Scalar]:
    rows = [
        ("int8_t", 1, "signed"),
        ("uint8_t", 1, "unsigned"),
        ("int16_t", 2, "signed"),
        ("uint16_t", 2, "unsigned"),
        ("int32_t", 4, "signed"),
        ("uint32_t", 4, "unsigned"),
        ("int64_t", 8, "signed"),
        ("uint64_t", 8, "unsigned"),
        ("char", 1, "signed"),  # char is signed on x86-64 Linux
        ("signed char", 1, "signed"),
        ("unsigned char", 1, "unsigned"),
        ("short", 2, "signed"),
        ("unsigned short", 2, "unsigned"),
        ("int", 4, "signed"),
        ("unsigned int", 4, "unsigned"),
        ("long", 8, "signed"),
        ("unsigned long", 8, "unsigned"),
        ("long long", 8, "signed"),
        ("unsigned long long", 8, "unsigned"),
        ("float", 4, "float"),
        ("double", 8, "float"),
        ("bool", 1, "bool"),
    ]
    return {name: Scalar(name, size, size, kind) for name, size, kind in rows}


SCALARS: dict[str, Scalar] = _table()

# Types written as one word.  BOOL is the PLC spelling of bool (Figure 11's I/O points).
SINGLE_WORD: dict[str, str] = {
    **{
        n: n
        for n in (
            "int8_t",
            "uint8_t",
            "int16_t",
            "uint16_t",
            "int32_t",
            "uint32_t",
            "int64_t",
            "uint64_t",
            "float",
            "double",
            "bool",
        )
    },
    "BOOL": "bool",
}

# The C words that combine into one type, in any order (`unsigned long int`, `long unsigned`).
COMBINING_WORDS = frozenset({"signed", "unsigned", "short", "long", "int", "char"})

# Every word that can start a scalar type.
TYPE_WORDS = frozenset(SINGLE_WORD) | COMBINING_WORDS


def combine(words: list[str]) -> str | None:
    """The C++ spelling of a combination of COMBINING_WORDS, or None when C does not allow it."""
    count = {w: words.count(w) for w in COMBINING_WORDS}
    signed, unsigned = count["signed"], count["unsigned"]
    short, long_, int_, char = count["short"], count["long"], count["int"], count["char"]
    if signed + unsigned > 1 or short > 1 or long_ > 2 or int_ > 1 or char > 1:
        return None
    if char:
        if short or long_ or int_:
            return None
        return "signed char" if signed else "unsigned char" if unsigned else "char"
    if short and long_:
        return None
    prefix = "unsigned " if unsigned else ""
    if short:
        return prefix + "short"
    if long_ == 2:
        return prefix + "long long"
    if long_ == 1:
        return prefix + "long"
    return "unsigned int" if unsigned else "int"  # int, signed, signed int, unsigned

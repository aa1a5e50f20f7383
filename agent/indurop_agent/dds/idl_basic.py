"""idl_basic.py -- ROS 2's basic field types, by the names rosbags' parsers give them, as cyclonedds
annotations with the kind and width of the values they hold.

One table for both users: protocol/dds/generate.py writes ros2_types.py with it (it loads this file
by path: nothing here imports the generated code), and declared.py builds and checks the message
types a dds.json declares with it.  Both say rosbags' parse errors with rosbags_reason.
"""

from __future__ import annotations

import ast
from typing import NamedTuple


class Basic(NamedTuple):
    annotation: str  # the cyclonedds annotation as Python source: "types.int16", "bool", "str"
    kind: str  # bool, signed, unsigned, float (a variable's layout kinds), char or string
    bits: int  # the values' width; 1 for bool, 0 for a string


BASIC = {
    "bool": Basic("bool", "bool", 1),
    "byte": Basic("types.byte", "unsigned", 8),  # IDL octet (ROS 2 byte)
    "char": Basic("types.char", "char", 8),  # IDL char; a .msg's char is uint8 (msg_basic)
    "int8": Basic("types.int8", "signed", 8),
    "uint8": Basic("types.uint8", "unsigned", 8),
    "int16": Basic("types.int16", "signed", 16),
    "uint16": Basic("types.uint16", "unsigned", 16),
    "int32": Basic("types.int32", "signed", 32),
    "uint32": Basic("types.uint32", "unsigned", 32),
    "int64": Basic("types.int64", "signed", 64),
    "uint64": Basic("types.uint64", "unsigned", 64),
    "float32": Basic("types.float32", "float", 32),
    "float64": Basic("types.float64", "float", 64),
    "string": Basic("str", "string", 0),
}


def msg_basic(name: str) -> str:
    """A .msg basic type as ROS 2 puts it on DDS: `char` is an uint8 there (rosidl's mapping)."""
    return "uint8" if name == "char" else name


def value_range(basic: str) -> tuple[float, float] | None:
    """The integers a signed or unsigned basic type holds; None for the others."""
    b = BASIC[basic]
    if b.kind == "signed":
        return -(1 << (b.bits - 1)), (1 << (b.bits - 1)) - 1
    if b.kind == "unsigned":
        return 0, (1 << b.bits) - 1
    return None


def holds(dst: tuple[str, int], src: tuple[str, int]) -> bool:
    """Whether every value of kind and width `src` is held exactly by `dst` (kind, bits): a
    variable's type against a message field's, in the direction the values go."""
    dkind, dbits = dst
    skind, sbits = src
    if skind == "bool":
        return dkind in ("bool", "signed", "unsigned")
    if dkind == "bool" or skind not in ("signed", "unsigned", "float"):
        return False
    if skind == "float":
        return dkind == "float" and dbits >= sbits
    if dkind == "float":
        return sbits <= (16 if dbits == 32 else 32)  # exact in a float's 24 or a double's 53 bits
    if dkind == "signed":
        return sbits <= dbits if skind == "signed" else sbits < dbits
    return skind == "unsigned" and sbits <= dbits


def rosbags_reason(e: Exception) -> str:
    """rosbags' parse error (the text it read, the offset where it gave up, ...) as a line number,
    the words there and what it expected."""
    lines = str(e).splitlines()
    if len(lines) >= 4 and lines[2].isdigit():
        try:
            text = ast.literal_eval(lines[1])
        except (ValueError, SyntaxError):
            text = ""
        line = text.count("\n", 0, int(lines[2])) + 1 - text.startswith("MSG: ")
        words = lines[3].strip()[:40]
        expected = f"; it expected {lines[-1]}" if len(lines) >= 5 else ""
        return f"line {line} of its definition: rosbags cannot read {words!r}{expected}"
    return lines[0] if lines else type(e).__name__

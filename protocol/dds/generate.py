#!/usr/bin/env python3
"""Writes the DDS bridge's generated files from their truths in protocol/.

- protocol/ros2/<package>/msg/<Message>.idl are ROS 2's message definitions in the form ROS 2 puts
  on the DDS wire (module <package>::msg::dds_, struct <Message>_).  They are the one truth of the
  bridge's types: this writes agent/indurop_agent/dds/ros2_types.py (cyclonedds IdlStruct classes)
  from them, and the compatibility test builds its separate C reader from the same files with
  Debian's idlc.
- protocol/dds/**/*.idl are indurop's own DDS types (module indurop::dds: the shared variables
  controllers export to each other); they are written into agent/indurop_agent/dds/indurop_types.py
  the same way, `@key` members becoming the type's keys.
- protocol/dds/bridge.schema.json is the shape of a set's dds.json: this writes it into
  agent/indurop_agent/dds/bridge_schema.py, after checking that every message type it names has
  its IDL here.

`--check` fails, naming this command, when a written file is stale.

Cyclone DDS's own idlc Python backend (`idlc -l py`) is not used: the cyclonedds wheel ships its
backend without an idlc, and Debian's idlc 0.10.2 crashes loading the wheel's 11.x backend
(docs/dds.md).  So this reads the small part of IDL the ROS 2 messages use — modules, structs,
constants, sequence<>, string, the basic types and the `@key` annotation — and refuses anything
else, naming file and line.

    python3 protocol/dds/generate.py [--check]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HERE = ROOT / "protocol" / "ros2"  # the ROS 2 messages' IDL files
OWN = ROOT / "protocol" / "dds"  # indurop's own DDS types' IDL files
SCHEMA = ROOT / "protocol" / "dds" / "bridge.schema.json"
OUT = ROOT / "agent" / "indurop_agent" / "dds"
COMMAND = "python3 protocol/dds/generate.py"

# IDL type -> (the annotation in the generated Python, the C/IDL spelling kept for the table)
BASIC = {
    "boolean": "bool",
    "octet": "types.byte",  # IDL octet (ROS 2 byte): TK_BYTE, which Cyclone 0.10 also knows
    "char": "types.char",
    "int8": "types.int8",
    "uint8": "types.uint8",
    "int16": "types.int16",
    "uint16": "types.uint16",
    "int32": "types.int32",
    "uint32": "types.uint32",
    "int64": "types.int64",
    "uint64": "types.uint64",
    "float": "types.float32",
    "double": "types.float64",
    "string": "str",
}

TOKEN = re.compile(r"\s*(?:(//[^\n]*)|(#include\s+\"[^\"]+\")|(::|[{};<>=,])|(@?[A-Za-z_][A-Za-z0-9_]*)|(-?\d+))")


class IdlError(ValueError):
    pass


@dataclass
class Struct:
    scoped: str  # sensor_msgs::msg::dds_::JointState_
    fields: list[tuple[str, str]] = field(default_factory=list)  # (name, type as written, scoped)
    where: str = ""
    keys: list[str] = field(default_factory=list)  # the members annotated @key, in order


def tokens(path: Path, root: Path = HERE):
    """(token, line) pairs; comments and #include lines are skipped (every file is read anyway)."""
    text = path.read_text(encoding="utf-8")
    pos = 0
    while text[pos:].strip():
        m = TOKEN.match(text, pos)
        if not m:
            line = text.count("\n", 0, pos) + 1
            raise IdlError(f"{path.relative_to(root)}:{line}: cannot read {text[pos : pos + 20].strip()!r}")
        pos = m.end()
        if m.group(1) or m.group(2):
            continue
        start = m.start(3) if m.group(3) else m.start(4) if m.group(4) else m.start(5)
        yield (m.group(3) or m.group(4) or m.group(5)), text.count("\n", 0, start) + 1


def parse(path: Path, structs: dict[str, Struct], root: Path = HERE) -> None:
    toks = list(tokens(path, root))
    rel = path.relative_to(root)
    i = 0
    scope: list[str] = []

    def expect(value: str) -> None:
        nonlocal i
        if i >= len(toks) or toks[i][0] != value:
            got, line = toks[i] if i < len(toks) else ("the end", toks[-1][1])
            raise IdlError(f"{rel}:{line}: expected {value!r}, found {got!r}")
        i += 1

    def name() -> str:
        nonlocal i
        tok, line = toks[i]
        if not re.fullmatch(r"[A-Za-z_]\w*", tok):  # (an annotation, @key, is not a name)
            raise IdlError(f"{rel}:{line}: expected a name, found {tok!r}")
        i += 1
        return tok

    def type_name() -> str:
        nonlocal i
        if toks[i][0] == "sequence":
            i += 1
            expect("<")
            inner = type_name()
            expect(">")
            return f"sequence<{inner}>"
        parts = [name()]
        while i < len(toks) and toks[i][0] == "::":
            i += 1
            parts.append(name())
        scoped = "::".join(parts)
        if len(parts) == 1 and scoped not in BASIC:
            raise IdlError(
                f"{rel}:{toks[i - 1][1]}: {scoped!r} is not a type this generator knows (write other structs fully scoped)"
            )
        return scoped

    while i < len(toks):
        tok, line = toks[i]
        if tok == "module":
            i += 1
            scope.append(name())
            expect("{")
        elif tok == "}":
            i += 1
            expect(";")
            if not scope:
                raise IdlError(f"{rel}:{line}: a '}}' closes nothing")
            scope.pop()
        elif tok == "const":
            i += 1
            type_name()
            name()
            expect("=")
            i += 1
            expect(";")
        elif tok == "struct":
            i += 1
            s = Struct("::".join([*scope, name()]), where=f"{rel}:{line}")
            expect("{")
            while toks[i][0] != "}":
                key = toks[i][0] == "@key"
                if toks[i][0].startswith("@") and not key:
                    raise IdlError(
                        f"{rel}:{toks[i][1]}: {toks[i][0]}: the only annotation this generator reads is @key"
                    )
                i += key
                t = type_name()
                s.fields.append((name(), t))
                if key:
                    s.keys.append(s.fields[-1][0])
                expect(";")
            i += 1
            expect(";")
            if s.scoped in structs:
                raise IdlError(f"{rel}:{line}: {s.scoped} is defined twice (also at {structs[s.scoped].where})")
            structs[s.scoped] = s
        else:
            raise IdlError(f"{rel}:{line}: {tok!r} is outside what this generator reads (module, struct, const)")
    if scope:
        raise IdlError(f"{rel}: module {'::'.join(scope)} is not closed")


def class_name(scoped: str) -> str:
    """sensor_msgs::msg::dds_::JointState_ -> JointState (std_msgs' Header: Header)."""
    return scoped.split("::")[-1].rstrip("_")


def annotation(t: str, structs: dict[str, Struct]) -> str:
    if t.startswith("sequence<"):
        return f"types.sequence[{annotation(t[9:-1], structs)}]"
    if t in BASIC:
        return BASIC[t]
    if t not in structs:
        raise IdlError(f"{t} is used but defined in no file of protocol/ros2")
    return class_name(t)


def render(structs: dict[str, Struct], title: str, source: str) -> str:
    names = [class_name(s) for s in structs]
    if len(set(names)) != len(names):
        raise IdlError("two structs would make the same Python class name: " + ", ".join(sorted(structs)))
    order: list[str] = []

    def visit(scoped: str) -> None:
        if scoped in order:
            return
        for _, t in structs[scoped].fields:
            inner = t[9:-1] if t.startswith("sequence<") else t
            while inner.startswith("sequence<"):
                inner = inner[9:-1]
            if inner in structs:
                visit(inner)
        order.append(scoped)

    for scoped in sorted(structs):
        visit(scoped)
    keyed = any(structs[s].keys for s in order)
    out = [
        f'"""{title}, as cyclonedds IdlStruct classes.',
        "",
        f"Generated from {source} by {COMMAND}; do not edit.",
        '"""',
        "",
        "from dataclasses import dataclass, field",
        "",
        *(["import cyclonedds.idl.annotations as annotate"] if keyed else []),
        "from cyclonedds.idl import IdlStruct",
        "from cyclonedds.idl import types",
        "",
        "__all__ = [",
        *(f'    "{class_name(s)}",' for s in order),
        "]",
    ]
    for scoped in order:
        s = structs[scoped]
        out += ["", "", "@dataclass", f'class {class_name(scoped)}(IdlStruct, typename="{scoped}"):']
        out.append(f'    """{scoped} ({s.where.split(":")[0]})."""')
        out.append("")
        for fname, t in s.fields:
            ann = annotation(t, structs)
            if t.startswith("sequence<"):
                default = " = field(default_factory=list)"
            elif t in structs:
                default = f" = field(default_factory={class_name(t)})"
            elif t == "string":
                default = ' = ""'
            elif t == "boolean":
                default = " = False"
            elif t in ("float", "double"):
                default = " = 0.0"
            else:
                default = " = 0"
            out.append(f"    {fname}: {ann}{default}")
        out += [f'    annotate.key("{k}")' for k in s.keys]
    return "\n".join(out) + "\n"


def render_schema(structs: dict[str, Struct]) -> str:
    schema = json.loads(SCHEMA.read_text(encoding="utf-8"))
    defs = schema["$defs"]
    for kind in ("scalar_type", "array_type"):
        for name in defs[kind]["enum"]:
            package, msg, message = name.split("/")
            if f"{package}::{msg}::dds_::{message}_" not in structs:
                raise IdlError(
                    f"{SCHEMA.relative_to(ROOT)}: {name} has no IDL (protocol/ros2/{package}/msg/{message}.idl)"
                )
    return "\n".join(
        [
            '"""The shape of a set\'s dds.json (docs/dds.md), as JSON Schema.',
            "",
            f"Generated from protocol/dds/bridge.schema.json by {COMMAND}; do not edit.",
            '"""',
            "",
            "import json",
            "",
            f"SCHEMA = json.loads({json.dumps(json.dumps(schema, indent=1))})",
            "",
        ]
    )


def generate() -> dict[Path, str]:
    structs: dict[str, Struct] = {}
    for path in sorted(HERE.rglob("*.idl")):
        parse(path, structs)
    own: dict[str, Struct] = {}
    for path in sorted(OWN.rglob("*.idl")):
        parse(path, own, OWN)
    return {
        OUT / "ros2_types.py": render(structs, "ROS 2 message types on the DDS wire", "protocol/ros2/**/*.idl"),
        OUT / "indurop_types.py": render(own, "indurop's own DDS types", "protocol/dds/**/*.idl"),
        OUT / "bridge_schema.py": render_schema(structs),
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="fail if the written file is stale")
    args = ap.parse_args()
    try:
        files = generate()
    except IdlError as e:
        print(f"generate.py: {e}", file=sys.stderr)
        return 2
    stale = [p for p, text in files.items() if not p.exists() or p.read_text(encoding="utf-8") != text]
    if args.check:
        for p in stale:
            print(f"{os.path.relpath(p, ROOT)} is stale: run {COMMAND}", file=sys.stderr)
        return 1 if stale else 0
    for p in stale:
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(files[p], encoding="utf-8")
        print(f"wrote {os.path.relpath(p, ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

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
- The recorder's MCAP files carry sensor_msgs/msg/JointState in ROS 2's CDR with its message
  definition as rosbag2 stores it (ros2msg: the type's .msg text, then each type it uses after a
  line of 80 '='): this writes agent/indurop_agent/recorder/ros2_msgdefs.py from the same IDL,
  the text made by rosbags' Typestore.generate_msgdef (docs/recorder.md).

`--check` fails, naming this command, when a written file is stale.

The IDL is read by rosbags (`rosbags.typesys.get_types_from_idl`), a maintained parser of ROS 2's
message definitions; this only writes the code.  rosbags reads definitions, not the preprocessor:
the `#include` lines, which Debian's idlc needs to build the test's reader from the same files, are
blanked before (the files are all read anyway); and it reads annotations without keeping them, so
the members annotated `@key` are found by one regular expression and checked against the fields
rosbags read (a file with keys holds one struct).  Cyclone DDS's own idlc Python backend
(`idlc -l py`) is not used: the cyclonedds wheel's idlc dies of a segmentation fault, and Debian's
idlc 0.10.2 of a bus error loading the wheel's 11.x backend (docs/dds.md).

    python3 protocol/dds/generate.py [--check]

rosbags is in the project's venv (bash packaging/venv.sh); run by another Python, this runs itself
again with the venv's.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HERE = ROOT / "protocol" / "ros2"  # the IDL files
OWN = ROOT / "protocol" / "dds"  # indurop's own IDL files
SCHEMA = ROOT / "protocol" / "dds" / "bridge.schema.json"
OUT = ROOT / "agent" / "indurop_agent" / "dds"
RECORDER = ROOT / "agent" / "indurop_agent" / "recorder"
MSGDEFS = ("sensor_msgs/msg/JointState",)  # the ROS 2 types the recorder writes
COMMAND = "python3 protocol/dds/generate.py"
VENV_PYTHON = ROOT / ".venv" / "bin" / "python"

try:
    from rosbags.interfaces import Nodetype
    from rosbags.typesys import Stores, TypesysError, get_types_from_idl, get_typestore
except ImportError:  # not the venv's Python
    if VENV_PYTHON.exists() and Path(sys.executable) != VENV_PYTHON and __name__ == "__main__":
        os.execv(VENV_PYTHON, [str(VENV_PYTHON), __file__, *sys.argv[1:]])
    sys.exit(f"generate.py: rosbags is not installed: run it with {VENV_PYTHON} (bash packaging/venv.sh makes it)")

# The basic types' cyclonedds annotations (agent/indurop_agent/dds/idl_basic.py, loaded by path:
# the package itself imports the files written here).
_spec = importlib.util.spec_from_file_location("idl_basic", OUT / "idl_basic.py")
idl_basic = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(idl_basic)
BASIC = idl_basic.BASIC
INCLUDE = re.compile(r"^[ \t]*#include[^\n]*", re.MULTILINE)
KEY = re.compile(r"@key\s+[^;]*?(\w+)\s*;")  # `@key string controller;` -> controller


class IdlError(ValueError):
    pass


@dataclass
class Struct:
    scoped: str  # sensor_msgs::msg::dds_::JointState_
    fields: list[tuple[str, tuple]] = field(default_factory=list)  # (name, rosbags' field description)
    where: str = ""  # the file
    keys: list[str] = field(default_factory=list)  # the members annotated @key, in order


def parse(path: Path, structs: dict[str, Struct], root: Path | None = None) -> None:
    """One IDL file's structs, read by rosbags, into `structs` by their scoped names; `root` (default
    protocol/ros2) is where the names in messages start."""
    rel = path.relative_to(root or HERE)
    text = INCLUDE.sub("", path.read_text(encoding="utf-8"))
    try:
        types = get_types_from_idl(text)
    except TypesysError as e:
        raise IdlError(f"{rel}: {idl_basic.rosbags_reason(e)}") from None
    keys = KEY.findall(re.sub(r"//[^\n]*", "", text))
    if keys and len(types) != 1:
        raise IdlError(f"{rel}: a file with @key members holds one struct (it has {len(types)})")
    for name, (_, fields) in types.items():
        scoped = name.replace("/", "::")  # rosbags names sensor_msgs::msg::dds_::JointState_ with slashes
        if scoped in structs:
            raise IdlError(f"{rel}: {scoped} is defined twice (also in {structs[scoped].where})")
        unknown = [k for k in keys if k not in {f for f, _ in fields}]
        if unknown:
            raise IdlError(f"{rel}: @key {unknown[0]} is not a member of {scoped}")
        structs[scoped] = Struct(scoped, list(fields), str(rel), keys)


def class_name(scoped: str) -> str:
    """sensor_msgs::msg::dds_::JointState_ -> JointState (std_msgs' Header: Header)."""
    return scoped.split("::")[-1].rstrip("_")


def annotation(desc: tuple, structs: dict[str, Struct], where: str) -> str:
    """rosbags' description of a field as its cyclonedds annotation."""
    node, rest = desc
    if node == Nodetype.BASE:
        name, bound = rest
        if name not in BASIC:
            raise IdlError(f"{where}: {name} has no cyclonedds type here")
        return f"types.bounded_str[{bound}]" if name == "string" and bound else BASIC[name].annotation
    if node == Nodetype.NAME:
        scoped = rest.replace("/", "::")
        if scoped not in structs:
            raise IdlError(f"{where}: {scoped} is used but defined in no file of protocol/ros2")
        return class_name(scoped)
    inner, size = rest
    inner = annotation(inner, structs, where)
    if node == Nodetype.ARRAY:
        return f"types.array[{inner}, {size}]"
    return f"types.sequence[{inner}, {size}]" if size else f"types.sequence[{inner}]"


def default(desc: tuple, structs: dict[str, Struct]) -> str:
    node, rest = desc
    if node == Nodetype.SEQUENCE:
        return " = field(default_factory=list)"
    if node == Nodetype.ARRAY:
        inner, size = rest
        return f" = field(default_factory=lambda: [{default(inner, structs)[3:]}] * {size})"
    if node == Nodetype.NAME:
        return f" = field(default_factory={class_name(rest.replace('/', '::'))})"
    kind = BASIC[rest[0]].kind
    return {"string": ' = ""', "char": ' = "\\0"', "bool": " = False", "float": " = 0.0"}.get(kind, " = 0")


def render(structs: dict[str, Struct], title: str, source: str) -> str:
    names = [class_name(s) for s in structs]
    if len(set(names)) != len(names):
        raise IdlError("two structs would make the same Python class name: " + ", ".join(sorted(structs)))
    order: list[str] = []

    def visit(scoped: str) -> None:
        if scoped in order:
            return
        for _, desc in structs[scoped].fields:
            while desc[0] in (Nodetype.ARRAY, Nodetype.SEQUENCE):
                desc = desc[1][0]
            inner = desc[1].replace("/", "::") if desc[0] == Nodetype.NAME else None
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
        out.append(f'    """{scoped} ({s.where})."""')
        out.append("")
        for fname, desc in s.fields:
            out.append(
                f"    {fname}: {annotation(desc, structs, f'{s.where}: {scoped}.{fname}')}{default(desc, structs)}"
            )
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


def ros_name(scoped: str) -> str:
    """sensor_msgs::msg::dds_::JointState_ (the DDS wire's name) -> sensor_msgs/msg/JointState (ROS 2's)."""
    parts = scoped.split("::")
    return "/".join([*parts[:-2], parts[-1].rstrip("_")]) if parts[-2:-1] == ["dds_"] else "/".join(parts)


def ros_desc(desc: tuple) -> tuple:
    """rosbags' description of a field with the types it names in ROS 2's spelling."""
    node, rest = desc
    if node == Nodetype.NAME:
        return node, ros_name(rest.replace("/", "::"))
    if node in (Nodetype.ARRAY, Nodetype.SEQUENCE):
        return node, (ros_desc(rest[0]), rest[1])
    return desc


def render_msgdefs(structs: dict[str, Struct]) -> str:
    store = get_typestore(Stores.EMPTY)
    store.register({ros_name(s): ([], [(f, ros_desc(d)) for f, d in st.fields]) for s, st in structs.items()})
    out = [
        '"""ROS 2 message definitions as rosbag2 stores them in MCAP (schema encoding ros2msg).',
        "",
        f"Generated from protocol/ros2/**/*.idl by {COMMAND} (rosbags' Typestore.generate_msgdef); do not edit.",
        '"""',
        "",
        "MSGDEFS = {",
    ]
    for name in MSGDEFS:
        text, _ = store.generate_msgdef(name, ros_version=2)
        out.append(f"    {json.dumps(name)}: {json.dumps(text)},")
    return "\n".join([*out, "}", ""])


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
        RECORDER / "ros2_msgdefs.py": render_msgdefs(structs),
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

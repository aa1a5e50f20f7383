#!/usr/bin/env python3
"""generate.py -- writes everything generated from protocol/control.json, the control protocol's
one description: irpd's limits and command table (rtcore/src/protocol/limits.hpp,
command_table.hpp), the agent's request types, models of irpd's answers and limits
(agent/indurop_agent/irpd/protocol.py), the web UI's limits (webui/src/api/protocol.ts) and the tables
of docs/control-protocol.md (between its "generated" markers).

    python3 protocol/generate.py           # rewrites the files that changed
    python3 protocol/generate.py --check   # exits 1 naming the stale ones, writes nothing

Standard library only.  Argument shapes are the JSON Schema subset irpd's decoder understands
(string, integer, boolean, number-or-boolean, lists of those or of objects); anything else is
refused here with the place in the spec, so that no language is left to guess.  So is a result
shape the answer models cannot say (ANSWER_KEYWORDS)."""

from __future__ import annotations

import argparse
import json
import keyword
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "protocol"))
import generated_files  # noqa: E402

SPEC = ROOT / "protocol" / "control.json"
COMMAND = "python3 protocol/generate.py"
CPP_LIMITS = "rtcore/src/protocol/limits.hpp"
CPP_COMMANDS = "rtcore/src/protocol/command_table.hpp"
PYTHON = "agent/indurop_agent/irpd/protocol.py"
TYPESCRIPT = "webui/src/api/protocol.ts"
DOCS = "docs/control-protocol.md"
INT64_MAX = 2**63 - 1
# The JSON Schema keywords an argument may use: those irpd's decoder checks, and the words for people.
ARGUMENT_KEYWORDS = {
    "type",
    "minLength",
    "maxLength",
    "minimum",
    "maximum",
    "minItems",
    "maxItems",
    "items",
    "properties",
    "required",
    "anyOf",
    "allOf",
    "unevaluatedProperties",
    "additionalProperties",
    "description",
    "default",
    "$ref",
}

# The JSON Schema keywords a shape of an answer may use (#/shapes, and a result with a "title"): each
# says something the agent's models of the answers say too.  "title" names the model of an object
# inside a shape or a result (a shape's own model is named after its key).
ANSWER_KEYWORDS = {
    "type",
    "properties",
    "required",
    "additionalProperties",
    "items",
    "minItems",
    "maxItems",
    "enum",
    "const",
    "anyOf",
    "allOf",
    "$ref",
    "title",
    "description",
}


class SpecError(Exception):
    """The spec says something the generator cannot turn into code; the message says where."""


# ---- reading the spec --------------------------------------------------------------------------


def load(path: Path = SPEC) -> dict:
    """The spec with every {"$limit": name} replaced by that limit's value, checked."""
    try:
        raw = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise SpecError(f"{path}: {e}") from e
    limits = {name: entry["value"] for name, entry in raw["limits"].items()}

    def resolve(node, where):
        if isinstance(node, dict):
            if set(node) == {"$limit"}:
                if node["$limit"] not in limits:
                    raise SpecError(f"{where}: no limit {node['$limit']!r}; the limits are {', '.join(limits)}")
                return limits[node["$limit"]]
            return {k: resolve(v, f"{where}/{k}") for k, v in node.items()}
        if isinstance(node, list):
            return [resolve(v, f"{where}/{i}") for i, v in enumerate(node)]
        return node

    spec = resolve(raw, "#")
    codes = {e["code"] for e in spec["errors"]}
    names = [c["name"] for c in spec["commands"]]
    if len(set(names)) != len(names):
        raise SpecError("#/commands: a command is described twice")
    for c in spec["commands"]:
        for code in c["errors"]:
            if code not in codes:
                raise SpecError(f"#/commands/{c['name']}/errors: {code!r} is not in #/errors")
        if c.get("runs_on") not in ("control", "main"):
            raise SpecError(f"#/commands/{c['name']}/runs_on: 'control' or 'main'")
        arguments(spec, c)  # refuses what the decoder could not check
    return spec


def ref(spec: dict, node: dict) -> tuple[str | None, dict]:
    """(the type's name, its schema) of a {"$ref": "#/types/x"}, with the node's own keys on top."""
    if "$ref" not in node:
        return None, node
    target = node["$ref"]
    if not target.startswith("#/types/") or target[8:] not in spec["types"]:
        raise SpecError(f"{target}: arguments may refer only to #/types/<name>")
    name = target[8:]
    _, base = ref(spec, spec["types"][name])
    return name, {**base, **{k: v for k, v in node.items() if k != "$ref"}}


class Arg:
    """One argument (or one member of an object in a list), as every language checks it."""

    def __init__(self, spec: dict, name: str, node: dict, required: bool, where: str):
        self.name, self.required, self.where = name, required, where
        self.type_name, schema = ref(spec, node)
        self.description = schema.get("description", "")
        self.default = schema.get("default")
        self.min = self.max = None
        self.members: list[Arg] = []
        self.one_of: list[str] = []
        self.item: Arg | None = None
        self.closed = False  # an object: no members but its own
        unchecked = set(schema) - ARGUMENT_KEYWORDS
        if unchecked:
            raise SpecError(
                f"{where}: {', '.join(sorted(unchecked))}: no language checks that; the keywords are "
                f"{', '.join(sorted(ARGUMENT_KEYWORDS))}"
            )
        kind = schema.get("type")
        if kind == "string":
            self.kind, self.min, self.max = "string", schema.get("minLength"), schema.get("maxLength")
        elif kind == "integer":
            self.kind, self.min, self.max = "integer", schema.get("minimum"), schema.get("maximum")
        elif kind == "boolean":
            self.kind = "boolean"
        elif kind == ["number", "boolean"]:
            self.kind = "scalar"
        elif kind == "array":
            self.min, self.max = schema.get("minItems"), schema.get("maxItems")
            item = Arg(spec, f"{name}[]", schema.get("items", {}), True, f"{where}/items")
            if item.kind == "string":
                self.kind, self.item = "string_list", item
            elif item.kind == "object" and item.closed:
                self.kind, self.item = "object_list", item
            elif item.kind == "object":
                raise SpecError(
                    f"{where}/items: an entry of a request's list takes no other members: "
                    "say \"unevaluatedProperties\": false"
                )
            else:
                raise SpecError(f"{where}/items: a list holds strings or objects")
        elif kind == "object":
            self.kind = "object"
            self.object_fields(spec, schema, where)
        else:
            raise SpecError(
                f"{where}: type {kind!r} is none of string, integer, boolean, [number, boolean], array, object"
            )
        for bound in (self.min, self.max):
            if bound is not None and not (isinstance(bound, int) and -INT64_MAX - 1 <= bound <= INT64_MAX):
                raise SpecError(f"{where}: the bound {bound!r} is no 64-bit integer")

    def object_fields(self, spec: dict, schema: dict, where: str) -> None:
        """Members in order (own, then those of allOf), and the anyOf-of-required rule."""
        parts = [schema] + [ref(spec, p)[1] for p in schema.get("allOf", [])]
        required = {name for part in parts for name in part.get("required", [])}
        for part in parts:
            for key, sub in part.get("properties", {}).items():
                self.members.append(Arg(spec, key, sub, key in required, f"{where}/properties/{key}"))
            for alternative in part.get("anyOf", []):
                if set(alternative) != {"required"} or len(alternative["required"]) != 1:
                    raise SpecError(f"{where}/anyOf: only [{{\"required\": [member]}}, ...] (at least one of)")
                self.one_of.append(alternative["required"][0])
        self.closed = schema.get("unevaluatedProperties", schema.get("additionalProperties")) is False

    def expected(self) -> str:
        """What the value must be, as the messages say it: "an integer from 0 to 1000000"."""
        if self.kind == "string":
            text = "a non-empty string" if self.min == 1 else "a string"
            if self.min not in (None, 0, 1):
                text += f" of at least {self.min} characters"
            return text + (f" of at most {self.max} characters" if self.max is not None else "")
        if self.kind == "integer":
            if self.min is not None and self.max is not None:
                return f"an integer from {self.min} to {self.max}"
            if self.max is not None:
                return f"an integer of at most {self.max}"
            return {None: "an integer", 0: "a non-negative integer", 1: "a positive integer"}.get(
                self.min, f"an integer of at least {self.min}"
            )
        if self.kind == "boolean":
            return "true or false"
        if self.kind == "scalar":
            return "a number or a boolean"
        if self.kind == "object":
            return "an object {" + ", ".join(m.name + ("" if m.required else "?") for m in self.members) + "}"
        size = "a non-empty list" if self.min == 1 else "a list"
        items = "strings" if self.kind == "string_list" else self.item.expected()[len("an object ") :]
        return f"{size} of at most {self.max} {items}" if self.max is not None else f"{size} of {items}"


def arguments(spec: dict, command: dict) -> list[Arg]:
    schema = command["arguments"]
    where = f"#/commands/{command['name']}/arguments"
    if schema.get("type") != "object":
        raise SpecError(f"{where}: arguments are an object schema")
    required = set(schema.get("required", []))
    unknown = required - set(schema.get("properties", {}))
    if unknown:
        raise SpecError(f"{where}/required: {', '.join(sorted(unknown))} not among the properties")
    args = [Arg(spec, k, v, k in required, f"{where}/properties/{k}") for k, v in schema.get("properties", {}).items()]
    for a in args:
        if a.kind == "object":
            raise SpecError(f"{a.where}: an argument is a value or a list, not an object")
    return args


def camel(name: str) -> str:
    return "".join(part.capitalize() for part in re.split(r"[_\W]+", name) if part)


def upper(name: str) -> str:
    return re.sub(r"\W", "_", name).upper()


# ---- C++ (irpd) --------------------------------------------------------------------------------


def cpp_string(text: str) -> str:
    return json.dumps(text, ensure_ascii=False)


def cpp_number(value) -> str:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SpecError(f"limit {value!r}: a number")
    if isinstance(value, float):
        return repr(value)
    return f"{value:_}".replace("_", "'")


def cpp_header(name: str, what: str, includes: tuple[str, ...] = ()) -> list[str]:
    return [
        f"// {name} -- {what}",
        "// Generated by protocol/generate.py from protocol/control.json: do not edit; edit the spec and",
        f"// run `{COMMAND}`.",
        "#pragma once",
        "",
        *(f'#include "{i}"' for i in includes),
        *([""] if includes else []),
        "#include <cstddef>",
        "#include <cstdint>",
    ]


def cpp_limits(spec: dict) -> str:
    out = cpp_header(
        "limits.hpp", "the control protocol's name, version, limits and error codes (docs/control-protocol.md)."
    )
    out += [
        "",
        "namespace irp::protocol {",
        "",
        f"inline constexpr const char *kProtocol = {cpp_string(spec['protocol'])};",
        f"inline constexpr int kVersion = {spec['version']};",
        "",
        "// ---- limits",
    ]
    for name, entry in spec["limits"].items():
        value = entry["value"]
        kind = "double" if isinstance(value, float) else "int64_t"
        out.append(f"// {entry['description']}")
        out.append(f"inline constexpr {kind} k{camel(name)} = {cpp_number(value)};")
    out += ["", "// ---- error codes (an answer's error.code)"]
    for e in spec["errors"]:
        out.append(f"// {e['description']}")
        out.append(f"inline constexpr const char *k{camel(e['code'])} = {cpp_string(e['code'])};")
    out += ["", "} // namespace irp::protocol", ""]
    return "\n".join(out)


def cpp_commands(spec: dict) -> str:
    commands = spec["commands"]
    out = cpp_header(
        "command_table.hpp",
        "the control protocol's commands and their arguments, as irpd checks "
        "them\n// (protocol/arguments.hpp) before a command runs.",
        ("protocol/limits.hpp",),
    )
    out += [
        "",
        "namespace irp::protocol {",
        "",
        "enum class Cmd { " + ", ".join(camel(c["name"]) for c in commands) + " };",
        f"inline constexpr std::size_t kCommandCount = {len(commands)};",
        f"inline constexpr const char *kCommandList = {cpp_string(', '.join(c['name'] for c in commands))};",
        "",
        "// How an argument is checked: String (min/max: its length), Integer (min/max: the range), Boolean,",
        "// Scalar (a number or a boolean), StringList and ObjectList (min/max: the entries).",
        "enum class ArgType { String, Integer, Boolean, Scalar, StringList, ObjectList };",
        "",
        "struct Arg {",
        "    const char *name;",
        "    ArgType type;",
        "    bool required;",
        "    bool has_min, has_max;",
        "    int64_t min, max;",
        "    const char *expected;          // what the value must be, for the messages",
        "    const Arg *members = nullptr;  // ObjectList: each entry's members; StringList: what an entry is",
        "    std::size_t member_count = 0;",
        "    bool one_of = false;           // an entry gives at least one of the members marked so",
        "};",
        "",
        "struct Command {",
        "    Cmd cmd;",
        "    const char *name;",
        "    const Arg *args;  // null when it takes none",
        "    std::size_t arg_count;",
        "    bool on_main;     // carried out by irpd's main thread (a change), else by the control thread",
        "};",
        "",
    ]

    def arg_line(a: Arg, members: str | None, count: int, one_of: bool) -> str:
        kind = {
            "string": "String",
            "integer": "Integer",
            "boolean": "Boolean",
            "scalar": "Scalar",
            "string_list": "StringList",
            "object_list": "ObjectList",
        }[a.kind]
        fields = [
            cpp_string(a.name),
            f"ArgType::{kind}",
            str(a.required).lower(),
            str(a.min is not None).lower(),
            str(a.max is not None).lower(),
            cpp_number(a.min or 0),
            cpp_number(a.max or 0),
            cpp_string(a.expected()),
            members or "nullptr",
            str(count),
            str(one_of).lower(),
        ]
        return "    {" + ", ".join(fields) + "},"

    tables = []
    for c in commands:
        args = arguments(spec, c)
        if not args:
            tables.append((c, None))
            continue
        prefix = f"k{camel(c['name'])}"
        for a in args:
            if a.kind in ("object_list", "string_list"):
                entries = a.item.members if a.kind == "object_list" else [a.item]
                out.append(f"inline constexpr Arg {prefix}{camel(a.name)}Entries[] = {{")
                out += [arg_line(m, None, 0, m.name in a.item.one_of) for m in entries]
                out += ["};", ""]
        out.append(f"inline constexpr Arg {prefix}Args[] = {{")
        for a in args:
            if a.kind in ("object_list", "string_list"):
                count = len(a.item.members) if a.kind == "object_list" else 1
                out.append(arg_line(a, f"{prefix}{camel(a.name)}Entries", count, False))
            else:
                out.append(arg_line(a, None, 0, False))
        out += ["};", ""]
        tables.append((c, f"{prefix}Args"))
    out.append("inline constexpr Command kCommands[kCommandCount] = {")
    for c, table in tables:
        count = f"sizeof {table} / sizeof {table}[0]" if table else "0"
        out.append(
            f"    {{Cmd::{camel(c['name'])}, {cpp_string(c['name'])}, {table or 'nullptr'}, {count}, "
            f"{str(c['runs_on'] == 'main').lower()}}},"
        )
    out += ["};", "", "} // namespace irp::protocol", ""]
    return "\n".join(out)


# ---- Python (the agent) ------------------------------------------------------------------------


def py_str(text: str) -> str:
    return json.dumps(text, ensure_ascii=False)


def py_field(a: Arg) -> str:
    """The Annotated type of an argument, with its range and description."""
    constraints = []
    if a.kind == "string":
        base = "StrictStr"
        if a.min is not None:
            constraints.append(f"min_length={a.min}")
        if a.max is not None:
            constraints.append(f"max_length={a.max}")
    elif a.kind == "integer":
        base = "StrictInt"
        if a.min is not None:
            constraints.append(f"ge={a.min:_}")
        if a.max is not None:
            constraints.append(f"le={a.max:_}")
    elif a.kind == "boolean":
        base = "StrictBool"
    elif a.kind == "scalar":
        base = "StrictBool | StrictInt | Annotated[StrictFloat, Field(allow_inf_nan=False)]"
    else:
        raise SpecError(f"{a.where}: no Python type for a {a.kind} type")
    if a.description:
        constraints.append(f"description={py_str(a.description)}")
    return f"Annotated[{base}, Field({', '.join(constraints)})]"


def python(spec: dict) -> str:
    out = [
        '"""protocol.py -- irpd\'s control protocol for the agent: its limits, error codes, commands, the',
        "types of their arguments and the models of irpd's answers (the API's request models are made of",
        "the former, its answers of the latter, so OpenAPI and the web UI's schema.d.ts follow).  irpd",
        "checks every request; the argument types say the same, earlier.",
        "",
        "Generated by protocol/generate.py from protocol/control.json: do not edit; edit the spec and run",
        f'`{COMMAND}`, then `cd webui && npm run gen-api`."""',
        "from __future__ import annotations",
        "",
        "from typing import Annotated, Literal",
        "",
        "from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictFloat, StrictInt, StrictStr, "
        "model_validator",
        "",
        f"PROTOCOL = {py_str(spec['protocol'])}",
        f"VERSION = {spec['version']}",
        "",
        "# ---- limits",
    ]
    for name, entry in spec["limits"].items():
        value = entry["value"]
        out.append(f"# {entry['description']}")
        out.append(f"{upper(name)} = {value:_}" if isinstance(value, int) else f"{upper(name)} = {value!r}")
    out += ["", "# ---- error codes (an answer's error.code)"]
    for e in spec["errors"]:
        out.append(f"# {e['description']}")
        out.append(f"{upper(e['code'])} = {py_str(e['code'])}")
    out.append("ERROR_CODES = (" + ", ".join(upper(e["code"]) for e in spec["errors"]) + ")")
    out += [
        "",
        "COMMANDS = (" + ", ".join(py_str(c["name"]) for c in spec["commands"]) + ")",
        "EVENT_KINDS = (" + ", ".join(py_str(k["kind"]) for k in spec["event_kinds"]) + ")",
        "",
        "# ---- argument types",
    ]
    objects = []
    for name, node in spec["types"].items():
        a = Arg(spec, name, {"$ref": f"#/types/{name}"}, True, f"#/types/{name}")
        if a.kind == "object":
            objects.append((name, a, node))
        else:
            out.append(f"{camel(name)} = {py_field(a)}")
    for name, a, node in objects:
        bases = [ref(spec, p)[0] for p in node.get("allOf", [])]
        base_members = {m.name for b in bases for m in Arg(spec, b, {"$ref": f"#/types/{b}"}, True, "").members}
        out += [
            "",
            "",
            f"class {camel(name)}({', '.join(camel(b) for b in bases) or 'BaseModel'}):",
            docstring(a.description),
            "",
        ]
        if not bases:
            out += ['    model_config = ConfigDict(extra="forbid")']
        for m in a.members:
            if m.name in base_members:
                continue
            field_type = camel(m.type_name) if m.type_name else py_field(m)
            # An optional member's description at the top of its schema (not inside anyOf), for OpenAPI.
            default = (
                f" | None = Field(None, description={py_str(m.description)})" if m.description else " | None = None"
            )
            out.append(f"    {m.name}: {field_type}" + ("" if m.required else default))
        own_one_of = [alternative["required"][0] for alternative in node.get("anyOf", [])]  # bases check theirs
        if own_one_of:
            listed = ", ".join(own_one_of[:-1]) + " or " + own_one_of[-1] if len(own_one_of) > 1 else own_one_of[0]
            out += [
                "",
                '    @model_validator(mode="after")',
                "    def _at_least_one(self):",
                "        if all(getattr(self, name) is None for name in ("
                + ", ".join(py_str(n) for n in own_one_of)
                + ")):",
                f'            raise ValueError("give at least one of {listed}")',
                "        return self",
            ]
    out += AnswerModels(spec).text()
    return "\n".join(out)


def py_literal(value) -> str:
    if isinstance(value, bool) or value is None:
        return repr(value)
    if isinstance(value, (int, str)):
        return json.dumps(value, ensure_ascii=False)
    raise SpecError(f"{value!r}: an enum or const of an answer is a string, an integer or a boolean")


def docstring(description: str) -> str:
    return f'    """{description[:1].upper() + description[1:]}."""'


class AnswerModels:
    """The pydantic models of irpd's answers: one for each object of #/shapes (named after its key),
    for each command result that has a "title", and for each object inside those (named by its
    "title", which it must have).  Each model comes after the ones its fields and bases name."""

    SCALARS = {"string": "str", "integer": "int", "number": "float", "boolean": "bool"}

    def __init__(self, spec: dict):
        self.spec = spec
        self.classes: list[str] = []
        self.named: dict[str, str] = {}  # a model's name -> where it is described
        for name in spec["shapes"]:
            self.shape(name)
        for c in spec["commands"]:
            if "title" in c["result"]["schema"]:
                self.type_of(c["result"]["schema"], f"#/commands/{c['name']}/result/schema")

    def text(self) -> list[str]:
        return [
            "",
            "",
            "# ---- irpd's answers (the result shapes)",
            "",
            "",
            "class IrpdShape(BaseModel):",
            '    """An answer from irpd, or a part of one: the fields the spec gives; any others a newer irpd adds',
            '    pass through."""',
            "",
            '    model_config = ConfigDict(extra="allow")',
            *self.classes,
            "",
        ]

    def shape(self, name: str) -> str:
        """The Python type of #/shapes/<name>; its model is written once."""
        node = self.spec["shapes"][name]
        if node.get("type") == "object" and "properties" in node:
            return self.model(node, node.get("title", camel(name)), f"#/shapes/{name}")
        return self.type_of(node, f"#/shapes/{name}")

    def target(self, node: dict, where: str) -> tuple[str, dict]:
        """(the shape's name, its schema) of a {"$ref": "#/shapes/<name>"}."""
        prefix, _, name = node["$ref"].rpartition("/")
        if prefix != "#/shapes" or name not in self.spec["shapes"]:
            raise SpecError(f"{where}: {node['$ref']}: an answer refers only to #/shapes/<name>")
        return name, self.spec["shapes"][name]

    def type_of(self, node: dict, where: str) -> str:
        """The Python type of a value of this schema (a model's name for an object with properties)."""
        unknown = set(node) - ANSWER_KEYWORDS
        if unknown:
            raise SpecError(
                f"{where}: {', '.join(sorted(unknown))}: the answer models do not say that; the keywords are "
                f"{', '.join(sorted(ANSWER_KEYWORDS))}"
            )
        if "$ref" in node:
            return self.shape(self.target(node, where)[0])
        if "anyOf" in node:
            alternatives = [a for a in node["anyOf"] if a != {"type": "null"}]
            types = [self.type_of(a, f"{where}/anyOf/{i}") for i, a in enumerate(alternatives)]
            return " | ".join(types + (["None"] if len(alternatives) < len(node["anyOf"]) else []))
        if "enum" in node:
            return f"Literal[{', '.join(py_literal(v) for v in node['enum'])}]"
        if "const" in node:
            return f"Literal[{py_literal(node['const'])}]"
        kinds = node.get("type") if isinstance(node.get("type"), list) else [node.get("type")]
        nullable = " | None" if "null" in kinds else ""
        kinds = [k for k in kinds if k != "null"]
        if kinds == ["number", "boolean"]:
            return "bool | int | float" + nullable
        if len(kinds) == 1 and kinds[0] in self.SCALARS:
            return self.SCALARS[kinds[0]] + nullable
        if kinds == ["array"] and "items" in node:
            listed = f"list[{self.type_of(node['items'], f'{where}/items')}]"
            bounds = [
                f"{key}={node[word]}"
                for word, key in (("minItems", "min_length"), ("maxItems", "max_length"))
                if word in node
            ]
            return (f"Annotated[{listed}, Field({', '.join(bounds)})]" if bounds else listed) + nullable
        if kinds == ["object"] and "properties" in node:
            if "title" not in node:
                raise SpecError(f"{where}: an object in an answer has a \"title\": its model's name")
            return self.model(node, node["title"], where) + nullable
        if kinds == ["object"] and isinstance(node.get("additionalProperties"), dict):
            return (
                f"dict[str, {self.type_of(node['additionalProperties'], f'{where}/additionalProperties')}]" + nullable
            )
        raise SpecError(
            f"{where}: type {node.get('type')!r}: an answer's value is a string, integer, number, boolean (or null), "
            "an enum, a const, an array with items, an object with properties or additionalProperties, or anyOf them"
        )

    def model(self, node: dict, name: str, where: str) -> str:
        """The model of an object: its own members, and those of the shapes in its allOf (its bases)
        that it requires where they do not."""
        if self.named.get(name) == where:
            return name
        if name in self.named:
            raise SpecError(f"{where}: a second model named {name} (the first: {self.named[name]})")
        self.named[name] = where
        bases, inherited = [], {}
        for i, part in enumerate(node.get("allOf", [])):
            if set(part) != {"$ref"}:
                raise SpecError(f"{where}/allOf/{i}: only {{\"$ref\": \"#/shapes/<name>\"}}")
            base = self.target(part, f"{where}/allOf/{i}")[1]
            if "properties" not in base:
                raise SpecError(f"{where}/allOf/{i}: a base is an object of #/shapes with properties")
            bases.append(self.type_of(part, f"{where}/allOf/{i}"))
            inherited.update({k: (v, k in base.get("required", [])) for k, v in base["properties"].items()})
        own = node.get("properties", {})
        required = node.get("required", [])
        unknown = [m for m in required if m not in own and m not in inherited]
        if unknown:
            raise SpecError(f"{where}/required: {', '.join(unknown)} not among the properties")
        members = [(m, sub, m in required, f"{where}/properties/{m}") for m, sub in own.items()]
        # A member a base has when it applies and this one always: its type, not its description (which
        # says when it is there).
        members += [
            (m, {k: v for k, v in inherited[m][0].items() if k != "description"}, True, where)
            for m in required
            if m not in own and not inherited[m][1]
        ]
        fields = [self.field(*member) for member in members]
        lines = ["", "", f"class {name}({', '.join(bases) or 'IrpdShape'}):"]
        if node.get("description"):
            lines.append(docstring(node["description"]))
            if fields:
                lines.append("")
        self.classes.append("\n".join(lines + (fields or ["    pass"])))
        return name

    def field(self, member: str, node: dict, required: bool, where: str) -> str:
        kind = self.type_of(node, where)
        options = [] if required else ["None"]
        attribute = member
        if keyword.iskeyword(member) or not member.isidentifier():
            attribute = re.sub(r"\W", "_", member) + "_"
            options.append(f"alias={py_str(member)}")
        if node.get("description"):
            options.append(f"description={py_str(node['description'])}")
        if not required and not kind.endswith(" | None"):
            kind += " | None"
        if options == ["None"]:
            return f"    {attribute}: {kind} = None"
        return f"    {attribute}: {kind}" + (f" = Field({', '.join(options)})" if options else "")


# ---- TypeScript (the web UI) -------------------------------------------------------------------


def typescript(spec: dict) -> str:
    out = [
        "// protocol.ts -- irpd's control protocol for the web UI: the limits its pre-checks read, the error",
        "// codes and the commands.  Generated by protocol/generate.py from protocol/control.json: do not",
        f"// edit; edit the spec and run `{COMMAND}`.",
        "",
    ]
    for name, entry in spec["limits"].items():
        value = entry["value"]
        out.append(f"/** {entry['description']} */")
        out.append(
            f"export const {upper(name)} = {value:_};"
            if isinstance(value, int)
            else f"export const {upper(name)} = {value!r};"
        )
    out += [
        "",
        "/** The codes of an answer's error.code. */",
        "export const ERROR_CODES = [" + ", ".join(json.dumps(e["code"]) for e in spec["errors"]) + "] as const;",
        "export type ErrorCode = (typeof ERROR_CODES)[number];",
        "",
        "export const COMMANDS = [" + ", ".join(json.dumps(c["name"]) for c in spec["commands"]) + "] as const;",
        "export type CommandName = (typeof COMMANDS)[number];",
        "",
    ]
    return "\n".join(out)


# ---- docs/control-protocol.md ------------------------------------------------------------------


def md_cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def md_arg(a: Arg) -> str:
    what = a.expected()
    if a.required:
        state = "required"
    elif a.default is not None:
        state = f"default {json.dumps(a.default)}"
    else:
        state = "optional"
    text = f"`{a.name}` ({what}; {state})"
    if a.kind == "object_list":
        text += ": " + ", ".join(
            f"`{m.name}` ({m.expected()}{'' if m.required else ', optional'})" for m in a.item.members
        )
        if a.item.one_of:
            text += ", at least one of " + ", ".join(f"`{n}`" for n in a.item.one_of)
    if a.description:
        text += f" — {a.description}"
    return text


def docs_blocks(spec: dict) -> dict[str, str]:
    commands = ["| cmd | arguments | result | errors |", "| --- | --- | --- | --- |"]
    for c in spec["commands"]:
        args = "; ".join(md_arg(a) for a in arguments(spec, c)) or ""
        errors = ", ".join(f"`{code}`" for code in c["errors"])
        commands.append(f"| `{c['name']}` | {md_cell(args)} | {md_cell(c['result']['description'])} | {errors} |")
    errors = [f"- `{e['code']}`: {e['description']}" for e in spec["errors"]]
    limits = ["| limit | value | |", "| --- | --- | --- |"]
    limits += [
        f"| `{name}` | {entry['value']:,} | {md_cell(entry['description'])} |" for name, entry in spec["limits"].items()
    ]
    kinds = [f"- `{k['kind']}`: {k['description']}" for k in spec["event_kinds"]]
    return {
        "errors": "\n".join(errors),
        "limits": "\n".join(limits),
        "commands": "\n".join(commands),
        "event-kinds": "\n".join(kinds),
    }


def begin(name: str) -> str:
    return f"<!-- generated: {name} (protocol/generate.py from protocol/control.json; edit those) -->"


def end(name: str) -> str:
    return f"<!-- end generated: {name} -->"


def docs(spec: dict, current: str) -> str:
    text = current
    for name, block in docs_blocks(spec).items():
        pattern = re.compile(re.escape(begin(name)) + r"\n(?:.*?\n)?" + re.escape(end(name)), re.S)
        if not pattern.search(text):
            raise SpecError(f"{DOCS} has no block {begin(name)} ... {end(name)}: put the markers where it goes")
        text = pattern.sub(lambda _, name=name, block=block: f"{begin(name)}\n{block}\n{end(name)}", text)
    return text


# ---- all of it ---------------------------------------------------------------------------------


def outputs(spec: dict, root: Path = ROOT) -> dict[str, str]:
    """Every generated file's path (relative to the repository) and its text as the spec makes it."""
    return {
        CPP_LIMITS: cpp_limits(spec),
        CPP_COMMANDS: cpp_commands(spec),
        PYTHON: python(spec),
        TYPESCRIPT: typescript(spec),
        DOCS: docs(spec, (root / DOCS).read_text()),
    }


def stale(root: Path = ROOT) -> list[str]:
    """The generated files that differ from what the spec makes now."""
    wanted = outputs(load(root / "protocol" / "control.json"), root)
    return [str(p.relative_to(root)) for p in generated_files.stale({root / k: v for k, v in wanted.items()})]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="only say which generated files are stale")
    args = parser.parse_args(argv)
    try:
        wanted = outputs(load())
    except (SpecError, KeyError) as e:
        print(f"generate.py: protocol/control.json: {e}", file=sys.stderr)
        return 2
    return generated_files.write_or_check({ROOT / k: v for k, v in wanted.items()}, args.check, COMMAND, ROOT)


if __name__ == "__main__":
    sys.exit(main())

"""bridge_file.py -- a set's dds.json (docs/dds.md): read, checked against its schema and the set.

The shape is protocol/dds/bridge.schema.json (generated into bridge_schema.py); the checks here
are what a schema cannot say: a topic mapped twice, a topic both published and subscribed, a
variable with two writers (two subscriptions, or a subscription and a module's `<writes>` in
module.xml; the imports' writers: sharing.py), the message types the file declares and the
fields of the mappings that use them (declared.py), and, against a layout, every mapped variable's
type against its field's, and the exported and imported variables (sharing.py).  Every refusal is a
BridgeFileError naming the file, the line and what to fix; the agent's upload (uploads.py) and the
bridge at start both use it.
"""

from __future__ import annotations

import json
import json.decoder
import json.scanner
from dataclasses import dataclass, field

import jsonschema

from ..irpd.variables import shown
from . import declared, ros2_types, sharing
from .bridge_schema import SCHEMA
from .declared import DeclarationError, Plan
from .idl_basic import BASIC, holds

BRIDGE_JSON = "dds.json"
MAX_BYTES = 1 << 20

_VALIDATOR = jsonschema.Draft202012Validator(SCHEMA)
_DEFS = SCHEMA["$defs"]
SCALAR_TYPES = tuple(_DEFS["scalar_type"]["enum"])
ARRAY_TYPES = tuple(_DEFS["array_type"]["enum"])


class BridgeFileError(ValueError):
    def __init__(self, message: str, line: int | None = None, file: str = BRIDGE_JSON):
        super().__init__(f"{file}:{line}: {message}" if line else f"{file}: {message}")
        self.file, self.line, self.reason = file, line, message


@dataclass(frozen=True)
class Mapping:
    topic: str  # the ROS 2 name without a leading slash; on the wire "rt/" + topic
    type: str  # std_msgs/msg/Float64
    variables: tuple[str, ...]  # one for a scalar type
    qos: str = "default"
    rate_hz: float = 10.0  # publish: how often; subscribe: at most this many samples written a second
    line: int | None = None
    plan: Plan | None = field(default=None, compare=False)  # a declared type's fields (declared.py)

    @property
    def is_array(self) -> bool:
        return self.type in ARRAY_TYPES

    @property
    def cls(self):
        """The cyclonedds class of its messages."""
        return self.plan.cls if self.plan else getattr(ros2_types, self.type.rsplit("/", 1)[-1])

    def leaves(self) -> list[tuple[str, str, str]]:
        """(field, basic type, variable) of every mapped variable: data or data[i] of a std_msgs type."""
        if self.plan:
            return [(leaf.field, leaf.basic, leaf.variable) for leaf in self.plan.leaves]
        basic = std_basic(self.type)
        if self.is_array:
            return [(f"data[{i}]", basic, v) for i, v in enumerate(self.variables)]
        return [("data", basic, self.variables[0])]


def std_basic(type_name: str) -> str:
    """std_msgs/msg/UInt8MultiArray -> uint8: the basic type of a std_msgs type's data."""
    return type_name.rsplit("/", 1)[-1].replace("MultiArray", "").lower()


@dataclass(frozen=True)
class BridgeFile:
    joint_states: bool = True
    joint_states_topic: str = "joint_states"
    joint_states_hz: float = 100.0
    frame_id: str = ""
    diagnostics: bool = True
    diagnostics_hz: float = 1.0
    publish: tuple[Mapping, ...] = ()
    subscribe: tuple[Mapping, ...] = ()
    description: str = ""
    written: dict[str, Mapping] = field(default_factory=dict)  # variable -> the mapping that writes it
    types: dict[str, declared.TypeDef] = field(default_factory=dict)  # the declared and shipped types
    export: tuple[sharing.Export, ...] = ()  # variables other controllers may import
    imports: tuple[sharing.Import, ...] = ()  # variables of other controllers written into this set's


class _Located(dict):
    line = 0


def _load_with_lines(text: str):
    """json.loads, but every object remembers the line it starts on (for the messages)."""
    decoder = json.JSONDecoder()
    plain = decoder.parse_object

    def parse_object(s_and_end, *args):
        s, end = s_and_end
        obj, after = plain(s_and_end, *args)
        located = _Located(obj)
        located.line = s.count("\n", 0, end) + 1
        return located, after

    decoder.parse_object = parse_object
    decoder.scan_once = json.scanner.py_make_scanner(decoder)
    return decoder.decode(text)


def _where(path) -> str:
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else p)
    return out or "the top level"


def _line_of(doc, path) -> int | None:
    line, node = getattr(doc, "line", None), doc
    for p in path:
        try:
            node = node[p]
        except (KeyError, IndexError, TypeError):
            break
        line = getattr(node, "line", line)
    return line


def parse(data: bytes | str, file: str = BRIDGE_JSON) -> BridgeFile:
    """dds.json's text -> BridgeFile; BridgeFileError naming the line and what to fix."""
    if len(data) > MAX_BYTES:
        raise BridgeFileError(f"larger than {MAX_BYTES >> 20} MiB", file=file)
    try:
        text = data.decode("utf-8") if isinstance(data, bytes) else data
        doc = _load_with_lines(text)
    except UnicodeDecodeError as e:
        raise BridgeFileError(f"not UTF-8: {e}", file=file) from None
    except json.JSONDecodeError as e:
        raise BridgeFileError(f"not valid JSON: {e.msg} (column {e.colno})", e.lineno, file) from None
    except RecursionError:
        raise BridgeFileError("nested too deeply", file=file) from None
    _check_type_names(doc, file)
    error = jsonschema.exceptions.best_match(_VALIDATOR.iter_errors(doc))
    if error is not None:
        raise BridgeFileError(
            f"{_where(error.absolute_path)}: {error.message}", _line_of(doc, error.absolute_path), file
        )
    try:
        types = declared.parse_types(doc.get("types", {}))
    except DeclarationError as e:
        raise BridgeFileError(str(e), _line_of(doc, ["types"]), file) from None

    def mappings(kind: str, rate_key: str, default_rate: float) -> tuple[Mapping, ...]:
        out = []
        for i, m in enumerate(doc.get(kind, [])):
            plan = None
            if "fields" in m:
                try:
                    plan = declared.compile_fields(types, m["type"], m["fields"], written=kind == "subscribe")
                except DeclarationError as e:
                    where = f"{kind} {m['topic'].lstrip('/')} ({m['type']})"
                    raise BridgeFileError(f"{where}: {e}", _line_of(doc, [kind, i, "fields"]), file) from None
            out.append(
                Mapping(
                    topic=m["topic"].lstrip("/"),
                    type=m["type"],
                    variables=plan.variables if plan else tuple(m.get("variables", ())) or (m["variable"],),
                    qos=m.get("qos", "default"),
                    rate_hz=float(m.get(rate_key, default_rate)),
                    line=m.line,
                    plan=plan,
                )
            )
        return tuple(out)

    js, diag = doc.get("joint_states", {}), doc.get("diagnostics", {})
    export, imports = sharing.parse(doc, lambda message, line: BridgeFileError(message, line, file))
    bridge = BridgeFile(
        joint_states=js.get("enabled", True),
        joint_states_topic=js.get("topic", "joint_states").lstrip("/"),
        joint_states_hz=float(js.get("rate_hz", 100)),
        frame_id=js.get("frame_id", ""),
        diagnostics=diag.get("enabled", True),
        diagnostics_hz=float(diag.get("rate_hz", 1)),
        publish=mappings("publish", "rate_hz", 10.0),
        subscribe=mappings("subscribe", "max_rate_hz", 100.0),
        description=doc.get("description", ""),
        types=types,
        export=export,
        imports=imports,
    )
    _check_topics(bridge, file)
    for m in bridge.subscribe:
        for v in m.variables:
            other = bridge.written.get(v)
            if other is not None:
                raise BridgeFileError(
                    f"{v} would have two writers: the subscriptions to {other.topic}{_field_of(other, v)} (line {other.line}) "
                    f"and {m.topic}{_field_of(m, v)} (line {m.line}); map it from one topic",
                    m.line,
                    file,
                )
            bridge.written[v] = m
    sharing.check_writers(imports, bridge.written, {}, lambda message, line: BridgeFileError(message, line, file))
    return bridge


def _field_of(m: Mapping, variable: str) -> str:
    """' (field speed)' for a declared type's mapping, '' for a std_msgs one."""
    fields = [f for f, _, v in m.leaves() if v == variable] if m.plan else []
    return f" (field {fields[0]})" if fields else ""


def _check_type_names(doc, file: str) -> None:
    """A mapping's type is a std_msgs type the bridge maps or one the file declares: said before the
    schema, which would otherwise ask a mistyped std_msgs type for a declared type's "fields"."""
    if not isinstance(doc, dict):
        return
    declared_names = doc.get("types") if isinstance(doc.get("types"), dict) else {}
    for kind in ("publish", "subscribe"):
        ms = doc.get(kind)
        for i, m in enumerate(ms if isinstance(ms, list) else []):
            t = m.get("type") if isinstance(m, dict) else None
            if isinstance(t, str) and t not in SCALAR_TYPES + ARRAY_TYPES and t not in declared_names:
                raise BridgeFileError(
                    f"{kind}[{i}].type: {t} is neither a std_msgs type the bridge maps ({', '.join(SCALAR_TYPES + ARRAY_TYPES)}) "
                    'nor declared in "types"',
                    _line_of(doc, [kind, i]),
                    file,
                )


def _check_topics(bridge: BridgeFile, file: str) -> None:
    seen: dict[str, tuple[str, int | None]] = {}
    if bridge.joint_states:
        seen[bridge.joint_states_topic] = ("joint_states", None)
    if bridge.diagnostics:
        seen["diagnostics"] = ("diagnostics", None)
    for kind, ms in (("publish", bridge.publish), ("subscribe", bridge.subscribe)):
        for m in ms:
            if m.topic in seen:
                what, line = seen[m.topic]
                at = f" (line {line})" if line else ""
                raise BridgeFileError(
                    f"{kind}: topic {m.topic} is already mapped by {what}{at}; one mapping per topic", m.line, file
                )
            seen[m.topic] = (kind, m.line)


def check_writers(bridge: BridgeFile, module_writes: dict[str, list[str]], file: str = BRIDGE_JSON) -> None:
    """A variable a subscription writes must not be declared by a module as one it writes
    (module.xml `<writes>`): refused naming both."""
    for module, paths in module_writes.items():
        for v in paths:
            m = bridge.written.get(v)
            if m is not None:
                raise BridgeFileError(
                    f"{v} would have two writers: module {module} (module.xml <writes>) and the "
                    f"subscription to {m.topic}{_field_of(m, v)}; drop one of them",
                    m.line,
                    file,
                )
    sharing.check_writers(bridge.imports, {}, module_writes, lambda message, line: BridgeFileError(message, line, file))


def check_variables(bridge: BridgeFile, scalars: dict[str, str], file: str = BRIDGE_JSON, kinds=None) -> None:
    """Every mapped variable is a scalar leaf of the layout (path -> its type), and, with `kinds`
    (type -> (kind, bits), layout_kinds), one whose values its field holds exactly (publish) or
    that holds every value of its field (subscribe): refused naming the mapping, field and variable."""
    for kind, ms in (("publish", bridge.publish), ("subscribe", bridge.subscribe)):
        for m in ms:
            for field_name, basic, v in m.leaves():
                if v not in scalars:
                    near = [p for p in scalars if p.startswith(v + ".") or p.startswith(v + "[")]
                    hint = f" (it is a struct or an array: map {near[0]}, ...)" if near else ""
                    raise BridgeFileError(
                        f"{kind} {m.topic}: field {field_name}: no scalar variable {v} in the layout{hint}",
                        m.line,
                        file,
                    )
                var = (kinds or {}).get(scalars[v])
                if var is None:
                    continue
                f = (BASIC[basic].kind, BASIC[basic].bits)
                if not (holds(f, var) if kind == "publish" else holds(var, f)):
                    goes = "into the field" if kind == "publish" else "into the variable"
                    raise BridgeFileError(
                        f"{kind} {m.topic}: field {field_name} ({basic}) and variable {v} ({scalars[v]}) do not fit: "
                        f"not every value of the {'variable' if kind == 'publish' else 'field'} goes {goes} exactly; "
                        "map a variable of a type that does, or change the field's type",
                        m.line,
                        file,
                    )


def check_layout(bridge: BridgeFile, layout: dict, file: str = BRIDGE_JSON) -> None:
    """Every mapped, exported and imported variable against the layout (layout.json), with the types
    their fields hold."""
    check_variables(bridge, layout_scalars(layout), file, kinds=layout_kinds(layout))
    sharing.check_layout(
        bridge.export, bridge.imports, layout, lambda message, line: BridgeFileError(message, line, file)
    )


def layout_scalars(layout: dict) -> dict[str, str]:
    """layout.json -> {scalar path: its type} (the leaves glbc lists, but a compiler's own)."""
    return {
        leaf["path"]: leaf["type"]
        for leaf in shown(layout.get("leaves", []))
        if leaf.get("type") in layout.get("scalars", {})
    }


def layout_kinds(layout: dict) -> dict[str, tuple[str, int]]:
    """layout.json -> {scalar type: (kind, bits)} for the types whose kind it gives."""
    out = {}
    for name, t in layout.get("scalars", {}).items():
        if t.get("kind") in ("bool", "signed", "unsigned", "float") and isinstance(t.get("size"), int):
            out[name] = (t["kind"], 1 if t["kind"] == "bool" else 8 * t["size"])
    return out

"""declared.py -- the message types a set's dds.json declares in ROS 2's .msg syntax (docs/dds.md
"Declared message types"), and the mappings of their fields to variables.

The definitions are read by rosbags' msg parser (`get_types_from_msg`), their fields may be the
basic types, the types the bridge ships (ros2_types: std_msgs/Header, builtin_interfaces/Time ...)
and the file's other declared types.  Each is built at load time as a cyclonedds IdlStruct under
ROS 2's DDS name (`pkg::msg::dds_::Name_`, fields in their order, `T[N]` an array, `T[<=N]` a
bounded sequence, `T[]` a sequence).  A mapping's "fields" is compiled into a Plan: which variable
fills which element, the constants and the stamps; the Plan builds a message from the variables'
values and reads the values back out of a received one.  Every refusal is a DeclarationError with
the words to fix it; bridge_file adds the file, the line and the mapping.
"""

from __future__ import annotations

import math
import typing
from dataclasses import dataclass

from cyclonedds.idl import IdlStruct, make_idl_struct, types
from rosbags.interfaces import Nodetype
from rosbags.typesys import TypesysError, get_types_from_msg

from . import ros2_types
from .idl_basic import BASIC, msg_basic, rosbags_reason, value_range

TIME = "builtin_interfaces/msg/Time"
MAX_LEAVES = 256  # variables one message maps


class DeclarationError(ValueError):
    pass


class Malformed(ValueError):
    """A received message that does not fit its mapping (a sequence of another length)."""


def _ros_name(cls) -> str:
    """sensor_msgs::msg::dds_::JointState_ -> sensor_msgs/msg/JointState."""
    package, msg, _, struct = cls.__idl_typename__.split("::")
    return f"{package}/{msg}/{struct[:-1]}"


SHIPPED = {_ros_name(getattr(ros2_types, n)): getattr(ros2_types, n) for n in ros2_types.__all__}


@dataclass(frozen=True)
class Field:
    name: str
    basic: str = ""  # a basic type (idl_basic.BASIC), or
    struct: str = ""  # a message type's ROS 2 name
    container: str = ""  # "", "array" or "sequence"
    size: int = 0  # the array's length, the sequence's bound (0: none)
    bound: int = 0  # a string's bound

    def __str__(self) -> str:
        element = self.struct or (f"string<={self.bound}" if self.bound else self.basic)
        if self.container == "array":
            return f"{element}[{self.size}]"
        if self.container == "sequence":
            return f"{element}[<={self.size}]" if self.size else f"{element}[]"
        return element


@dataclass(frozen=True)
class TypeDef:
    name: str  # cell_msgs/msg/CellStatus
    fields: tuple[Field, ...]
    cls: type


def _shipped_fields(cls) -> tuple[Field, ...]:
    """A generated class's fields, read from its cyclonedds annotations."""
    out = []
    for name, ann in typing.get_type_hints(cls, include_extras=True).items():
        container, size, bound = "", 0, 0
        marker = typing.get_args(ann)[1] if typing.get_origin(ann) is typing.Annotated else None
        if isinstance(marker, (types.array, types.sequence)):
            container = "array" if isinstance(marker, types.array) else "sequence"
            size = marker.length if container == "array" else marker.max_length or 0
            ann = marker.subtype
            marker = typing.get_args(ann)[1] if typing.get_origin(ann) is typing.Annotated else None
        if isinstance(ann, type) and issubclass(ann, IdlStruct):
            out.append(Field(name, struct=_ros_name(ann), container=container, size=size))
            continue
        if isinstance(marker, types.bounded_str):
            basic, bound = "string", marker.max_length
        else:
            basic = marker if isinstance(marker, str) else {bool: "bool", str: "string"}[ann]
        out.append(Field(name, basic=basic, container=container, size=size, bound=bound))
    return tuple(out)


_SHIPPED_DEFS = {name: TypeDef(name, _shipped_fields(cls), cls) for name, cls in SHIPPED.items()}
_BUILT: dict[tuple, type] = {}  # the classes made, by their definitions: a reload reuses them


def _field(name: str, desc, where: str) -> Field:
    node, rest = desc
    container, size = "", 0
    if node in (Nodetype.ARRAY, Nodetype.SEQUENCE):
        container = "array" if node == Nodetype.ARRAY else "sequence"
        (node, rest), size = rest
    if node == Nodetype.NAME:
        return Field(name, struct=rest, container=container, size=size)
    basic, bound = rest
    basic = msg_basic(basic)
    if basic not in BASIC:
        raise DeclarationError(f"{where}: field {name}: {basic} is not a type ROS 2 puts on DDS here")
    return Field(name, basic=basic, container=container, size=size, bound=bound)


def parse_types(declared: dict[str, str]) -> dict[str, TypeDef]:
    """dds.json's "types" -> their definitions and cyclonedds classes, with the shipped ones."""
    raw: dict[str, tuple[Field, ...]] = {}
    for name, text in declared.items():
        where = f"types: {name}"
        if name in SHIPPED:
            raise DeclarationError(f"{where} is a type the bridge ships; declare types of a package of your own")
        try:
            parsed = get_types_from_msg(text, name)
        except TypesysError as e:
            raise DeclarationError(f"{where}: {rosbags_reason(e)}") from None
        fields = tuple(_field(n, d, where) for n, d in parsed[name][1])
        if not fields:
            raise DeclarationError(f"{where} declares no field")
        raw[name] = fields
    for name, fields in raw.items():
        for f in fields:
            if f.struct and f.struct not in SHIPPED and f.struct not in raw:
                bare = f.struct.rsplit("/", 1)[-1]
                raise DeclarationError(
                    f"types: {name}: field {f.name}: unknown type {bare if f.struct.startswith(name.rsplit('/', 1)[0]) else f.struct} "
                    f"(not a basic type, not one the bridge ships ({', '.join(sorted(SHIPPED))}), not declared in types)"
                )
    defs = dict(_SHIPPED_DEFS)

    def build(name: str, path: tuple[str, ...]) -> None:
        if name in defs:
            return
        if name in path:
            raise DeclarationError(f"types: {name} contains itself ({' -> '.join((*path, name))})")
        for f in raw[name]:
            if f.struct:
                build(f.struct, (*path, name))
        key = (name, declared[name], *(defs[f.struct].cls for f in raw[name] if f.struct))
        if key not in _BUILT:
            package, _, short = name.split("/")
            annotations = {f.name: _annotation(f, defs) for f in raw[name]}
            _BUILT[key] = make_idl_struct(f"{short}_", f"{package}::msg::dds_::{short}_", annotations)
        defs[name] = TypeDef(name, raw[name], _BUILT[key])

    for name in raw:
        build(name, ())
    return defs


def _annotation(f: Field, defs: dict[str, TypeDef]):
    if f.struct:
        element = defs[f.struct].cls
    elif f.basic == "string":
        element = types.bounded_str[f.bound] if f.bound else str
    else:
        a = BASIC[f.basic].annotation
        element = getattr(types, a.split(".", 1)[1]) if a.startswith("types.") else bool
    if f.container == "array":
        return types.array[element, f.size]
    if f.container == "sequence":
        return types.sequence[element, f.size] if f.size else types.sequence[element]
    return element


# ---- a mapping's fields ------------------------------------------------------------------------
@dataclass(frozen=True)
class Leaf:
    field: str  # where in the message: joints[2], header.frame_id
    basic: str  # its basic type
    variable: str


class Plan:
    """How one mapping fills its message type from variables, and reads them from a message."""

    def __init__(self, typedef: TypeDef, root, leaves: list[Leaf]):
        self.type, self.cls, self.root, self.leaves = typedef, typedef.cls, root, tuple(leaves)

    @property
    def variables(self) -> tuple[str, ...]:
        return tuple(leaf.variable for leaf in self.leaves)

    def build(self, values, stamp_ns: int):
        """The message with `values` (one per leaf, in order, as traced doubles) and the stamp."""
        return _build(self.root, values, stamp_ns)

    def read(self, message) -> list:
        """The leaves' values in `message`; Malformed if a sequence has another length."""
        out: list = [None] * len(self.leaves)
        _read(self.root, message, out)
        return out


def cast(basic: str, value: float):
    """A traced double as a field of `basic` type: bool, int (in the type's range), or float."""
    kind = BASIC[basic].kind
    if kind == "bool":
        return bool(value)
    if kind in ("signed", "unsigned"):
        if not math.isfinite(value):
            return 0
        low, high = value_range(basic)
        return max(low, min(high, int(value)))
    return float(value)


def fits(basic: str, value) -> bool:
    """A received value its field type allows (irpd checks it against the variable's own type)."""
    if isinstance(value, bool):
        return True
    if isinstance(value, float):
        return math.isfinite(value)
    span = value_range(basic)
    return isinstance(value, int) and (span is None or span[0] <= value <= span[1])


def _build(node, values, stamp_ns):
    kind = node[0]
    if kind == "var":
        return cast(node[2], values[node[1]])
    if kind == "const":
        return list(node[1]) if isinstance(node[1], list) else node[1]
    if kind == "stamp":
        return ros2_types.Time(sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000)
    if kind == "list":
        return [_build(c, values, stamp_ns) for c in node[1]]
    return node[1](**{name: _build(c, values, stamp_ns) for name, c in node[2]})


def _read(node, value, out) -> None:
    kind = node[0]
    if kind == "var":
        out[node[1]] = value
    elif kind == "list":
        if len(value) != len(node[1]):
            raise Malformed(f"{len(value)} elements where {len(node[1])} are mapped")
        for c, v in zip(node[1], value):
            _read(c, v, out)
    elif kind == "struct":
        for name, c in node[2]:
            _read(c, getattr(value, name), out)


def compile_fields(defs: dict[str, TypeDef], type_name: str, fields: dict, written: bool) -> Plan:
    """A mapping's "fields" against its type: every field mapped, to a variable (a list of them for
    an array or a sequence), a constant ({"const": ...}), the sample's stamp ({"stamp": true}, a
    builtin_interfaces/Time) or, for a message field, its own {"fields": {...}}.  `written`: a
    subscription (no variable twice)."""
    leaves: list[Leaf] = []
    root = _compile_struct(defs, defs[type_name], fields, "", leaves)
    if written:
        seen: dict[str, str] = {}
        for leaf in leaves:
            if leaf.variable in seen:
                raise DeclarationError(
                    f"{leaf.variable} would have two writers: fields {seen[leaf.variable]} and {leaf.field}; map it once"
                )
            seen[leaf.variable] = leaf.field
    plan = Plan(defs[type_name], root, leaves)
    try:  # a constant cyclonedds cannot put in its field (a string over its bound ...)
        plan.build([0.0] * len(leaves), 0).serialize()
    except Exception as e:
        raise DeclarationError(f"a constant does not fit its field: {e}") from None
    return plan


def _compile_struct(defs, td: TypeDef, spec: dict, prefix: str, leaves: list[Leaf]):
    names = [f.name for f in td.fields]
    for key in spec:
        if key not in names:
            raise DeclarationError(f"field {prefix}{key}: {td.name} has no such field (its fields: {', '.join(names)})")
    children = []
    for f in td.fields:
        path = prefix + f.name
        if f.name not in spec:
            how = 'a variable, {"const": ...}' + (', {"stamp": true}' if f.struct == TIME else "")
            if f.struct and not f.container:
                how = '{"fields": {...}}' + (' or {"stamp": true}' if f.struct == TIME else "")
            raise DeclarationError(f"field {path} ({f}) is not mapped; map it to {how}")
        children.append((f.name, _compile_field(defs, f, spec[f.name], path, leaves)))
    return ("struct", td.cls, tuple(children))


def _compile_field(defs, f: Field, spec, path: str, leaves: list[Leaf]):
    what = f"field {path} ({f})"
    if isinstance(spec, dict) and "const" in spec:
        return ("const", _constant(f, spec["const"], what))
    if isinstance(spec, dict) and "stamp" in spec:
        if f.struct != TIME or f.container:
            raise DeclarationError(f'{what}: {{"stamp": true}} is for a {TIME} field')
        return ("stamp",)
    if f.struct and not f.container:
        if not (isinstance(spec, dict) and "fields" in spec):
            raise DeclarationError(f'{what} is a message: map its fields with {{"fields": {{...}}}}')
        return _compile_struct(defs, defs[f.struct], spec["fields"], path + ".", leaves)
    if isinstance(spec, dict):
        raise DeclarationError(
            f'{what} is not a message: map it to {"a list of variables" if f.container else "a variable"}'
        )
    if f.struct or BASIC[f.basic].kind in ("string", "char"):
        raise DeclarationError(f'{what} cannot hold a variable\'s value: give it {{"const": ...}}')
    if not f.container:
        if not isinstance(spec, str):
            raise DeclarationError(f"{what} takes one variable, not a list")
        return _leaf(f.basic, path, spec, leaves)
    if not isinstance(spec, list):
        raise DeclarationError(f"{what} takes a list of variables, one per element")
    if f.container == "array" and len(spec) != f.size:
        raise DeclarationError(f"{what} maps {_count(spec)}; it has {f.size} elements: map each once")
    if f.size and len(spec) > f.size:
        raise DeclarationError(f"{what} maps {_count(spec)}; it holds at most {f.size}")
    return ("list", tuple(_leaf(f.basic, f"{path}[{i}]", v, leaves) for i, v in enumerate(spec)))


def _count(variables: list) -> str:
    return f"{len(variables)} variable" + ("" if len(variables) == 1 else "s")


def _leaf(basic: str, path: str, variable: str, leaves: list[Leaf]):
    if len(leaves) >= MAX_LEAVES:
        raise DeclarationError(f"field {path}: one message maps at most {MAX_LEAVES} variables")
    leaves.append(Leaf(path, basic, variable))
    return ("var", len(leaves) - 1, basic)


def _constant(f: Field, value, what: str):
    if f.container:
        if not isinstance(value, list):
            raise DeclarationError(f"{what}: its constant is a list")
        if f.container == "array" and len(value) != f.size or f.size and len(value) > f.size:
            raise DeclarationError(f"{what}: a constant of {len(value)} elements does not fit")
        if f.struct and value:
            raise DeclarationError(f'{what}: a list of messages is mapped as {{"const": []}} (empty) only')
        return [_scalar_constant(f.basic, v, what) for v in value]
    if f.struct:
        raise DeclarationError(f'{what} is a message: map its fields with {{"fields": {{...}}}}')
    return _scalar_constant(f.basic, value, what)


def _scalar_constant(basic: str, value, what: str):
    kind = BASIC[basic].kind
    ok = {
        "bool": isinstance(value, bool),
        "string": isinstance(value, str),
        "char": isinstance(value, str) and len(value) == 1,
        "float": isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value),
    }.get(kind, isinstance(value, int) and not isinstance(value, bool) and fits(basic, value))
    if not ok:
        raise DeclarationError(f"{what}: {value!r} is not a {basic} value")
    return float(value) if kind == "float" else value

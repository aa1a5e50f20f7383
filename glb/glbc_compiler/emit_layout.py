# emit_layout.py -- Layout -> layout.json: every variable and every scalar leaf with its full
# path, type, offset and size, the struct types, and the layout hash that binds header to segment.
#
# The hash is sha256 over json.dumps({"types": ..., "variables": ...}, sort_keys=True,
# separators=(",", ":"), ensure_ascii=True) with the variables' `source` fields left out, so
# that the same declarations give the same hash whatever the files are called.  A variable's
# type_id is the first 16 hex digits of sha256 over the same kind of JSON of its full type
# (scalars by C++ name, structs by their fields, recursively; no generated struct names).

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterator
from typing import Any

from .layout import Layout, StructType, Type, Variable, qualify

FORMAT = "indurop-layout"
VERSION = 1


def _type_name(t: Type) -> str:
    return t.qualname if isinstance(t, StructType) else t.name


def _types(layout: Layout) -> dict[str, Any]:
    return {
        st.qualname: {
            "size": st.size,
            "align": st.align,
            "fields": [
                {"name": f.name, "type": _type_name(f.type), "offset": f.offset, "size": f.size, "dims": list(f.dims)}
                | _iec(f.iec_type)
                for f in st.fields
            ],
        }
        for st in layout.types
    }


def _iec(iec_type: str | None) -> dict[str, str]:
    """The IEC type stc declared a variable or field with, or nothing (a .glb declaration has none)."""
    return {"iec_type": iec_type} if iec_type else {}


def _lock_group(group: str | None) -> dict[str, str]:
    """The lock group of a variable that shares its lock (Decl.lock_group); absent otherwise, so that
    layouts without groups are unchanged."""
    return {"lock_group": group} if group is not None else {}


def _internal(internal: bool) -> dict[str, bool]:
    """A compiler's own variable (stc's init flags) and its leaves carry "internal": true, so that
    every view of the variables leaves them out; others have no such key (their layouts unchanged)."""
    return {"internal": True} if internal else {}


def _canonical(value: Any) -> bytes:
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=True).encode("ascii")


def _describe(t: Type) -> Any:
    """What a value of t means, byte by byte: a scalar's C++ name, or a struct's fields."""
    if isinstance(t, StructType):
        return {
            "fields": [
                {"name": f.name, "type": _describe(f.type), "offset": f.offset, "size": f.size, "dims": list(f.dims)}
                for f in t.fields
            ]
        }
    return t.name


def type_id(v: Variable) -> str:
    """Equal for two variables exactly when their bytes mean the same thing (glbc --previous)."""
    described = {"type": _describe(v.type), "dims": list(v.dims), "size": v.size}
    return hashlib.sha256(_canonical(described)).hexdigest()[:16]


def _variable(v: Variable) -> dict[str, Any]:
    qualifier = {"retain": v.retain} if v.retain else {}  # absent when not qualified: older layouts unchanged
    return (
        {
            "path": v.path,
            "namespace": v.namespace,
            "name": v.name,
            "type": _type_name(v.type),
            "type_id": type_id(v),
            "offset": v.offset,
            "size": v.size,
            "align": v.align,
            "dims": list(v.dims),
            "lock": v.lock,
        }
        | qualifier
        | _iec(v.iec_type)
        | _internal(v.internal)
        | _lock_group(v.lock_group)
    )


def layout_hash(types: dict[str, Any], variables: list[dict[str, Any]]) -> str:
    return hashlib.sha256(
        _canonical({"types": types, "variables": [{k: x for k, x in v.items() if k != "source"} for v in variables]})
    ).hexdigest()


def _leaves(
    path: str, t: Type, dims: list[int], offset: int, lock: int, iec_type: str | None = None
) -> Iterator[dict[str, Any]]:
    if dims:
        stride = t.size
        for d in dims[1:]:
            stride *= d
        for i in range(dims[0]):
            yield from _leaves(f"{path}[{i}]", t, dims[1:], offset + i * stride, lock, iec_type)
    elif isinstance(t, StructType):
        for f in t.fields:
            yield from _leaves(f"{path}.{f.name}", f.type, f.dims, offset + f.offset, lock, f.iec_type)
    else:
        yield {"path": path, "type": t.name, "offset": offset, "size": t.size, "lock": lock} | _iec(iec_type)


def document(layout: Layout) -> dict[str, Any]:
    """The layout.json document, as a dict (in the order it is written)."""
    types = _types(layout)
    variables = [_variable(v) | {"source": v.loc.short()} for v in layout.variables]
    used = {
        t.name: t
        for t in [v.type for v in layout.variables] + [f.type for st in layout.types for f in st.fields]
        if not isinstance(t, StructType)
    }
    scalars = {name: {"size": s.size, "align": s.align, "kind": s.kind} for name, s in sorted(used.items())}
    own = layout_hash(types, variables)
    # A layout is not its own ancestor, and each ancestor is listed once: recompiling an unchanged
    # .glb against its own layout must not push older layouts (and the holes they keep) out.
    lineage, seen = [], {own}
    for entry in layout.lineage:
        if entry["hash"] not in seen:
            seen.add(entry["hash"])
            lineage.append(entry)
    return {
        "format": FORMAT,
        "version": VERSION,
        "hash": own,
        "data_size": layout.data_size,
        "lock_count": layout.lock_count,
        **({"changes": layout.changes} if layout.changes is not None else {}),  # glbc --previous only
        "sources": list(layout.sources),
        "namespaces": list(layout.namespaces),
        "defines": {qualify(d.namespace, d.name): d.value for d in layout.defines},
        "scalars": scalars,
        "types": types,
        "variables": variables,
        "leaves": [
            leaf | _internal(v.internal)
            for v in layout.variables
            for leaf in _leaves(v.path, v.type, v.dims, v.offset, v.lock, v.iec_type)
        ],
        "lineage": lineage,
    }


def _dump(value: Any, indent: int, in_list: bool) -> str:
    """Pretty JSON with one line per variable, field, leaf and scalar type (an object of plain values
    inside a list or below the second level)."""
    pad = "  " * indent

    def flat(x) -> bool:
        return not isinstance(x, (dict, list)) or (
            isinstance(x, list) and all(not isinstance(y, (dict, list)) for y in x)
        )

    if isinstance(value, dict):
        if not value:
            return "{}"
        if (in_list or indent >= 2) and all(flat(x) for x in value.values()):
            return json.dumps(value, ensure_ascii=False)
        items = [f'{pad}  {json.dumps(k, ensure_ascii=False)}: {_dump(x, indent + 1, False)}' for k, x in value.items()]
        return "{\n" + ",\n".join(items) + f"\n{pad}}}"
    if isinstance(value, list):
        if flat(value):
            return json.dumps(value, ensure_ascii=False)
        items = [f"{pad}  {_dump(x, indent + 1, True)}" for x in value]
        return "[\n" + ",\n".join(items) + f"\n{pad}]"
    return json.dumps(value, ensure_ascii=False)


def render(layout: Layout) -> str:
    return _dump(document(layout), 0, False) + "\n"

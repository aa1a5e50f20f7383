# xml_types.py -- the tree's types as written (TypeRef, STRING, ARRAY, subrange, enum, STRUCT) and
# initial values as PLCopen XML 2.01 <dataType> content and <value> elements, and variable lists.

from __future__ import annotations

from lxml import etree
from plcopen_import.read import q
from stc_compiler import tree as t
from stc_compiler.errors import StError

from .st_print import expr

# the schema's elementary types (its elementaryTypes group), by the names ST writes them with
ELEMENTARY = {
    n: n
    for n in (
        "BOOL BYTE WORD DWORD LWORD SINT INT DINT LINT USINT UINT UDINT ULINT REAL LREAL TIME DATE DT TOD".split()
    )
}
ELEMENTARY |= {"DATE_AND_TIME": "DT", "TIME_OF_DAY": "TOD"}
UNSIGNED = {"BYTE", "WORD", "DWORD", "LWORD", "USINT", "UINT", "UDINT", "ULINT"}

# the interface's variable lists, by VarDecl.kind (the schema's order of them is free)
LISTS = {
    "VAR": "localVars",
    "VAR_TEMP": "tempVars",
    "VAR_INPUT": "inputVars",
    "VAR_OUTPUT": "outputVars",
    "VAR_IN_OUT": "inOutVars",
    "VAR_EXTERNAL": "externalVars",
    "VAR_GLOBAL": "globalVars",
}


def sub(parent: etree._Element, tag: str, **attrs: str) -> etree._Element:
    return etree.SubElement(parent, q(tag), {k: v for k, v in attrs.items() if v is not None})


def data_type(parent: etree._Element, spec) -> None:
    """The type `spec` as the one child of `parent` (a <type>, <baseType> or <returnType>)."""
    if isinstance(spec, t.TypeRef):
        name = ELEMENTARY.get(spec.name.upper())
        if name:
            sub(parent, name)
        elif spec.name.upper() in ("STRING", "WSTRING"):
            sub(parent, spec.name.lower())
        else:
            sub(parent, "derived", name=spec.name)
    elif isinstance(spec, t.StringSpec):
        sub(parent, "wstring" if spec.wide else "string", length=expr(spec.length) if spec.length else None)
    elif isinstance(spec, t.ArraySpec):
        a = sub(parent, "array")
        for low, high in spec.ranges:
            sub(a, "dimension", lower=expr(low), upper=expr(high))
        data_type(sub(a, "baseType"), spec.element)
    elif isinstance(spec, t.SubrangeSpec):
        unsigned = spec.base.name.upper() in UNSIGNED
        s = sub(parent, "subrangeUnsigned" if unsigned else "subrangeSigned")
        sub(s, "range", lower=expr(spec.low), upper=expr(spec.high))
        data_type(sub(s, "baseType"), spec.base)
    elif isinstance(spec, t.EnumSpec):
        values = sub(sub(parent, "enum"), "values")
        for v in spec.values:
            sub(values, "value", name=v.name, value=expr(v.value) if v.value is not None else None)
    elif isinstance(spec, t.StructSpec):
        s = sub(parent, "struct")
        for m in spec.members:
            variable(s, m)
    else:
        raise StError(spec.place, "export", f"a type of kind {type(spec).__name__} has no PLCopen XML form")


def value(parent: etree._Element, init) -> None:
    """An initial value (an expression, [array], (struct)) as the one child of `parent`."""
    if isinstance(init, t.ArrayInit):
        a = sub(parent, "arrayValue")
        for item in init.items:
            v = sub(a, "value", repetitionValue=str(item.count) if item.count is not None else None)
            if item.value is None:
                sub(v, "simpleValue")  # `3()`: the element type's initial values
            else:
                value(v, item.value)
    elif isinstance(init, t.StructInit):
        s = sub(parent, "structValue")
        for name, _place, v in init.fields:
            value(sub(s, "value", member=name), v)
    else:
        sub(parent, "simpleValue", value=expr(init))


def variable(parent: etree._Element, d: t.VarDecl) -> None:
    v = sub(parent, "variable", name=d.name, address=d.location)
    data_type(sub(v, "type"), d.spec)
    if d.init is not None:
        value(sub(v, "initialValue"), d.init)


def var_lists(parent: etree._Element, decls: list[t.VarDecl], tag: str | None = None) -> None:
    """`decls` as variable lists under `parent`, one per run of the same kind and qualifiers (in
    their order); `tag` names the list for every kind (a configuration's or resource's globalVars)."""
    run: etree._Element | None = None
    key = None
    for d in decls:
        k = (d.kind, d.constant, d.retain, d.persistent)
        if k != key:
            name = tag or LISTS.get(d.kind)
            if name is None:
                raise StError(d.place, "export", f"{d.name}: a {d.kind} has no PLCopen XML variable list")
            flags = {"constant": d.constant, "retain": d.retain, "persistent": d.persistent}
            run = sub(parent, name, **{f: "true" for f, on in flags.items() if on})
            key = k
        variable(run, d)

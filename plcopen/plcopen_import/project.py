# project.py -- a PLCopen XML project -> the ST compiler's Unit (st/stc_compiler/tree.py): data types,
# POU interfaces, global variables and configurations are written out as ST declarations, one XML
# element per line, and parsed by stc's own grammar (every node then placed back at its element's
# line in the XML file); bodies come from st_text.py (ST), ld.py, fbd.py and sfc.py (graphical).

from __future__ import annotations

import importlib.util
import re

from lxml import etree
from stc_compiler import tree as t
from stc_compiler.errors import Place, StError, StErrors
from stc_compiler.parse import parse_text

from . import graph, st_text
from .context import Ctx
from .read import local, place, q, read_file

# the variable lists of a POU interface and their ST section keywords
SECTIONS = {
    "inputVars": "VAR_INPUT",
    "outputVars": "VAR_OUTPUT",
    "inOutVars": "VAR_IN_OUT",
    "localVars": "VAR",
    "tempVars": "VAR_TEMP",
    "externalVars": "VAR_EXTERNAL",
    "globalVars": "VAR_GLOBAL",
}
POU_KINDS = {"program": "PROGRAM", "functionBlock": "FUNCTION_BLOCK", "function": "FUNCTION"}
DIRECT = re.compile(r"%[IQM][XBWDL*]?[0-9.]*$", re.IGNORECASE)
# elementary type elements whose ST name differs from the tag
_TYPE_NAMES = {"dt": "DT", "tod": "TOD", "date": "DATE", "time": "TIME"}


class Text:
    """ST text written line by line, each line remembering the XML element it stands for."""

    def __init__(self, file: str) -> None:
        self.file = file
        self.lines: list[str] = []
        self.elements: list[etree._Element | None] = []
        self.origins: list[str] = []

    def add(self, line: str, el: etree._Element | None, origin: str = "") -> None:
        """A line for `el`; `origin` names it in errors (`main_test variable LOGGER0`)."""
        self.lines.append(line)
        self.elements.append(el)
        self.origins.append(origin)

    def place(self, line: int) -> Place:
        if not 0 < line <= len(self.elements):
            return place(self.file, None)
        return place(self.file, self.elements[line - 1], self.origins[line - 1])

    def parse(self) -> t.Unit:
        """The text parsed by stc's parser; every place moved to its XML element's line."""
        try:
            unit = parse_text(self.file, "\n".join(self.lines) + "\n")
        except StError as e:
            raise StError(self.place(e.line), e.code, e.message) from None
        st_text.replace_places(unit, lambda p: self.place(p.line))
        return unit


def _fail(file: str, el: etree._Element, message: str) -> StError:
    return StError(place(file, el), "plcopen", message)


# ---- types and values ---------------------------------------------------------------------------


def type_text(file: str, type_el: etree._Element) -> str:
    """A <type>, <baseType> or <returnType> element -> its ST spelling."""
    kids = [c for c in type_el if isinstance(c.tag, str)]
    if len(kids) != 1:
        raise _fail(file, type_el, "a type needs exactly one type element")
    el = kids[0]
    tag = local(el)
    if tag == "derived":
        return el.get("name")
    if tag in ("string", "wstring"):
        length = el.get("length")
        return tag.upper() + (f"[{length}]" if length else "")
    if tag == "array":
        dims = ", ".join(f"{d.get('lower')}..{d.get('upper')}" for d in el.findall(q("dimension")))
        return f"ARRAY[{dims}] OF {type_text(file, el.find(q('baseType')))}"
    if tag in ("subrangeSigned", "subrangeUnsigned"):
        r = el.find(q("range"))
        return f"{type_text(file, el.find(q('baseType')))} ({r.get('lower')}..{r.get('upper')})"
    if tag == "enum":  # a value's number, when the file gives one, kept (Slow := 5)
        values = el.find(q("values")).findall(q("value"))
        return (
            "(" + ", ".join(v.get("name") + (f" := {v.get('value')}" if v.get("value") else "") for v in values) + ")"
        )
    if tag in ("struct", "pointer") or tag.startswith("ANY"):
        raise _fail(file, el, f"a <{tag}> type is not supported here; declare it as a named data type")
    return _TYPE_NAMES.get(tag, tag.upper() if tag.islower() else tag)


def value_text(file: str, el: etree._Element) -> str:
    """An <initialValue> (or a <value> inside one) -> ST initial value text."""
    kids = [c for c in el if isinstance(c.tag, str) and local(c) != "documentation"]
    if len(kids) != 1:
        raise _fail(file, el, "an initial value needs one simpleValue, arrayValue or structValue")
    v = kids[0]
    tag = local(v)
    if tag == "simpleValue":
        return v.get("value", "")
    if tag == "arrayValue":
        items = []
        for item in v.findall(q("value")):
            text = value_text(file, item)
            rep = item.get("repetitionValue")
            items.append(f"{rep}({text})" if rep else text)
        return "[" + ", ".join(items) + "]"
    if tag == "structValue":
        return "(" + ", ".join(f"{m.get('member')} := {value_text(file, m)}" for m in v.findall(q("value"))) + ")"
    raise _fail(file, v, f"<{tag}> is not an initial value")


def _variable(text: Text, var: etree._Element, owner: str) -> None:
    """One <variable> of a var list, on one line: `name [AT %addr] : type [:= init];`."""
    file = text.file
    name = var.get("name")
    address = var.get("address") or ""
    # a direct address (%IX0.0, %QW3, %MD1) names a PLC's I/O image, which indurop has not: the variable
    # stays an ordinary one (its path is shown, forced and monitored); `%ns.var` binds a shared variable
    at = f" AT {address}" if address and not DIRECT.match(address) else ""
    typ = type_text(file, var.find(q("type")))
    init = var.find(q("initialValue"))
    text.add(
        f"  {name}{at} : {typ}{' := ' + value_text(file, init) if init is not None else ''};",
        var,
        f"{owner} variable {name}",
    )


def _var_list(text: Text, section: str, lst: etree._Element, owner: str) -> None:
    quals = [w for w in ("constant", "retain", "persistent") if lst.get(w) == "true"]
    if lst.get("nonretain") == "true":
        quals.append("NON_RETAIN")
    text.add(f"{section} {' '.join(w.upper() for w in quals)}".rstrip(), lst, owner)
    for var in lst.findall(q("variable")):
        _variable(text, var, owner)
    text.add("END_VAR", lst, owner)


def _data_type(text: Text, dt: etree._Element) -> None:
    file = text.file
    base = dt.find(q("baseType"))
    inner = [c for c in base if isinstance(c.tag, str)][0]
    init = dt.find(q("initialValue"))
    tail = f" := {value_text(file, init)}" if init is not None else ""
    origin = f"type {dt.get('name')}"
    if local(inner) == "struct":
        text.add(f"TYPE {dt.get('name')} : STRUCT", dt, origin)
        for var in inner.findall(q("variable")):
            _variable(text, var, origin)
        text.add("END_STRUCT; END_TYPE", dt, origin)
    else:
        text.add(f"TYPE {dt.get('name')} : {type_text(file, base)}{tail}; END_TYPE", dt, origin)


# ---- configurations ------------------------------------------------------------------------------


def _resource(text: Text, res: etree._Element, conf: str) -> None:
    origin = f"{conf}, resource {res.get('name')}"
    text.add(f"RESOURCE {res.get('name')} ON PLC", res, origin)
    for lst in res.findall(q("globalVars")):
        _var_list(text, "VAR_GLOBAL", lst, origin)
    for task in res.findall(q("task")):
        params = []
        if task.get("interval"):
            params.append(f"INTERVAL := {task.get('interval')}")
        if task.get("single"):
            params.append(f"SINGLE := {task.get('single')}")
        params.append(f"PRIORITY := {task.get('priority', '0')}")
        text.add(f"TASK {task.get('name')} ({', '.join(params)});", task, f"{origin}, task {task.get('name')}")
    for task in res.findall(q("task")):
        for inst in task.findall(q("pouInstance")):
            text.add(
                f"PROGRAM {inst.get('name')} WITH {task.get('name')} : {inst.get('typeName')};",
                inst,
                f"{origin}, pouInstance {inst.get('name')}",
            )
    # a pouInstance directly under the resource is bound to no task: when it would run is not said
    # (Beremiz runs it every tick of the resource, other runtimes never), so it is refused
    for inst in res.findall(q("pouInstance")):
        raise StError(
            place(text.file, inst, f"{origin}, pouInstance {inst.get('name')}"),
            "task",
            f"the instance '{inst.get('name')}' of {inst.get('typeName')} is bound to no task (it is directly under "
            "the resource); put it into a <task> (in the editor: give the instance a task) so that it has a period",
        )
    text.add("END_RESOURCE", res, origin)


def _configuration(text: Text, conf: etree._Element) -> None:
    origin = f"configuration {conf.get('name')}"
    text.add(f"CONFIGURATION {conf.get('name')}", conf, origin)
    for lst in conf.findall(q("globalVars")):
        _var_list(text, "VAR_GLOBAL", lst, origin)
    for res in conf.findall(q("resource")):
        _resource(text, res, origin)
    text.add("END_CONFIGURATION", conf, origin)


# ---- POUs ---------------------------------------------------------------------------------------


def _pou_header(text: Text, pou: etree._Element) -> None:
    file = text.file
    kind = POU_KINDS[pou.get("pouType")]
    ret = pou.find(f"{q('interface')}/{q('returnType')}")
    returns = f" : {type_text(file, ret)}" if kind == "FUNCTION" and ret is not None else ""
    name = pou.get("name")
    text.add(f"{kind} {name}{returns}", pou, name)
    iface = pou.find(q("interface"))
    for lst in iface if iface is not None else []:
        if not isinstance(lst.tag, str) or local(lst) in ("returnType", "documentation", "addData"):
            continue
        section = SECTIONS.get(local(lst))
        if section is None:
            raise _fail(file, lst, f"<{local(lst)}> in POU '{pou.get('name')}' is not supported")
        _var_list(text, section, lst, name)
    text.add(f"END_{kind}", pou, name)


def _sfc_module():
    if importlib.util.find_spec(f"{__package__}.sfc") is None:
        return None
    return importlib.import_module(f"{__package__}.sfc")


def body_of(ctx: Ctx, name: str, body_el: etree._Element) -> list:
    """The statements of a <body> (a POU's, an action's or a transition's) named `name` in errors."""
    langs = [c for c in body_el if isinstance(c.tag, str) and local(c) != "documentation"]
    if not langs:
        return []
    lang_el = langs[0]
    lang = local(lang_el)
    if lang == "ST":
        src, line = st_text.text_of(lang_el)
        return st_text.statements(ctx.file, src, line, f"{name} (ST)")
    if lang in ("LD", "FBD"):
        from . import fbd, ld

        body = graph.body_graph(ctx.file, name, lang_el)
        return (ld if lang == "LD" else fbd).translate(ctx, body)
    if lang == "SFC":
        sfc = _sfc_module()
        if sfc is None:
            raise StError(place(ctx.file, lang_el, f"{name} (SFC)"), "plcopen", "SFC bodies are not supported yet")
        return sfc.translate(ctx, ctx.pou_el, graph.body_graph(ctx.file, name, lang_el))
    if lang == "IL":
        from . import il

        return il.translate(ctx, name, lang_el)
    raise StError(place(ctx.file, lang_el, name), "plcopen", f"a <{lang}> body is not supported")


def unit_of(file: str, root: etree._Element, flows: dict | None = None) -> t.Unit:
    """The Unit of a project read by read.read (its types, POUs, globals and configurations).  `flows`,
    when given, gets every graphical body's values (Ctx.flows: (body, localId, formal) -> expression),
    for the live view to fold on sampled values after check()."""
    text = Text(file)
    types = root.find(q("types"))
    pous = types.findall(f"{q('pous')}/{q('pou')}") if types is not None else []
    for dt in types.findall(f"{q('dataTypes')}/{q('dataType')}") if types is not None else []:
        _data_type(text, dt)
    for pou in pous:
        _pou_header(text, pou)
    for conf in root.findall(f"{q('instances')}/{q('configurations')}/{q('configuration')}"):
        _configuration(text, conf)
    unit = text.parse()
    errors: list[StError] = []
    for pou_el, pou in zip(pous, unit.pous, strict=True):
        ctx = Ctx(file, pou_el, pou, flows)
        try:
            bodies = pou_el.findall(q("body"))
            if bodies:
                pou.body = body_of(ctx, pou.name, bodies[0])
        except StError as e:
            errors.append(e)
        except StErrors as e:
            errors.extend(e.errors)
    if errors:
        raise StErrors(errors)
    return unit


def read_unit(path: str) -> t.Unit:
    """A PLCopen XML file -> its Unit (read_file + unit_of)."""
    return unit_of(path, read_file(path))

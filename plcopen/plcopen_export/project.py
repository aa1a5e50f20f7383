# project.py -- the running set's programs as one PLCopen XML 2.01 project: the Units' data types,
# POUs (interfaces from the tree; ST bodies as the text written in their source file; a POU that came
# from a PLCopen file keeps that file's body, actions and transitions, positions included) and
# configurations with their resources, tasks, global variables and program instances.  Written with
# lxml, checked against the TC6 schema before it is returned.

from __future__ import annotations

import copy
import datetime
from pathlib import Path

from lxml import etree
from plcopen_import.read import NS, XHTML, local, q, schema
from stc_compiler import tree as t
from stc_compiler.errors import Place, StError, StErrors
from stc_compiler.parse import parse_file, read

from .st_print import body_text, expr
from .xml_types import data_type, sub, value, var_lists

POU_TYPES = {"PROGRAM": "program", "FUNCTION_BLOCK": "functionBlock", "FUNCTION": "function"}
PRODUCT = "indurop"


def source_pou(pou: t.Pou) -> etree._Element | None:
    """The <pou> element of the PLCopen file `pou` was imported from (import_unit keeps it on the Pou
    as `xml`), or None for a POU written in ST."""
    el = getattr(pou, "xml", None)
    return el if isinstance(el, etree._Element) and local(el) == "pou" else None


def export(
    units: list[t.Unit],
    texts: dict[str, str] | None = None,
    name: str = "indurop",
    when: datetime.datetime | None = None,
) -> bytes:
    """The Units (a set's parsed sources, not st/lib's) as a PLCopen XML 2.01 file's bytes.
    `texts`: source file -> its text, for ST bodies (read from the file when not given); `when`: the
    file's creation time (default now, UTC)."""
    texts = dict(texts or {})
    when = when or datetime.datetime.now(datetime.UTC).replace(microsecond=0)
    root = etree.Element(q("project"), nsmap={None: NS, "xhtml": XHTML})
    sub(
        root,
        "fileHeader",
        companyName=PRODUCT,
        productName=PRODUCT,
        productVersion="1",
        creationDateTime=when.isoformat(),
    )
    header = sub(root, "contentHeader", name=name)
    coords = sub(header, "coordinateInfo")
    for lang in ("fbd", "ld", "sfc"):
        sub(sub(coords, lang), "scaling", x="1", y="1")
    types = sub(root, "types")
    data_types = sub(types, "dataTypes")
    pous = sub(types, "pous")
    errors: list[StError] = []
    configurations = []
    globals_ = []
    for unit in units:
        for d in unit.types:
            _guard(errors, _data_type, data_types, d)
        for p in unit.pous:
            _guard(errors, _pou, pous, p, texts)
        configurations += unit.configurations
        globals_ += unit.globals
    instances = sub(sub(root, "instances"), "configurations")
    if globals_ and not configurations:  # top-level VAR_GLOBAL: PLCopen keeps globals in a configuration
        configurations = [t.Configuration(globals_[0].place, "Globals", [], [])]
    for i, c in enumerate(configurations):
        _guard(errors, _configuration, instances, c, globals_ if i == 0 else [])
    if errors:
        raise StErrors(errors)
    _validate(root)
    return etree.tostring(root, xml_declaration=True, encoding="UTF-8", pretty_print=True)


def _guard(errors: list[StError], f, *args) -> None:
    try:
        f(*args)
    except StError as e:
        errors.append(e)
    except StErrors as e:
        errors += e.errors


def _data_type(parent: etree._Element, d: t.TypeDecl) -> None:
    if d.extern:
        raise StError(
            d.place, "export", f"TYPE {d.name} is implemented in C++ ({{extern}}): PLCopen XML has no form for it"
        )
    el = sub(parent, "dataType", name=d.name)
    data_type(sub(el, "baseType"), d.spec)
    if d.init is not None:
        value(sub(el, "initialValue"), d.init)


def _pou(parent: etree._Element, p: t.Pou, texts: dict[str, str]) -> None:
    if p.extern:
        raise StError(p.place, "export", f"{p.name} is implemented in C++ ({{extern}}): PLCopen XML has no form for it")
    el = sub(parent, "pou", name=p.name, pouType=POU_TYPES[p.kind])
    src = source_pou(p)
    declared = None
    if src is not None and src.find(q("interface")) is not None:
        # the file's own variables: hidden ones the translation added (edge memories, steps) are not written
        declared = {v.get("name", "").upper() for v in src.iterfind(f"{q('interface')}//{q('variable')}")}
    interface = sub(el, "interface")
    if p.returns is not None:
        data_type(sub(interface, "returnType"), p.returns)
    var_lists(interface, [d for d in p.vars if declared is None or d.name.upper() in declared])
    if src is not None:
        for tag in ("actions", "transitions", "body"):
            for part in src.iterfind(q(tag)):
                el.append(copy.deepcopy(part))
        return
    file = p.place.file
    if file not in texts:
        texts[file] = read(file)
    st = sub(sub(el, "body"), "ST")
    etree.SubElement(st, f"{{{XHTML}}}p").text = body_text(p, texts[file])


def _configuration(parent: etree._Element, c: t.Configuration, top_globals: list[t.VarDecl]) -> None:
    el = sub(parent, "configuration", name=c.name)
    for r in c.resources:
        _resource(el, r)
    var_lists(el, top_globals + c.vars, "globalVars")


def _resource(parent: etree._Element, r: t.Resource) -> None:
    el = sub(parent, "resource", name=r.name)
    known = {task.name.upper() for task in r.tasks}
    by_task: dict[str, list[t.ProgramConfig]] = {}
    free = []
    errors: list[StError] = []
    for p in r.programs:
        if p.args or p.retain is not None:
            errors.append(
                StError(
                    p.place,
                    "export",
                    f"PROGRAM {p.name}: a program instance's arguments and RETAIN/NON_RETAIN have no PLCopen XML form; "
                    "declare them in the program instead",
                )
            )
        elif p.task is not None and p.task.upper() in known:
            by_task.setdefault(p.task.upper(), []).append(p)
        elif p.task is None:
            free.append(p)
        else:
            errors.append(
                StError(p.place, "export", f"PROGRAM {p.name} runs WITH {p.task}, which resource {r.name} has not")
            )
    for task in r.tasks:
        params = {k: expr(v) for k, (_place, v) in task.params.items()}
        try:
            priority = _priority(task)
        except StError as e:
            errors.append(e)
            priority = "0"
        task_el = sub(
            el, "task", name=task.name, interval=params.get("INTERVAL"), single=params.get("SINGLE"), priority=priority
        )
        for p in by_task.get(task.name.upper(), []):
            sub(task_el, "pouInstance", name=p.name, typeName=p.type_name)
    var_lists(el, r.vars, "globalVars")
    for p in free:
        sub(el, "pouInstance", name=p.name, typeName=p.type_name)
    if errors:
        raise StErrors(errors)


def _priority(task: t.Task) -> str:
    given = task.params.get("PRIORITY")
    if given is None:
        return "0"
    place, e = given
    number = e.const if isinstance(e.const, int) else getattr(e, "value", None)
    if not isinstance(number, int) or isinstance(number, bool) or not 0 <= number <= 65535:
        raise StError(place, "export", f"TASK {task.name}: PLCopen XML needs its PRIORITY as a number 0..65535")
    return str(number)


def _validate(root: etree._Element) -> None:
    """The file is checked against the schema the importer reads with: an error here is the exporter's."""
    for e in schema().iter_errors(root):
        raise StError(
            Place("export", 1, 1), "internal", f"the exported file does not follow the schema: {e.path}: {e.reason}"
        )


def import_unit(file: str, data: bytes | None = None) -> t.Unit:
    """A PLCopen XML source imported (plcopen_import), each Pou keeping the <pou> element it came from
    (`xml`), whose drawing the export writes back."""
    from plcopen_import.project import unit_of as imported
    from plcopen_import.read import read as read_xml
    from plcopen_import.read import read_file

    root = read_file(file) if data is None else read_xml(file, data)
    unit = imported(file, root)
    elements = {el.get("name", "").upper(): el for el in root.iterfind(f"{q('types')}/{q('pous')}/{q('pou')}")}
    for pou in unit.pous:
        pou.xml = elements.get(pou.name.upper())
    return unit


def unit_of(path: str) -> t.Unit:
    """A set's source file: PLCopen XML (.xml) imported, ST parsed."""
    return import_unit(path) if Path(path).suffix.lower() == ".xml" else parse_file(path)


def export_files(paths: list[str], name: str = "indurop") -> bytes:
    """The set's source files (every one parsed; the errors of all reported) as one PLCopen XML file."""
    units, errors = [], []
    for p in paths:
        try:
            units.append(unit_of(p))
        except StError as e:
            errors.append(e)
        except StErrors as e:
            errors += e.errors
    if errors:
        raise StErrors(errors)
    return export(units, name=name)

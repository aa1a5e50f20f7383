"""plc_diagram.py -- the live view's drawing (docs/programming.md "The live view"): a set's PLCopen XML
file read by the importer's own reader (plcopen_import.read: size bound, no DTD, the TC6 v2.01
schema) and a graphical POU's body as plcopen_import.graph sees it, turned into what the browser
draws: each element with its kind, place and size, its label (variable, block type, step name ...),
its pins at their absolute positions, and each connection as a wire with its polyline.

    found = project(stc, files_dir / "plc.xml", "plc.xml")      # kept by file (a stored set never changes)
    outline(found)                                            # the POUs, their kinds and body languages
    diagram(found, "main")                                    # the diagram of POU main

Nothing here evaluates: the values shown on a diagram come from the monitor (plc_monitor.py)."""

from __future__ import annotations

import functools
import importlib
import sys
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

from . import st_check

GRAPHICAL = ("LD", "FBD", "SFC")
POU_KINDS = {"program": "PROGRAM", "functionBlock": "FUNCTION_BLOCK", "function": "FUNCTION"}


class DiagramError(Exception):
    """The file or POU cannot be drawn: the message says why (a StError's text, or what is missing);
    `first` is the importer's first error as stc's JSON (file, line, column, code, message)."""

    def __init__(self, message: str, first: dict | None = None) -> None:
        super().__init__(message)
        self.first = first


class NoSuchPou(DiagramError):
    """The file has no POU of that name (the message lists those it has)."""


@functools.cache
def importer(stc: Path) -> SimpleNamespace:
    """plcopen_import's reader and graph, from plcopen/ beside the ST compiler's folder (st/)."""
    st_check.compiler(stc)  # stc_compiler on sys.path: the importer's errors are its StErrors
    folder = str(Path(stc).resolve().parent.parent / "plcopen")
    if not (Path(folder) / "plcopen_import").is_dir():
        raise st_check.CompilerMissing(f"the PLCopen importer is not beside {stc} ({folder}/plcopen_import)")
    if folder not in sys.path:
        sys.path.insert(0, folder)
    return SimpleNamespace(**{n: importlib.import_module(f"plcopen_import.{n}") for n in ("read", "graph", "st_text")})


def plcopen_paths(store, set_id: str) -> list[str]:
    """A stored set's PLCopen XML files: those the upload took for one (kind `plcopen`, uploads.is_plcopen)."""
    return sorted(f["path"] for f in store.manifest(set_id)["files"] if f["kind"] == "plcopen")


@dataclass
class Project:
    path: str  # the file in the set
    root: object  # lxml <project>
    imp: SimpleNamespace


@functools.lru_cache(maxsize=8)
def _read(stc: Path, source: Path, name: str) -> Project | DiagramError:
    imp = importer(stc)
    try:
        with open(source, "rb") as f:
            data = f.read(imp.read.MAX_XML_BYTES + 1)
        return Project(name, imp.read.read(name, data), imp)
    except imp.read.StErrors as e:
        return DiagramError("; ".join(str(x) for x in e.errors), e.errors[0].as_json())
    except imp.read.StError as e:
        return DiagramError(str(e), e.as_json())


def project(stc: Path, source: Path, name: str) -> Project:
    """The file read and validated (kept: a stored set's file never changes), or a DiagramError."""
    found = _read(stc, source, name)
    if isinstance(found, DiagramError):
        raise found
    return found


def _pous(p: Project):
    q = p.imp.read.q
    return p.root.iterfind(f"{q('types')}/{q('pous')}/{q('pou')}")


def _body_lang(p: Project, pou) -> tuple[str | None, object | None]:
    body = pou.find(p.imp.read.q("body"))
    if body is None:
        return None, None
    for child in body:
        if isinstance(child.tag, str) and p.imp.read.local(child) != "documentation":
            return p.imp.read.local(child), child
    return None, None


def outline(p: Project) -> list[dict]:
    """Every POU with its kind, its body's language and its line, then the configurations."""
    q = p.imp.read.q
    out = []
    for pou in _pous(p):
        lang, _ = _body_lang(p, pou)
        kind = POU_KINDS.get(pou.get("pouType", ""), pou.get("pouType", ""))
        out.append({"name": pou.get("name"), "kind": kind, "line": pou.sourceline, "language": lang})
    for conf in p.root.iterfind(f"{q('instances')}/{q('configurations')}/{q('configuration')}"):
        out.append({"name": conf.get("name"), "kind": "CONFIGURATION", "line": conf.sourceline, "language": None})
    return out


def _pou(p: Project, name: str):
    for pou in _pous(p):
        if pou.get("name", "").upper() == name.upper():
            return pou
    known = ", ".join(x.get("name", "?") for x in _pous(p)) or "none"
    raise NoSuchPou(f"{p.path} has no POU {name!r}; its POUs: {known}")


def diagram(p: Project, name: str) -> dict:
    """POU `name`'s body as the view draws it (an ST or IL body: its text, no elements)."""
    imp = p.imp
    pou = _pou(p, name)
    lang, lang_el = _body_lang(p, pou)
    kind = POU_KINDS.get(pou.get("pouType", ""), pou.get("pouType", ""))
    out = {"path": p.path, "pou": pou.get("name"), "kind": kind, "language": lang, "elements": [], "wires": []}
    if lang not in GRAPHICAL:
        out["text"] = imp.st_text.text_of(lang_el)[0] if lang_el is not None else ""
        return {**out, "width": 0, "height": 0}
    try:
        body = imp.graph.body_graph(p.path, pou.get("name"), lang_el)
    except imp.read.StError as e:
        raise DiagramError(str(e)) from None
    elements = [_element(imp, e) for e in sorted(body.elements.values(), key=lambda e: e.id)]
    wires = [
        {"from_id": link.ref, "from_pin": link.formal or None, "to_id": e.id, "to_pin": pin.name, "points": link.points}
        for e in body.elements.values()
        for pin in e.inputs
        for link in pin.links
    ]
    xs = [x for el in elements for x in (el["x"] + el["width"],)] + [pt[0] for w in wires for pt in w["points"]]
    ys = [y for el in elements for y in (el["y"] + el["height"],)] + [pt[1] for w in wires for pt in w["points"]]
    return {**out, "elements": elements, "wires": wires, "width": max(xs, default=0), "height": max(ys, default=0)}


def _element(imp, e) -> dict:
    """One element: what it shows and where its pins are."""
    q = imp.read.q
    el = e.el
    label = None
    if e.kind in ("contact", "coil"):
        label = (e.text("variable") or "").strip()
    elif e.kind in ("inVariable", "outVariable", "inOutVariable"):
        label = (e.text("expression") or "").strip()
    elif e.kind == "block":
        label = el.get("typeName")
    elif e.kind == "step":
        label = el.get("name")
    elif e.kind in ("connector", "continuation", "label"):
        label = el.get("name") or el.get("label")
    elif e.kind in ("jump", "jumpStep"):
        label = el.get("label") or el.get("targetName")
    elif e.kind == "comment":
        content = el.find(q("content"))
        label = " ".join("".join(content.itertext()).split()) if content is not None else ""
    out = {
        "id": e.id,
        "kind": e.kind,
        "x": e.x,
        "y": e.y,
        "width": e.w,
        "height": e.h,
        "label": label,
        "instance": el.get("instanceName") or None,
        "negated": el.get("negated") == "true",
        "edge": el.get("edge", "none"),
        "storage": el.get("storage", "none"),
        "initial": el.get("initialStep") == "true",
        "order": e.order,
        "inputs": [
            {"name": p.name, "x": e.x + p.rel[0], "y": e.y + p.rel[1], "negated": p.negated, "edge": p.edge}
            for p in e.inputs
        ],
        "outputs": [
            {"name": name or None, "x": e.x + rel[0], "y": e.y + rel[1], "negated": _out_negated(imp, el, name)}
            for name, rel in e.outputs
        ],
        "actions": [],
        "condition": None,
    }
    if e.kind == "transition":
        out["condition"] = _condition(imp, el)
    elif e.kind == "actionBlock":
        out["actions"] = [_action(imp, a) for a in el.findall(q("action"))]
    return out


def _out_negated(imp, el, name: str | None) -> bool:
    if not name:
        return False
    q = imp.read.q
    for var in el.iterfind(f"{q('outputVariables')}/{q('variable')}"):
        if var.get("formalParameter") == name:
            return var.get("negated") == "true"
    return False


def _condition(imp, el) -> str | None:
    """A transition's condition as written: inline ST text, the name of a named transition, or
    None when drawn as a connection (then the wire into its `condition` pin shows it)."""
    q = imp.read.q
    cond = el.find(q("condition"))
    if cond is None:
        return None
    ref = cond.find(q("reference"))
    if ref is not None:
        return ref.get("name")
    inline = cond.find(q("inline"))
    if inline is not None:
        st = inline.find(q("ST"))
        return imp.st_text.text_of(st)[0].strip() if st is not None else None
    return None


def _action(imp, a) -> dict:
    q = imp.read.q
    ref = a.find(q("reference"))
    inline = a.find(q("inline"))
    text = None
    if inline is not None:
        st = inline.find(q("ST"))
        text = imp.st_text.text_of(st)[0].strip() if st is not None else None
    return {
        "qualifier": a.get("qualifier", "N"),
        "duration": a.get("duration") or None,
        "indicator": a.get("indicator") or None,
        "name": ref.get("name") if ref is not None else None,
        "text": text,
    }

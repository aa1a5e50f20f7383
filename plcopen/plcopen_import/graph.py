# graph.py -- a graphical body (LD, FBD or SFC, and the LD/FBD networks inside SFC transitions and
# actions) as a graph: its elements by localId, each with its position and size, its input pins and
# the connections into them.  ld.py, fbd.py and sfc.py translate this graph; the live view draws it.

from __future__ import annotations

from dataclasses import dataclass, field

from lxml import etree
from stc_compiler.errors import Place, StError

from .read import local, place, q


@dataclass
class Link:
    """One <connection> into an input pin: from element `ref`'s output `formal` (a block's output
    parameter; None for an element with one output), drawn through `points`."""

    ref: int
    formal: str | None
    points: list[tuple[float, float]]


@dataclass
class Pin:
    """A connectionPointIn.  name: the block parameter it feeds (formalParameter), 'condition' for a
    transition's condition, None for an element's only input.  Several links into one pin: their
    values OR-ed (LD power) or, in SFC, the branches converging."""

    name: str | None
    links: list[Link]
    negated: bool = False
    edge: str = "none"  # rising / falling on a block input
    rel: tuple[float, float] = (0.0, 0.0)


@dataclass
class Element:
    """One element with a localId: kind is its tag (contact, coil, block, inVariable, step, ...)."""

    id: int
    kind: str
    el: etree._Element
    x: float
    y: float
    w: float
    h: float
    inputs: list[Pin] = field(default_factory=list)
    outputs: list[tuple[str | None, tuple[float, float]]] = field(default_factory=list)  # (name, relPosition)

    def attr(self, name: str, default: str | None = None) -> str | None:
        return self.el.get(name, default)

    def text(self, tag: str) -> str | None:
        """The text of a child such as <expression> (inVariable, outVariable)."""
        child = self.el.find(q(tag))
        return child.text if child is not None else None

    @property
    def order(self) -> int:
        """executionOrderId; 0 (or none) means the standard's order decides."""
        return int(self.el.get("executionOrderId") or 0)


@dataclass
class Body:
    """A graphical body: file and POU for places, lang 'LD' | 'FBD' | 'SFC'."""

    file: str
    pou: str
    lang: str
    el: etree._Element
    elements: dict[int, Element]

    def origin(self, element: Element | None, where: str = "") -> Place:
        """The Place of an element for errors and line maps: `main (LD) rung 4, contact localId 17`."""
        words = f"{self.pou} ({self.lang})"
        if where:
            words += f" {where}"
        if element is not None:
            words += f"{',' if where else ''} {element.kind} localId {element.id}"
        return place(self.file, element.el if element is not None else self.el, words)

    def source(self, link: Link, at: Element) -> Element:
        """The element a link comes from, or a StError naming the missing localId."""
        found = self.elements.get(link.ref)
        if found is None:
            raise StError(self.origin(at), "plcopen", f"a connection to localId {link.ref}, which no element has")
        return found


def _xy(el: etree._Element | None) -> tuple[float, float]:
    return (float(el.get("x", 0)), float(el.get("y", 0))) if el is not None else (0.0, 0.0)


def _pin(cpi: etree._Element, name: str | None, owner: etree._Element | None) -> Pin:
    links = [
        Link(int(c.get("refLocalId")), c.get("formalParameter"), [_xy(p) for p in c.findall(q("position"))])
        for c in cpi.findall(q("connection"))
    ]
    negated = owner is not None and owner.get("negated") == "true"
    edge = owner.get("edge", "none") if owner is not None else "none"
    return Pin(name, links, negated, edge, _xy(cpi.find(q("relPosition"))))


def _element(el: etree._Element) -> Element:
    x, y = _xy(el.find(q("position")))
    e = Element(int(el.get("localId")), local(el), el, x, y, float(el.get("width", 0)), float(el.get("height", 0)))
    for child in el:
        tag = local(child) if isinstance(child.tag, str) else ""
        if tag == "connectionPointIn":
            e.inputs.append(_pin(child, None, None))
        elif tag == "connectionPointOut":
            e.outputs.append((child.get("formalParameter"), _xy(child.find(q("relPosition")))))
        elif tag == "condition":  # an SFC transition's condition drawn as a connection
            cpi = child.find(q("connectionPointIn"))
            if cpi is not None:
                e.inputs.append(_pin(cpi, "condition", None))
        elif tag in ("inputVariables", "inOutVariables", "outputVariables"):
            for var in child.findall(q("variable")):
                name = var.get("formalParameter")
                cpi = var.find(q("connectionPointIn"))
                if cpi is not None and tag != "outputVariables":
                    e.inputs.append(_pin(cpi, name, var))
                cpo = var.find(q("connectionPointOut"))
                if cpo is not None and tag != "inputVariables":
                    e.outputs.append((name, _xy(cpo.find(q("relPosition")))))
    return e


def body_graph(file: str, pou: str, lang_el: etree._Element) -> Body:
    """The graph of an <LD>, <FBD> or <SFC> element (a POU's body, or a transition's or action's).
    A localId used twice is an error naming both."""
    elements: dict[int, Element] = {}
    lang = local(lang_el)
    body = Body(file, pou, lang, lang_el, elements)
    for el in lang_el:
        if not isinstance(el.tag, str) or el.get("localId") is None:
            continue  # comments, and SFC action blocks' inner <action localId="0"> are read by sfc.py
        e = _element(el)
        if e.id in elements:
            first = elements[e.id]
            raise StError(
                body.origin(e),
                "plcopen",
                f"localId {e.id} is used twice (also by the {first.kind} at line {first.el.sourceline})",
            )
        elements[e.id] = e
    return body

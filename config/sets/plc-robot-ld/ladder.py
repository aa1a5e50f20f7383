# ladder.py -- a small ladder drawing kit for generate.py: rungs described as contacts, coils and
# blocks (with variables on their pins) become PLCopen XML 2.01 LD elements with localIds, laid-out
# positions and connections, one rung under the other (the order they run in: top to bottom).

from __future__ import annotations

from dataclasses import dataclass, field

from lxml import etree
from plcopen_export.xml_types import sub
from plcopen_import.read import XHTML, q

PIN = 20  # a block's pin pitch
TOP = 30  # a block's first pin below its top
EL_W, EL_H = 21, 16  # a contact's or coil's size
BLOCK_W = 130
GAP = 30  # between elements along a rung
RAIL_X, RAIL_W = 20, 10
RIGHT_X = 1180  # the right power rail
CHAR_W = 8  # a variable's width per character


@dataclass
class Contact:
    var: str
    negated: bool = False


@dataclass
class Coil:
    var: str
    storage: str = "none"  # set / reset


@dataclass
class Block:
    """A function or FB call: `inputs` pin -> a variable/literal (an inVariable) or a list of contacts
    (power from the left rail through them; [] is the rail itself); `in_outs` pin -> variable;
    `outputs` pin -> a variable (an outVariable) or a Coil.  EN from the rail, ENO to the right rail."""

    type: str
    instance: str | None = None
    inputs: dict = field(default_factory=dict)
    in_outs: dict = field(default_factory=dict)
    outputs: dict = field(default_factory=dict)


@dataclass
class Rung:
    """contacts in series from the left rail into coils in series to the right rail, or one block."""

    comment: str | None = None
    contacts: list = field(default_factory=list)
    coils: list = field(default_factory=list)
    block: Block | None = None


class Drawing:
    """An <LD> element filled rung by rung."""

    def __init__(self) -> None:
        self.ld = etree.Element(q("LD"))
        self.next_id = 1
        self.y = 20

    def _id(self) -> int:
        n = self.next_id
        self.next_id += 1
        return n

    def _el(self, tag: str, x: float, y: float, w: float, h: float, **attrs) -> tuple[etree._Element, int]:
        lid = self._id()
        el = sub(self.ld, tag, localId=str(lid), height=str(h), width=str(w), **attrs)
        sub(el, "position", x=str(x), y=str(y))
        return el, lid

    @staticmethod
    def _in(el: etree._Element, rel: tuple, source: tuple | None) -> None:
        """A connectionPointIn at rel (from el's position), connected to source (localId, formal, abs xy)."""
        cpi = sub(el, "connectionPointIn")
        sub(cpi, "relPosition", x=str(rel[0]), y=str(rel[1]))
        if source is not None:
            ref, formal, (sx, sy), here = source
            c = sub(cpi, "connection", refLocalId=str(ref), formalParameter=formal)
            sub(c, "position", x=str(here[0]), y=str(here[1]))
            if sy != here[1]:
                mid = (here[0] + sx) / 2
                sub(c, "position", x=str(mid), y=str(here[1]))
                sub(c, "position", x=str(mid), y=str(sy))
            sub(c, "position", x=str(sx), y=str(sy))

    @staticmethod
    def _out(el: etree._Element, rel: tuple, **attrs) -> None:
        sub(sub(el, "connectionPointOut", **attrs), "relPosition", x=str(rel[0]), y=str(rel[1]))

    def _rail(self, rows: list[float], top: float, bottom: float) -> tuple[int, list[tuple]]:
        el, lid = self._el("leftPowerRail", RAIL_X, top, RAIL_W, bottom - top)
        for r in rows:
            self._out(el, (RAIL_W, r - top), formalParameter="")
        return lid, [(lid, None, (RAIL_X + RAIL_W, r)) for r in rows]

    def _right(self, sources: list[tuple], top: float, bottom: float) -> None:
        el, _ = self._el("rightPowerRail", RIGHT_X, top, RAIL_W, bottom - top)
        for ref, formal, (sx, sy) in sources:
            self._in(el, (0, sy - top), (ref, formal, (sx, sy), (RIGHT_X, sy)))

    def _chain(self, contacts: list[Contact], start: tuple, x: float, row: float) -> tuple[tuple, float]:
        """Contacts in series on `row` from `start` (localId, formal, xy); the last one's output and the x after it."""
        src = start
        for c in contacts:
            el, lid = self._el("contact", x, row - EL_H / 2, EL_W, EL_H, negated="true" if c.negated else None)
            self._in(el, (0, EL_H / 2), (*src, (x, row)))
            self._out(el, (EL_W, EL_H / 2))
            sub(el, "variable").text = c.var
            src = (lid, None, (x + EL_W, row))
            x += EL_W + GAP
        return src, x

    def _coils(self, coils: list[Coil], src: tuple, x: float, row: float) -> tuple:
        for c in coils:
            storage = c.storage if c.storage != "none" else None
            el, lid = self._el("coil", x, row - EL_H / 2, EL_W, EL_H, storage=storage)
            self._in(el, (0, EL_H / 2), (*src, (x, row)))
            self._out(el, (EL_W, EL_H / 2))
            sub(el, "variable").text = c.var
            src = (lid, None, (x + EL_W, row))
            x += EL_W + GAP
        return src

    def _comment(self, text: str) -> None:
        el, _ = self._el("comment", RAIL_X, self.y, RIGHT_X - RAIL_X, 24)
        etree.SubElement(sub(el, "content"), f"{{{XHTML}}}p").text = text
        self.y += 34

    def rung(self, r: Rung) -> None:
        if r.comment:
            self._comment(r.comment)
        if r.block is None:
            top = self.y
            row = top + 20
            _, (start,) = self._rail([row], top, top + 40)
            src, x = self._chain(r.contacts, start, RAIL_X + RAIL_W + GAP, row)
            last = self._coils(r.coils, src, max(x, RIGHT_X - 2 * (EL_W + GAP)), row)
            self._right([last], top, top + 40)
            self.y = top + 50
        else:
            self._block(r.block)

    def _block(self, b: Block) -> None:
        ins = [("EN", [])] + list(b.inputs.items()) + list(b.in_outs.items())
        outs = [("ENO", None)] + list(b.outputs.items())
        top = self.y
        h = TOP + PIN * max(len(ins), len(outs))
        if b.instance:
            top += 16  # the instance's name is drawn above the block
        longest = max([len(v) for _, v in ins if isinstance(v, list)] + [5])  # the longest contact chain
        bx = RAIL_X + RAIL_W + (longest + 1) * (EL_W + GAP)
        rows = [top + TOP + PIN * i for i in range(max(len(ins), len(outs)))]
        power_rows = [rows[i] for i, (_, v) in enumerate(ins) if isinstance(v, list)]
        _, starts = self._rail(power_rows, top, top + h)
        starts = iter(starts)
        sources = {}
        for i, (pin, v) in enumerate(ins):
            row = rows[i]
            if isinstance(v, list):
                src, _ = self._chain(v, next(starts), RAIL_X + RAIL_W + GAP, row)
            else:
                w = max(40, CHAR_W * len(v) + 10)
                el, lid = self._el("inVariable", bx - GAP - w, row - EL_H / 2, w, EL_H)
                self._out(el, (w, EL_H / 2))
                sub(el, "expression").text = v
                src = (lid, None, (bx - GAP, row))
            sources[pin] = src
        blk, bid = self._el("block", bx, top, BLOCK_W, h, typeName=b.type, instanceName=b.instance)
        groups = {"inputVariables": [], "inOutVariables": [], "outputVariables": []}
        for i, (pin, _) in enumerate(ins):
            groups["inOutVariables" if pin in b.in_outs else "inputVariables"].append((i, pin))
        for tag in groups:
            container = sub(blk, tag)
            if tag == "outputVariables":
                for j, (pin, _) in enumerate(outs):
                    self._out(sub(container, "variable", formalParameter=pin), (BLOCK_W, rows[j] - top))
                continue
            for i, pin in groups[tag]:
                v = sub(container, "variable", formalParameter=pin)
                self._in(v, (0, rows[i] - top), (*sources[pin], (bx, rows[i])))
        ends = [(bid, "ENO", (bx + BLOCK_W, rows[0]))]
        for j, (pin, target) in enumerate(outs[1:], start=1):
            src = (bid, pin, (bx + BLOCK_W, rows[j]))
            if isinstance(target, Coil):
                ends.append(self._coils([target], src, RIGHT_X - 2 * (EL_W + GAP), rows[j]))
            else:
                w = max(40, CHAR_W * len(target) + 10)
                el, _ = self._el("outVariable", bx + BLOCK_W + GAP, rows[j] - EL_H / 2, w, EL_H)
                self._in(el, (0, EL_H / 2), (*src, (bx + BLOCK_W + GAP, rows[j])))
                sub(el, "expression").text = target
        self._right(ends, top, top + h)
        self.y = top + h + 20

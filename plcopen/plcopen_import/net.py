# net.py -- a graphical network (an LD or FBD body, or the LD/FBD elements drawn inside an SFC body)
# -> tree statements.  The elements that act (coils, output variables, function-block calls, jumps,
# labels, returns) run in the file's executionOrderId, else top to bottom then left to right (rows 10
# units high), and each pulls the values it needs on demand: a function block is called once, just
# before its first output is read; a function's call is written into the expression that reads it.
# Contacts and coils are ld.py's; the rest is shared by LD and FBD.

from __future__ import annotations

import copy

from stc_compiler import tree as t
from stc_compiler.errors import Place, StError

from . import st_text
from .graph import Body, Element, Pin

ROW = 10.0  # elements whose y differ by at most this are on one row (SOURCES.md rule (d))
ACTING = {"coil", "outVariable", "inOutVariable", "block", "jump", "label", "return"}
UNNUMBERED = {"leftPowerRail", "rightPowerRail", "comment", "label"}  # not part of one rung
PASSIVE = {"leftPowerRail", "rightPowerRail", "comment", "inVariable", "contact", "connector", "continuation"}


def true(p: Place) -> t.Literal:
    return t.Literal(p, "bool", True, "TRUE")


def false(p: Place) -> t.Literal:
    return t.Literal(p, "bool", False, "FALSE")


def is_true(e: t.Expr | None) -> bool:
    return isinstance(e, t.Literal) and e.kind == "bool" and e.value is True


def both(p: Place, a: t.Expr, b: t.Expr) -> t.Expr:
    if is_true(a):
        return b
    if is_true(b):
        return a
    return t.Binary(p, "AND", a, b)


def either(p: Place, values: list[t.Expr]) -> t.Expr:
    out = values[0]
    for v in values[1:]:
        out = t.Binary(p, "OR", out, v)
    return out


def positional(elements: list[Element]) -> list[Element]:
    """Top to bottom, then left to right within a row of ROW units; executionOrderId first when set."""
    ordered = sorted((e for e in elements if e.order), key=lambda e: e.order)
    rest = sorted((e for e in elements if not e.order), key=lambda e: (e.y, e.x))
    rows: list[list[Element]] = []
    for e in rest:
        if rows and e.y - rows[-1][0].y <= ROW:
            rows[-1].append(e)
        else:
            rows.append([e])
    return ordered + [e for row in rows for e in sorted(row, key=lambda e: e.x)]


def _components(body: Body) -> dict[int, int]:
    """Each element's connected component (rails and comments apart): LD rungs, FBD networks."""
    parent = {i: i for i in body.elements}

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    rails = {i for i, e in body.elements.items() if e.kind in ("leftPowerRail", "rightPowerRail")}
    named: dict[str, int] = {}
    for e in body.elements.values():
        if e.id in rails:
            continue
        for pin in e.inputs:
            for link in pin.links:
                if link.ref in parent and link.ref not in rails:
                    parent[find(link.ref)] = find(e.id)
        if e.kind in ("connector", "continuation"):
            key = (e.attr("name") or "").upper()
            if key in named:
                parent[find(named[key])] = find(e.id)
            named.setdefault(key, e.id)
    return {i: find(i) for i in body.elements}


class Net:
    def __init__(self, ctx, body: Body, word: str) -> None:
        self.ctx = ctx
        self.body = body
        self.word = word
        self.items: list[tuple] = []  # ("stmt", s) | ("jump", cond, label, place) | ("label", name)
        self.emitted: set[int] = set()
        self.busy: list[Element] = []
        self.guards: list[t.Expr] = []
        self.calls: dict[int, tuple[t.Call | None, t.Expr | None]] = {}  # a function block: its call, its EN
        self.edges: dict[tuple[int, str | None], t.Expr] = {}
        self._component = _components(body)
        self._numbers: dict[int, int] = {}

    # ---- places and hidden variables ----

    def where(self, e: Element) -> str:
        if e.kind in UNNUMBERED:
            return ""
        comp = self._component.get(e.id, e.id)
        if comp not in self._numbers:
            self._numbers[comp] = len(self._numbers) + 1
        return f"{self.word} {self._numbers[comp]}"

    def place(self, e: Element) -> Place:
        return self.body.origin(e, self.where(e))

    def error(self, e: Element, message: str) -> StError:
        return StError(self.place(e), "plcopen", message)

    def variable(self, e: Element, text: str | None) -> t.Expr:
        """The ST expression an element names (a contact's or coil's variable, a variable's expression)."""
        if not text or not text.strip():
            raise self.error(e, "no variable or expression is given")
        p = self.place(e)
        return st_text.expression(p.file, text, p.line, p.origin)

    def trigger(self, e: Element, pin: str | None, kind: str, clk: t.Expr) -> t.Expr:
        """An edge: a hidden R_TRIG/F_TRIG instance called with CLK := clk once; its Q."""
        key = (e.id, pin)
        if key not in self.edges:
            p = self.place(e)
            name = f"_edge{e.id}" + (f"_{pin}" if pin else "")
            self.ctx.declare(t.VarDecl(p, name, "VAR", t.TypeRef(p, "R_TRIG" if kind == "rising" else "F_TRIG")))
            self.emit(t.CallStmt(p, t.Call(p, t.Name(p, name), [t.Arg(p, "CLK", clk)])))
            self.edges[key] = t.Member(p, t.Name(p, name), "Q")
        return copy.deepcopy(self.edges[key])

    def emit(self, stmt) -> None:
        self.items.append(("stmt", stmt))

    # ---- values ----

    def pin_value(self, e: Element, pin: Pin) -> t.Expr | None:
        """The value flowing into a pin: its connections' values OR-ed, negated or edge-triggered as drawn;
        None when nothing is connected."""
        values = []
        for link in pin.links:
            if link.ref not in self.body.elements:
                raise self.error(e, f"a connection to localId {link.ref}, which no element has")
            values.append(self.value_of(self.body.elements[link.ref], link.formal, e))
        if not values:
            return None
        p = self.place(e)
        v = either(p, values)
        if pin.negated:
            v = t.Unary(p, "NOT", v)
        if pin.edge in ("rising", "falling"):
            v = self.trigger(e, pin.name, pin.edge, v)
        return v

    def power(self, e: Element) -> t.Expr:
        """The power (LD) or value into an element's only input; FALSE when nothing is connected."""
        v = self.pin_value(e, e.inputs[0]) if e.inputs else None
        return v if v is not None else false(self.place(e))

    def value_of(self, src: Element, formal: str | None, reader: Element) -> t.Expr:
        looped = any(b.id == src.id for b in self.busy)
        if looped and src.kind == "block" and src.attr("instanceName") and formal and formal.upper() != "ENO":
            # a loop through a function block instance: its output is a variable, read as its last call left it
            return t.Member(self.place(src), t.Name(self.place(src), src.attr("instanceName")), formal)
        if looped:
            loop = self.busy[[b.id for b in self.busy].index(src.id) :]
            names = " -> ".join(
                f"{b.kind} localId {b.id}" + (f" ({b.attr('typeName')})" if b.attr("typeName") else "") for b in loop
            )
            raise self.error(
                src, f"a cycle without a variable: {names} -> back; feed the value back through a variable"
            )
        self.busy.append(src)
        try:
            v = self._value(src, formal)
        finally:
            self.busy.pop()
        key = (self.body.pou, src.id, formal or None)
        self.ctx.flows.setdefault(key, v)
        return copy.deepcopy(v)

    def _value(self, src: Element, formal: str | None) -> t.Expr:
        from . import ld

        p = self.place(src)
        kind = src.kind
        if kind == "leftPowerRail":
            return true(p)
        if kind == "contact":
            return ld.contact_value(self, src)
        if kind == "coil":
            return self.power(src)
        if kind == "block":
            return self.block_output(src, formal)
        if kind in ("inVariable", "inOutVariable"):
            v = self.variable(src, src.text("expression"))
            return t.Unary(p, "NOT", v) if src.attr("negated") == "true" and kind == "inVariable" else v
        if kind == "continuation":
            name = (src.attr("name") or "").upper()
            for c in self.body.elements.values():
                if c.kind == "connector" and (c.attr("name") or "").upper() == name:
                    return self.power(c)
            raise self.error(src, f"no connector is named '{src.attr('name')}'")
        raise self.error(src, f"a {kind} has no output to connect from")

    # ---- blocks ----

    def block(self, e: Element) -> None:
        """Calls a function block (once), or prepares a function's call for the expressions that read it."""
        if e.id in self.emitted:
            return
        p = self.place(e)
        en = None
        args = []
        for pin in e.inputs:
            if pin.name and pin.name.upper() == "EN":
                en = self.pin_value(e, pin)
                continue
            v = self.pin_value(e, pin)
            if v is not None:
                args.append(t.Arg(p, pin.name, v))
        en = None if en is None or is_true(en) else en
        typ, inst = e.attr("typeName"), e.attr("instanceName")
        self.emitted.add(e.id)
        if inst:
            stmt = t.CallStmt(p, t.Call(p, t.Name(p, inst), args))
            self.emit(t.If(p, [(en, [stmt])], None) if en is not None else stmt)
            self.calls[e.id] = (None, en)
        else:
            self.calls[e.id] = (t.Call(p, t.Name(p, typ), args), en)

    def block_output(self, e: Element, formal: str | None) -> t.Expr:
        self.block(e)
        call, en = self.calls[e.id]
        p = self.place(e)
        if formal and formal.upper() == "ENO":
            return copy.deepcopy(en) if en is not None else true(p)
        if call is None:
            if not formal:
                raise self.error(e, "a connection from a function block names no output (formalParameter)")
            v = t.Member(p, t.Name(p, e.attr("instanceName")), formal)
        else:
            if en is not None:
                self.guards.append(copy.deepcopy(en))
            v = copy.deepcopy(call)
        if self._negated_output(e, formal):
            v = t.Unary(p, "NOT", v)
        return v

    @staticmethod
    def _negated_output(e: Element, formal: str | None) -> bool:
        from .read import q

        for var in e.el.iterfind(f"{q('outputVariables')}/{q('variable')}"):
            if var.get("formalParameter") == formal:
                return var.get("negated") == "true"
        return False

    # ---- statements ----

    def assign(self, e: Element, target_text: str | None, value_of) -> None:
        """target := value, under the EN of the functions the value goes through."""
        saved, self.guards = self.guards, []
        try:
            target = self.variable(e, target_text)
            value = value_of()
            guards = self.guards
        finally:
            self.guards = saved
        p = self.place(e)
        stmt = t.Assign(p, target, value)
        if guards:
            cond = guards[0]
            for g in guards[1:]:
                cond = t.Binary(p, "AND", cond, g)
            stmt = t.If(p, [(cond, [stmt])], None)
        self.emit(stmt)

    def statement(self, e: Element) -> None:
        from . import ld

        kind = e.kind
        p = self.place(e)
        if kind == "coil":
            ld.coil_statement(self, e)
        elif kind in ("outVariable", "inOutVariable"):
            if any(pin.links for pin in e.inputs):
                neg = e.attr("negated") == "true" and kind == "outVariable"
                self.assign(e, e.text("expression"), lambda: t.Unary(p, "NOT", self.power(e)) if neg else self.power(e))
        elif kind == "block":
            self.block(e)
        elif kind == "jump":
            self.items.append(("jump", self.power(e), e.attr("label") or "", p))
        elif kind == "label":
            self.items.append(("label", (e.attr("label") or "").upper()))
        elif kind == "return":
            self.emit(t.If(p, [(self.power(e), [t.Return(p)])], None))

    def translate(self) -> list:
        for e in self.body.elements.values():
            if e.kind not in ACTING and e.kind not in PASSIVE:
                raise self.error(e, f"a <{e.kind}> is not an {self.body.lang} element this import supports")
            for pin in e.inputs:  # every connection, also of an element nothing reads
                for link in pin.links:
                    if link.ref not in self.body.elements:
                        raise self.error(e, f"a connection to localId {link.ref}, which no element has")
        for e in positional([e for e in self.body.elements.values() if e.kind in ACTING]):
            self.statement(e)
        self.every_flow()
        return self.take()

    def every_flow(self) -> None:
        """ctx.flows gets the value of every output drawn, also of those nothing reads (a coil at the
        right rail, a block's unused output): the live view shows them all."""
        for e in positional(list(self.body.elements.values())):
            if e.kind in UNNUMBERED or e.kind in ("jump", "return", "connector", "outVariable", "label"):
                continue
            for formal, _ in e.outputs or ([(None, None)] if e.kind in ("contact", "coil") else []):
                if (self.body.pou, e.id, formal or None) not in self.ctx.flows:
                    saved, self.guards = self.guards, []
                    try:
                        self.value_of(e, formal, e)
                    finally:
                        self.guards = saved

    def take(self) -> list:
        """The statements written so far (jumps resolved), and the list emptied."""
        items, self.items = self.items, []
        return _structure(items)


def _structure(items: list[tuple]) -> list:
    """Jumps to a label further down become `IF NOT cond THEN <what lies between> END_IF`."""
    out: list = []
    i = 0
    while i < len(items):
        item = items[i]
        if item[0] == "stmt":
            out.append(item[1])
        elif item[0] == "jump":
            _, cond, label, p = item
            j = next(
                (k for k in range(i + 1, len(items)) if items[k][0] == "label" and items[k][1] == label.upper()), None
            )
            if j is None:
                raise StError(
                    p,
                    "plcopen",
                    f"the jump to '{label}' finds no label after it (a jump goes forward, and two jumps may not cross)",
                )
            out.append(t.If(p, [(t.Unary(p, "NOT", cond), _structure(items[i + 1 : j]))], None))
            i = j
        i += 1
    return out

# context.py -- what the body translations share while one POU is translated (the contract between
# project.py, ld.py, fbd.py and sfc.py): the POU's tree to add hidden variables to, the values flowing
# out of every graphical element (for the live view), and the entry points sfc.py calls back into.

from __future__ import annotations

from lxml import etree
from stc_compiler import tree as t
from stc_compiler.errors import StError


class Ctx:
    """One POU being translated.  flows[(body_key, localId, formal)] is the tree expression of the value
    leaving an element's output (LD: the power after a contact, coil or block's ENO; FBD: a block's
    output or a variable); body_key is the body's name as its origins print it (the POU's name, or
    `POU.action` for an action's or transition's body)."""

    def __init__(self, file: str, pou_el: etree._Element, pou: t.Pou, flows: dict | None = None) -> None:
        self.file = file
        self.pou_el = pou_el
        self.pou = pou
        self.flows: dict[tuple[str, int, str | None], t.Expr] = {} if flows is None else flows
        self._nets: dict[int, object] = {}

    def declare(self, decl: t.VarDecl) -> None:
        """Adds a hidden variable (an edge memory, a step, an action control) to the POU."""
        taken = {v.name.upper() for v in self.pou.vars}
        if decl.name.upper() in taken:
            raise StError(decl.place, "plcopen", f"the POU already declares '{decl.name}', a name the import needs")
        self.pou.vars.append(decl)

    def net(self, body):
        """The network evaluator of a graphical body (one per body: its blocks are called once)."""
        found = self._nets.get(id(body))
        if found is None:
            from .net import Net

            found = self._nets[id(body)] = Net(self, body, "rung" if body.lang == "LD" else "network")
        return found

    def connection_expr(self, body, element, pin) -> t.Expr:
        """The value flowing into `pin` of `element` (graph.Pin), e.g. an SFC transition's condition drawn
        as a connection to LD contacts or an FBD network.  Statements it needs first (a block's call, an
        edge memory's update) are in `ctx.net(body).take()`, to be run before the expression."""
        return self.net(body).pin_value(element, pin)

    def body_statements(self, body_el: etree._Element, origin_name: str) -> list:
        """The statements of a named action's or transition's <body> (ST, LD or FBD)."""
        from .project import body_of

        return body_of(self, origin_name, body_el)

# ld.py -- a Ladder Diagram body -> tree statements.  Power flows from the left rail through contacts
# (normally open, normally closed, rising, falling: an edge keeps its memory in a hidden R_TRIG/F_TRIG
# instance `_edge<localId>`) to coils (plain, negated, set, reset, rising, falling), blocks (EN/ENO),
# jumps and returns; several connections into one pin are OR-ed (a branch).  The network machinery
# (order, blocks, jumps) is net.py's, shared with FBD.

from __future__ import annotations

from stc_compiler import tree as t

from .graph import Body, Element
from .net import Net, both, true


def translate(ctx, body: Body) -> list:
    """The statements of an LD body; every node placed at `body.origin(element, "rung N")`."""
    return ctx.net(body).translate()


def contact_value(net: Net, e: Element) -> t.Expr:
    """The power leaving a contact: the power into it AND its condition."""
    p = net.place(e)
    var = net.variable(e, e.text("variable"))
    edge = e.attr("edge", "none")
    if edge in ("rising", "falling"):
        cond = net.trigger(e, None, edge, var)
    else:
        cond = t.Unary(p, "NOT", var) if e.attr("negated") == "true" else var
    return both(p, net.power(e), cond)


def coil_statement(net: Net, e: Element) -> None:
    """A coil writes its variable from the power into it (the power goes on through it unchanged)."""
    p = net.place(e)
    storage = e.attr("storage", "none")
    edge = e.attr("edge", "none")
    if storage in ("set", "reset"):
        target = net.variable(e, e.text("variable"))
        value = true(p) if storage == "set" else t.Literal(p, "bool", False, "FALSE")
        net.emit(t.If(p, [(net.power(e), [t.Assign(p, target, value)])], None))
        return

    def value() -> t.Expr:
        power = net.power(e)
        if edge in ("rising", "falling"):
            return net.trigger(e, None, edge, power)
        return t.Unary(p, "NOT", power) if e.attr("negated") == "true" else power

    net.assign(e, e.text("variable"), value)

# fbd.py -- a Function Block Diagram body -> tree statements: blocks, in/out/inOut variables,
# connections, connectors and continuations (joined by name), feedback through a variable (its value
# of the previous assignment), jumps, labels and returns.  Order: executionOrderId, else top to
# bottom then left to right, blocks called on demand (net.py); a cycle that no variable breaks is an
# error naming its blocks.

from __future__ import annotations

from .graph import Body


def translate(ctx, body: Body) -> list:
    """The statements of an FBD body; every node placed at `body.origin(element, "network N")`."""
    return ctx.net(body).translate()

"""writes.py -- a client's Write of a shared variable (docs/opcua.md "Writes"): only an operator or an
admin may (a viewer gets BadUserAccessDenied); the value must be of the variable's kind (a Boolean
for a bool, an integer type for an integer, a number for a float: BadTypeMismatch), an array whole
or by an IndexRange of one dimension; irpd's typed `write` does the rest, as PUT /variables does
(a value out of the type's range is refused by irpd: BadOutOfRange).  A write irpd refuses because
the variable is forced (its error code `forced`, docs/forcing.md) is BadUserAccessDenied, the reason
(who forced it) in the audit line and the server's output.  An array is written element by element,
all or none: an element forced now or out of its type's range is sent first, so that irpd's refusal
comes before any other element is written (a force set between the look and the writes can still
leave the elements before it written).  Every write, done or refused,
is one line of the agent's audit log (<data>/audit.jsonl, action write_variable) with the OPC UA
user, the client's address and the endpoint."""

from __future__ import annotations

import asyncio
import math

from asyncua import ua

from ..access.audit import AuditLog
from ..irpd.client import IrpdClient, IrpdRefused, IrpdUnavailable
from .values import INTEGERS, Var, index_range

FLOATS = (ua.VariantType.Float, ua.VariantType.Double)


def _fits(var: Var, value) -> bool:
    if var.variant == ua.VariantType.Boolean:
        return isinstance(value, bool)
    if isinstance(value, bool):
        return False
    if var.variant in INTEGERS:
        return isinstance(value, int)
    return isinstance(value, (int, float)) and math.isfinite(value)


def _flatten(value) -> list:
    if isinstance(value, (list, tuple)):
        return [x for v in value for x in _flatten(v)]
    return [value]


class Writes:
    def __init__(self, irpd: IrpdClient, audit: AuditLog, endpoint: str):
        self.irpd = irpd  # a connection of its own: writes never wait behind the status polls
        self.audit = audit
        self.endpoint = endpoint

    async def write(self, session, var: Var, wv: ua.WriteValue) -> ua.StatusCode:
        user = session.user
        peer = session.name if isinstance(session.name, tuple) else ("unknown", 0)
        who = {
            "id": f"opcua-session-{session.session_id.Identifier}",
            "name": getattr(user, "name", None),
            "role": getattr(user, "agent_role", None),
            "user": getattr(user, "name", None) if getattr(user, "via", "") == "password" else None,
            "via": "opcua",
        }
        raw = wv.Value.Value.Value if wv.Value is not None and wv.Value.Value is not None else None
        entry = {"who": who, "client": str(peer[0]), "target": var.path, "endpoint": self.endpoint}
        if wv.IndexRange:
            entry["index_range"] = wv.IndexRange
        value_for_log = raw if isinstance(raw, (bool, int, float, list)) else repr(raw)[:200]

        def done(code: int, detail: str | None = None, **more) -> ua.StatusCode:
            status = ua.StatusCode(code)
            result = "ok" if status.is_good() else "error"
            self.audit.write("write_variable", **entry, result=result, value=value_for_log, opcua_status=status.name,
                             **({"detail": detail} if detail else {}), **more)  # fmt: skip
            return status

        if not (hasattr(user, "may_write") and user.may_write()):
            role = getattr(user, "agent_role", "none")
            return done(ua.StatusCodes.BadUserAccessDenied, f"writing needs the operator role; the session has {role}")
        if wv.Value is None or wv.Value.Value is None or raw is None:
            return done(ua.StatusCodes.BadTypeMismatch, "no value")
        leaves = list(var.leaves)
        if var.dims:
            if not isinstance(raw, (list, tuple)):
                return done(ua.StatusCodes.BadTypeMismatch, f"{var.path} is an array of {len(leaves)}")
            values = _flatten(raw)
            if wv.IndexRange:
                picked = index_range(wv.IndexRange, len(leaves)) if len(var.dims) == 1 else None
                if picked is None:
                    return done(ua.StatusCodes.BadIndexRangeInvalid, f"index range {wv.IndexRange!r} of {var.dims}")
                leaves = [leaves[i] for i in picked]
            if len(values) != len(leaves):
                return done(ua.StatusCodes.BadTypeMismatch, f"{len(values)} values for {len(leaves)} elements")
        else:
            if wv.IndexRange:
                return done(ua.StatusCodes.BadIndexRangeNoData, "an index range of a scalar")
            values = [raw]
        if not all(_fits(var, v) for v in values):
            return done(ua.StatusCodes.BadTypeMismatch, f"{var.path} holds {var.type} ({var.variant.name})")
        pairs = list(zip(leaves, values))
        if len(pairs) > 1:
            pairs = await self._refused_first(var, pairs)
        try:
            for leaf, v in pairs:
                await asyncio.to_thread(self.irpd.request, "write", path=leaf, value=v)
        except IrpdRefused as e:
            if not e.forced:
                return done(ua.StatusCodes.BadOutOfRange, str(e))
            print(f"indurop-opcua: write of {var.path} refused: {e}", flush=True)
            return done(ua.StatusCodes.BadUserAccessDenied, str(e))
        except IrpdUnavailable as e:
            return done(ua.StatusCodes.BadNoCommunication, str(e))
        return done(ua.StatusCodes.Good)

    async def _refused_first(self, var: Var, pairs: list) -> list:
        """The elements irpd will refuse (forced now, or out of the type's range) moved to the front:
        its refusal of the first then ends the write before any element is written."""
        low, high = INTEGERS.get(var.variant, (None, None))
        forced: set[str] = set()
        try:
            listed = await asyncio.to_thread(self.irpd.request, "forces")
            forced = {f["path"] for f in listed.get("forces", [])}
        except (IrpdRefused, IrpdUnavailable):
            pass  # the writes below meet the same error

        def refused(pair) -> bool:
            leaf, v = pair
            return leaf in forced or (low is not None and not low <= v <= high)

        return sorted(pairs, key=lambda pair: not refused(pair))

"""capture_checks.py -- whether a capture can be armed as asked, and if not what to fix: its channels
(at most MAX_CHANNELS, each a numeric scalar of the running layout), its pre-trigger length against
the rings' capacity, its post-trigger length and its memory against the limits (capture_limits.py).
The capture engine calls check_request() before it asks irpd to trace anything."""

from __future__ import annotations

from collections.abc import Callable

from ..irpd.variables import Segment, VariableError, number_problem
from . import capture_limits as L
from .capture import capture_bytes, rows_of
from .triggers import trigger_variables


class CaptureError(Exception):
    """A request the captures cannot take: the HTTP status and what to fix."""

    def __init__(self, status: int, message: str):
        super().__init__(message)
        self.status = status


def channels_of(request: dict) -> list[str]:
    """The capture's columns: its variables, then the trigger's that are not among them."""
    out = list(request["variables"])
    return out + [v for v in trigger_variables(request["trigger"]) if v not in out]


def check_request(request: dict, ask: Callable[..., dict], taken_bytes: int) -> tuple[list[str], dict[str, str]]:
    """The capture's channels and their types, or CaptureError.  `ask(cmd)` asks irpd (CaptureError
    503 when it does not answer); `taken_bytes`: what the other armed captures take."""
    channels = channels_of(request)
    if len(channels) > L.MAX_CHANNELS:
        extra = len(channels) - len(request["variables"])
        raise CaptureError(
            422,
            f"{len(channels)} channels ({len(request['variables'])} variables and {extra} more of the "
            f"trigger's, first '{channels[L.MAX_CHANNELS]}' over); a capture traces at most {L.MAX_CHANNELS}",
        )
    types = numeric_types(request, channels, ask)
    describe = ask("trace")
    capacity, basic = int(describe["capacity"]), int(describe["basic_period_ns"])
    pre, post = rows_of(request["pre"], basic), rows_of(request["post"], basic)
    if pre > capacity:
        raise CaptureError(
            422,
            f"pre-trigger of {pre} rows ({pre * basic / 1e9:g} s at the basic period of {basic / 1e3:g} µs) "
            f"is longer than the trace rings hold: at most {capacity} rows ({capacity * basic / 1e9:g} s); shorten pre",
        )
    if post > L.MAX_POST_ROWS:
        raise CaptureError(422, f"post-trigger of {post} rows; at most {L.MAX_POST_ROWS}: shorten post")
    need = capture_bytes(len(channels), pre, post, request["trigger"]["kind"] != "condition", basic)
    if need > L.MAX_CAPTURE_BYTES:
        raise CaptureError(
            422,
            f"this capture would take {need / L.MiB:.1f} MiB ({pre} + 1 + {post} rows of {len(channels)} "
            f"channels, and its history); a capture may take {L.MAX_CAPTURE_BYTES // L.MiB} MiB: "
            "fewer rows or fewer channels",
        )
    if taken_bytes + need > L.MAX_TOTAL_BYTES:
        raise CaptureError(
            409,
            f"the armed captures take {taken_bytes / L.MiB:.1f} MiB and this one would take {need / L.MiB:.1f} MiB; "
            f"all together may take {L.MAX_TOTAL_BYTES // L.MiB} MiB: disarm one, or capture fewer rows",
        )
    return channels, types


def numeric_types(request: dict, channels: list[str], ask: Callable[..., dict]) -> dict[str, tuple[str, str | None]]:
    """Each channel's type and IEC type (layout.json's iec_type of a Structured Text variable, else
    None), when every one is a numeric scalar of the running layout."""
    name = (ask("status").get("shared_memory") or {}).get("variables")
    if not name:
        raise CaptureError(409, "the running set has no shared variables (no layout): nothing to capture")
    try:
        seg = Segment(name)
    except VariableError as e:
        raise CaptureError(503, str(e)) from e
    try:
        in_trigger = set(trigger_variables(request["trigger"]))
        types = {}
        for path in channels:
            problem = number_problem(path, seg.leaves, seg.scalars, traced=True, unknown=seg.unknown)
            if problem:
                raise CaptureError(422, f"{'the trigger' if path in in_trigger else 'a variable'}: {problem}")
            types[path] = (seg.leaves[path]["type"], seg.leaves[path].get("iec_type"))
        return types
    finally:
        seg.close()

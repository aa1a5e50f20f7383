"""events.py -- GET /api/v1/events: irpd's event log (starts, swaps, faults, deadline misses, ...)
and the agent's own events (uploads, activations, restores, token changes), merged by time.
Two cursors, one per source: ?since= for irpd's, ?agent_since= for the agent's."""

from __future__ import annotations

from fastapi import APIRouter, Query, Request

from ...irpd import protocol
from ...irpd.client import IrpdRefused, IrpdUnavailable
from ..deps import IrpdDep, ViewerDep
from ..models import EventsPage

router = APIRouter(tags=["events"])


@router.get("/events")
def events(
    request: Request,
    irpd: IrpdDep,
    _: ViewerDep,
    since: int = Query(0, ge=0, description="irpd's cursor (the `next` of the last page)"),
    agent_since: int = Query(0, ge=0, description="the agent's cursor (the `agent_next` of the last page)"),
    limit: int = Query(protocol.EVENTS_DEFAULT_LIMIT, ge=1, le=5000, description="at most this many from each source"),
) -> EventsPage:
    """If irpd does not answer, the page has the agent's events and says why in `irpd`."""
    ours = request.app.state.events.since(agent_since, limit)
    try:
        theirs = irpd.request("events", since=since, limit=limit) or {}
        irpd_state = "ok"
    except (IrpdUnavailable, IrpdRefused) as e:
        theirs, irpd_state = {"next": since, "dropped": 0, "events": []}, f"unavailable: {e}"
    merged = [{**e, "source": "irpd"} for e in theirs.get("events", [])]
    merged += [{**e, "source": "agent"} for e in ours["events"]]
    merged.sort(key=lambda e: e.get("time_ns", 0))
    return EventsPage(
        events=merged,
        next=theirs.get("next", since),
        agent_next=ours["next"],
        dropped=int(theirs.get("dropped", 0)) + ours["dropped"],
        irpd=irpd_state,
    )

"""alarms.py -- the alarms (docs/alarms.md): GET /alarms (what needs attention, the counts),
GET /alarms/history (filters, paging) and its CSV, acknowledging and shelving (operator, audited),
and WebSocket /alarms/live, which pushes every transition with the counts."""

from __future__ import annotations

import asyncio
import csv
import io
import json
from collections import deque
from contextlib import contextmanager
from datetime import UTC, datetime, timedelta
from typing import Annotated

from fastapi import APIRouter, Body, Depends, HTTPException, Query, Request, WebSocket
from fastapi.responses import StreamingResponse
from starlette.websockets import WebSocketDisconnect

from ...alarms.manager import AlarmError, AlarmManager, public_row
from ...alarms.store import HistoryFilter
from ..deps import OperatorDep, ViewerDep, audited
from ..models import AckAll, AckAnswer, AlarmHistory, AlarmList, AlarmPublic, AlarmState, Severity, ShelveRequest
from .stream import authenticate, stop_session_watch

router = APIRouter(tags=["alarms"])

MAX_QUEUED = 256  # push messages waiting for one client; beyond them it gets a fresh snapshot instead
CSV_COLUMNS = ("seq", "time", "key", "module", "id", "event", "state", "severity", "text", "detail", "value")
CSV_MORE = ("who", "note", "count")
EPOCH = datetime(1970, 1, 1, tzinfo=UTC)
INT64_MAX = 2**63 - 1  # what SQLite's integers hold


def alarm_manager(request: Request) -> AlarmManager:
    return request.app.state.alarms


AlarmsDep = Annotated[AlarmManager, Depends(alarm_manager)]


def _ns(t: datetime | None) -> int | None:
    """A time given with a zone, or in UTC without one, as ns since the epoch (exact: no float on
    the way), held to what a 64-bit time holds (years 1677 .. 2262)."""
    if t is None:
        return None
    if t.tzinfo is None:
        t = t.replace(tzinfo=UTC)
    ns = (t - EPOCH) // timedelta(microseconds=1) * 1000
    return min(max(ns, -INT64_MAX - 1), INT64_MAX)


def history_filter(
    since: datetime | None = Query(None, description="transitions at or after it (ISO 8601; UTC without a zone)"),
    until: datetime | None = Query(None, description="transitions at or before it"),
    module: str | None = Query(None, max_length=200, description="one module's (irpd, agent: the platform's)"),
    key: str | None = Query(None, max_length=300, description="one alarm's"),
    severity: Severity | None = Query(None),
    state: AlarmState | None = Query(None, description="the state the transition left the alarm in"),
    after: int | None = Query(
        None, ge=0, le=INT64_MAX, description="only transitions with a larger seq (following the history)"
    ),
) -> HistoryFilter:
    return HistoryFilter(_ns(since), _ns(until), module, key, severity, state, after)


FilterDep = Annotated[HistoryFilter, Depends(history_filter)]


@contextmanager
def answered(request: Request, who, action: str, key: str, **details):
    """An operator's change of one alarm: audited, and the manager's refusal as its HTTP status."""
    with audited(request, who, action, target=key, **details):
        try:
            yield
        except AlarmError as e:
            raise HTTPException(e.status, str(e)) from e


@router.get("/alarms")
def alarms(manager: AlarmsDep, _: ViewerDep) -> AlarmList:
    """The alarms that need attention or are shelved, the counts (the banner's), the newest one and
    how irpd's alarm segment is read."""
    return manager.snapshot()


@router.get("/alarms/history")
def history(
    manager: AlarmsDep,
    _: ViewerDep,
    f: FilterDep,
    limit: int = Query(100, ge=1, le=1000),
    offset: int = Query(0, ge=0, le=INT64_MAX),
) -> AlarmHistory:
    rows, total = manager.store.query(f, limit, offset)
    return AlarmHistory(transitions=[public_row(r) for r in rows], total=total, offset=offset, limit=limit)


def _cell(value) -> str:
    """A CSV cell a spreadsheet shows as text: a module's text starting with = + - @ is not a formula."""
    text = "" if value is None else str(value)
    return "'" + text if text[:1] in ("=", "+", "-", "@", "\t", "\r") else text


@router.get(
    "/alarms/history.csv",
    response_class=StreamingResponse,
    responses={200: {"content": {"text/csv": {}}, "description": "the history, oldest first"}},
)
def history_csv(manager: AlarmsDep, _: ViewerDep, f: FilterDep) -> StreamingResponse:
    """Every transition matching the filters, oldest first, as CSV (the columns of the JSON)."""

    def lines():
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(CSV_COLUMNS + CSV_MORE)
        for n, row in enumerate(manager.store.rows(f), 1):
            t = public_row(row)
            who = t["who"]["name"] if t["who"] else ""
            writer.writerow(
                [t["seq"], t["time"], *(_cell(t[c]) for c in CSV_COLUMNS[2:10]), t["value"], _cell(who)]
                + [_cell(t["note"]), t["count"]]
            )
            if n % 500 == 0:
                yield out.getvalue()
                out.seek(0)
                out.truncate()
        yield out.getvalue()

    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    return StreamingResponse(
        lines(), media_type="text/csv", headers={"Content-Disposition": f'attachment; filename="alarms-{stamp}.csv"'}
    )


@router.post("/alarms/ack")
def acknowledge_all(
    request: Request, manager: AlarmsDep, who: OperatorDep, body: AckAll | None = Body(None)
) -> AckAnswer:
    """Acknowledges every unacknowledged alarm (of `module` when given), shelved ones too."""
    module = body.module if body else None
    with audited(request, who, "alarm_ack_all", target=module or "*") as entry:
        keys = manager.acknowledge_all(who.as_dict(), module)
        entry["keys"] = keys
    return AckAnswer(acknowledged=keys, counts=manager.counts())


@router.post("/alarms/{key:path}/ack")
def acknowledge(key: str, request: Request, manager: AlarmsDep, who: OperatorDep) -> AlarmPublic:
    """Acknowledges one alarm: 404 when no alarm of that key needs attention, 409 when it is
    acknowledged already."""
    with answered(request, who, "alarm_ack", key):
        return manager.acknowledge(key, who.as_dict())


@router.post("/alarms/{key:path}/confirm")
def confirm(key: str, request: Request, manager: AlarmsDep, who: OperatorDep) -> AlarmPublic:
    """Confirms an acknowledged alarm (OPC UA's Confirm: the cause is dealt with): 404 when no
    alarm of that key needs attention, 409 when it is not acknowledged or confirmed already."""
    with answered(request, who, "alarm_confirm", key):
        return manager.confirm(key, who.as_dict())


@router.post("/alarms/{key:path}/shelve")
def shelve(key: str, body: ShelveRequest, request: Request, manager: AlarmsDep, who: OperatorDep) -> AlarmPublic:
    """Sets an alarm aside for `minutes` with a reason: it leaves the counts and comes back when the
    time is up.  An alarm held, or one declared by a module of the running set (404 otherwise)."""
    with answered(request, who, "alarm_shelve", key, minutes=body.minutes, reason=body.reason):
        return manager.shelve(key, body.minutes, body.reason, who.as_dict())


@router.post("/alarms/{key:path}/unshelve")
def unshelve(key: str, request: Request, manager: AlarmsDep, who: OperatorDep) -> AlarmPublic:
    with answered(request, who, "alarm_unshelve", key):
        return manager.unshelve(key, who.as_dict())


@router.websocket("/alarms/live")
async def live(ws: WebSocket) -> None:
    """A viewer (a token in the Authorization header or a first message {"token"}, or the browser's
    session cookie from this agent's own page), then JSON messages: first
    {"snapshot": GET /alarms}, then {"transitions": [...], "changed": [alarms], "counts"} for every
    change.  A client that falls MAX_QUEUED messages behind gets one {"snapshot", "missed"} instead."""
    await ws.accept()
    allowed, _ = await authenticate(ws)
    if not allowed:
        return
    manager: AlarmManager = ws.app.state.alarms
    loop = asyncio.get_running_loop()
    queue: deque = deque()
    wake = asyncio.Event()
    missed = [0]

    def deliver(message: dict) -> None:  # on the event loop
        if len(queue) >= MAX_QUEUED:
            missed[0] += sum(len(m.get("transitions", ())) for m in queue) + len(message["transitions"])
            queue.clear()
            queue.append(None)  # a snapshot instead
        else:
            queue.append(message)
        wake.set()

    def listener(message: dict) -> None:  # on the thread that changed an alarm
        loop.call_soon_threadsafe(deliver, message)

    async def pump() -> None:
        await ws.send_text(json.dumps({"snapshot": await asyncio.to_thread(manager.snapshot)}))
        while True:
            await wake.wait()
            wake.clear()
            while queue:
                message = queue.popleft()
                if message is None:
                    message = {"snapshot": await asyncio.to_thread(manager.snapshot), "missed": missed[0]}
                await ws.send_text(json.dumps(message))

    stop = manager.subscribe(listener)  # before the snapshot: nothing falls between them
    task = asyncio.create_task(pump())
    task.add_done_callback(lambda t: t.cancelled() or t.exception())  # a send to a closed socket ends it quietly
    try:
        while not task.done():
            message = await ws.receive()
            if message["type"] == "websocket.disconnect":
                break
    except (WebSocketDisconnect, RuntimeError):
        pass
    finally:
        stop()
        task.cancel()
        stop_session_watch(ws)

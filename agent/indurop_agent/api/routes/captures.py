"""captures.py -- the triggered captures (docs/recorder.md "Triggered captures"): arm one (operator),
list them with their state, read a shot's rows as columns for the plot panel, re-arm, disarm,
trigger now and delete (operator, audited), and the limits the web UI checks before it asks."""

from __future__ import annotations

from contextlib import contextmanager
from typing import Annotated

import numpy as np
from fastapi import APIRouter, Depends, HTTPException, Query, Request, Response

from ...recorder.capture_engine import CaptureEngine, CaptureError
from ...recorder.capture_models import CaptureLimits, CaptureList, CapturePublic, CaptureRequest, ShotRows
from ..deps import OperatorDep, ViewerDep, audited

router = APIRouter(tags=["captures"])

REFUSALS = {
    404: {"description": "no capture of that id"},
    409: {"description": "not in a state for it, or irpd refused its channels (its message)"},
    422: {
        "description": "what to fix: an unknown variable, a path that is not a number, a length or a count over its limit"
    },
    503: {"description": "irpd does not answer"},
}


def engine(request: Request) -> CaptureEngine:
    return request.app.state.captures


EngineDep = Annotated[CaptureEngine, Depends(engine)]


@contextmanager
def answered():
    try:
        yield
    except CaptureError as e:
        raise HTTPException(e.status, str(e)) from e


@router.get("/captures/limits")
def limits(captures: EngineDep, _: ViewerDep) -> CaptureLimits:
    """The captures' limits, with the running trace rings' capacity (the longest pre-trigger)."""
    return captures.limits()


@router.get("/captures")
def list_captures(captures: EngineDep, _: ViewerDep) -> CaptureList:
    """Every capture with its state (idle, armed, triggered, done) and its shots, oldest first."""
    return {"captures": captures.list()}


@router.post("/captures", status_code=201, responses=REFUSALS)
def arm(body: CaptureRequest, request: Request, captures: EngineDep, who: OperatorDep) -> CapturePublic:
    """Arms a new capture: its variables and the trigger's are traced (owner "capture"), its
    pre-trigger buffer fills, and each trigger makes a shot of pre + 1 + post rows."""
    spec = body.model_dump(mode="json")
    with audited(request, who, "capture_arm", name=body.name, trigger=spec["trigger"]["kind"]) as entry, answered():
        public = captures.create(spec, who.name)
        entry["target"] = public["id"]
    return public


@router.get("/captures/{capture_id}", responses=REFUSALS)
def get_capture(capture_id: str, captures: EngineDep, _: ViewerDep) -> CapturePublic:
    with answered(), captures.lock:
        return captures.public(captures.get(capture_id))


def _change(request: Request, who, action: str, capture_id: str, call):
    with audited(request, who, action, target=capture_id), answered():
        return call()


@router.post("/captures/{capture_id}/arm", responses=REFUSALS)
def rearm(capture_id: str, request: Request, captures: EngineDep, who: OperatorDep) -> CapturePublic:
    """Arms an idle or done capture again, as it was asked for (its shots are kept; new ones go on numbering)."""
    return _change(request, who, "capture_arm", capture_id, lambda: captures.rearm(capture_id, who.name))


@router.post("/captures/{capture_id}/disarm", responses=REFUSALS)
def disarm(capture_id: str, request: Request, captures: EngineDep, who: OperatorDep) -> CapturePublic:
    """Idle: a shot being collected is saved with the rows it has."""
    return _change(request, who, "capture_disarm", capture_id, lambda: captures.disarm(capture_id))


@router.post("/captures/{capture_id}/trigger", responses=REFUSALS)
def trigger_now(capture_id: str, request: Request, captures: EngineDep, who: OperatorDep) -> CapturePublic:
    """Triggers an armed capture now, whatever its trigger: the row whose due time is now."""
    return _change(request, who, "capture_trigger", capture_id, lambda: captures.trigger(capture_id))


@router.delete("/captures/{capture_id}", status_code=204, responses=REFUSALS)
def delete(capture_id: str, request: Request, captures: EngineDep, who: OperatorDep) -> Response:
    """Disarms it and deletes it with its shots."""
    _change(request, who, "capture_delete", capture_id, lambda: captures.delete(capture_id))
    return Response(status_code=204)


@router.get("/captures/{capture_id}/shots/{shot}", responses=REFUSALS)
def shot_rows(
    capture_id: str,
    shot: int,
    captures: EngineDep,
    _: ViewerDep,
    channel: list[str] | None = Query(None, description="only these channels (repeat it), in this order"),
    every: int = Query(1, ge=1, le=1_000_000, description="every n-th row, from the first"),
) -> ShotRows:
    """One shot's rows as columns (seq, t_ns, one list per channel), with its trigger seq, pre and
    post counts and drops; `shot` 0 is the newest."""
    with answered():
        with captures.lock:
            captures.get(capture_id)
        if shot == 0:
            kept = captures.shots.summaries(capture_id)
            if not kept:
                raise CaptureError(404, f"capture {capture_id} has no shot yet")
            shot = kept[-1]["shot"]
        data = captures.shots.read(capture_id, shot)
        if data is None:
            raise CaptureError(404, f"capture {capture_id} has no shot {shot}; GET /captures/{capture_id} lists them")
        paths = data.paths
        wanted = channel or paths
        unknown = [c for c in wanted if c not in paths]
        if unknown:
            raise CaptureError(422, f"'{unknown[0]}' is not a channel of this shot (it has {', '.join(paths)})")
    rows = slice(None, None, every)
    columns = [data.values[paths.index(c), rows] for c in wanted]
    return {
        "capture": capture_id,
        "summary": data.summary,
        "channels": [data.header["channels"][paths.index(c)] for c in wanted],
        "basic_period_ns": data.header["basic_period_ns"],
        "seq": data.seq[rows].tolist(),
        "t_ns": data.t_ns[rows].tolist(),
        "columns": [np.where(np.isnan(col), None, col).tolist() for col in columns],
        "every": every,
    }

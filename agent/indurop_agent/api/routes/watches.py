"""watches.py -- the watch lists kept with a stored set (docs/programming.md "Watch lists"): list and
read them (any role), save and delete them (operator, audited).  They live in
<data>/sets/<id>/watches/<name>.json (sets/watch_lists.py); the Watch page reads their values
with POST /variables/read."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Depends, Request, Response

from ...sets.watch_lists import WatchLists
from ..deps import OperatorDep, ViewerDep, audited
from ..monitor_models import MAX_WATCH_BYTES, MAX_WATCHES, WatchList, WatchSaved
from ..monitor_models import WatchLists as WatchListAnswer
from .scopes import REFUSALS, answered

router = APIRouter(tags=["watches"])


def lists(request: Request) -> WatchLists:
    return request.app.state.watches


ListsDep = Annotated[WatchLists, Depends(lists)]


@router.get("/sets/{set_id}/watches", responses=REFUSALS)
def list_watches(set_id: str, watches: ListsDep, _: ViewerDep) -> WatchListAnswer:
    """The set's watch lists, by name."""
    with answered():
        found = watches.list(set_id)
    return {
        "set_id": set_id,
        "watches": [{**e, "set_id": set_id} for e in found],
        "max_configs": MAX_WATCHES,
        "max_bytes": MAX_WATCH_BYTES,
    }


@router.get("/sets/{set_id}/watches/{name:path}", responses=REFUSALS)
def get_watch(set_id: str, name: str, watches: ListsDep, _: ViewerDep) -> WatchSaved:
    with answered():
        return {**watches.get(set_id, name), "set_id": set_id}


@router.put("/sets/{set_id}/watches/{name:path}", responses=REFUSALS)
def put_watch(
    set_id: str, name: str, body: WatchList, request: Request, watches: ListsDep, who: OperatorDep
) -> WatchSaved:
    """Saves a watch list with the set under `name` (replacing one of that name).  The set is not
    changed (its id is the hash of its files): the list is kept beside it."""
    with audited(request, who, "watch_save", name, set_id=set_id) as entry, answered():
        saved, new = watches.put(set_id, name, body, who.as_dict())
        entry["new"] = new
    return {**saved, "set_id": set_id}


@router.delete("/sets/{set_id}/watches/{name:path}", status_code=204, responses=REFUSALS)
def delete_watch(set_id: str, name: str, request: Request, watches: ListsDep, who: OperatorDep) -> Response:
    with audited(request, who, "watch_delete", name, set_id=set_id), answered():
        watches.delete(set_id, name)
    return Response(status_code=204)

"""scopes.py -- the trace configurations kept with a stored set (docs/recorder.md "Trace
configurations"): list and read them (any role), save and delete them (operator, audited).  They
live in <data>/sets/<id>/scopes/<name>.json (scope_configs.py)."""

from __future__ import annotations

from contextlib import contextmanager
from typing import Annotated

from fastapi import APIRouter, Depends, HTTPException, Request, Response

from ...recorder.scope_configs import ScopeConfigs, ScopeError
from ..deps import OperatorDep, ViewerDep, audited
from ..scope_models import MAX_CONFIG_BYTES, MAX_CONFIGS, ScopeConfig, ScopeList, ScopeSaved

router = APIRouter(tags=["scopes"])

REFUSALS = {
    400: {"description": "a name that could be a path: names are 1 to 64 of [A-Za-z0-9_.-], first a letter or digit"},
    404: {"description": "no such set, or no such configuration"},
    409: {"description": f"the set holds {MAX_CONFIGS} configurations already"},
    413: {"description": f"a configuration over {MAX_CONFIG_BYTES} bytes"},
    422: {"description": "a body that is not a configuration (pydantic's message), or a damaged file"},
}


def configs(request: Request) -> ScopeConfigs:
    return request.app.state.scopes


ConfigsDep = Annotated[ScopeConfigs, Depends(configs)]


@contextmanager
def answered():
    try:
        yield
    except ScopeError as e:
        raise HTTPException(e.status, e.message) from e


def _public(set_id: str, entry: dict) -> dict:
    return {**entry, "set_id": set_id}


@router.get("/sets/{set_id}/scopes", responses=REFUSALS)
def list_scopes(set_id: str, scopes: ConfigsDep, _: ViewerDep) -> ScopeList:
    """The set's trace configurations, by name."""
    with answered():
        found = scopes.list(set_id)
    return {
        "set_id": set_id,
        "scopes": [_public(set_id, e) for e in found],
        "max_configs": MAX_CONFIGS,
        "max_bytes": MAX_CONFIG_BYTES,
    }


@router.get("/sets/{set_id}/scopes/{name:path}", responses=REFUSALS)
def get_scope(set_id: str, name: str, scopes: ConfigsDep, _: ViewerDep) -> ScopeSaved:
    with answered():
        return _public(set_id, scopes.get(set_id, name))


@router.put("/sets/{set_id}/scopes/{name:path}", responses=REFUSALS)
def put_scope(
    set_id: str, name: str, body: ScopeConfig, request: Request, scopes: ConfigsDep, who: OperatorDep
) -> ScopeSaved:
    """Saves a trace configuration with the set under `name` (replacing one of that name).  The set
    is not changed (its id is the hash of its files): the configuration is kept beside it."""
    with audited(request, who, "scope_save", name, set_id=set_id) as entry, answered():
        saved, new = scopes.put(set_id, name, body, who.as_dict())
        entry["new"] = new
    return _public(set_id, saved)


@router.delete("/sets/{set_id}/scopes/{name:path}", status_code=204, responses=REFUSALS)
def delete_scope(set_id: str, name: str, request: Request, scopes: ConfigsDep, who: OperatorDep) -> Response:
    with audited(request, who, "scope_delete", name, set_id=set_id), answered():
        scopes.delete(set_id, name)
    return Response(status_code=204)

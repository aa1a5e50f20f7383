"""variables.py -- GET /api/v1/variables (every shared variable of the running set's layout),
GET /api/v1/variables/{path} (one value, or every leaf of a group, read consistently from shared
memory; each flagged `forced` when irpd holds it forced), PUT /api/v1/variables/{path} (operator: irpd
writes the value, type-checked against the layout; refused for a forced variable), POST
/api/v1/variables/read (many leaves in one pass: the Watch page, the monitor) and GET /api/v1/layout
(the running layout.json, to lay a changed .glb out against: glbc --previous)."""

import orjson
from fastapi import APIRouter, HTTPException, Request, Response
from pydantic import BaseModel, ConfigDict

from ...irpd import protocol
from ...irpd.variables import Segment, VariableError
from ..deps import IrpdDep, OperatorDep, ViewerDep, ask, audited
from ..models import GroupValue, VariableList, VariableValue
from ..monitor_models import ReadAnswer, ReadRequest
from .forces import forced_now, forced_paths

router = APIRouter(tags=["variables"])
JSON = "application/json"


def segment(request: Request, irpd, status: dict | None = None) -> Segment:
    """The running layout's segment (`status`: irpd's, when the caller asked for it already).  Without
    `status`, the segment held is taken as it is when it was named on the connection to irpd open now
    and its file is still there: an irpd keeps its segment as long as it runs (docs/shared-variables.md),
    and a restarted irpd (a managed restart too) is a new connection (the client's `hello`) and a new
    file; else irpd's `status` names it."""
    cached = getattr(request.app.state, "segment", None)
    if status is None and cached is not None and cached.hello is irpd.hello and not cached.replaced():
        cached.refresh()  # an online change may have published another layout
        return cached
    status = status if status is not None else ask(irpd, "status")
    name = status.get("shared_memory", {}).get("variables")
    if not name:
        raise HTTPException(404, "the running set has no shared variables (no layout)")
    if cached is not None and cached.name == name and not cached.replaced():
        cached.hello = irpd.hello
        cached.refresh()
        return cached
    try:
        seg = Segment(name)
    except VariableError as e:
        raise HTTPException(503, str(e)) from e
    seg.name, seg.hello = name, irpd.hello
    request.app.state.segment = seg
    return seg


@router.get("/variables")
def list_variables(request: Request, irpd: IrpdDep, _: ViewerDep) -> VariableList:
    status = ask(irpd, "status")
    seg = segment(request, irpd, status)
    forced = forced_paths(irpd, status)
    return {
        "layout_hash": seg.hash,
        "variables": [
            {
                **{k: leaf[k] for k in ("path", "type", "size", "iec_type") if k in leaf},
                "forced": leaf["path"] in forced,
            }
            for leaf in seg.leaves.values()
        ],
    }


@router.post("/variables/read", response_model=ReadAnswer)
def read_variables(body: ReadRequest, request: Request, irpd: IrpdDep, _: ViewerDep) -> Response:
    """The values of many leaves, read in one pass over the shared memory (never a request to irpd's
    RT threads): a path that names no leaf (unknown, a group, a type the agent cannot decode) is an
    entry of `errors` with the reason, the others are read.  A float that is not finite is null."""
    forced = forced_now(irpd)  # the one request to irpd (its control thread) per read
    seg = segment(request, irpd)
    read, errors = seg.read_many(body.paths)
    values = [
        {"path": leaf["path"], "type": leaf["type"], "value": v, "forced": leaf["path"] in forced} for leaf, v in read
    ]
    # the answer as ReadAnswer says, written by orjson (NaN and infinities as null) without a model per value
    return Response(orjson.dumps({"layout_hash": seg.hash, "values": values, "errors": errors}), media_type=JSON)


@router.get(
    "/layout",
    response_class=Response,
    responses={200: {"content": {"application/json": {}}, "description": "the layout.json text"}},
)
def running_layout(request: Request, irpd: IrpdDep, _: ViewerDep) -> Response:
    """The running shared-variable layout (glbc's layout.json, as published last in the segment): the
    file to give glbc --previous, or indurop_add_glb(... PREVIOUS), when a .glb changes."""
    seg = segment(request, irpd)
    return Response(
        seg.text,
        media_type="application/json",
        headers={"Content-Disposition": 'attachment; filename="layout.json"', "ETag": f'"{seg.hash}"'},
    )


@router.get(
    "/variables/{path:path}",
    responses={404: {"description": "the path names no leaf and no group (the nearest names it has)"}},
)
def read_variable(path: str, request: Request, irpd: IrpdDep, _: ViewerDep) -> VariableValue | GroupValue:
    """A leaf's value (`{path, value, layout_hash}`), or for a group (a namespace, a struct, an array
    or one of its elements, e.g. `PLC_ROBOT.IO_STATUS`, `joint[1]`) every leaf under it
    (`{path, values: [{path, type, value}], layout_hash}`)."""
    status = ask(irpd, "status")
    seg = segment(request, irpd, status)
    try:
        leaves = seg.select(path)
        values = seg.values(leaves)
    except VariableError as e:
        raise HTTPException(404, str(e)) from e
    forced = forced_paths(irpd, status)
    if leaves[0]["path"] == path:
        return {"path": path, "value": values[0], "layout_hash": seg.hash, "forced": path in forced}
    return {
        "path": path,
        "values": [
            {"path": leaf["path"], "type": leaf["type"], "value": v, "forced": leaf["path"] in forced}
            for leaf, v in zip(leaves, values)
        ],
        "layout_hash": seg.hash,
    }


class VariableWrite(BaseModel):
    """The new value: irpd checks it against the variable's type and range (409 with its message)."""

    model_config = ConfigDict(extra="forbid")
    value: protocol.VariableValue


@router.put(
    "/variables/{path:path}",
    responses={
        404: {"description": "a compiler's own variable (layout.json's internal), which no user sees or writes"},
        409: {
            "description": "irpd refused: unknown path, wrong type, out of range, or forced (who forced it: unforce it first)"
        },
    },
)
def write_variable(
    path: str, body: VariableWrite, request: Request, irpd: IrpdDep, who: OperatorDep
) -> protocol.VariableWritten:
    with audited(request, who, "write_variable", path, value=body.value):
        if ask(irpd, "status").get("shared_memory", {}).get("variables"):
            seg = segment(request, irpd)
            if path not in seg.leaves and any(leaf["path"] == path for leaf in seg.layout["leaves"]):
                raise HTTPException(404, seg.unknown(path))  # a compiler's own variable: no one else's to write
        result = ask(irpd, "write", path=path, value=body.value)
    return result if isinstance(result, dict) else {"path": path, "value": body.value}

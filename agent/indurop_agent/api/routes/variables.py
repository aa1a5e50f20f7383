"""variables.py -- GET /api/v1/variables (every shared variable of the running set's layout) and
GET /api/v1/variables/{path} (one value, read consistently from shared memory)."""
from fastapi import APIRouter, HTTPException, Request

from ...variables import Segment, VariableError
from ..deps import IrpdDep, ViewerDep, ask

router = APIRouter(tags=["variables"])


def segment(request: Request, irpd) -> Segment:
    name = ask(irpd, "status").get("shared_memory", {}).get("variables")
    if not name:
        raise HTTPException(404, "the running set has no shared variables (no layout)")
    cached = getattr(request.app.state, "segment", None)
    if cached is not None and cached.name == name:
        return cached
    try:
        seg = Segment(name)
    except VariableError as e:
        raise HTTPException(503, str(e)) from e
    seg.name = name
    request.app.state.segment = seg
    return seg


@router.get("/variables")
def list_variables(request: Request, irpd: IrpdDep, _: ViewerDep) -> dict:
    seg = segment(request, irpd)
    return {"layout_hash": seg.hash,
            "variables": [{k: leaf[k] for k in ("path", "type", "size")} for leaf in seg.layout["leaves"]]}


@router.get("/variables/{path:path}")
def read_variable(path: str, request: Request, irpd: IrpdDep, _: ViewerDep) -> dict:
    seg = segment(request, irpd)
    try:
        return {"path": path, "value": seg.read(path), "layout_hash": seg.hash}
    except VariableError as e:
        raise HTTPException(404, str(e)) from e

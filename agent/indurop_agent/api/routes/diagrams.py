"""diagrams.py -- the live view of the Programs page (docs/programming.md "The live view"): a graphical
POU (LD, FBD, SFC) of a set's PLCopen XML file as the browser draws it, from the file's own layout
(sets/plc_diagram.py), and, with Monitor on, its live values in one request per refresh: the value
leaving each element as the translation computes it, and the variables the elements show
(sets/plc_monitor.py).  Every role reads them."""

from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter, HTTPException, Request

from ...irpd.variables import VariableError
from ...sets import plc_diagram, plc_monitor, st_check
from ..deps import IrpdDep, ViewerDep
from ..diagram_models import Diagram, DiagramMonitorAnswer, DiagramMonitorRequest
from .forces import forced_now
from .programs import _compiler_missing, _set_id, _set_sources, _stc
from .variables import segment

router = APIRouter(tags=["programs"])
NOT_FOUND = {404: {"description": "no such set, no active set, no such PLCopen XML file in it, or no such POU"}}
UNREADABLE = {422: {"description": "the file is not a PLCopen XML file the importer reads (the reason, at its line)"}}


def plcopen_file(request: Request, set_id: str, path: str) -> plc_diagram.Project:
    """The set's PLCopen XML file `path`, read (404 when it has none by that name, 422 when unreadable)."""
    known = plc_diagram.plcopen_paths(request.app.state.store, set_id)
    if path not in known:
        raise HTTPException(
            404, f"set {set_id} has no PLCopen XML file {path!r}; its PLCopen files: {', '.join(known) or 'none'}"
        )
    source: Path = request.app.state.store.files_dir(set_id) / path
    try:
        return plc_diagram.project(_stc(request), source, path)
    except st_check.CompilerMissing as e:
        raise _compiler_missing(e) from e
    except plc_diagram.DiagramError as e:
        raise HTTPException(422, str(e)) from e


@router.get("/programs/diagram", responses={**NOT_FOUND, **UNREADABLE})
def program_diagram(request: Request, _: ViewerDep, path: str, pou: str, set: str | None = None) -> Diagram:
    """POU `pou` of the set's (default: the active set's) PLCopen XML file `path` as drawn in the file:
    its elements with their positions, sizes, labels and pins, and its wires with their polylines
    (an ST or IL body: its text)."""
    set_id = _set_id(request, set)
    found = plcopen_file(request, set_id, path)
    try:
        return Diagram(set_id=set_id, **plc_diagram.diagram(found, pou))
    except plc_diagram.NoSuchPou as e:
        raise HTTPException(404, str(e)) from e
    except plc_diagram.DiagramError as e:
        raise HTTPException(422, str(e)) from e


@router.post("/programs/diagram/monitor", responses={**NOT_FOUND, **UNREADABLE})
def monitor_diagram(body: DiagramMonitorRequest, request: Request, irpd: IrpdDep, _: ViewerDep) -> DiagramMonitorAnswer:
    """The live values of POU `pou` of the set's (default: the active set's) PLCopen XML file `path`:
    the value leaving each element as the translation computes it (project.unit_of's flows), folded with the
    compiler's own folding on the variables read, and the variables the elements show (a step: active
    and for how long).  One read of the shared memory."""
    set_id = _set_id(request, body.set)
    key = (set_id, body.path, body.pou.upper())
    found = plc_monitor.kept(key)  # analysed already: a refresh reads no file
    if found is None:
        plcopen_file(request, set_id, body.path)  # 404 / 422 as the diagram
        data = (request.app.state.store.files_dir(set_id) / body.path).read_bytes()
        try:
            found = plc_monitor.analyse(_stc(request), key, _set_sources(request, set_id), body.path, data, body.pou)
        except st_check.CompilerMissing as e:
            raise _compiler_missing(e) from e
        except plc_diagram.NoSuchPou as e:
            raise HTTPException(404, str(e)) from e
        except plc_diagram.DiagramError as e:
            raise HTTPException(422, str(e)) from e
    forced = forced_now(irpd)
    seg = segment(request, irpd)
    try:
        answer = found.snapshot(seg, forced)
    except VariableError as e:
        raise HTTPException(503, str(e)) from e
    return DiagramMonitorAnswer(set_id=set_id, **answer)

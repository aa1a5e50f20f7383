"""programs.py -- the Programs page (docs/programming.md): a set's Structured Text files and their
POUs, a file's source, the check of an edited file in its set (errors and symbols, from the
compiler in this process: sets/st_check.py), an edit applied as a new set made from the set with
the file replaced (built as an upload is, its manifest saying `derived_from`; irpd's dry run in the
answer; activated on request through the sets' activation), a file's history across sets and the
diff of two versions, the set's programs as one PLCopen XML file (sets/st_export.py), and the monitor: the values of the variables of the lines shown and the
conditions evaluated (sets/st_monitor.py).  Rollback is POST /sets/rollback.  Viewers read and check; applying an edit
needs the role an upload needs (admin)."""

from __future__ import annotations

import difflib
import functools
import hashlib
import json
from pathlib import Path

import orjson
from fastapi import APIRouter, HTTPException, Query, Request, Response
from starlette.concurrency import run_in_threadpool

from ...irpd.variables import VariableError
from ...sets import plc_diagram, st_build, st_check, st_export, st_monitor, uploads
from ...sets.activation import irpd_validation
from ...sets.store import remove_tree
from ..deps import AdminDep, IrpdDep, ViewerDep, audited
from ..models import ActivateRequest
from ..monitor_models import MonitorAnswer, MonitorRequest
from ..program_models import (
    ApplyRequest,
    ApplyResult,
    CheckRequest,
    CheckResult,
    FileDiff,
    FileHistory,
    FileVersion,
    ProgramFile,
    ProgramList,
    ProgramSource,
)
from . import sets as sets_routes
from .forces import forced_now
from .variables import segment

router = APIRouter(tags=["programs"])
SOURCE_KINDS = ("st", "plcopen")  # a program's sources: their history and diffs
NOT_FOUND = {404: {"description": "no such set, no active set, or no such .st file in it"}}


def _set_id(request: Request, set_id: str | None) -> str:
    store = request.app.state.store
    if set_id is None:
        set_id = store.active_id()
        if set_id is None:
            raise HTTPException(
                404, "no set is active; give `set`, or activate a set first (POST /api/v1/sets/{id}/activate)"
            )
    if store.manifest(set_id) is None:
        raise HTTPException(404, f"no set {set_id!r}; GET /api/v1/sets lists them")
    return set_id


def _st_paths(manifest: dict) -> list[str]:
    return sorted(f["path"] for f in manifest["files"] if f["kind"] == "st")


def _file_of(request: Request, set_id: str, path: str, kinds: tuple[str, ...] = ("st",)) -> dict:
    manifest = request.app.state.store.manifest(set_id)
    for f in manifest["files"]:
        if f["path"] == path and f["kind"] in kinds:
            return f
    known = ", ".join(_st_paths(manifest)) or "none"
    raise HTTPException(404, f"set {set_id} has no .st file {path!r}; its .st files: {known}")


def _text(request: Request, set_id: str, path: str) -> str:
    return (request.app.state.store.files_dir(set_id) / path).read_text(encoding="utf-8", errors="replace")


@functools.lru_cache(maxsize=8)
def _sources(files_dir: Path, paths: tuple[str, ...], layout: str | None) -> st_check.SetSources:
    """A stored set's .st texts and layout (a set never changes: kept by its folder)."""
    texts = {p: (files_dir / p).read_text(encoding="utf-8", errors="replace") for p in paths}
    doc = None
    if layout is not None:
        try:
            doc = json.loads((files_dir / layout).read_bytes())
        except (OSError, ValueError):
            doc = None
    return st_check.SetSources(texts, doc)


def _set_sources(request: Request, set_id: str) -> st_check.SetSources:
    store = request.app.state.store
    manifest = store.manifest(set_id)
    folder = store.files_dir(set_id)
    by_path = {
        f["path"]: uploads.Received(f["path"], folder / f["path"], f["sha256"], f["size"]) for f in manifest["files"]
    }
    return _sources(folder, tuple(_st_paths(manifest)), st_build.set_layout(by_path))


def _stc(request: Request) -> Path:
    return st_build.find_stc(request.app.state.settings.stc)


def _compiler_missing(e: st_check.CompilerMissing) -> HTTPException:
    return HTTPException(500, str(e))


@router.get("/programs", responses=NOT_FOUND)
def list_programs(request: Request, _: ViewerDep, set: str | None = None) -> ProgramList:
    """The set's (default: the active set's) .st files and the POUs in each, with their lines; no
    files and no set when none is active (irpd started on a folder the store does not hold)."""
    if set is None and request.app.state.store.active_id() is None:
        return ProgramList(set_id=None, active=False, files=[])
    set_id = _set_id(request, set)
    manifest = request.app.state.store.manifest(set_id)
    try:
        files = [
            ProgramFile(**st_check.outline(_stc(request), p, _text(request, set_id, p))) for p in _st_paths(manifest)
        ]
        files += [
            _plcopen_outline(request, set_id, p) for p in plc_diagram.plcopen_paths(request.app.state.store, set_id)
        ]
    except st_check.CompilerMissing as e:
        raise _compiler_missing(e) from e
    return ProgramList(set_id=set_id, active=set_id == request.app.state.store.active_id(), files=files)


def _plcopen_outline(request: Request, set_id: str, path: str) -> ProgramFile:
    """A PLCopen XML file's POUs with their body languages (an LD, FBD or SFC one opens the live view)."""
    try:
        found = plc_diagram.project(_stc(request), request.app.state.store.files_dir(set_id) / path, path)
    except plc_diagram.DiagramError as e:
        return ProgramFile(path=path, pous=[], plcopen=True, error=e.first)
    return ProgramFile(path=path, pous=plc_diagram.outline(found), plcopen=True)


@router.get("/programs/source", responses=NOT_FOUND)
def program_source(request: Request, _: ViewerDep, path: str, set: str | None = None) -> ProgramSource:
    """A .st file's text as stored in the set (default: the active set)."""
    set_id = _set_id(request, set)
    f = _file_of(request, set_id, path)
    return ProgramSource(set_id=set_id, path=path, sha256=f["sha256"], source=_text(request, set_id, path))


@router.get(
    "/programs/export",
    response_class=Response,
    responses={
        **NOT_FOUND,
        200: {"content": {"application/xml": {}}, "description": "a PLCopen XML 2.01 project (TC6 XML v2.01)"},
        422: {"description": "a source has what PLCopen XML cannot say (e.g. a POU implemented in C++)"},
    },
)
def export_programs(request: Request, _: ViewerDep, set: str | None = None) -> Response:
    """The set's (default: the active set's) programs as one PLCopen XML 2.01 project, to open in a
    PLC editor: data types, POUs (ST bodies as written; a POU imported from PLCopen XML with its
    drawing), configurations, tasks and program instances (docs/plcopen-xml.md "Export")."""
    set_id = _set_id(request, set)
    manifest = request.app.state.store.manifest(set_id)
    paths = sorted(f["path"] for f in manifest["files"] if f["kind"] in ("st", "plcopen"))
    if not paths:
        raise HTTPException(404, f"set {set_id} has no programs (.st or PLCopen XML files) to export")
    try:
        data = st_export.export(_stc(request), request.app.state.store.files_dir(set_id), paths, f"set {set_id}")
    except st_check.CompilerMissing as e:
        raise _compiler_missing(e) from e
    except st_export.ExportError as e:
        raise HTTPException(422, f"set {set_id} cannot be written as PLCopen XML: {e}") from e
    return Response(
        data, media_type="application/xml", headers={"Content-Disposition": f'attachment; filename="{set_id}.xml"'}
    )


@router.post("/programs/check", responses=NOT_FOUND)
def check_program(body: CheckRequest, request: Request, _: ViewerDep) -> CheckResult:
    """Checks `source` as the set's file `path`, with the set's other .st files as stored and its
    .glb variables: every error with its place, and the symbols (POUs, variables with their IEC
    type and shared-variable paths, FB types, functions).  Nothing is stored."""
    set_id = _set_id(request, body.set)
    _file_of(request, set_id, body.path)
    try:
        result = st_check.check(_stc(request), _set_sources(request, set_id), body.path, body.source)
    except st_check.CompilerMissing as e:
        raise _compiler_missing(e) from e
    return CheckResult(set_id=set_id, **result)


@router.post("/programs/monitor", responses=NOT_FOUND, response_model=MonitorAnswer)
def monitor_program(body: MonitorRequest, request: Request, irpd: IrpdDep, _: ViewerDep) -> Response:
    """The running values of the variables in lines from_line..to_line of the set's (default: the
    active set's) file `path`, each where it is (an FB instance or a struct as a group: its fields
    when named in `expand`), and the IF/ELSIF/WHILE/UNTIL conditions and CASE selectors evaluated
    on them with the compiler's own folding (or why not).  One read of the shared memory."""
    set_id = _set_id(request, body.set)
    found = st_monitor.kept((set_id, body.path))  # the set's file analysed already: a refresh reads no file
    if found is None:
        _file_of(request, set_id, body.path)
        try:
            found = st_monitor.analyse(_stc(request), (set_id, body.path), _set_sources(request, set_id), body.path)
        except st_check.CompilerMissing as e:
            raise _compiler_missing(e) from e
    forced = forced_now(irpd)
    seg = segment(request, irpd)
    try:
        answer = found.snapshot(seg, forced, body.from_line, body.to_line, body.expand)
    except VariableError as e:
        raise HTTPException(503, str(e)) from e
    # MonitorAnswer, every field given (st_monitor.py), written by orjson (a float not finite as null)
    return Response(orjson.dumps({"set_id": set_id, **answer}), media_type="application/json")


def _derive(request: Request, irpd, base: str, path: str, source: str, who) -> dict:
    """Stores the base set with `path` replaced by `source`, built as an upload (its .st compiled
    against the running layout), with irpd's dry run as its validation; returns the manifest."""
    state = request.app.state
    store = state.store
    staging = store.staging_dir()
    try:
        data = source.encode("utf-8")
        edited = staging / "edited.st"
        edited.write_bytes(data)
        received = [
            uploads.Received(f["path"], store.blobs / f["sha256"], f["sha256"], f["size"])
            for f in store.manifest(base)["files"]
            if f["path"] != path
        ]
        received.append(uploads.Received(path, edited, hashlib.sha256(data).hexdigest(), len(data)))
        limits = uploads.Limits.of(state.settings)
        received = sets_routes.build_st(request, irpd, received, staging, limits)
        files = uploads.check_set(received)
        manifest, new = store.commit(files, who.as_dict(), sets_routes.NOT_CHECKED_YET, {"set_id": base, "path": path})
        for kept in (state.scopes, state.watches):  # the trace configurations and watch lists follow the edit
            kept.copy(base, manifest["id"])
        validation = irpd_validation(state.irpd_swap, store.module_xml(manifest["id"]), state.settings.swap_timeout_s)
        return store.save_validation(manifest["id"], validation)
    finally:
        remove_tree(staging)


@router.post("/programs/apply", responses={**NOT_FOUND, **sets_routes.REFUSALS})
async def apply_program(body: ApplyRequest, request: Request, who: AdminDep, irpd: IrpdDep) -> ApplyResult:
    """A new set made from the set (default: the active one) with `path` replaced by `source`: built
    as an upload is, stored with `derived_from`, checked by irpd against what runs (the dry run:
    variables added, removed, converted; modules kept, replaced; online or restart and its expected
    downtime).  With `activate`, then activated as POST /sets/{id}/activate does (`mode`)."""
    base = _set_id(request, body.set)
    _file_of(request, base, body.path)
    with audited(request, who, "program_edit", path=body.path, derived_from=base) as entry:
        manifest = await run_in_threadpool(_derive, request, irpd, base, body.path, body.source, who)
        entry["target"] = manifest["id"]
        entry["valid"] = manifest["validation"]["valid"]
    request.app.state.events.add(
        "upload", f"{who.name} edited {body.path}: set {manifest['id']} made from set {base}", set_id=manifest["id"]
    )
    report = None
    if body.activate:
        report = await run_in_threadpool(
            sets_routes.activate, manifest["id"], request, who, ActivateRequest(mode=body.mode)
        )
    return ApplyResult(
        set=sets_routes.public_set(request, request.app.state.store.manifest(manifest["id"])), report=report
    )


@router.get("/programs/history")
def program_history(request: Request, _: ViewerDep, path: str) -> FileHistory:
    """Every stored set holding the .st file (or PLCopen XML file) `path`, newest first, with the
    file's sha256 and the set it was made from when it was an edit."""
    store = request.app.state.store
    active = store.active_id()
    versions = []
    for m in store.list():
        f = next((f for f in m["files"] if f["path"] == path and f["kind"] in SOURCE_KINDS), None)
        if f is not None:
            versions.append(
                FileVersion(
                    set_id=m["id"],
                    created=m["created"],
                    by=m.get("by"),
                    sha256=f["sha256"],
                    active=m["id"] == active,
                    derived_from=(m.get("derived_from") or {}).get("set_id"),
                )
            )
    if not versions:
        raise HTTPException(404, f"no stored set holds a .st or PLCopen XML file {path!r}")
    return FileHistory(path=path, versions=versions)


@router.get("/programs/diff", responses=NOT_FOUND)
def program_diff(
    request: Request,
    _: ViewerDep,
    path: str,
    old: str = Query(description="the set of the older version"),
    new: str | None = Query(None, description="the set of the newer version; default: the active set"),
) -> FileDiff:
    """The unified diff of `path` (a .st or PLCopen XML file) from set `old` to set `new`."""
    old_id, new_id = _set_id(request, old), _set_id(request, new)
    _file_of(request, old_id, path, SOURCE_KINDS)
    _file_of(request, new_id, path, SOURCE_KINDS)
    a = _text(request, old_id, path).splitlines(keepends=True)
    b = _text(request, new_id, path).splitlines(keepends=True)
    diff = "".join(difflib.unified_diff(a, b, f"{old_id}/{path}", f"{new_id}/{path}"))
    return FileDiff(path=path, old=old_id, new=new_id, diff=diff)

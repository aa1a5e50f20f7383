"""sets.py -- module sets: upload (admin), list and read (viewer), activate and roll back
(operator).  The store is agent/indurop_agent/sets/store.py; uploads are checked by uploads.py;
activation is a hot swap in irpd (activation.py)."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, Request
from starlette.concurrency import run_in_threadpool

from ...irpd.client import IrpdRefused, IrpdUnavailable
from ...sets import st_build, uploads
from ...sets.activation import RestartFellBack, irpd_validation
from ...sets.errors import LocatedError, place
from ...sets.store import StoreError, remove_tree, set_id_of
from ..deps import AdminDep, IrpdDep, OperatorDep, ViewerDep, audited
from ..models import ActivateRequest, ActiveSet, ErrorBody, SetPublic, SetSummary, SwapReport
from .variables import segment

router = APIRouter(tags=["sets"])

NOT_CHECKED_YET = {"valid": None, "errors": [], "problems": [], "warnings": ["not checked yet"], "schedule": None}
UPLOAD_BODY = {
    "requestBody": {
        "required": True,
        "content": {
            "multipart/form-data": {
                "schema": {
                    "type": "object",
                    "properties": {
                        "files": {
                            "type": "array",
                            "items": {"type": "string", "format": "binary"},
                            "description": "one part per file; its filename is the path in the set (module.xml, lib/cntr1.so)",
                        },
                        "archive": {
                            "type": "string",
                            "format": "binary",
                            "description": "or: the whole set as one .tar.gz",
                        },
                    },
                }
            },
            "application/gzip": {
                "schema": {"type": "string", "format": "binary", "description": "the set as a .tar.gz"}
            },
        },
    }
}
REFUSALS = {
    400: {
        "model": ErrorBody,
        "description": "a bad name, module.xml or file content, or .st sources that do not compile; the "
        "detail says what to fix, file/line/column where, and `problems` lists every compile error",
    },
    413: {"model": ErrorBody, "description": "a file, the upload or the file count is over the limit"},
    415: {"model": ErrorBody, "description": "a kind of file a set does not hold"},
    500: {"model": ErrorBody, "description": "the ST compiler is missing here, or failed on sources it accepted"},
}


def build_st(request: Request, irpd, received: list, staging, limits) -> list:
    """The upload's files with its .st sources built (sets/st_build.py), laid out against the layout
    irpd runs (GET /layout's) when it runs one."""
    try:
        previous = segment(request, irpd).text
    except HTTPException:  # no layout runs, or irpd cannot be asked: a fresh layout
        previous = None
    settings = request.app.state.settings
    stc = st_build.find_stc(settings.stc)
    return st_build.build(received, staging, limits, stc, settings.st_build_timeout_s, previous)


def _located(manifest: dict) -> dict:
    """The manifest with its validation's errors also as problems, for sets stored before the
    validation kept them (without places: checking the set again gives them)."""
    validation = manifest["validation"]
    if "problems" in validation:
        return manifest
    return {
        **manifest,
        "validation": {**validation, "problems": [{"message": e} for e in validation.get("errors") or []]},
    }


def public_set(request: Request, manifest: dict) -> SetPublic:
    return SetPublic(**_located(manifest), active=manifest["id"] == request.app.state.store.active_id())


def _store_error(e: StoreError) -> HTTPException:
    return HTTPException(e.status, str(e))


@router.post("/sets", status_code=201, openapi_extra=UPLOAD_BODY, responses=REFUSALS)
async def upload_set(request: Request, who: AdminDep, irpd: IrpdDep) -> SetPublic:
    """Stores a set (nothing is stored if any file is refused) and has irpd check it.  The same
    files again give the same id and the stored set.  A set holding .st files is compiled first
    (docs/st.md, "Uploading ST"); its compile errors refuse it, each in `problems` with its place."""
    state = request.app.state
    staging = state.store.staging_dir()
    try:
        with audited(request, who, "upload") as entry:
            limits = uploads.Limits.of(state.settings)
            received = await uploads.receive(request, staging, limits)
            if st_build.has_st(received):  # Structured Text: compiled here, against the running layout
                received = await run_in_threadpool(build_st, request, irpd, received, staging, limits)
            files = await run_in_threadpool(uploads.check_set, received)
            entry["target"] = set_id_of(files)
            entry["files"] = {f.path: f.sha256 for f in files}
            manifest, new = await run_in_threadpool(state.store.commit, files, who.as_dict(), NOT_CHECKED_YET)
            if new or manifest["validation"]["valid"] is None:  # checked now, or again now irpd may answer
                module_xml = state.store.module_xml(manifest["id"])
                validation = await run_in_threadpool(
                    irpd_validation, state.irpd_swap, module_xml, state.settings.swap_timeout_s
                )
                manifest = await run_in_threadpool(state.store.save_validation, manifest["id"], validation)
            entry["new"] = new
            entry["valid"] = manifest["validation"]["valid"]
    finally:
        await run_in_threadpool(remove_tree, staging)
    state.events.add(
        "upload",
        f"set {manifest['id']} uploaded by {who.name} ({len(files)} files, "
        f"{'new' if new else 'already stored'}, valid: {manifest['validation']['valid']})",
        set_id=manifest["id"],
    )
    return public_set(request, manifest)


@router.get("/sets")
def list_sets(request: Request, _: ViewerDep) -> list[SetSummary]:
    """Every stored set, newest first."""
    active = request.app.state.store.active_id()
    return [
        SetSummary(
            id=m["id"],
            created=m["created"],
            by=m["by"],
            files=len(m["files"]),
            valid=m["validation"]["valid"],
            active=m["id"] == active,
        )
        for m in request.app.state.store.list()
    ]


@router.get("/sets/active", responses={404: {"description": "no set has been activated through the agent"}})
def active_set(request: Request, _: ViewerDep) -> ActiveSet:
    store = request.app.state.store
    active = store.active()
    manifest = store.manifest(active["set_id"]) if active else None
    if manifest is None:
        raise HTTPException(404, "no set has been activated through the agent yet; POST /api/v1/sets/{id}/activate")
    return ActiveSet(
        **_located(manifest),
        active=True,
        since=active["since"],
        action=active["action"],
        rollback_to=store.rollback_target(),
    )


@router.get("/sets/{set_id}", responses={404: {"description": "no such set"}})
def get_set(set_id: str, request: Request, _: ViewerDep) -> SetPublic:
    manifest = request.app.state.store.manifest(set_id)
    if manifest is None:
        raise HTTPException(404, f"no set {set_id!r}; GET /api/v1/sets lists them")
    return public_set(request, manifest)


@router.post("/sets/{set_id}/check", responses={404: {"description": "no such set"}})
async def check_set(set_id: str, request: Request, _: OperatorDep) -> SetPublic:
    """Has irpd check the stored set again against what runs now (the dry run before an activation):
    its slot table, whether it can be taken online, the shared variables it adds, removes and moves,
    and, where only a restart can run it, why and the expected downtime.  Kept as its validation."""
    state = request.app.state
    if state.store.manifest(set_id) is None:
        raise HTTPException(404, f"no set {set_id!r}; GET /api/v1/sets lists them")
    validation = await run_in_threadpool(
        irpd_validation, state.irpd_swap, state.store.module_xml(set_id), state.settings.swap_timeout_s
    )
    manifest = await run_in_threadpool(state.store.save_validation, set_id, validation)
    return public_set(request, manifest)


def _run_swap(call, root=None):
    """`root`: the folder of the set being activated, so that a refusal can say where in it."""

    def where(e: IrpdRefused) -> dict:
        return place(e.error, root) if root is not None else {}

    try:
        return call()
    except StoreError as e:
        raise _store_error(e) from e
    except RestartFellBack as e:  # irpd restarted, and runs its old set again
        raise LocatedError(409, str(e), **where(e)) from e
    except IrpdRefused as e:
        raise LocatedError(
            409,
            f"irpd refused the set and kept the running one: {e}",
            **where(e),
        ) from e
    except IrpdUnavailable as e:
        raise HTTPException(503, str(e)) from e


def _note(entry: dict, report: dict | None) -> None:
    """The audit line's outcome of an activation: generation, mode, and a restart's downtime."""
    entry["generation"] = (report or {}).get("generation")
    entry["mode"] = (report or {}).get("mode", entry.get("mode"))
    if entry["mode"] == "restart":
        entry["downtime_ns"] = (report or {}).get("downtime_ns")


@router.post("/sets/rollback", responses={409: {"description": "nothing to roll back to, or irpd refused"}})
def rollback(request: Request, who: OperatorDep, body: ActivateRequest | None = None) -> SwapReport:
    """Activates the set that was active before the current one (mode as for activate)."""
    state = request.app.state
    mode = (body or ActivateRequest()).mode
    with audited(request, who, "rollback", mode=mode) as entry:
        entry["from"] = state.store.active_id()
        entry["target"] = state.store.rollback_target()
        target = entry["target"]
        root = state.store.files_dir(target) if target else None
        target, report = _run_swap(lambda: state.activator.rollback(who.as_dict(), mode), root)
        _note(entry, report)
    return SwapReport(**(report or {}))


@router.post(
    "/sets/{set_id}/activate",
    responses={
        404: {"description": "no such set"},
        409: {
            "model": ErrorBody,
            "description": "irpd refused the set "
            "(its message; file and line where it names them), a set "
            "that needs a restart in mode online, or a restart after "
            "which irpd came back on its old set",
        },
    },
)
def activate(set_id: str, request: Request, who: OperatorDep, body: ActivateRequest | None = None) -> SwapReport:
    """Puts this set into irpd: mode online (the default) hot-swaps it at a macro-period boundary and
    refuses (409) a set that needs a restart, naming why; mode restart restarts irpd (same pid) onto
    it; auto restarts only when needed.  On refusal, or when a restarted irpd came back on its old
    set (409), nothing changes."""
    state = request.app.state
    mode = (body or ActivateRequest()).mode
    with audited(request, who, "activate", set_id, mode=mode) as entry:
        entry["from"] = state.store.active_id()
        root = state.store.files_dir(set_id) if state.store.manifest(set_id) is not None else None
        report = _run_swap(lambda: state.activator.activate(set_id, who.as_dict(), mode=mode), root)
        _note(entry, report)
    return SwapReport(**(report or {}))

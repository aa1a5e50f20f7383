"""system.py -- the System page's routes (admin; docs/administration.md): the figures, irpd's and the
agent's restart, their logs (read, searched, followed), the backup download and its restore (a dry
run first), the TLS certificate's upload, and the set store's prune (POST /sets/prune)."""

from __future__ import annotations

import json
import tempfile
from datetime import UTC, datetime
from pathlib import Path
from typing import Literal

from fastapi import APIRouter, HTTPException, Query, Request
from fastapi.responses import FileResponse, StreamingResponse
from starlette.background import BackgroundTask
from starlette.concurrency import run_in_threadpool

from ...irpd.client import IrpdRefused, IrpdUnavailable
from ...sets.activation import RestartFellBack
from ...sets.store import StoreError, remove_tree
from ...system import backup, restore, tls
from ...system.info import gather
from ...system.logs import MAX_GREP_CHARS, MAX_LINES, LogQuery, LogUnavailable, no_source, sources
from ...system.restart import NoSupervisor
from ..deps import AdminDep, audited, client_address
from ..models import (
    AgentRestart,
    ErrorBody,
    IrpdRestartReport,
    LogLine,
    LogPage,
    PruneReport,
    PruneRequest,
    RestorePlan,
    SystemInfo,
    TlsCertificate,
    TlsInstalled,
    TlsUpload,
)

router = APIRouter(tags=["system"])

LogName = Literal["irpd", "agent"]
MAX_FOLLOWERS = 8  # log follows at once (each may run a journalctl)
GZIP_TYPES = ("application/gzip", "application/x-gzip", "application/octet-stream")
BINARY = {"type": "string", "format": "binary"}
RESTORE_BODY = {
    "requestBody": {
        "required": True,
        "content": {
            kind: {"schema": {**BINARY, "description": "a backup from GET /system/backup"}}
            for kind in ("application/gzip", "application/octet-stream")
        },
    }
}
REFUSED = {"model": ErrorBody}


# ---- the figures -----------------------------------------------------------------------------
@router.get("/system")
def system_info(request: Request, _: AdminDep) -> SystemInfo:
    """Versions and uptimes of the agent and irpd, the data folder's disk use and free space, the
    TLS certificate served (fingerprint, expiry), where the logs come from."""
    return gather(request.app.state)


# ---- restarts --------------------------------------------------------------------------------
@router.post(
    "/system/restart/irpd",
    responses={
        409: {
            **REFUSED,
            "description": "irpd refused the restart, or could not start the set and came back on its old one",
        },
        503: {**REFUSED, "description": "irpd does not answer (systemd restarts a dead irpd by itself)"},
    },
)
def restart_irpd(request: Request, who: AdminDep) -> IrpdRestartReport:
    """irpd's managed restart onto the active set: its outputs go to safe values, it stops, and the
    same process starts again on the set (docs/hot-reload.md); answers once it runs again."""
    state = request.app.state
    with audited(request, who, "irpd_restart", state.store.active_id()) as entry:
        try:
            report = state.activator.restart_irpd()
        except RestartFellBack as e:
            raise HTTPException(409, str(e)) from e
        except IrpdRefused as e:
            raise HTTPException(409, f"irpd refused the restart: {e}") from e
        except IrpdUnavailable as e:
            raise HTTPException(503, str(e)) from e
        entry["target"] = report.get("set_id")
        entry["downtime_ns"] = report.get("downtime_ns")
        entry["pid"] = report.get("pid")
    return IrpdRestartReport(**report)


@router.post(
    "/system/restart/agent",
    status_code=202,
    responses={409: {**REFUSED, "description": "nothing would start the agent again (no systemd, no demo script)"}},
)
def restart_agent(request: Request, who: AdminDep) -> AgentRestart:
    """Ends the agent gracefully a moment after this answer, for its supervisor (systemd, or
    packaging/demo.sh) to start it again: a few seconds without the API and the web UI."""
    state = request.app.state
    with audited(request, who, "agent_restart", "indurop-agent"):
        try:
            state.agent_restart.request()
        except NoSupervisor as e:
            raise HTTPException(409, str(e)) from e
    state.events.add("agent_restart", f"the agent restarts, asked by {who.name}")
    return AgentRestart(
        restarting=True,
        supervisor=state.agent_restart.supervisor,
        detail=f"the agent stops now and {state.agent_restart.supervisor} starts it again",
    )


# ---- logs ------------------------------------------------------------------------------------
def _source(request: Request, log: str):
    source = sources(request.app.state.settings)[log]
    if source is None:
        raise HTTPException(404, no_source(log))
    return source


def _query(lines: int, grep: str | None, since: datetime | None) -> LogQuery:
    if since is not None and since.tzinfo is None:
        since = since.replace(tzinfo=UTC)  # a time without a zone is UTC, as everywhere in the API
    return LogQuery(lines=lines, grep=grep or None, since=since)


LINES = Query(200, ge=1, le=MAX_LINES, description="at most this many lines: the newest that match")
GREP = Query(None, max_length=MAX_GREP_CHARS, description="only lines holding this text (any case)")
SINCE = Query(None, description="only lines from this time on (ISO 8601; UTC without a zone)")


@router.get("/system/logs/{log}", responses={404: {**REFUSED, "description": "no source for this log here"}})
def read_log(
    log: LogName,
    request: Request,
    _: AdminDep,
    lines: int = LINES,
    grep: str | None = GREP,
    since: datetime | None = SINCE,
) -> LogPage:
    """The last lines of irpd's or the agent's log (journal or file), oldest first."""
    source = _source(request, log)
    try:
        found, truncated = source.read(_query(lines, grep, since))
    except LogUnavailable as e:
        raise HTTPException(503, str(e)) from e
    return LogPage(log=log, source=source.describe(), lines=found, truncated=truncated)


@router.get(
    "/system/logs/{log}/follow",
    response_class=StreamingResponse,
    responses={
        200: {
            "description": "newline-delimited JSON, one LogLine a line: the last `lines` that match, then each new "
            "one as it is written, until the client closes",
            "content": {"application/x-ndjson": {"schema": {"$ref": "#/components/schemas/LogLine"}}},
        },
        404: {**REFUSED, "description": "no source for this log here"},
        429: {**REFUSED, "description": f"{MAX_FOLLOWERS} logs are followed already"},
    },
)
async def follow_log(
    log: LogName,
    request: Request,
    _: AdminDep,
    lines: int = LINES,
    grep: str | None = GREP,
    since: datetime | None = SINCE,
) -> StreamingResponse:
    """irpd's or the agent's log, live."""
    state = request.app.state
    source = _source(request, log)
    if state.log_followers >= MAX_FOLLOWERS:
        raise HTTPException(429, f"{MAX_FOLLOWERS} logs are followed already; close one", headers={"Retry-After": "5"})
    query = _query(lines, grep, since)

    async def stream():
        state.log_followers += 1  # counted while the stream runs (a response never started counts nothing)
        try:
            async for line in source.follow(query):
                yield json.dumps(LogLine(**line).model_dump(), ensure_ascii=False) + "\n"
        except LogUnavailable as e:  # the answer has begun: the last line says why it ends
            yield json.dumps({"log": log, "time": None, "message": f"(the log stopped: {e})"}) + "\n"
        finally:
            state.log_followers -= 1

    return StreamingResponse(
        stream(), media_type="application/x-ndjson", headers={"Cache-Control": "no-store", "X-Accel-Buffering": "no"}
    )


# ---- backup and restore ----------------------------------------------------------------------
@router.get(
    "/system/backup",
    response_class=FileResponse,
    responses={200: {"description": "the backup (.tar.gz)", "content": {"application/gzip": {"schema": BINARY}}}},
)
async def download_backup(
    request: Request,
    who: AdminDep,
    with_secrets: bool = Query(False, description="also the users' password hashes and the TLS private key"),
) -> FileResponse:
    """A backup of the data folder: the sets, the active set and history, the tokens (their hashes),
    the users (without password hashes unless with_secrets), the audit log, the alarm database, the
    settings kept there, the TLS certificate (its key only with_secrets); manifest.json lists every
    file's size and SHA-256."""
    state = request.app.state
    with audited(request, who, "backup", None, with_secrets=with_secrets) as entry:
        path, manifest = await run_in_threadpool(
            backup.create, state.settings.data_dir, state.store, state.activator, with_secrets
        )
        entry["target"] = path.name
        entry["files"] = len(manifest["files"])
        entry["sets"] = len(manifest["summary"]["sets"])
    return FileResponse(
        path, media_type="application/gzip", filename=path.name, background=BackgroundTask(remove_tree, path.parent)
    )


async def _receive_archive(request: Request, folder: Path, limit: int) -> Path:
    """The request body into `folder`/backup.tar.gz, refused (413) once it passes `limit` bytes."""
    kind = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if kind not in GZIP_TYPES:
        raise HTTPException(
            415, f"send the backup as the body with Content-Type application/gzip (not {kind or 'none'})"
        )
    length = request.headers.get("content-length")
    if length is not None and length.isdigit() and int(length) > limit:
        raise HTTPException(413, f"the backup is {length} bytes; at most {limit} are accepted (max_backup_bytes)")
    target = folder / "backup.tar.gz"
    received = 0
    with open(target, "xb") as f:
        async for chunk in request.stream():
            received += len(chunk)
            if received > limit:
                raise HTTPException(413, f"the backup is larger than {limit} bytes (max_backup_bytes)")
            await run_in_threadpool(f.write, chunk)
    if received == 0:
        raise HTTPException(400, "the body is empty: send the backup (.tar.gz) as the body")
    return target


@router.post(
    "/system/restore",
    openapi_extra=RESTORE_BODY,
    responses={
        400: {**REFUSED, "description": "not a backup, or an unsafe or altered one: the detail names the member"},
        413: {**REFUSED, "description": "over max_backup_bytes or max_backup_members"},
        415: {**REFUSED, "description": "not sent as application/gzip"},
        507: {**REFUSED, "description": "no room for it on the data folder's file system"},
    },
)
async def restore_backup(
    request: Request,
    who: AdminDep,
    dry_run: bool = Query(False, description="true: check the archive and say what it would replace, change nothing"),
) -> RestorePlan:
    """Checks a backup whole (every member's type, name, size and SHA-256 against its manifest, then
    its content) and answers what restoring it replaces.  Unless dry_run, the checked backup is
    staged and the agent restarts to apply it before it opens anything (the files it replaces are
    kept in <data>/replaced-<time>/)."""
    state = request.app.state
    settings = state.settings
    upload = Path(tempfile.mkdtemp(prefix="restore-upload-", dir=state.store.tmp))
    staging = None
    try:
        with audited(request, who, "restore_backup", None, dry_run=dry_run) as entry:
            archive = await _receive_archive(request, upload, settings.max_backup_bytes)
            try:
                staging, review = await run_in_threadpool(
                    restore.verify, archive, state.store.tmp, settings.data_dir, restore.Limits.of(settings)
                )
            except restore.RestoreError as e:
                raise HTTPException(e.status, e.message) from e
            entry["target"] = review["archive"]["created"]
            entry["sets_added"] = review["sets"]["added"]
            entry["files"] = [f["path"] for f in review["files"]]
            restarting = False
            if not dry_run:  # (the live data folder is not touched until the agent starts again)
                await run_in_threadpool(
                    restore.stage, staging, settings.data_dir, review, who.as_dict(), client_address(request)
                )
                staging = None
                try:
                    state.agent_restart.request()
                    restarting = True
                except NoSupervisor:
                    pass
            entry["restarting"] = restarting
    finally:
        await run_in_threadpool(remove_tree, upload)
        if staging is not None:
            await run_in_threadpool(remove_tree, staging)
    if not dry_run:
        state.events.add(
            "restore_backup",
            f"a backup of {review['archive']['created']} is staged by {who.name}; "
            + ("the agent restarts to apply it" if restarting else "it is applied when the agent starts again"),
        )
    public = {k: v for k, v in review.items() if not k.startswith("_")}
    return RestorePlan(**public, dry_run=dry_run, restarting=restarting)


# ---- the TLS certificate ---------------------------------------------------------------------
@router.post(
    "/system/tls",
    responses={
        400: {**REFUSED, "description": "not a usable pair: the detail says what (expired, another key, ...)"},
        409: {**REFUSED, "description": "the agent serves plain HTTP, or its certificate is outside the data folder"},
    },
)
def upload_tls(body: TlsUpload, request: Request, who: AdminDep) -> TlsInstalled:
    """Replaces the certificate and key the agent serves (their files, which must be in the data
    folder, as the package has them) after checking them; the agent restarts to serve them."""
    state = request.app.state
    settings = state.settings
    if settings.tls_cert is None:
        raise HTTPException(
            409, "the agent serves plain HTTP (started without --tls-cert): there is no certificate to replace"
        )
    cert_path, key_path = Path(settings.tls_cert).resolve(), Path(settings.tls_key).resolve()
    if not (cert_path.is_relative_to(settings.data_dir) and key_path.is_relative_to(settings.data_dir)):
        raise HTTPException(
            409,
            f"the agent serves {cert_path} and {key_path}, outside its data folder {settings.data_dir}: replace "
            "them there by hand (the agent cannot write them)",
        )
    with audited(request, who, "tls_upload", None) as entry:
        try:
            described = tls.check_pair(body.certificate.encode(), body.key.encode())
        except tls.CertificateError as e:
            raise HTTPException(400, str(e)) from e
        entry["target"] = described["fingerprint_sha256"]
        entry["subject"], entry["not_after"] = described["subject"], described["not_after"]
        tls.install(cert_path, key_path, body.certificate.encode(), body.key.encode())
        try:
            state.agent_restart.request()
            restarting = True
        except NoSupervisor:
            restarting = False
        entry["restarting"] = restarting
    state.events.add(
        "tls_upload", f"a TLS certificate ({described['fingerprint_sha256'][:23]}…) installed by {who.name}"
    )
    return TlsInstalled(certificate=TlsCertificate(path=str(cert_path), **described), restarting=restarting)


# ---- the set store's prune -------------------------------------------------------------------
@router.post("/sets/prune", tags=["sets"])
def prune_sets(body: PruneRequest, request: Request, who: AdminDep) -> PruneReport:
    """Deletes the sets that are neither active, nor the rollback target, nor among the newest
    keep_last, then the stored files (blobs) no remaining set uses; dry_run says what would go."""
    state = request.app.state
    if body.dry_run:
        return PruneReport(**state.store.prune(body.keep_last, dry_run=True))
    with audited(request, who, "sets_prune", None, keep_last=body.keep_last) as entry:
        try:
            with state.activator.exclusive():
                report = state.store.prune(body.keep_last, dry_run=False)
        except StoreError as e:
            raise HTTPException(e.status, str(e)) from e
        entry["deleted"] = [s["id"] for s in report["deleted"]]
        entry["blobs"], entry["bytes"] = len(report["blobs"]), report["bytes"]
    state.events.add(
        "sets_prune",
        f"{len(report['deleted'])} set(s) and {len(report['blobs'])} blob(s) ({report['bytes']} bytes) pruned by "
        f"{who.name}; {len(report['kept'])} kept",
    )
    return PruneReport(**report)

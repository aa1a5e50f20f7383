"""recordings.py -- the recorder's routes (docs/recorder.md): start and stop recordings (operator,
audited), list and read them, download their MCAP files, export their rows as CSV or Parquet (any
signed-in role), delete them (operator, audited).  Captures live in the same store and are listed,
downloaded, exported and deleted here too."""

from __future__ import annotations

import io
import zipfile
from collections.abc import Iterator
from datetime import UTC, datetime
from pathlib import Path
from typing import Annotated, Literal

from fastapi import APIRouter, Depends, HTTPException, Query, Request, Response
from fastapi.responses import StreamingResponse

from ...irpd.trace import MAX_CHANNELS
from ...recorder.export import FORMATS, csv_chunks, parquet_chunks
from ...recorder.manager import Recorder, Wanted
from ...recorder.mcap_out import JOINT_FILE_SUFFIX, Variable, field_names
from ...recorder.store import Store, StoreError
from ..deps import OperatorDep, ViewerDep, audited
from ..recording_models import RecordingList, RecordingPublic, RecordingStart

router = APIRouter(tags=["recordings"])
READ_CHUNK = 1 << 20


def recorder(request: Request) -> Recorder:
    return request.app.state.recorder


RecorderDep = Annotated[Recorder, Depends(recorder)]
ERRORS = {
    400: {"description": "a bad name, an unknown or non-scalar variable, a variable twice, max_bytes over the quota"},
    404: {"description": "no such recording"},
    409: {
        "description": "the name is taken; irpd refused to trace (its message names every owner's channels); "
        "not running (stop) or being written (delete)"
    },
    503: {"description": "irpd unreachable"},
    507: {"description": "the disk is too full to record"},
}


def refusal(e: StoreError) -> HTTPException:
    return HTTPException(e.status, e.message)


def _time(ns: int | None) -> str | None:
    if ns is None:
        return None
    return datetime.fromtimestamp(ns / 1e9, UTC).isoformat(timespec="microseconds").replace("+00:00", "Z")


def recorded_variables(meta: dict) -> list[Variable]:
    """The variables of a recording's or capture's entry.json."""
    return [
        Variable(v["path"], v.get("type", "?"), v.get("unit", ""), v.get("iec_type"))
        for v in meta.get("variables") or []
    ]


def public(meta: dict) -> dict:
    """A recording's or capture's entry.json as the API shows it."""
    parts = meta.get("parts") or []
    variables = recorded_variables(meta)
    first, last = meta.get("first_unix_ns"), meta.get("last_unix_ns")
    return {
        "name": meta["name"],
        "kind": meta.get("kind", "recording"),
        "state": meta.get("state", "damaged"),
        "cause": meta.get("cause"),
        "reason": meta.get("reason"),
        "created": meta.get("created", ""),
        "created_by": meta.get("created_by"),
        "ended": meta.get("ended"),
        "variables": [
            {"path": v.path, "type": v.type, "iec_type": v.iec_type, "unit": v.unit, "field": f}
            for v, f in zip(variables, field_names([v.path for v in variables]))
        ],
        "decimation": meta.get("decimation"),
        "stop": meta.get("stop"),
        "rows": meta.get("rows", 0),
        "drops": meta.get("drops", 0),
        "gaps": meta.get("gaps") or [],
        "parts": [
            {
                **{
                    k: p.get(k)
                    for k in ("file", "size", "rows", "drops", "first_seq", "last_seq", "irpd_pid", "recovered")
                },
                "first_time": _time(p.get("first_unix_ns")),
                "last_time": _time(p.get("last_unix_ns")),
                "closed": bool(p.get("closed")),
            }
            for p in parts
        ],
        "size": sum(p.get("size") or 0 for p in parts),
        "duration_s": (last - first) / 1e9 if first is not None and last is not None else None,
        "first_time": _time(first),
        "last_time": _time(last),
        "basic_period_ns": meta.get("basic_period_ns"),
        "joint_states": [j["name"] for j in meta.get("joints") or []],
        "download": f"/api/v1/recordings/{meta['name']}/download",
        "shot": _shot_of(meta.get("capture")),
    }


def _shot_of(header) -> dict | None:
    """A capture shot's header (capture_files.py) as RecordingPublic.shot."""
    if not isinstance(header, dict):
        return None
    try:
        return {
            "capture": str(header["capture"]),
            "shot": int(header["shot"]),
            "trigger_seq": int(header["trigger_seq"]),
            "cause": str(header.get("cause", "")),
        }
    except (KeyError, TypeError, ValueError):
        return None


def current(rec: Recorder, name: str) -> dict:
    """The meta of `name`: the recorder thread's while it runs, else entry.json's."""
    live = rec.live(name)
    if live is not None:
        return live
    try:
        return rec.store.get(name).meta
    except StoreError as e:
        raise refusal(e) from e


@router.get("/recordings", response_model=RecordingList)
def list_recordings(rec: RecorderDep, _: ViewerDep) -> dict:
    """Every recording and capture, oldest first, with the folder's quota and use, and the trace
    rings' channels each owner holds."""
    store: Store = rec.store
    owners = rec.owners()
    channels = None
    if owners is not None:
        traced = {p for paths in owners.values() for p in paths}
        channels = {"limit": MAX_CHANNELS, "traced": len(traced), "owners": {k: len(v) for k, v in owners.items()}}
    return {
        "recordings": [public(current(rec, e.name)) for e in store.entries()],
        "quota_bytes": store.quota_bytes,
        "used_bytes": store.used(),
        "disk_free_bytes": store.disk_free(),
        "min_free_bytes": store.min_free_bytes,
        "channels": channels,
    }


@router.post("/recordings", status_code=201, response_model=RecordingPublic, responses=ERRORS)
def start_recording(body: RecordingStart, request: Request, rec: RecorderDep, who: OperatorDep) -> dict:
    """Starts recording every row (or every `decimation`-th) of the variables into
    <data-dir>/recordings/<name>/, until `stop` says or POST .../stop."""
    variables = [(v, "") if isinstance(v, str) else (v.path, v.unit) for v in body.variables]
    wanted = Wanted(body.name, variables, body.decimation, body.stop.duration_s, body.stop.max_bytes)
    with audited(request, who, "recording_start", body.name, variables=[p for p, _ in variables]):
        try:
            meta = rec.begin(wanted, who.user or who.name)
        except StoreError as e:
            raise refusal(e) from e
    return public(meta)


@router.get("/recordings/{name}", response_model=RecordingPublic, responses=ERRORS)
def get_recording(name: str, rec: RecorderDep, _: ViewerDep) -> dict:
    return public(current(rec, name))


@router.post("/recordings/{name}/stop", response_model=RecordingPublic, responses=ERRORS)
def stop_recording(name: str, request: Request, rec: RecorderDep, who: OperatorDep) -> dict:
    """Stops a running recording: its last part is closed (complete) and it is kept."""
    with audited(request, who, "recording_stop", name):
        try:
            meta = rec.end(name, who.user or who.name)
        except StoreError as e:
            raise refusal(e) from e
    return public(meta)


@router.delete("/recordings/{name}", status_code=204, responses=ERRORS)
def delete_recording(name: str, request: Request, rec: RecorderDep, who: OperatorDep) -> Response:
    """Deletes a recording or capture and its files (not while it is being written)."""
    with audited(request, who, "recording_delete", name):
        try:
            rec.delete(name)
        except StoreError as e:
            raise refusal(e) from e
    return Response(status_code=204)


def _file_chunks(path: Path, size: int) -> Iterator[bytes]:
    """The first `size` bytes of a file (a part being written grows meanwhile)."""
    with open(path, "rb") as f:
        left = size
        while left > 0:
            chunk = f.read(min(READ_CHUNK, left))
            if not chunk:
                break
            left -= len(chunk)
            yield chunk


class _ZipSink(io.RawIOBase):
    """A write-only, unseekable stream for zipfile: what it is given is taken in chunks."""

    def __init__(self):
        self.buffer = bytearray()

    def writable(self) -> bool:
        return True

    def write(self, data) -> int:
        self.buffer += data
        return len(data)

    def take(self) -> bytes:
        data = bytes(self.buffer)
        self.buffer.clear()
        return data


def _zip_chunks(paths: list[Path]) -> Iterator[bytes]:
    """A .zip (stored, not compressed: MCAP chunks are compressed already) of the parts."""
    sink = _ZipSink()
    with zipfile.ZipFile(sink, "w", zipfile.ZIP_STORED, allowZip64=True) as z:
        for path in paths:
            size = path.stat().st_size
            with z.open(zipfile.ZipInfo(path.name, datetime.now().timetuple()[:6]), "w", force_zip64=True) as dst:
                for chunk in _file_chunks(path, size):
                    dst.write(chunk)
                    yield sink.take()
    yield sink.take()


@router.get(
    "/recordings/{name}/download",
    response_class=StreamingResponse,
    responses={
        200: {"content": {"application/octet-stream": {}, "application/zip": {}}, "description": "an .mcap or a .zip"},
        **ERRORS,
    },
)
def download_recording(
    name: str,
    rec: RecorderDep,
    _: ViewerDep,
    part: int | None = Query(None, ge=1, description="only this part (1: the first); default: every part"),
) -> StreamingResponse:
    """The recording's MCAP file, or with several files (it resumed after a restart, or has a
    .joint_states.mcap beside each part) a .zip of them; `part` picks one part.  A part being written comes as far as it is flushed (without its index:
    readers read it front to back)."""
    try:
        entry = rec.store.get(name)
    except StoreError as e:
        raise refusal(e) from e
    parts = entry.parts()
    paths = entry.files()
    if part is not None:
        if part > len(parts):
            raise HTTPException(404, f"'{name}' has {len(parts)} part(s); part {part} does not exist")
        chosen = parts[part - 1].name.removesuffix(".mcap")
        paths = [p for p in paths if p.name.removesuffix(JOINT_FILE_SUFFIX).removesuffix(".mcap") == chosen]
    if not paths:
        raise HTTPException(404, f"'{name}' has no file yet (no row recorded)")
    if len(paths) == 1:
        size = paths[0].stat().st_size
        suffix = "" if part is None else f"-part{part}"
        return StreamingResponse(
            _file_chunks(paths[0], size),
            media_type="application/octet-stream",
            headers={
                "Content-Disposition": f'attachment; filename="{name}{suffix}.mcap"',
                "Content-Length": str(size),
            },
        )
    return StreamingResponse(
        _zip_chunks(paths),
        media_type="application/zip",
        headers={"Content-Disposition": f'attachment; filename="{name}.zip"'},
    )


@router.get(
    "/recordings/{name}/export",
    response_class=StreamingResponse,
    responses={200: {"content": {t: {} for t in FORMATS.values()}, "description": "the rows"}, **ERRORS},
)
def export_recording(
    name: str,
    rec: RecorderDep,
    _: ViewerDep,
    format: Literal["csv", "parquet"] = Query("csv", description="csv or parquet"),
) -> StreamingResponse:
    """Every row of every part as CSV or Parquet (seq, t_ns, unix_ns, a column per variable named
    by its path), made while it is sent."""
    try:
        entry = rec.store.get(name)
    except StoreError as e:
        raise refusal(e) from e
    meta = current(rec, name)
    variables = recorded_variables(meta)
    parts = entry.parts()
    chunks = csv_chunks(parts, variables) if format == "csv" else parquet_chunks(parts, variables, name)
    return StreamingResponse(
        chunks,
        media_type=FORMATS[format],
        headers={"Content-Disposition": f'attachment; filename="{name}.{format}"'},
    )

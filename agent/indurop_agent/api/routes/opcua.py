"""opcua.py -- the OPC UA server seen from the agent (docs/opcua.md "The trust list"): its state from
<data>/opcua/status.json (the server writes it; the agent owns no OPC UA endpoint) and the client
applications' certificates in <data>/opcua/pki, trusted, rejected or removed by an admin.  Each change
is a rename or an unlink in those folders (opcua/pki.py), audited; the server reads the trusted folder
again at the next session, without a restart."""

from __future__ import annotations

import json
import time
from datetime import datetime
from pathlib import Path

from fastapi import APIRouter, HTTPException, Request
from pydantic import ValidationError

from ...opcua.pki import BAD_THUMBPRINT, Pki, PkiError
from ..deps import AdminDep, ViewerDep, audited
from ..models import ErrorBody
from ..opcua_models import OpcuaCertificate, OpcuaSecurity, OpcuaServerCertificate, OpcuaState, OpcuaTrustChange

router = APIRouter(tags=["opcua"])

STALE_FILES = 3  # status.json older than this many of its periods (and STALE_MIN_S): the server stopped
STALE_MIN_S = 15.0
MAX_STATUS_BYTES = 1 << 20
# status.json's fields that GET /opcua passes on as they are
STATUS_FIELDS = ("endpoint", "application_uri", "pid", "started", "updated", "age_s", "irpd", "layout_hash")
STATUS_FIELDS += ("sessions", "subscriptions", "monitored_items")
REFUSED = {
    400: {"model": ErrorBody, "description": BAD_THUMBPRINT},
    404: {"model": ErrorBody, "description": "no certificate with this thumbprint in pki/trusted or pki/rejected"},
}


def opcua_dir(request: Request) -> Path:
    return request.app.state.settings.data_dir / "opcua"


def read_status(folder: Path) -> tuple[str, str, dict]:
    """(server state, message, status.json's body) -- see OpcuaState.server."""
    path = folder / "status.json"
    try:
        if path.stat().st_size > MAX_STATUS_BYTES:
            raise ValueError("larger than 1 MiB")
        body = json.loads(path.read_text(encoding="utf-8"))
        if not isinstance(body, dict) or body.get("format") != 1:
            raise ValueError("not format 1")
    except FileNotFoundError:
        return "off", f"the OPC UA server has not run with this data folder (no {path})", {}
    except (OSError, ValueError) as e:
        return "unreadable", f"{path}: {e}", {}
    try:
        age = time.time() - datetime.fromisoformat(body["updated"].replace("Z", "+00:00")).timestamp()
    except (KeyError, TypeError, ValueError, AttributeError):
        return "unreadable", f"{path}: no time of writing (updated)", {}
    body["age_s"] = round(max(0.0, age), 1)
    period = body.get("status_file_s") if isinstance(body.get("status_file_s"), (int, float)) else 5.0
    if age > max(STALE_MIN_S, STALE_FILES * period):
        return "stale", f"the OPC UA server last wrote its status {age:.0f} s ago: it is stopped or stuck", body
    return "ok", "", body


def state_of(folder: Path) -> OpcuaState:
    server, message, body = read_status(folder)
    listing = Pki(folder).listing()
    fields: dict = {}
    if body:
        try:
            fields = {
                "security": OpcuaSecurity(**body["security"]) if isinstance(body.get("security"), dict) else None,
                "certificate": OpcuaServerCertificate(**body["certificate"])
                if isinstance(body.get("certificate"), dict)
                else None,
                "refused": (body.get("trust") or {}).get("refused"),
                **{k: body.get(k) for k in STATUS_FIELDS},
            }
            return OpcuaState(server=server, message=message, **fields, **listing)
        except (ValidationError, TypeError, AttributeError) as e:
            server, message = "unreadable", f"{folder / 'status.json'}: {e}"
    return OpcuaState(server=server, message=message, **listing)


@router.get("/opcua")
def opcua_state(request: Request, _: ViewerDep) -> OpcuaState:
    """The OPC UA server's endpoint, security (with a warning when None or anonymous sessions are on),
    sessions and figures as it last wrote them, and the trust list: the client applications'
    certificates, trusted and rejected."""
    return state_of(opcua_dir(request))


def _change(request: Request, who, action: str, thumbprint: str) -> OpcuaTrustChange:
    pki = Pki(opcua_dir(request))
    with audited(request, who, f"opcua_{action}", thumbprint[:80]) as entry:
        try:
            if action == "remove":
                hits = pki.remove(thumbprint)
                cert, changed = hits[0], True
                detail = f"removed {', '.join(f'{h.folder}/{h.path.name}' for h in hits)}"
            else:
                to = "trusted" if action == "trust" else "rejected"
                before = pki.find(thumbprint)
                cert, name = pki.move(thumbprint, to)
                changed = not (len(before) == 1 and before[0].folder == to)
                cert.folder, cert.path = to, cert.path.parent.parent / to / name
                detail = f"{'moved to' if changed else 'already in'} {to}/{name}"
        except PkiError as e:
            raise HTTPException(e.status, str(e)) from e
        described = cert.describe()
        entry.update(target=cert.sha256, subject=described["subject"], file=cert.path.name, folder=cert.folder)
    request.app.state.events.add("opcua_trust", f"OPC UA client certificate {described['subject']}: {detail}")
    return OpcuaTrustChange(action=action, certificate=OpcuaCertificate(**described), changed=changed, detail=detail)


@router.post("/opcua/certificates/{thumbprint}/trust", responses=REFUSED)
def trust(thumbprint: str, request: Request, who: AdminDep) -> OpcuaTrustChange:
    """Moves a client application's certificate to pki/trusted: its next session is let in (no
    restart).  Its SHA-1 or SHA-256 thumbprint, as GET /opcua lists them."""
    return _change(request, who, "trust", thumbprint)


@router.post("/opcua/certificates/{thumbprint}/reject", responses=REFUSED)
def reject(thumbprint: str, request: Request, who: AdminDep) -> OpcuaTrustChange:
    """Moves a certificate to pki/rejected: new sessions of that application are refused
    (BadCertificateUntrusted); those open go on until they close."""
    return _change(request, who, "reject", thumbprint)


@router.delete("/opcua/certificates/{thumbprint}", responses=REFUSED)
def remove(thumbprint: str, request: Request, who: AdminDep) -> OpcuaTrustChange:
    """Deletes the certificate from the trust list (both folders).  The application is refused from
    then on, and its certificate lands in pki/rejected again at its next try."""
    return _change(request, who, "remove", thumbprint)

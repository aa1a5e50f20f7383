"""opcua_alarms.py -- the OPC UA server acknowledging and confirming alarms for its sessions' users
(docs/opcua.md "Alarms"): only the server's credential (<data>/opcua-token, opcua/link.py) is let
in, never a user's token or session; the user it acts for is checked here against the agent's users
and roles (operator or more), and each change, done or refused, is audited as the user via opcua.
GET /opcua/alarms gives the server the alarms' states (AckedState, ConfirmedState of its events)."""

from __future__ import annotations

import hmac

from fastapi import APIRouter, Depends, HTTPException, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from ...access.auth import Identity, allows
from ..deps import AuthFailure, http_failure
from ..models import AlarmList, AlarmPublic
from ..opcua_models import OpcuaAlarmAction
from .alarms import AlarmsDep, answered

router = APIRouter(tags=["opcua"])
_bearer = HTTPBearer(auto_error=False)


def opcua_server(request: Request, credentials: HTTPAuthorizationCredentials | None = Depends(_bearer)) -> None:
    """Lets in the OPC UA server's own token only (401 otherwise).  A wrong token does not count
    toward the address's lockout: the token is 256 random bits (nothing to guess), and a server
    pointed at another agent would otherwise lock the appliance's own loopback address out."""
    sent = credentials.credentials.encode() if credentials else b""
    if not hmac.compare_digest(sent, request.app.state.opcua_token.encode()):
        raise http_failure(AuthFailure(401, "only the OPC UA server's token (<data>/opcua-token) is let in here"))


def acting(request: Request, body: OpcuaAlarmAction) -> Identity:
    """Who the server acts for: a password user as the agent knows them now (a user disabled or
    given another role since the session signed in counts), the others with the server's role."""
    role = body.role
    if body.method == "password":
        user = request.app.state.users.get(body.user)
        role = user.role if user is not None and not user.disabled else "none"
    return Identity(body.session, body.user, role, body.user if body.method == "password" else None, "opcua")


def change(request: Request, key: str, body: OpcuaAlarmAction, action: str, do) -> dict:
    who = acting(request, body)
    with answered(request, who, action, key, opcua_client=body.client, comment=body.comment):
        if not allows(who.role, "operator"):
            why = "is unknown or disabled" if who.role == "none" else f"has the {who.role} role"
            raise HTTPException(403, f"{action} needs the operator role; {body.user} {why}")
        return do(key, who.as_dict(), body.comment)


@router.get("/opcua/alarms", dependencies=[Depends(opcua_server)])
def opcua_alarms(manager: AlarmsDep) -> AlarmList:
    """GET /alarms for the OPC UA server."""
    return manager.snapshot()


@router.post("/opcua/alarms/{key:path}/ack", dependencies=[Depends(opcua_server)])
def opcua_acknowledge(key: str, body: OpcuaAlarmAction, request: Request, manager: AlarmsDep) -> AlarmPublic:
    """An OPC UA Acknowledge: as POST /alarms/{key}/ack by the session's user (404, 409 the same; 403
    below operator)."""
    return change(request, key, body, "alarm_ack", manager.acknowledge)


@router.post("/opcua/alarms/{key:path}/confirm", dependencies=[Depends(opcua_server)])
def opcua_confirm(key: str, body: OpcuaAlarmAction, request: Request, manager: AlarmsDep) -> AlarmPublic:
    """An OPC UA Confirm: as POST /alarms/{key}/confirm by the session's user."""
    return change(request, key, body, "alarm_confirm", manager.confirm)

"""deps.py -- what the routes depend on, as named types: the irpd client and the caller's role."""
from __future__ import annotations

from typing import Annotated

from fastapi import Depends, HTTPException, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from ..auth import allows
from ..irpd_client import IrpdClient, IrpdRefused, IrpdUnavailable

_bearer = HTTPBearer(auto_error=False)


def irpd(request: Request) -> IrpdClient:
    return request.app.state.irpd


IrpdDep = Annotated[IrpdClient, Depends(irpd)]


def require(role: str):
    """A dependency that lets through a token of `role` or above (401 without one, 403 below it)."""

    def check(request: Request, credentials: HTTPAuthorizationCredentials | None = Depends(_bearer)) -> str:
        if credentials is None:
            raise HTTPException(401, "a bearer token is required (Authorization: Bearer <token>)",
                                headers={"WWW-Authenticate": "Bearer"})
        have = request.app.state.tokens.role_of(credentials.credentials)
        if have is None:
            raise HTTPException(401, "unknown token", headers={"WWW-Authenticate": "Bearer"})
        if not allows(have, role):
            raise HTTPException(403, f"this needs the {role} role; the token has {have}")
        return have

    return check


ViewerDep = Annotated[str, Depends(require("viewer"))]
OperatorDep = Annotated[str, Depends(require("operator"))]
AdminDep = Annotated[str, Depends(require("admin"))]


def ask(client: IrpdClient, cmd: str, **arguments):
    """A control-socket request, with irpd's failures as HTTP errors (503 unreachable, 409 refused)."""
    try:
        return client.request(cmd, **arguments)
    except IrpdUnavailable as e:
        raise HTTPException(503, str(e)) from e
    except IrpdRefused as e:
        raise HTTPException(409, str(e)) from e

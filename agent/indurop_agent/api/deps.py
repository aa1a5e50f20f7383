"""deps.py -- what the routes depend on, as named types: the irpd clients, the caller's identity
(role checked, brute-force lockout applied), and `audited`, which writes a mutation's audit line."""

from __future__ import annotations

from contextlib import contextmanager
from typing import Annotated

from fastapi import Depends, HTTPException, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from starlette.exceptions import HTTPException as AnyHTTPException  # FastAPI's and Starlette's (security.py's)

from .. import protocol
from ..auth import Identity, allows
from ..irpd_client import IrpdClient, IrpdRefused, IrpdUnavailable

_bearer = HTTPBearer(auto_error=False)


def irpd(request: Request) -> IrpdClient:
    return request.app.state.irpd


def swap_irpd(request: Request) -> IrpdClient:
    """The connection for commands that swap irpd's schedule (load, set_period, ...: seconds), so
    that reads on the other connection do not wait behind them."""
    return request.app.state.irpd_swap


IrpdDep = Annotated[IrpdClient, Depends(irpd)]
SwapIrpdDep = Annotated[IrpdClient, Depends(swap_irpd)]


def client_address(request: Request) -> str:
    return request.client.host if request.client else "unknown"


class AuthFailure(Exception):
    """A token refused: status 401 (unknown), 403 (role too low) or 429 (address locked out)."""

    def __init__(self, status: int, message: str, retry_after: int = 0):
        super().__init__(message)
        self.status, self.message, self.retry_after = status, message, retry_after


def check_token(state, address: str, token: str, role: str) -> Identity:
    """The identity of `token` if it has `role` or above; counts unknown tokens per client address
    and locks the address out after too many (HTTP routes and the WebSocket stream alike)."""
    wait = state.lockout.retry_after(address)
    if wait:
        raise AuthFailure(429, f"too many unknown tokens from {address}; try again in {wait} s", wait)
    who = state.tokens.identify(token)
    if who is None:
        if state.lockout.failed(address):
            window = int(state.lockout.window_s)
            state.audit.write(
                "lockout",
                who=None,
                client=address,
                target=address,
                result="ok",
                detail=f"{state.lockout.attempts} unknown tokens within {window} s",
            )
            state.events.add(
                "lockout", f"client {address} locked out for {window} s after {state.lockout.attempts} unknown tokens"
            )
            raise AuthFailure(429, f"too many unknown tokens from {address}; try again in {window} s", window)
        raise AuthFailure(401, "unknown token")
    if not allows(who.role, role):
        raise AuthFailure(403, f"this needs the {role} role; the token has {who.role}")
    return who


def require(role: str):
    """A dependency that lets through a token of `role` or above (401 without one or with an
    unknown one, 403 below the role, 429 while the client's address is locked out)."""

    def check(request: Request, credentials: HTTPAuthorizationCredentials | None = Depends(_bearer)) -> Identity:
        if credentials is None:
            wait = request.app.state.lockout.retry_after(client_address(request))
            if wait:
                raise HTTPException(
                    429,
                    f"too many unknown tokens from {client_address(request)}; try again in {wait} s",
                    headers={"Retry-After": str(wait)},
                )
            raise HTTPException(
                401,
                "a bearer token is required (Authorization: Bearer <token>)",
                headers={"WWW-Authenticate": "Bearer"},
            )
        try:
            return check_token(request.app.state, client_address(request), credentials.credentials, role)
        except AuthFailure as e:
            headers = (
                {"Retry-After": str(e.retry_after)}
                if e.retry_after
                else ({"WWW-Authenticate": "Bearer"} if e.status == 401 else None)
            )
            raise HTTPException(e.status, e.message, headers=headers) from e

    return check


ViewerDep = Annotated[Identity, Depends(require("viewer"))]
OperatorDep = Annotated[Identity, Depends(require("operator"))]
AdminDep = Annotated[Identity, Depends(require("admin"))]


def ask(client: IrpdClient, cmd: str, *, timeout: float | None = None, **arguments):
    """A control-socket request, with irpd's failures as HTTP errors (503 unreachable, 404 a module
    or record irpd does not have, 409 refused)."""
    try:
        return client.request(cmd, timeout=timeout, **arguments)
    except IrpdUnavailable as e:
        raise HTTPException(503, str(e)) from e
    except IrpdRefused as e:
        raise HTTPException(404 if e.code == protocol.NOT_FOUND else 409, str(e)) from e


@contextmanager
def audited(request: Request, who: Identity, action: str, target: str | None = None, **details):
    """Writes one audit line for the mutation in the `with` block: result ok, or error with the
    HTTP status and detail of the exception that left it.  The block may add details (JSON data)
    to the yielded dict, and set its "target"."""
    entry = {"target": target, **details}
    log = request.app.state.audit
    common = {"who": who.as_dict(), "client": client_address(request)}
    try:
        yield entry
    except AnyHTTPException as e:
        log.write(action, **common, **entry, result="error", status=e.status_code, detail=e.detail)
        raise
    except Exception as e:
        log.write(action, **common, **entry, result="error", status=500, detail=f"{type(e).__name__}: {e}")
        raise
    else:
        log.write(action, **common, **entry, result="ok")

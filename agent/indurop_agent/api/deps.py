"""deps.py -- what the routes depend on, as named types: the irpd clients, the caller's identity
(a bearer token, or a browser session's cookie with its CSRF token on changes; role checked,
brute-force lockout applied), and `audited`, which writes a mutation's audit line."""

from __future__ import annotations

import hmac
from contextlib import contextmanager
from dataclasses import replace
from typing import Annotated

from fastapi import Depends, HTTPException, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from starlette.exceptions import HTTPException as AnyHTTPException  # FastAPI's and Starlette's (security.py's)

from ..access.auth import Identity, allows, lesser_role
from ..access.sessions import BACKGROUND_HEADER, COOKIE, CSRF_HEADER, Session
from ..irpd import protocol
from ..irpd.client import IrpdClient, IrpdRefused, IrpdUnavailable

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
    """A credential refused: status 401 (unknown token, ended session), 403 (role too low, no CSRF
    token: kind "csrf") or 429 (address locked out); `who`: the caller when known (a role too low)."""

    def __init__(self, status: int, message: str, retry_after: int = 0, who: Identity | None = None, kind=None):
        super().__init__(message)
        self.status, self.message, self.retry_after = status, message, retry_after
        self.who, self.kind = who, kind


def remember(request: Request, e: AuthFailure) -> None:
    """Keeps who was refused and why for the refusal's audit line (audit_refusal)."""
    request.state.refused_who, request.state.refusal_kind = e.who, e.kind


def audit_refusal(request: Request, status: int, detail, kind: str | None = None) -> None:
    """The audit line of a refused request (refusals.py: rate-limited per kind): a 401, a 403 (a
    role too low, or kind "csrf"), a 422 (kind "invalid").  Who: the caller refused, or the one
    whose credentials passed before the route refused; None when not known."""
    state = request.state
    kind = kind or getattr(state, "refusal_kind", None) or ("unauthenticated" if status == 401 else "forbidden")
    who = getattr(state, "refused_who", None) or getattr(state, "identity", None)
    request.app.state.refusals.write(
        kind,
        who=who.as_dict() if who is not None else None,
        client=client_address(request),
        route=f"{request.method} {request.url.path}",
        status=status,
        detail=detail,
    )


SAFE_METHODS = ("GET", "HEAD", "OPTIONS")
NEED_CREDENTIALS = (
    "a bearer token is required (Authorization: Bearer <token>), or a browser session: sign in with "
    "POST /api/v1/session"
)


def locked_out_message(address: str, wait: int) -> str:
    return f"too many unknown tokens or wrong passwords from {address}; try again in {wait} s"


def note_lockout(state, target: str, client: str, what: str, window: int, why: str) -> None:
    """Audits a lockout that just began (of an address or a user name: `what` says which, e.g.
    "client 10.0.0.7") and adds it to the events.  `target` may be a name a client sent: it is
    stored as JSON data, and `what` must show it quoted (repr)."""
    state.audit.write("lockout", who=None, client=client, target=target, result="ok", detail=f"{why} within {window} s")
    state.events.add("lockout", f"{what} locked out for {window} s after {why}")


def lockout_failed(state, lockout, key: str, address: str, what: str, failures: str) -> int:
    """Counts one failure of `key` (an address, a user name) in `lockout`; when that locks it out
    now, audits it and adds the event (note_lockout) and returns the seconds (else 0)."""
    if not lockout.failed(key):
        return 0
    window = int(lockout.window_s)
    note_lockout(state, key, address, what, window, f"{lockout.attempts} {failures}")
    return window


def address_failed(state, address: str) -> int:
    """Counts a failed credential (an unknown token, a wrong password) from `address`; the seconds
    it is now locked out for (0: not)."""
    return lockout_failed(
        state, state.lockout, address, address, f"client {address}", "unknown tokens or wrong passwords"
    )


def name_failed(state, name: str, address: str) -> int:
    """Counts a wrong password for the user name `name` (a sign-in, or a wrong current_password
    through a session left open); the seconds it is now locked for (0: not)."""
    return lockout_failed(state, state.name_lockout, name, address, f"user name {name!r}", "wrong passwords")


def name_locked(wait: int) -> HTTPException:
    """The 429 of a locked user name, with Retry-After."""
    return HTTPException(
        429, f"this user name is locked for {wait} s after wrong passwords", headers={"Retry-After": str(wait)}
    )


def with_owner(state, who: Identity) -> Identity | None:
    """A token's identity as its owner allows: its role capped by the owner's; None when the owner
    is disabled or gone (their tokens are revoked then; this also covers a hand-edited file)."""
    if who.user is None:
        return who
    owner = state.users.get(who.user)
    if owner is None or owner.disabled:
        return None
    return replace(who, role=lesser_role(who.role, owner.role))


def check_token(state, address: str, token: str, role: str) -> Identity:
    """The identity of `token` if it has `role` or above; counts unknown tokens per client address
    and locks the address out after too many (HTTP routes and the WebSocket stream alike)."""
    wait = state.lockout.retry_after(address)
    if wait:
        raise AuthFailure(429, locked_out_message(address, wait), wait)
    who = state.tokens.identify(token)
    if who is None:
        window = address_failed(state, address)
        if window:
            raise AuthFailure(429, locked_out_message(address, window), window)
        raise AuthFailure(401, "unknown token")
    who = with_owner(state, who)
    if who is None:
        raise AuthFailure(401, "the token's user is disabled")
    if not allows(who.role, role):
        raise AuthFailure(403, f"this needs the {role} role; the token has {who.role}", who=who)
    return who


def session_ended(state) -> str:
    idle, lifetime = state.sessions.idle_s, state.sessions.lifetime_s
    return (
        f"the session has ended (signed out, no request for {idle / 60:g} min, or older than "
        f"{lifetime / 3600:g} h); sign in again"
    )


def session_identity(state, s: Session) -> Identity | None:
    """Who a live session is (its user's current role), or None when the user is disabled or gone."""
    user = state.users.get(s.user)
    if user is None or user.disabled:
        return None
    return Identity(s.handle, user.name, user.role, user.name, "session")


def check_session(state, session_id: str, method: str, headers, role: str, touch: bool = True) -> Identity:
    """The identity of a session cookie if its user has `role` or above.  A change (any method but
    GET, HEAD, OPTIONS) must carry the session's CSRF token in the X-CSRF-Token header: another site
    can make the browser send the cookie, never read the token.  A request counts as the user's
    (the idle timeout starts again) unless the UI marked it as its own (X-Indurop-Background)."""
    s = state.sessions.find(session_id)
    who = session_identity(state, s) if s is not None else None
    if who is None:
        if s is not None:
            state.sessions.end(session_id)
        raise AuthFailure(401, session_ended(state))
    if method not in SAFE_METHODS:
        sent = headers.get(CSRF_HEADER)
        if sent is None or not hmac.compare_digest(sent.encode(), s.csrf.encode()):
            raise AuthFailure(
                403,
                f"a change made with the session cookie needs the session's CSRF token in the {CSRF_HEADER} header "
                "(POST /api/v1/session and GET /api/v1/session give it)",
                who=who,
                kind="csrf",
            )
    if not allows(who.role, role):
        raise AuthFailure(403, f"this needs the {role} role; the user has {who.role}", who=who)
    if touch and headers.get(BACKGROUND_HEADER) is None:
        state.sessions.touch(s)
    return who


def identity_by_id(state, identity_id: str) -> Identity | None:
    """The token or live session an id names (a viewer ticket's), as it may act now; None when it
    was revoked, has ended, or its user is disabled."""
    who = state.tokens.by_id(identity_id)
    if who is not None:
        return with_owner(state, who)
    s = state.sessions.by_handle(identity_id)
    return session_identity(state, s) if s is not None else None


def http_failure(e: AuthFailure, clear_cookie: bool = False) -> HTTPException:
    headers = {}
    if e.retry_after:
        headers["Retry-After"] = str(e.retry_after)
    elif e.status == 401:
        headers["WWW-Authenticate"] = "Bearer"
    if clear_cookie:
        headers["Set-Cookie"] = f"{COOKIE}=; Max-Age=0; Path=/; HttpOnly; SameSite=Strict"
    return HTTPException(e.status, e.message, headers=headers or None)


def require(role: str):
    """A dependency that lets through a token, or a session, of `role` or above (401 without one or
    with an unknown or ended one, 403 below the role or a change without the CSRF token, 429 while
    the client's address is locked out).  A bearer token comes first: a script's request is never
    taken for the browser's."""

    def check(request: Request, credentials: HTTPAuthorizationCredentials | None = Depends(_bearer)) -> Identity:
        state = request.app.state
        if credentials is not None:
            try:
                request.state.identity = check_token(state, client_address(request), credentials.credentials, role)
                return request.state.identity
            except AuthFailure as e:
                remember(request, e)
                raise http_failure(e) from e
        session_id = request.cookies.get(COOKIE)
        if session_id:
            try:
                request.state.identity = check_session(state, session_id, request.method, request.headers, role)
                return request.state.identity
            except AuthFailure as e:
                remember(request, e)
                raise http_failure(e, clear_cookie=e.status == 401) from e
        wait = state.lockout.retry_after(client_address(request))
        if wait:
            raise HTTPException(
                429, locked_out_message(client_address(request), wait), headers={"Retry-After": str(wait)}
            )
        raise HTTPException(401, NEED_CREDENTIALS, headers={"WWW-Authenticate": "Bearer"})

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
        request.state.audited = True  # this line is the refusal's (no second one: audit_refusal)
        raise
    except Exception as e:
        log.write(action, **common, **entry, result="error", status=500, detail=f"{type(e).__name__}: {e}")
        raise
    else:
        log.write(action, **common, **entry, result="ok")

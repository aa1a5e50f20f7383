"""session.py -- the browser's sign-in: POST /session with a name and a password gives a session
cookie (HttpOnly, SameSite=Strict, Secure under HTTPS) and its CSRF token; GET /session says who is
signed in (or that no user exists yet: the first-run page); DELETE /session signs out.

Guessing is slowed three ways: wrong passwords lock the user name out for a while (name_lockout),
failed sign-ins count with unknown tokens against the client's address (lockout), and at most
`password_hash_slots` password checks run at once (each costs argon2's memory and time), a flood
beyond them waiting at most HASH_WAIT_S and then getting 503.  Docs: docs/administration.md.
"""

from __future__ import annotations

from datetime import UTC, datetime

from fastapi import APIRouter, HTTPException, Request, Response

from ...access.sessions import COOKIE, Session
from ..deps import (
    AuthFailure,
    address_failed,
    check_session,
    client_address,
    http_failure,
    locked_out_message,
    name_failed,
    name_locked,
    remember,
    session_identity,
)
from ..models import SessionState, SignIn

router = APIRouter(tags=["session"])

HASH_WAIT_S = 5.0
WRONG = "wrong user name or password (or the user is disabled)"


def iso(t: float) -> str:
    return datetime.fromtimestamp(t, UTC).isoformat(timespec="seconds").replace("+00:00", "Z")


def secure(request: Request) -> bool:
    """The cookie is Secure when the browser reached the agent over HTTPS (its own TLS, or a proxy
    the agent believes)."""
    return request.url.scheme == "https" or request.app.state.settings.tls_cert is not None


def state_of(request: Request, s: Session | None) -> SessionState:
    state = request.app.state
    idle = state.sessions.idle_s
    who = session_identity(state, s) if s is not None else None
    if who is None:
        return SessionState(signed_in=False, first_run=not state.users.any(), idle_timeout_s=idle)
    return SessionState(
        signed_in=True,
        first_run=False,
        name=who.name,
        role=who.role,
        csrf_token=s.csrf,
        idle_timeout_s=idle,
        expires=iso(state.sessions.absolute_deadline(s)),
    )


def clear_cookie(response: Response, request: Request) -> None:
    response.delete_cookie(COOKIE, path="/", secure=secure(request), httponly=True, samesite="strict")


def hash_slot(request: Request):
    """A password check may begin (a slot taken: release it), or 503."""
    slots = request.app.state.hash_slots
    if not slots.acquire(timeout=HASH_WAIT_S):
        raise HTTPException(503, "too many sign-ins at once; try again in a second", headers={"Retry-After": "1"})
    return slots


def refused_sign_in(request: Request, name: str) -> HTTPException:
    """A wrong name or password: counted against the name and the address, audited (the name as
    JSON data, however hostile), and answered 401, or 429 when it just locked either out."""
    state = request.app.state
    address = client_address(request)
    state.audit.write("sign_in", who=None, client=address, target=name, result="error", status=401, detail=WRONG)
    request.state.audited = True  # this line is the refusal's
    window = max(address_failed(state, address), name_failed(state, name, address))
    if window:
        return HTTPException(
            429, f"too many wrong passwords; try again in {window} s", headers={"Retry-After": str(window)}
        )
    return HTTPException(401, WRONG)


@router.post(
    "/session",
    responses={
        401: {"description": "wrong name or password, or a disabled user"},
        429: {"description": "the name or the client's address is locked out for a while (Retry-After)"},
        503: {"description": "too many password checks at once"},
    },
)
def sign_in(body: SignIn, request: Request, response: Response) -> SessionState:
    """Signs in with a name and a password: a new session (never the one the browser had: its
    cookie, if any, is ended), the cookie, and the CSRF token to send with every change."""
    state = request.app.state
    address = client_address(request)
    wait = state.lockout.retry_after(address)
    if wait:
        raise HTTPException(429, locked_out_message(address, wait), headers={"Retry-After": str(wait)})
    wait = state.name_lockout.retry_after(body.name)
    if wait:  # even the right password: a guess that happens to be right must not get through
        raise name_locked(wait)
    slots = hash_slot(request)
    try:
        user = state.users.verify(body.name, body.password)
    finally:
        slots.release()
    if user is None:
        raise refused_sign_in(request, body.name)
    state.name_lockout.forget(body.name)
    session_id, s = state.sessions.create(user.name, address, replacing=request.cookies.get(COOKIE))
    who = session_identity(state, s)
    state.audit.write("sign_in", who=who.as_dict(), client=address, target=user.name, result="ok")
    response.set_cookie(  # no Max-Age: the browser forgets it when it closes; the agent ends it anyway
        COOKIE,
        session_id,
        path="/",
        secure=secure(request),
        httponly=True,
        samesite="strict",
    )
    return state_of(request, s)


@router.get("/session")
def get_session(request: Request, response: Response) -> SessionState:
    """Who the browser is signed in as, with the CSRF token; or signed_in false (and first_run when
    no user exists yet).  Needs no credentials."""
    state = request.app.state
    session_id = request.cookies.get(COOKIE)
    if not session_id:
        return state_of(request, None)
    try:
        check_session(state, session_id, "GET", request.headers, "viewer")
    except AuthFailure:
        clear_cookie(response, request)
        return state_of(request, None)
    return state_of(request, state.sessions.find(session_id))


@router.delete("/session", status_code=204, response_model=None, responses={403: {"description": "no CSRF token"}})
def sign_out(request: Request, response: Response) -> None:
    """Signs out: the session ends on the server (its cookie is refused from now on) and the
    browser is told to forget the cookie.  Without a live session there is nothing to end."""
    state = request.app.state
    session_id = request.cookies.get(COOKIE)
    clear_cookie(response, request)
    if not session_id:
        return
    try:
        who = check_session(state, session_id, "DELETE", request.headers, "viewer", touch=False)
    except AuthFailure as e:
        if e.status == 401:
            return  # already ended
        remember(request, e)
        raise http_failure(e) from e
    state.sessions.end(session_id)
    state.audit.write("sign_out", who=who.as_dict(), client=client_address(request), target=who.name, result="ok")

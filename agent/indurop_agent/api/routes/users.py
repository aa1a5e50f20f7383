"""users.py -- the people who sign in (admin): list them, add one, change a role, disable (which
revokes their tokens and ends their sessions) or enable one, reset a password; and every user's
own: their record, their tokens, a change of their own password.  Every change is audited with
who made it.  Docs: docs/administration.md."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, HTTPException, Path, Request

from ...access.auth import allows
from ...access.users import User, UserError
from ..deps import AdminDep, ViewerDep, audited, client_address, name_failed, name_locked
from ..models import PasswordChange, UserCreate, UserPublic, UserUpdate
from .session import hash_slot
from .tokens import TokenInfo

router = APIRouter(tags=["users"])

NameParam = Annotated[str, Path(max_length=256, description="the user name")]
MISSING = {404: {"description": "no such user"}}


def public(state, user: User) -> UserPublic:
    return UserPublic(
        **user.public(), tokens=len(state.tokens.list(owner=user.name)), sessions=state.sessions.count(user.name)
    )


def refused(e: UserError) -> HTTPException:
    """A store's refusal as an answer: 422 names the field, as FastAPI's own validation does."""
    if e.status == 422:
        return HTTPException(422, [{"loc": ["body", e.field], "msg": e.message, "type": "value_error"}])
    return HTTPException(e.status, e.message)


def need_user(state, name: str) -> User:
    user = state.users.get(name)
    if user is None:
        raise HTTPException(404, f"no user {name!r}; GET /api/v1/users lists them")
    return user


def self_or_admin(who, name: str) -> None:
    if who.user != name and not allows(who.role, "admin"):
        raise HTTPException(403, f"this needs the admin role, or to be signed in as {name!r}; you are {who.name}")


def actor(who) -> str:
    return who.user or who.name


@router.get("/users")
def list_users(request: Request, _: AdminDep) -> list[UserPublic]:
    state = request.app.state
    return [public(state, u) for u in state.users.list()]


@router.post("/users", status_code=201, responses={409: {"description": "the name is taken"}})
def add_user(body: UserCreate, request: Request, who: AdminDep) -> UserPublic:
    """A new user with a role and a first password (docs/administration.md, "Passwords").  The
    first admin is created this way with the admin token the agent wrote at its first start."""
    state = request.app.state
    with audited(request, who, "user_add", body.name, role=body.role):
        slots = hash_slot(request)
        try:
            user = state.users.add(body.name, body.role, body.password, actor(who))
        except UserError as e:
            raise refused(e) from None
        finally:
            slots.release()
    state.events.add("user_add", f"user {user.name} ({user.role}) added by {actor(who)}")
    return public(state, user)


@router.get("/users/{name}", responses=MISSING)
def get_user(request: Request, who: ViewerDep, name: NameParam) -> UserPublic:
    """A user's record (admin, or the user themself)."""
    self_or_admin(who, name)
    state = request.app.state
    return public(state, need_user(state, name))


@router.patch("/users/{name}", responses={**MISSING, 409: {"description": "the last enabled admin"}})
def change_user(body: UserUpdate, request: Request, who: AdminDep, name: NameParam) -> UserPublic:
    """Changes a user's role, or disables (their tokens are revoked, their sessions end) or enables
    them.  The last enabled admin can be neither demoted nor disabled."""
    state = request.app.state
    details = {k: v for k, v in body.model_dump().items() if v is not None}
    with audited(request, who, "user_change", name, **details) as entry:
        before = need_user(state, name)
        try:
            user = state.users.set_role(name, body.role) if body.role is not None else before
            if body.disabled is not None:
                user = state.users.set_disabled(name, body.disabled)
        except UserError as e:
            raise refused(e) from None
        entry["before"] = {"role": before.role, "disabled": before.disabled}
        if user.disabled:
            entry["tokens_revoked"] = state.tokens.revoke_owned(name)
            entry["sessions_ended"] = state.sessions.end_user(name)
    changes = ", ".join(f"{k} {v}" for k, v in details.items())
    state.events.add("user_change", f"user {name}: {changes}, by {actor(who)}")
    return public(state, user)


@router.put(
    "/users/{name}/password",
    status_code=204,
    response_model=None,
    responses={
        **MISSING,
        422: {"description": "a password the rules refuse, or a wrong current_password"},
        429: {"description": "the name is locked after wrong passwords (Retry-After)"},
    },
)
def change_password(body: PasswordChange, request: Request, who: ViewerDep, name: NameParam) -> None:
    """A user's own new password (with current_password; their other sessions end), or an admin's
    reset of another user's (every session of that user ends)."""
    state = request.app.state
    self_or_admin(who, name)
    own = who.user == name
    with audited(request, who, "user_password", name, how="changed" if own else "reset") as entry:
        need_user(state, name)
        if own and body.current_password is None:
            raise refused(UserError(422, "give the present password to change it", "current_password"))
        if own:
            wait = state.name_lockout.retry_after(name)
            if wait:
                raise name_locked(wait)
        slots = hash_slot(request)
        try:
            state.users.set_password(name, body.password, current=body.current_password if own else None)
        except UserError as e:
            if e.field == "current_password":  # guessing through a session left open counts too
                window = name_failed(state, name, client_address(request))
                if window:
                    raise name_locked(window) from None
            raise refused(e) from None
        finally:
            slots.release()
        entry["sessions_ended"] = state.sessions.end_user(name, keep=who.id if who.via == "session" else None)
    state.events.add("user_password", f"user {name}: password {'changed' if own else 'reset by ' + actor(who)}")


@router.get("/users/{name}/tokens", responses=MISSING)
def user_tokens(request: Request, who: ViewerDep, name: NameParam) -> list[TokenInfo]:
    """The tokens a user owns (admin, or the user themself); never the tokens themselves."""
    self_or_admin(who, name)
    state = request.app.state
    need_user(state, name)
    return [TokenInfo(**t) for t in state.tokens.list(owner=name)]

"""tokens.py -- bearer tokens, for scripts: who am I (any role); create one for a role and a user
(shown once), list them (all, or one user's), revoke one (admin).  A token never has more than its
user's role; a disabled user's tokens are revoked (users.py)."""

from typing import Literal

from fastapi import APIRouter, HTTPException, Query, Request
from pydantic import BaseModel, ConfigDict, Field

from ...access.auth import ROLES, allows
from ..deps import AdminDep, ViewerDep, audited
from ..models import UserName

router = APIRouter(tags=["tokens"])


class TokenCreate(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str = Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.-]+$")
    role: Literal["viewer", "operator", "admin"]
    owner: UserName | None = Field(
        None,
        description="the user it belongs to (default: the caller's user; none for the appliance's admin token); "
        "its role may not be above theirs",
    )


class TokenPublic(BaseModel):
    id: str = Field(description="names the token in the audit log and in DELETE /tokens/{id}")
    name: str
    role: str
    owner: str | None = Field(None, description="the user it belongs to; null: the appliance")
    token: str = Field(description="shown only in this answer; stored hashed")


class Me(BaseModel):
    id: str
    name: str
    role: Literal["viewer", "operator", "admin"]
    user: str | None = Field(None, description="the signed-in user, or the token's owner")
    via: Literal["token", "session"] = "token"


class TokenInfo(BaseModel):
    id: str
    name: str
    role: str
    created: str | None
    owner: str | None = Field(None, description="the user it belongs to; null: the appliance")


@router.get("/auth/me")
def me(who: ViewerDep) -> Me:
    """Who the caller is: the token's (or session's) id, name and role (what a UI shows as editable)."""
    return Me(id=who.id, name=who.name, role=who.role, user=who.user, via=who.via)


@router.post(
    "/tokens",
    status_code=201,
    responses={404: {"description": "no such owner"}, 409: {"description": "the owner is disabled"}},
)
def create_token(body: TokenCreate, request: Request, who: AdminDep) -> TokenPublic:
    state = request.app.state
    owner = body.owner or who.user
    with audited(request, who, "token_create", body.name, role=body.role, owner=owner) as entry:
        if owner is not None:
            user = state.users.get(owner)
            if user is None:
                raise HTTPException(404, f"no user {owner!r}; GET /api/v1/users lists them")
            if user.disabled:
                raise HTTPException(409, f"{owner} is disabled; enable the user first")
            if not allows(user.role, body.role):
                raise HTTPException(
                    422,
                    [
                        {
                            "loc": ["body", "role"],
                            "msg": f"{owner} has the {user.role} role; a token of theirs may have "
                            f"{', '.join(ROLES[: ROLES.index(user.role) + 1])}",
                            "type": "value_error",
                        }
                    ],
                )
        token, identity = state.tokens.add(body.name, body.role, owner)
        entry["token_id"] = identity.id
    state.events.add(
        "token_create",
        f"token {identity.id} ({body.name}, {body.role}, {owner or 'appliance'}) created by {who.user or who.name}",
    )
    return TokenPublic(id=identity.id, name=body.name, role=body.role, owner=owner, token=token)


@router.get("/tokens")
def list_tokens(
    request: Request, _: AdminDep, owner: str | None = Query(None, max_length=256, description="only this user's")
) -> list[TokenInfo]:
    return [TokenInfo(**t) for t in request.app.state.tokens.list(owner=owner)]


@router.delete(
    "/tokens/{token_id}",
    status_code=204,
    responses={404: {"description": "no such token"}, 409: {"description": "the last admin token"}},
)
def revoke_token(token_id: str, request: Request, who: AdminDep) -> None:
    state = request.app.state
    with audited(request, who, "token_revoke", token_id) as entry:
        try:
            gone = state.tokens.revoke(token_id, admin_users=bool(state.users.enabled_admins()))
        except KeyError:
            raise HTTPException(404, f"no token with id {token_id!r}; GET /api/v1/tokens lists them") from None
        except ValueError as e:
            raise HTTPException(409, str(e)) from None
        entry["name"], entry["role"], entry["owner"] = gone.name, gone.role, gone.user
    state.events.add("token_revoke", f"token {gone.id} ({gone.name}, {gone.role}) revoked by {who.user or who.name}")

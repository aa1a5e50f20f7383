"""tokens.py -- bearer tokens: who am I (any role); create one for a role (shown once), list them,
revoke one (admin)."""

from typing import Literal

from fastapi import APIRouter, HTTPException, Request
from pydantic import BaseModel, Field

from ..deps import AdminDep, ViewerDep, audited

router = APIRouter(tags=["tokens"])


class TokenCreate(BaseModel):
    name: str = Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.-]+$")
    role: Literal["viewer", "operator", "admin"]


class TokenPublic(BaseModel):
    id: str = Field(description="names the token in the audit log and in DELETE /tokens/{id}")
    name: str
    role: str
    token: str = Field(description="shown only in this answer; stored hashed")


class Me(BaseModel):
    id: str
    name: str
    role: Literal["viewer", "operator", "admin"]


class TokenInfo(BaseModel):
    id: str
    name: str
    role: str
    created: str | None


@router.get("/auth/me")
def me(who: ViewerDep) -> Me:
    """Who the token is: its id, name and role (what a UI shows as editable)."""
    return Me(id=who.id, name=who.name, role=who.role)


@router.post("/tokens", status_code=201)
def create_token(body: TokenCreate, request: Request, who: AdminDep) -> TokenPublic:
    with audited(request, who, "token_create", body.name, role=body.role) as entry:
        token, identity = request.app.state.tokens.add(body.name, body.role)
        entry["token_id"] = identity.id
    request.app.state.events.add(
        "token_create", f"token {identity.id} ({body.name}, {body.role}) created by {who.name}"
    )
    return TokenPublic(id=identity.id, name=body.name, role=body.role, token=token)


@router.get("/tokens")
def list_tokens(request: Request, _: AdminDep) -> list[TokenInfo]:
    return [TokenInfo(**t) for t in request.app.state.tokens.list()]


@router.delete(
    "/tokens/{token_id}",
    status_code=204,
    responses={404: {"description": "no such token"}, 409: {"description": "the last admin token"}},
)
def revoke_token(token_id: str, request: Request, who: AdminDep) -> None:
    with audited(request, who, "token_revoke", token_id) as entry:
        try:
            gone = request.app.state.tokens.revoke(token_id)
        except KeyError:
            raise HTTPException(404, f"no token with id {token_id!r}; GET /api/v1/tokens lists them") from None
        except ValueError as e:
            raise HTTPException(409, str(e)) from None
        entry["name"], entry["role"] = gone.name, gone.role
    request.app.state.events.add("token_revoke", f"token {gone.id} ({gone.name}, {gone.role}) revoked by {who.name}")

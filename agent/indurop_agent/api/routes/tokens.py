"""tokens.py -- POST /api/v1/tokens (admin): a new bearer token for a role, shown once."""
from typing import Literal

from fastapi import APIRouter, Request
from pydantic import BaseModel, Field

from ..deps import AdminDep

router = APIRouter(tags=["tokens"])


class TokenCreate(BaseModel):
    name: str = Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.-]+$")
    role: Literal["viewer", "operator", "admin"]


class TokenPublic(BaseModel):
    name: str
    role: str
    token: str = Field(description="shown only in this answer; stored hashed")


@router.post("/tokens", status_code=201)
def create_token(body: TokenCreate, request: Request, _: AdminDep) -> TokenPublic:
    token = request.app.state.tokens.add(body.name, body.role)
    return TokenPublic(name=body.name, role=body.role, token=token)

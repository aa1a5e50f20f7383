"""auth.py -- bearer tokens, their identities and roles.

Tokens are stored hashed (sha256) in <data-dir>/tokens.json; the first start creates an admin
token, writes it to <data-dir>/admin-token (mode 0600) and says where it is.  There are no
default credentials: that token lets the first admin user be created (users.py).  Roles, each
including the one before: viewer < operator < admin.  A token's id is the first 12 hex digits of
its hash: it names the token in the audit log and in DELETE /tokens/{id} without revealing it.

A token belongs to a user (its "owner"), who can never give it more than their own role, and whose
tokens are revoked when the user is disabled.  Tokens without an owner belong to the appliance: the
first start's admin token, and tokens made before there were users or with that token.
"""

from __future__ import annotations

import hashlib
import json
import os
import secrets
import threading
from dataclasses import asdict, dataclass
from datetime import UTC, datetime
from pathlib import Path

from ..files import write_json

ROLES = ("viewer", "operator", "admin")
ID_LENGTH = 12
TOKEN_PREFIX = "irp_"


def _hash(token: str) -> str:
    return hashlib.sha256(token.encode()).hexdigest()


def now_iso() -> str:
    """The current UTC time as ISO 8601 with microseconds, e.g. 2025-01-31T12:00:00.123456Z."""
    return datetime.now(UTC).isoformat(timespec="microseconds").replace("+00:00", "Z")


@dataclass(frozen=True)
class Identity:
    """Who made a request.  id: the token's id, or the session's handle; name: the token's name, or
    the signed-in user's; role: what the request may do; user: the person behind it (a session's
    user, a token's owner; None for a token of the appliance); via: "token" or "session"."""

    id: str
    name: str
    role: str
    user: str | None = None
    via: str = "token"

    def as_dict(self) -> dict:
        return asdict(self)


class TokenStore:
    def __init__(self, data_dir: Path):
        self.path = data_dir / "tokens.json"
        self.admin_token_path = data_dir / "admin-token"
        self._lock = threading.Lock()
        self._tokens: dict[str, dict] = {}
        if self.path.exists():
            self._tokens = json.loads(self.path.read_text())

    def ensure_admin(self) -> Path | None:
        """Creates the first admin token if there is no token at all; returns where it was written."""
        with self._lock:
            if self._tokens:
                return None
            token = self._add_locked("admin", "admin")
        fd = os.open(self.admin_token_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "w") as f:
            f.write(token + "\n")
        return self.admin_token_path

    def add(self, name: str, role: str, owner: str | None = None) -> tuple[str, Identity]:
        """A new token for `role`, belonging to `owner` (a user name, or None: the appliance):
        (the token, shown once; its identity)."""
        if role not in ROLES:
            raise ValueError(f"role must be one of {', '.join(ROLES)}")
        with self._lock:
            token = self._add_locked(name, role, owner)
        return token, self.identify(token)

    @staticmethod
    def _mint() -> str:
        """A new secret. The prefix names what it is (for secret scanners and for people) and
        keeps it from starting with "-", which a command line would read as an option."""
        return TOKEN_PREFIX + secrets.token_urlsafe(32)

    def _add_locked(self, name: str, role: str, owner: str | None = None) -> str:
        token = self._mint()
        entry = {"name": name, "role": role, "created": now_iso()}
        if owner is not None:
            entry["owner"] = owner
        self._tokens[_hash(token)] = entry
        self._save()
        return token

    @staticmethod
    def _identity(digest: str, entry: dict) -> Identity:
        return Identity(digest[:ID_LENGTH], entry["name"], entry["role"], entry.get("owner"))

    def identify(self, token: str) -> Identity | None:
        """The identity of a token (its own role: deps.py caps it by its owner's), or None for an
        unknown one."""
        digest = _hash(token)
        entry = self._tokens.get(digest)
        return self._identity(digest, entry) if entry else None

    def by_id(self, token_id: str) -> Identity | None:
        """The identity of the token with this id (viewer tickets), or None."""
        return next((self._identity(d, e) for d, e in self._tokens.items() if d[:ID_LENGTH] == token_id), None)

    def role_of(self, token: str) -> str | None:
        who = self.identify(token)
        return who.role if who else None

    def list(self, owner: str | None = None) -> list[dict]:
        """Every token (or `owner`'s) as {id, name, role, created, owner}; never the token or its hash."""
        return [
            {
                "id": digest[:ID_LENGTH],
                "name": e["name"],
                "role": e["role"],
                "created": e.get("created"),
                "owner": e.get("owner"),
            }
            for digest, e in self._tokens.items()
            if owner is None or e.get("owner") == owner
        ]

    def revoke(self, token_id: str, admin_users: bool = False) -> Identity:
        """Removes the token with this id; KeyError if there is none, ValueError for the last admin
        token while no enabled admin user exists (`admin_users`): someone must be able to administer."""
        with self._lock:
            digest = next((d for d in self._tokens if d[:ID_LENGTH] == token_id), None)
            if digest is None:
                raise KeyError(token_id)
            entry = self._tokens[digest]
            admins = [d for d, e in self._tokens.items() if e["role"] == "admin"]
            if entry["role"] == "admin" and admins == [digest] and not admin_users:
                raise ValueError(
                    "this is the last admin token and there is no enabled admin user; create an admin user "
                    "(POST /api/v1/users) or another admin token before revoking it"
                )
            del self._tokens[digest]
            self._save()
        return self._identity(digest, entry)

    def revoke_owned(self, owner: str) -> list[str]:
        """Removes every token of `owner` (a user disabled); their ids."""
        with self._lock:
            gone = [d for d, e in self._tokens.items() if e.get("owner") == owner]
            for d in gone:
                del self._tokens[d]
            if gone:
                self._save()
        return [d[:ID_LENGTH] for d in gone]

    def _save(self) -> None:
        write_json(self.path, self._tokens)


def allows(role: str, needed: str) -> bool:
    return ROLES.index(role) >= ROLES.index(needed)


def lesser_role(a: str, b: str) -> str:
    """The lower of two roles (a token's own, and its owner's)."""
    return min(a, b, key=ROLES.index)

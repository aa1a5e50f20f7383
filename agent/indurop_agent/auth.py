"""auth.py -- bearer tokens and roles.

Tokens are stored hashed (sha256) in <data-dir>/tokens.json; the first start creates an admin
token, writes it to <data-dir>/admin-token (mode 0600) and says where it is.  There are no
default credentials.  Roles, each including the one before: viewer < operator < admin.
"""
from __future__ import annotations

import hashlib
import json
import os
import secrets
from pathlib import Path

ROLES = ("viewer", "operator", "admin")


def _hash(token: str) -> str:
    return hashlib.sha256(token.encode()).hexdigest()


class TokenStore:
    def __init__(self, data_dir: Path):
        self.path = data_dir / "tokens.json"
        self.admin_token_path = data_dir / "admin-token"
        self._tokens: dict[str, dict] = {}
        if self.path.exists():
            self._tokens = json.loads(self.path.read_text())

    def ensure_admin(self) -> Path | None:
        """Creates the first admin token if there is no token at all; returns where it was written."""
        if self._tokens:
            return None
        token = secrets.token_urlsafe(32)
        self._tokens[_hash(token)] = {"name": "admin", "role": "admin"}
        self._save()
        fd = os.open(self.admin_token_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "w") as f:
            f.write(token + "\n")
        return self.admin_token_path

    def add(self, name: str, role: str) -> str:
        if role not in ROLES:
            raise ValueError(f"role must be one of {', '.join(ROLES)}")
        token = secrets.token_urlsafe(32)
        self._tokens[_hash(token)] = {"name": name, "role": role}
        self._save()
        return token

    def role_of(self, token: str) -> str | None:
        entry = self._tokens.get(_hash(token))
        return entry["role"] if entry else None

    def _save(self) -> None:
        tmp = self.path.with_suffix(".tmp")
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "w") as f:
            json.dump(self._tokens, f, indent=1)
        os.replace(tmp, self.path)


def allows(role: str, needed: str) -> bool:
    return ROLES.index(role) >= ROLES.index(needed)

"""users.py -- the people who sign in: a name, a role, an argon2id password hash (argon2-cffi's
PasswordHasher), a disabled flag and when they were created, last signed in and last changed their
password; kept in <data-dir>/users.json (mode 0600, replaced atomically).

The rules a name and a password must follow live here (NAME_RULE, password_problem) and are
documented in docs/administration.md.  Users are disabled, never deleted: a name in the audit log
keeps meaning one person.  A hash made with other parameters than the ones configured is replaced
at the next successful sign-in (PasswordHasher.check_needs_rehash).
"""

from __future__ import annotations

import json
import re
import secrets
import threading
import unicodedata
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from argon2 import PasswordHasher
from argon2.exceptions import InvalidHashError, VerificationError, VerifyMismatchError

from ..files import write_json
from .auth import ROLES, now_iso

NAME_PATTERN = r"^[a-z][a-z0-9._-]{1,31}$"
NAME_RULE = "2 to 32 characters: lowercase letters, digits, '.', '_' or '-', starting with a letter"
PASSWORD_MIN, PASSWORD_MAX = 12, 1024
_NAME = re.compile(NAME_PATTERN)
_CONTROL = re.compile(r"[\x00-\x1f\x7f]")
FORMAT = 1  # users.json's "format"


def name_problem(name: str) -> str | None:
    """What is wrong with a user name (None: nothing)."""
    return None if _NAME.fullmatch(name) else f"a user name has {NAME_RULE}"


def normalized(password: str) -> str:
    """The password as hashed: NFC, so that the same characters typed on another keyboard or system
    (composed or decomposed accents) give the same password."""
    return unicodedata.normalize("NFC", password)


def encodable(text: str) -> bool:
    """Whether `text` is UTF-8 (JSON lets a client send an unpaired surrogate, which is not)."""
    try:
        text.encode()
    except UnicodeEncodeError:
        return False
    return True


def password_problem(name: str, password: str) -> str | None:
    """What is wrong with a new password for `name` (None: nothing); the rules of
    docs/administration.md, "Passwords"."""
    password = normalized(password)
    if not encodable(password):
        return "a password is text: it holds an unpaired surrogate (\\ud800-\\udfff)"
    if len(password) < PASSWORD_MIN:
        return f"a password has at least {PASSWORD_MIN} characters (this one has {len(password)})"
    if len(password) > PASSWORD_MAX:
        return f"a password has at most {PASSWORD_MAX} characters"
    if _CONTROL.search(password):
        return "a password holds no control characters (tab, newline, escape, ...)"
    if name.lower() in password.lower():
        return "a password must not contain the user name"
    return None


def password_matches(hasher: PasswordHasher, digest: str, password: str) -> bool:
    """Whether `password` is the one `digest` (an argon2 hash of users.json) was made from; also for
    readers of users.json that never write it (the OPC UA server, docs/opcua.md)."""
    if not encodable(password) or not digest:
        return False
    try:
        return hasher.verify(digest, normalized(password))
    except (VerifyMismatchError, VerificationError, InvalidHashError):
        return False


class UserError(Exception):
    """A refused change: `status` (404 no such user, 409 a conflict, 422 bad input), the `field`
    it is about (422), and a message that says what to do."""

    def __init__(self, status: int, message: str, field: str | None = None):
        super().__init__(message)
        self.status, self.message, self.field = status, message, field


@dataclass(frozen=True)
class User:
    name: str
    role: str
    disabled: bool
    created: str
    created_by: str | None
    last_sign_in: str | None
    password_changed: str
    hash: str

    def public(self) -> dict:
        """Everything but the hash."""
        d = asdict(self)
        del d["hash"]
        return d


def parse_users(stored) -> dict[str, User]:
    """The users of a users.json's content (`{"format": 1, "users": {name: fields}}`), or ValueError
    saying what is wrong with it (a restore checks a backup's file with this before using it)."""
    if not isinstance(stored, dict) or not isinstance(stored.get("users"), dict):
        raise ValueError('not a users file ({"format": 1, "users": {name: {...}}})')
    if stored.get("format") != FORMAT:
        raise ValueError(f"format {stored.get('format')!r}; this agent reads format {FORMAT}")
    users = {}
    for name, fields in stored["users"].items():
        try:
            user = User(name=name, **fields)
        except TypeError as e:
            raise ValueError(f"user {name!r}: {e}") from None
        if name_problem(name) or user.role not in ROLES or not isinstance(user.hash, str):
            raise ValueError(f"user {name!r}: a bad name, role or hash")
        users[name] = user
    return users


def without_password_hashes(stored: dict) -> dict:
    """A users file's content with every password hash emptied: the users keep their names, roles
    and history, and no password matches until an admin sets one (a backup without secrets)."""
    users = parse_users(stored)
    return {"format": FORMAT, "users": {n: {**_fields(replace(u, hash=""))} for n, u in users.items()}}


def _fields(user: User) -> dict:
    fields = asdict(user)
    del fields["name"]
    return fields


class UserStore:
    """The users of one data directory.  Thread-safe; every change is written before it returns."""

    def __init__(self, data_dir: Path, hasher: PasswordHasher | None = None):
        self.path = data_dir / "users.json"
        self.hasher = hasher or PasswordHasher()
        self._lock = threading.Lock()
        self._users: dict[str, User] = {}
        if self.path.exists():
            self._users = parse_users(json.loads(self.path.read_text()))
        self._decoy: str | None = None

    # ---- reading --------------------------------------------------------------------------------
    def get(self, name: str) -> User | None:
        return self._users.get(name)

    def list(self) -> list[User]:
        return sorted(self._users.values(), key=lambda u: u.name)

    def any(self) -> bool:
        return bool(self._users)

    def enabled_admins(self) -> list[str]:
        return [u.name for u in self._users.values() if u.role == "admin" and not u.disabled]

    # ---- signing in -----------------------------------------------------------------------------
    def verify(self, name: str, password: str) -> User | None:
        """The user if `password` is theirs and they are enabled, else None (as slowly either way).
        A good password's hash is renewed when the configured parameters changed."""
        user = self._users.get(name)
        candidate = normalized(password) if encodable(password) else "\ufffd"  # never anyone's: too short
        try:
            if user is None or user.disabled or not user.hash:  # not user.hash: restored without secrets
                self.hasher.verify(self._decoy_hash(), candidate)
                return None
            self.hasher.verify(user.hash, candidate)
        except (VerifyMismatchError, VerificationError, InvalidHashError):
            return None
        with self._lock:
            current = self._users.get(name)
            if current is None or current.disabled or current.hash != user.hash:
                return None  # changed meanwhile
            fresh = self.hasher.hash(candidate) if self.hasher.check_needs_rehash(current.hash) else current.hash
            current = replace(current, last_sign_in=now_iso(), hash=fresh)
            self._users[name] = current
            self._save()
        return current

    # ---- changes --------------------------------------------------------------------------------
    def add(self, name: str, role: str, password: str, by: str | None) -> User:
        problem = name_problem(name)
        if problem:
            raise UserError(422, problem, "name")
        if role not in ROLES:
            raise UserError(422, f"role must be one of {', '.join(ROLES)}", "role")
        problem = password_problem(name, password)
        if problem:
            raise UserError(422, problem, "password")
        digest = self.hasher.hash(normalized(password))
        with self._lock:
            if name in self._users:
                raise UserError(409, f"there is already a user {name!r} (users are disabled, not deleted)")
            now = now_iso()
            user = User(name, role, False, now, by, None, now, digest)
            self._users[name] = user
            self._save()
        return user

    def set_password(self, name: str, password: str, current: str | None = None) -> User:
        """A new password for `name`; `current`, when given, must be the present one (a user
        changing their own).  The new one must follow the rules and differ from the present one."""
        user = self._need(name)
        problem = password_problem(name, password)
        if problem:
            raise UserError(422, problem, "password")
        if current is not None and not self._matches(user.hash, current):
            raise UserError(422, "this is not the present password", "current_password")
        if self._matches(user.hash, password):
            raise UserError(422, "the new password must differ from the present one", "password")
        digest = self.hasher.hash(normalized(password))
        with self._lock:
            user = replace(self._need(name), hash=digest, password_changed=now_iso())
            self._users[name] = user
            self._save()
        return user

    def set_role(self, name: str, role: str) -> User:
        if role not in ROLES:
            raise UserError(422, f"role must be one of {', '.join(ROLES)}", "role")
        with self._lock:
            user = self._need(name)
            if user.role == "admin" and role != "admin" and self._last_admin(name):
                raise UserError(409, f"{name} is the last enabled admin; make another user admin first")
            user = replace(user, role=role)
            self._users[name] = user
            self._save()
        return user

    def set_disabled(self, name: str, disabled: bool) -> User:
        with self._lock:
            user = self._need(name)
            if disabled and user.role == "admin" and self._last_admin(name):
                raise UserError(409, f"{name} is the last enabled admin; make another user admin first")
            user = replace(user, disabled=disabled)
            self._users[name] = user
            self._save()
        return user

    # ---- inside ---------------------------------------------------------------------------------
    def _decoy_hash(self) -> str:
        """Verified when a name is unknown or disabled, so that such a sign-in takes as long as a
        wrong password: the answer's timing does not tell which names exist."""
        if self._decoy is None:
            self._decoy = self.hasher.hash(secrets.token_urlsafe(16))
        return self._decoy

    def _need(self, name: str) -> User:
        user = self._users.get(name)
        if user is None:
            raise UserError(404, f"no user {name!r}; GET /api/v1/users lists them")
        return user

    def _last_admin(self, name: str) -> bool:
        return self.enabled_admins() == [name]

    def _matches(self, digest: str, password: str) -> bool:
        return password_matches(self.hasher, digest, password)

    def _save(self) -> None:
        write_json(self.path, {"format": FORMAT, "users": {u.name: _fields(u) for u in self._users.values()}})

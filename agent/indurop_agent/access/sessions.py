"""sessions.py -- browser sessions: what a sign-in with a name and a password (POST /session) gives,
kept on the server; the browser holds only the random id in an HttpOnly cookie.

A session ends when it is signed out, after `idle_s` without a request that the user made (the web
UI marks its background polls, which do not count), after `lifetime_s` whatever happens, and when its
user is disabled, changes or gets a new password.  Every sign-in draws a new id (secrets), so an id
planted in a browser before the sign-in is never the signed-in one (session fixation).

<data-dir>/sessions.json (mode 0600) keeps them across a restart of the agent, by the SHA-256 of
their id: the file alone does not let anyone in.  Each session also has a CSRF token, which every
request that changes something must carry in the X-CSRF-Token header when the cookie signs it in.
The file is written when a session begins or ends, and at most once a minute per session for its
last request time (a restart may therefore end a session up to a minute early).
"""

from __future__ import annotations

import hashlib
import json
import secrets
import threading
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from ..files import write_json

COOKIE = "indurop_session"
CSRF_HEADER = "X-CSRF-Token"
# Sent by the web UI with the requests that it makes on its own (polls): they keep the session
# neither alive nor from its idle timeout.
BACKGROUND_HEADER = "X-Indurop-Background"
SAVE_SEEN_EVERY_S = 60.0
FORMAT = 1
HANDLE_LENGTH = 12


def digest(session_id: str) -> str:
    return hashlib.sha256(session_id.encode()).hexdigest()


@dataclass(frozen=True)
class Session:
    key: str  # the SHA-256 of the id (hex): how it is stored
    user: str
    csrf: str
    created: float  # Unix time
    last_seen: float  # the last request the user made
    client: str  # the address it was signed in from

    @property
    def handle(self) -> str:
        """Names the session in the audit log and in a viewer ticket without giving it away."""
        return self.key[:HANDLE_LENGTH]


class SessionStore:
    def __init__(
        self,
        path: Path,
        idle_s: float,
        lifetime_s: float,
        max_per_user: int = 32,
        max_total: int = 4096,
        clock=time.time,
    ):
        self.path, self.idle_s, self.lifetime_s = path, idle_s, lifetime_s
        self.max_per_user, self.max_total, self.clock = max_per_user, max_total, clock
        self._lock = threading.Lock()
        self._sessions: dict[str, Session] = {}
        self._saved_seen: dict[str, float] = {}
        if path.exists():
            stored = json.loads(path.read_text())
            for key, fields in stored.get("sessions", {}).items():
                self._sessions[key] = Session(key=key, **fields)
                self._saved_seen[key] = fields["last_seen"]

    # ---- the deadlines ------------------------------------------------------------------------------
    def idle_deadline(self, s: Session) -> float:
        return min(s.last_seen + self.idle_s, self.absolute_deadline(s))

    def absolute_deadline(self, s: Session) -> float:
        return s.created + self.lifetime_s

    def _alive(self, s: Session, now: float) -> bool:
        return now < self.idle_deadline(s)

    # ---- sign-in, look-up, sign-out -----------------------------------------------------------------
    def create(self, user: str, client: str, replacing: str | None = None) -> tuple[str, Session]:
        """A new session for `user`: (its id, for the cookie; the session).  `replacing`: the id the
        browser sent along (a previous session, or one planted in it), which ends here."""
        session_id = secrets.token_urlsafe(32)
        now = self.clock()
        s = Session(digest(session_id), user, secrets.token_urlsafe(32), now, now, client)
        with self._lock:
            if replacing is not None:
                self._drop(digest(replacing))
            self._sweep(now)
            mine = sorted((x for x in self._sessions.values() if x.user == user), key=lambda x: x.last_seen)
            for old in mine[: max(0, len(mine) - self.max_per_user + 1)]:
                self._drop(old.key)  # the oldest give way: a user cannot pile sessions up
            while len(self._sessions) >= self.max_total:
                self._drop(min(self._sessions.values(), key=lambda x: x.last_seen).key)
            self._sessions[s.key] = s
            self._save()
        return session_id, s

    def find(self, session_id: str) -> Session | None:
        """The live session of this id, or None (unknown, signed out or expired; an expired one
        is forgotten)."""
        key = digest(session_id)
        with self._lock:
            s = self._sessions.get(key)
            if s is None:
                return None
            if not self._alive(s, self.clock()):
                self._drop(key)
                self._save()
                return None
            return s

    def by_handle(self, handle: str) -> Session | None:
        """The live session a handle names (viewer tickets), without counting as a request."""
        now = self.clock()
        with self._lock:
            return next(
                (s for k, s in self._sessions.items() if k[:HANDLE_LENGTH] == handle and self._alive(s, now)), None
            )

    def touch(self, s: Session) -> None:
        """A request the user made: the idle timeout starts again."""
        now = self.clock()
        with self._lock:
            current = self._sessions.get(s.key)
            if current is None:
                return
            self._sessions[s.key] = replace(current, last_seen=now)
            if now - self._saved_seen.get(s.key, 0.0) >= SAVE_SEEN_EVERY_S:
                self._save()

    def end(self, session_id: str) -> Session | None:
        """Signs a session out; the one it was, or None."""
        key = digest(session_id)
        with self._lock:
            s = self._sessions.get(key)
            if s is not None:
                self._drop(key)
                self._save()
            return s

    def end_user(self, user: str, keep: str | None = None) -> int:
        """Ends every session of `user` but the one whose handle is `keep`; how many ended."""
        with self._lock:
            gone = [k for k, s in self._sessions.items() if s.user == user and k[:HANDLE_LENGTH] != keep]
            for k in gone:
                self._drop(k)
            if gone:
                self._save()
        return len(gone)

    def count(self, user: str) -> int:
        now = self.clock()
        with self._lock:
            return sum(1 for s in self._sessions.values() if s.user == user and self._alive(s, now))

    # ---- inside -------------------------------------------------------------------------------------
    def _drop(self, key: str) -> None:
        self._sessions.pop(key, None)
        self._saved_seen.pop(key, None)

    def _sweep(self, now: float) -> None:
        for key in [k for k, s in self._sessions.items() if not self._alive(s, now)]:
            self._drop(key)

    def _save(self) -> None:
        sessions = {}
        for key, s in self._sessions.items():
            fields = asdict(s)
            del fields["key"]
            sessions[key] = fields
            self._saved_seen[key] = s.last_seen
        write_json(self.path, {"format": FORMAT, "sessions": sessions})

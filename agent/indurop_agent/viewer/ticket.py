"""ticket.py -- short-lived signed tickets that let an <iframe> (which cannot send an Authorization
header) open the 3D view through the agent's proxy.

GET /robot hands a viewer a URL with ?ticket=<expiry>.<token id>.<HMAC-SHA256>, signed with a
secret the agent draws at start (so a restart invalidates every ticket) and valid for
`viewer_ticket_s` (10 min).  The proxy trades a good ticket for an HttpOnly, SameSite=Strict
cookie of the same form (purpose "session", valid `viewer_session_s`) scoped to the viewer's path,
and redirects to the URL without the ticket.  The id is a token's or a browser session's handle;
every check asks who it is now: a revoked token's, an ended session's or a disabled user's tickets
and cookies stop working at once."""

from __future__ import annotations

import base64
import hashlib
import hmac
import re
import secrets
import time
from collections.abc import Callable

from ..access.auth import Identity

TICKET = re.compile(r"^(\d{1,12})\.([0-9a-f]{12})\.([A-Za-z0-9_-]{43})$")


class TicketError(Exception):
    """A ticket or cookie that does not open the view; the message says why."""


class Tickets:
    """identify(id): the identity a token id or session handle has now, or None (revoked, ended)."""

    def __init__(
        self,
        identify: Callable[[str], Identity | None],
        ticket_s: float = 600.0,
        session_s: float = 3600.0,
        secret: bytes | None = None,
    ):
        self.identify, self.ticket_s, self.session_s = identify, ticket_s, session_s
        self._secret = secret or secrets.token_bytes(32)

    def _sign(self, purpose: str, expires: int, token_id: str) -> str:
        mac = hmac.new(self._secret, f"{purpose}|{expires}|{token_id}".encode(), hashlib.sha256).digest()
        return base64.urlsafe_b64encode(mac).rstrip(b"=").decode()

    def issue(self, who: Identity, purpose: str = "url", now: float | None = None) -> str:
        lifetime = self.ticket_s if purpose == "url" else self.session_s
        expires = int((time.time() if now is None else now) + lifetime)
        return f"{expires}.{who.id}.{self._sign(purpose, expires, who.id)}"

    def check(self, ticket: str, purpose: str = "url", now: float | None = None) -> Identity:
        m = TICKET.match(ticket or "")
        if m is None:
            raise TicketError("not a viewer ticket; GET /api/v1/robot gives a viewer_url with a fresh one")
        expires, token_id, mac = int(m.group(1)), m.group(2), m.group(3)
        if not hmac.compare_digest(mac, self._sign(purpose, expires, token_id)):
            raise TicketError(
                "the viewer ticket's signature does not match (the agent restarted, or it was "
                "altered); GET /api/v1/robot gives a fresh one"
            )
        if expires <= (time.time() if now is None else now):
            raise TicketError("the viewer ticket has expired; GET /api/v1/robot gives a fresh one")
        who = self.identify(token_id)
        if who is None:
            raise TicketError(
                "the token this viewer ticket was issued to has been revoked, or the session has ended; "
                "GET /api/v1/robot gives a fresh one"
            )
        return who

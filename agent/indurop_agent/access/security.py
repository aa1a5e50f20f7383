"""security.py -- the agent's guards that are not about roles: the brute-force lockout (of client
addresses that try unknown tokens or wrong passwords, and of user names whose password is guessed),
the body-size limit of every request but a set upload, and the deadline of request bodies that
stall."""

from __future__ import annotations

import asyncio
import json
import threading
import time
from collections import OrderedDict, deque

from starlette.exceptions import HTTPException


class Lockout:
    """`attempts` failures of one key (a client address, a user name) within `window_s` lock it out
    for `window_s`.

    While locked, every credential for that key is refused, good or bad (a correct guess must not
    get through).  At most `max_addresses` keys are remembered, the least recent dropped.
    """

    def __init__(self, attempts: int = 10, window_s: float = 60.0, max_addresses: int = 10000, clock=time.monotonic):
        self.attempts, self.window_s, self.max_addresses, self.clock = attempts, window_s, max_addresses, clock
        self._failures: OrderedDict[str, deque] = OrderedDict()
        self._locked_until: dict[str, float] = {}
        self._lock = threading.Lock()

    def retry_after(self, address: str) -> int:
        """Seconds until `address` may try again (0: it is not locked out)."""
        with self._lock:
            until = self._locked_until.get(address)
            if until is None:
                return 0
            left = until - self.clock()
            if left <= 0:
                del self._locked_until[address]
                return 0
            return max(1, int(left + 0.999))

    def failed(self, address: str) -> bool:
        """Counts one unknown token from `address`; True when that locks it out (just now)."""
        now = self.clock()
        with self._lock:
            failures = self._failures.pop(address, None) or deque()
            failures.append(now)
            while failures and failures[0] <= now - self.window_s:
                failures.popleft()
            if len(failures) >= self.attempts:
                self._locked_until[address] = now + self.window_s
                failures.clear()
                return True
            self._failures[address] = failures  # most recent last
            while len(self._failures) > self.max_addresses:
                self._failures.popitem(last=False)
            return False

    def forget(self, key: str) -> None:
        """Clears the failures counted for `key` (a user name whose right password was given)."""
        with self._lock:
            self._failures.pop(key, None)


class BodyTooLarge(HTTPException):
    """Raised from inside the body read: an HTTPException, so FastAPI answers it as it is (413)."""

    def __init__(self, limit: int):
        super().__init__(413, too_large_message(limit))


def too_large_message(limit: int) -> str:
    return f"the request body is larger than {limit} bytes; only set uploads (POST /api/v1/sets) may be larger"


class BodyLimitMiddleware:
    """Answers 413 to a request whose body is larger than `limit` bytes, by its Content-Length or,
    when it streams without one, as soon as more than that has arrived.  Requests for which
    `exempt(method, path)` is true (set uploads, which check their own limits while streaming to
    disk) pass untouched."""

    def __init__(self, app, limit: int, exempt=lambda method, path: False):
        self.app, self.limit, self.exempt = app, limit, exempt

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http" or self.exempt(scope["method"], scope["path"]):
            return await self.app(scope, receive, send)
        length = dict(scope["headers"]).get(b"content-length")
        if length is not None and (not length.isdigit() or int(length) > self.limit):
            return await self._refuse(send)
        seen = 0
        started = False

        async def limited_receive():
            nonlocal seen
            message = await receive()
            if message["type"] == "http.request":
                seen += len(message.get("body", b""))
                if seen > self.limit:
                    raise BodyTooLarge(self.limit)
            return message

        async def watched_send(message):
            nonlocal started
            started = started or message["type"] == "http.response.start"
            await send(message)

        try:
            await self.app(scope, limited_receive, watched_send)
        except BodyTooLarge:
            if not started:
                await self._refuse(send)

    async def _refuse(self, send):
        await send_refusal(send, 413, too_large_message(self.limit))


async def send_refusal(send, status: int, detail: str) -> None:
    """An ASGI response {"detail": ...} with `status` that closes the connection (the body that
    caused it was not read to its end)."""
    body = json.dumps({"detail": detail}).encode()
    await send(
        {
            "type": "http.response.start",
            "status": status,
            "headers": [
                (b"content-type", b"application/json"),
                (b"content-length", str(len(body)).encode()),
                (b"connection", b"close"),
            ],
        }
    )
    await send({"type": "http.response.body", "body": body})


class BodyTimeout(HTTPException):
    def __init__(self, detail: str):
        super().__init__(408, detail)


class BodyTimeoutMiddleware:
    """Answers 408 to a request whose body stalls: no byte for `idle_s`, or (all but the requests for
    which `exempt(method, path)` is true: set uploads, which may be large) not complete within
    `total_s`.  A client that trickles a body must not hold a connection and a task for ever."""

    def __init__(self, app, idle_s: float, total_s: float, exempt=lambda method, path: False):
        self.app, self.idle_s, self.total_s, self.exempt = app, idle_s, total_s, exempt

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        loop = asyncio.get_running_loop()
        deadline = None if self.exempt(scope["method"], scope["path"]) else loop.time() + self.total_s
        complete = False
        started = False

        async def timed_receive():
            nonlocal complete
            if complete:  # after the body: waiting for the disconnect is not a body read
                return await receive()
            wait = self.idle_s if deadline is None else min(self.idle_s, deadline - loop.time())
            try:
                message = await asyncio.wait_for(receive(), max(wait, 0.001))
            except TimeoutError:
                raise BodyTimeout(self._why(deadline is not None and loop.time() >= deadline)) from None
            if message["type"] != "http.request" or not message.get("more_body", False):
                complete = True
            return message

        async def watched_send(message):
            nonlocal started
            started = started or message["type"] == "http.response.start"
            await send(message)

        try:
            await self.app(scope, timed_receive, watched_send)
        except BodyTimeout as e:
            if not started:
                await send_refusal(send, 408, e.detail)

    def _why(self, total: bool) -> str:
        if total:
            return f"the request body did not arrive within {self.total_s:g} s (body_timeout_s); send it at once"
        return f"the request body stalled: no byte for {self.idle_s:g} s (body_idle_s)"

"""server.py -- how the agent's HTTP server meets slow and numerous clients: uvicorn with a request
header deadline, a connection cap answered with a clear 503, and the open-file limit raised to
what the cap needs (docs/security.md, "Limits").

uvicorn (0.32) times out idle keep-alive connections only: a client that opens a connection and
dribbles its request headers one byte at a time (slowloris) would hold it forever.  HeaderDeadline
closes such a connection with 408 once `header_timeout_s` passes without complete headers.  Slow
bodies are the ASGI layer's concern (security.BodyTimeoutMiddleware).
"""

from __future__ import annotations

import json
import resource

import h11
from uvicorn.protocols.http.h11_impl import H11Protocol

from .headers import headers_for

# File descriptors kept back from the connection cap: irpd's sockets, the set store's files,
# shared-memory segments, the viewer's server and its clients.
FD_RESERVE = 256


def raw_response(status: int, reason: str, detail: str, extra: dict[str, str] | None = None) -> bytes:
    """A whole HTTP/1.1 response with a JSON {"detail"} body, written before h11 has a request."""
    body = json.dumps({"detail": detail}).encode()
    headers = {
        "content-type": "application/json",
        "content-length": str(len(body)),
        "connection": "close",
        **{k.decode(): v.decode() for k, v in headers_for()},  # as on every other answer
        **(extra or {}),
    }
    head = f"HTTP/1.1 {status} {reason}\r\n" + "".join(f"{k}: {v}\r\n" for k, v in headers.items()) + "\r\n"
    return head.encode("latin-1") + body


def raise_fd_limit(wanted: int) -> tuple[int, int]:
    """Raises the soft RLIMIT_NOFILE towards `wanted` (never above the hard limit, never lowers it);
    returns (soft, hard) as they are afterwards."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    target = wanted if hard == resource.RLIM_INFINITY else min(wanted, hard)
    if target > soft:
        resource.setrlimit(resource.RLIMIT_NOFILE, (target, hard))
    return resource.getrlimit(resource.RLIMIT_NOFILE)


def connection_cap(max_connections: int) -> tuple[int, str | None]:
    """The number of client connections the agent can hold with the file descriptors it may open:
    `max_connections`, or fewer (with a line saying why) when the hard limit is too low."""
    soft, hard = raise_fd_limit(max_connections + FD_RESERVE)
    if soft >= max_connections + FD_RESERVE:
        return max_connections, None
    cap = max(16, soft - FD_RESERVE)
    return cap, (
        f"indurop-agent: the open-file limit is {soft} (hard {hard}): at most {cap} connections instead of "
        f"max_connections {max_connections} (raise LimitNOFILE or lower max_connections)"
    )


def protocol(header_timeout_s: float, max_connections: int) -> type[H11Protocol]:
    """uvicorn's h11 protocol with the header deadline and the connection cap."""

    class HeaderDeadline(H11Protocol):
        _deadline = None
        _started = False  # bytes of the current request have arrived

        def connection_made(self, transport) -> None:
            super().connection_made(transport)
            if len(self.connections) > max_connections:
                self.transport.write(
                    raw_response(
                        503,
                        "Service Unavailable",
                        f"the agent holds {max_connections} connections (its max_connections); close idle ones or try "
                        "again later",
                        {"retry-after": "5"},
                    )
                )
                self.transport.close()
                return
            self._arm()

        def _arm(self) -> None:
            self._disarm()
            self._deadline = self.loop.call_later(header_timeout_s, self._expired)

        def _disarm(self) -> None:
            if self._deadline is not None:
                self._deadline.cancel()
                self._deadline = None

        def _expired(self) -> None:
            self._deadline = None
            if self.transport.is_closing() or self.conn.their_state is not h11.IDLE:
                return
            if self._started:  # a request begun and never finished gets a reason; silence just a close
                self.transport.write(
                    raw_response(
                        408,
                        "Request Timeout",
                        f"the request line and headers did not arrive within {header_timeout_s:g} s (header_timeout_s)",
                    )
                )
            self.transport.close()

        def data_received(self, data: bytes) -> None:
            self._started = True
            super().data_received(data)
            if self.conn.their_state is not h11.IDLE:  # the headers are in (or the connection was upgraded)
                self._disarm()

        def on_response_complete(self) -> None:
            super().on_response_complete()
            self._started = False
            if not self.transport.is_closing() and self.conn.their_state is h11.IDLE:
                self._arm()  # the next request's headers have the same deadline

        def connection_lost(self, exc) -> None:
            self._disarm()
            super().connection_lost(exc)

    return HeaderDeadline

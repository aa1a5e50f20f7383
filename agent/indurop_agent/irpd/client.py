"""client.py -- the agent's side of irpd's control socket (docs/control-protocol.md).

One connection, re-opened when irpd restarts; every call has a timeout, so a stopped irpd makes
requests fail fast (the API answers 503) instead of hanging.  Commands that swap the schedule
(`load`, `set_period`, ...) can take seconds: they pass a longer per-call `timeout`, and the agent
sends them on a connection of their own so that reads do not wait behind them.
"""

from __future__ import annotations

import json
import socket
import threading
import time
from typing import Any

from . import protocol

PROTOCOL = protocol.PROTOCOL
PROTOCOL_VERSIONS = tuple(range(1, protocol.VERSION + 1))  # the versions of irpd this agent can talk to


class IrpdUnavailable(Exception):
    """irpd does not answer on its control socket (not running, or restarting)."""


class IrpdRefused(Exception):
    """irpd answered the request with an error."""

    def __init__(self, code: str, message: str, error: dict | None = None):
        super().__init__(message)
        self.code = code
        # The error object irpd sent (#/shapes/error: code, message and the fields of its place that
        # are known), or just those fields; errors.place() reads the place from it.
        self.error = error or {}

    @property
    def forced(self) -> bool:
        """A write irpd refused because a force holds the variable (its code `forced`; the message
        names who forced it).  The one place the agent tells this refusal from the others: the API
        answers it 409 as any refusal, OPC UA BadUserAccessDenied (docs/forcing.md)."""
        return self.code == protocol.FORCED


class IrpdClient:
    def __init__(self, path: str, timeout_s: float = 2.0):
        self.path = path
        self.timeout_s = timeout_s
        self._lock = threading.Lock()
        self._sock: socket.socket | None = None
        self._file = None
        self._next_id = 0
        self.hello: dict[str, Any] | None = None

    def _connect(self, wait: float) -> None:
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        sock.settimeout(wait)
        try:
            sock.connect(self.path)
            file = sock.makefile("rw", encoding="utf-8", newline="\n")
            hello = json.loads(file.readline() or "null")
        except (OSError, ValueError) as e:
            sock.close()
            raise IrpdUnavailable(f"irpd is not reachable on {self.path}: {e}") from e
        if (
            not isinstance(hello, dict)
            or hello.get("protocol") != PROTOCOL
            or hello.get("version") not in PROTOCOL_VERSIONS
        ):
            sock.close()
            versions = " or ".join(map(str, PROTOCOL_VERSIONS))
            raise IrpdUnavailable(f"{self.path} does not speak {PROTOCOL} version {versions}: {hello!r}")
        self._sock, self._file, self.hello = sock, file, hello

    def close(self) -> None:
        with self._lock:
            self._drop()

    def _drop(self) -> None:
        if self._sock is not None:
            self._sock.close()
        self._sock = self._file = None

    @property
    def version(self) -> int | None:
        """The protocol version of the irpd last connected to (None before the first connection)."""
        return self.hello.get("version") if self.hello else None

    def request(self, cmd: str, *, timeout: float | None = None, **arguments: Any) -> Any:
        """Sends one command and returns its result; raises IrpdUnavailable or IrpdRefused.

        `timeout` (seconds) replaces the client's default for this call only, and bounds the whole
        call: the wait for requests queued before it on the one connection counts, so a stopped
        irpd makes every caller fail after its own timeout instead of after everyone else's.  A
        request that times out is not sent again (irpd may still carry it out); one that met a
        connection broken by irpd's restart is sent once more on a new connection.
        """
        wait = self.timeout_s if timeout is None else timeout
        deadline = time.monotonic() + wait
        if not self._lock.acquire(timeout=wait):
            raise IrpdUnavailable(
                f"irpd did not answer '{cmd}' within {wait:g} s on {self.path}: "
                "earlier requests are still waiting for it"
            )
        try:
            for attempt in (1, 2):
                left = max(deadline - time.monotonic(), 0.05)
                if self._sock is None:
                    self._connect(left)
                self._next_id += 1
                try:
                    self._sock.settimeout(left)
                    self._file.write(json.dumps({"id": self._next_id, "cmd": cmd, **arguments}) + "\n")
                    self._file.flush()
                    line = self._file.readline()
                    if not line:
                        raise OSError("connection closed")
                    answer = json.loads(line)
                except TimeoutError as e:
                    self._drop()  # a late answer would be read as the next request's
                    raise IrpdUnavailable(f"irpd did not answer '{cmd}' within {wait:g} s on {self.path}") from e
                except (OSError, ValueError) as e:
                    self._drop()
                    if attempt == 2:
                        raise IrpdUnavailable(f"irpd stopped answering on {self.path}: {e}") from e
                    continue
                finally:
                    if self._sock is not None:
                        self._sock.settimeout(self.timeout_s)
                if not isinstance(answer, dict):
                    self._drop()
                    raise IrpdUnavailable(f"irpd sent a non-object answer on {self.path}: {answer!r:.200}")
                if answer.get("ok"):
                    return answer.get("result")
                error = answer.get("error") or {}
                raise IrpdRefused(
                    error.get("code", protocol.REFUSED), error.get("message", "irpd refused the request"), error
                )
        finally:
            self._lock.release()
        raise IrpdUnavailable(f"irpd is not reachable on {self.path}")

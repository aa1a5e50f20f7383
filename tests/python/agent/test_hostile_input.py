"""test_hostile_input.py -- the bad-input battery over HTTP: a real agent (uvicorn on 127.0.0.1) in
front of a real irpd running the paper's Figure 1 set, attacked the ways a network client can.

  auth       no token / an unknown token / a role too low on every route, the WebSocket stream
             and the 3D view's proxy (page and WebSocket)
  lockout    guessing tokens locks the guessing address out (429 + Retry-After), not the others;
             X-Forwarded-For does not let a client pick its address
  size       JSON bodies and uploads over the limits, with Content-Length, without, chunked
  slow       slowloris headers, stalled and trickled bodies (408), while others are served
  many       1000 idle WebSocket connections while others are served; the connection cap
  names      traversal names in uploads (../, absolute, percent-encoded, NUL, backslash) and
             links and devices inside .tar.gz archives; traversal in URL paths
  logs       format strings, ANSI escapes and newlines in every text that reaches a log, user
             names signing in among them
  guessing   a flood of password guesses from many addresses: the name locks, the checks queue

Expected everywhere: a 4xx whose detail names what to fix, never a 5xx; nothing written outside
the agent's data directory; irpd keeps running its set.  irpd's overruns and misses during the
battery are recorded (rt-during-battery.json in the test's tmp folder, and printed), not asserted: on a shared VM
they move without the battery (docs/security.md has a run's figures).

One agent and one irpd serve the whole file (module scope), so the tests run in file order and
the last one checks the file system and irpd after everything before it.
"""

from __future__ import annotations

import json
import os
import resource
import socket
import tarfile
import time
import urllib.parse
from pathlib import Path

import httpx
import pytest
from agent_helpers import (
    API,
    FIG1,
    IRPD,
    ROOT,
    files_body,
    free_port,
    module_xml,
    multipart,
    output,
    start_agent,
    start_irpd,
    stop,
    tar_gz,
)
from websockets.exceptions import ConnectionClosed, InvalidStatus
from websockets.sync.client import connect

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")

# In every name an attack tries to write outside the data dir: one run's own, the same in each of
# pytest-xdist's workers (the names are in the tests' ids, which every worker must collect alike).
MARKER = f"hostile{os.environ.get('PYTEST_XDIST_TESTRUNUID', str(os.getpid()))[:8]}"
LIMITS = {
    "max_body_bytes": 4096,
    "max_file_bytes": 64 << 10,
    "max_upload_bytes": 128 << 10,
    "max_files": 64,
    "header_timeout_s": 2,
    "body_idle_s": 2,
    "body_timeout_s": 4,
    "lockout_attempts": 5,
    "lockout_window_s": 60,
    "irpd_poll_s": 0.5,
}
ANSWER_S = 30  # a bound on any one answer (a hang fails, never a figure)
ROLES = ("viewer", "operator", "admin")

# The role every route of the API needs (None: none).  A new route must be added here.
NEEDS = {
    ("GET", "/health"): None,
    ("GET", "/status"): "viewer",
    ("GET", "/schedule"): "viewer",
    ("GET", "/host"): "viewer",
    ("GET", "/modules"): "viewer",
    ("GET", "/modules/{name}"): "viewer",
    ("PATCH", "/modules/{name}"): "operator",
    ("POST", "/modules/changes"): "operator",
    ("GET", "/jitter"): "viewer",
    ("GET", "/jitter/histograms"): "viewer",
    ("GET", "/variables"): "viewer",
    ("GET", "/variables/{path}"): "viewer",
    ("PUT", "/variables/{path}"): "operator",
    ("POST", "/variables/read"): "viewer",
    ("GET", "/forces"): "viewer",
    ("PUT", "/forces/{path}"): "operator",
    ("DELETE", "/forces/{path}"): "operator",
    ("GET", "/programs"): "viewer",
    ("GET", "/programs/source"): "viewer",
    ("GET", "/programs/history"): "viewer",
    ("GET", "/programs/diff"): "viewer",
    ("GET", "/programs/export"): "viewer",
    ("POST", "/programs/monitor"): "viewer",
    ("GET", "/programs/diagram"): "viewer",
    ("POST", "/programs/diagram/monitor"): "viewer",
    ("POST", "/programs/check"): "viewer",
    ("POST", "/programs/apply"): "admin",
    ("GET", "/sets"): "viewer",
    ("POST", "/sets"): "admin",
    ("GET", "/sets/active"): "viewer",
    ("GET", "/sets/{set_id}"): "viewer",
    ("POST", "/sets/rollback"): "operator",
    ("POST", "/sets/{set_id}/activate"): "operator",
    ("GET", "/robot"): "viewer",
    ("POST", "/sets/{set_id}/check"): "operator",
    ("GET", "/layout"): "viewer",
    ("GET", "/robot/urdf"): "viewer",
    ("PUT", "/robot/joints"): "admin",
    ("GET", "/events"): "viewer",
    ("GET", "/alarms"): "viewer",
    ("GET", "/line"): "viewer",
    ("GET", "/alarms/history"): "viewer",
    ("GET", "/alarms/history.csv"): "viewer",
    ("POST", "/alarms/ack"): "operator",
    ("POST", "/alarms/{key}/ack"): "operator",
    ("POST", "/alarms/{key}/confirm"): "operator",
    ("POST", "/alarms/{key}/shelve"): "operator",
    ("POST", "/alarms/{key}/unshelve"): "operator",
    ("GET", "/audit"): "admin",
    ("GET", "/auth/me"): "viewer",
    ("GET", "/tokens"): "admin",
    ("POST", "/tokens"): "admin",
    ("DELETE", "/tokens/{token_id}"): "admin",
    ("POST", "/session"): None,
    ("GET", "/session"): None,
    ("DELETE", "/session"): None,
    ("GET", "/users"): "admin",
    ("POST", "/users"): "admin",
    ("GET", "/users/{name}"): "viewer",  # and only one's own but for an admin (test_users.py)
    ("PATCH", "/users/{name}"): "admin",
    ("PUT", "/users/{name}/password"): "viewer",
    ("GET", "/users/{name}/tokens"): "viewer",
    ("GET", "/system"): "admin",
    ("POST", "/system/restart/irpd"): "admin",
    ("POST", "/system/restart/agent"): "admin",
    ("GET", "/system/logs/{log}"): "admin",
    ("GET", "/system/logs/{log}/follow"): "admin",
    ("GET", "/system/backup"): "admin",
    ("POST", "/system/restore"): "admin",
    ("POST", "/system/tls"): "admin",
    ("POST", "/sets/prune"): "admin",
    ("GET", "/recordings"): "viewer",
    ("POST", "/recordings"): "operator",
    ("GET", "/recordings/{name}"): "viewer",
    ("POST", "/recordings/{name}/stop"): "operator",
    ("DELETE", "/recordings/{name}"): "operator",
    ("GET", "/recordings/{name}/download"): "viewer",
    ("GET", "/recordings/{name}/export"): "viewer",
    ("GET", "/captures"): "viewer",
    ("GET", "/captures/limits"): "viewer",
    ("POST", "/captures"): "operator",
    ("GET", "/captures/{capture_id}"): "viewer",
    ("GET", "/captures/{capture_id}/shots/{shot}"): "viewer",
    ("POST", "/captures/{capture_id}/arm"): "operator",
    ("POST", "/captures/{capture_id}/disarm"): "operator",
    ("POST", "/captures/{capture_id}/trigger"): "operator",
    ("DELETE", "/captures/{capture_id}"): "operator",
    ("GET", "/sets/{set_id}/scopes"): "viewer",
    ("GET", "/sets/{set_id}/scopes/{name}"): "viewer",
    ("PUT", "/sets/{set_id}/scopes/{name}"): "operator",
    ("DELETE", "/sets/{set_id}/scopes/{name}"): "operator",
    ("GET", "/sets/{set_id}/watches"): "viewer",
    ("GET", "/sets/{set_id}/watches/{name}"): "viewer",
    ("PUT", "/sets/{set_id}/watches/{name}"): "operator",
    ("DELETE", "/sets/{set_id}/watches/{name}"): "operator",
    ("GET", "/opcua"): "viewer",
    ("POST", "/opcua/certificates/{thumbprint}/trust"): "admin",
    ("POST", "/opcua/certificates/{thumbprint}/reject"): "admin",
    ("DELETE", "/opcua/certificates/{thumbprint}"): "admin",
    # the OPC UA server's own token only, no user's (tests/python/opcua/test_opcua_alarm_ack.py)
    ("GET", "/opcua/alarms"): None,
    ("POST", "/opcua/alarms/{key}/ack"): None,
    ("POST", "/opcua/alarms/{key}/confirm"): None,
}
SAMPLE = {
    "{name}": "cntr1",
    "{path}": "knu.Robot.tick",
    "{set_id}": "0" * 64,
    "{token_id}": "0" * 12,
    "{key}": "PLC/8",
    "{log}": "irpd",
    "{capture_id}": "0" * 10,
    "{shot}": "1",
    "{thumbprint}": "0" * 40,
}


class Battery:
    """The agent and irpd under attack, the tokens per role, and what to compare afterwards."""

    def __init__(self, tmp: Path):
        self.tmp, self.sock, self.data = tmp, tmp / "irpd.sock", tmp / "data"
        self.agent = None
        self.irpd = start_irpd(self.sock, FIG1, f"hostile-{os.getpid()}", log=tmp / "irpd.log")
        try:
            self._start(tmp)
        except BaseException:
            self.stop()  # what was started, by pid
            raise

    def stop(self) -> None:
        if self.agent is not None:
            stop(self.agent)
        stop(self.irpd)

    def _start(self, tmp: Path) -> None:
        config = tmp / "agent.json"
        config.write_text(json.dumps(LIMITS))
        self.port = free_port()
        self.agent = start_agent(self.port, self.data, self.sock, "--config", str(config), log=tmp / "agent.log")
        self.base = f"http://127.0.0.1:{self.port}"
        self.url = self.base + API
        self.answers: list[tuple[str, int]] = []  # every status the battery saw, for the no-5xx check
        self.tokens = {"admin": (self.data / "admin-token").read_text().strip()}
        for role in ("operator", "viewer"):
            r = httpx.post(f"{self.url}/tokens", json={"name": f"battery-{role}", "role": role}, headers=self.h())
            assert r.status_code == 201, r.text
            self.tokens[role] = r.json()["token"]
        self.stats_before = self.get("/jitter").json()
        self.status_before = self.get("/status").json()

    def h(self, role: str = "admin") -> dict:
        return {"Authorization": f"Bearer {self.tokens[role]}"}

    def request(
        self, method: str, path: str, role: str | None = "admin", source: str | None = None, **kw
    ) -> httpx.Response:
        headers = {**(self.h(role) if role else {}), **kw.pop("headers", {})}
        transport = httpx.HTTPTransport(local_address=source) if source else None
        with httpx.Client(transport=transport, timeout=ANSWER_S) as c:
            r = c.request(method, f"{self.url}{path}", headers=headers, **kw)
        self.answers.append((f"{method} {path}", r.status_code))
        return r

    def get(self, path: str, role: str | None = "admin", **kw) -> httpx.Response:
        return self.request("GET", path, role, **kw)

    def raw(self, data: bytes, source: str = "127.0.0.1") -> socket.socket:
        s = socket.socket()
        s.bind((source, 0))
        s.connect(("127.0.0.1", self.port))
        s.settimeout(ANSWER_S)
        if data:
            s.sendall(data)
        return s


def read_response(s: socket.socket) -> tuple[int, dict, bytes]:
    """(status, headers, body) of one HTTP/1.1 response read from a raw socket to its end."""
    buf = b""
    while b"\r\n\r\n" not in buf:
        chunk = s.recv(65536)
        if not chunk:
            raise AssertionError(f"the connection closed without a full response: {buf!r}")
        buf += chunk
    head, body = buf.split(b"\r\n\r\n", 1)
    lines = head.decode("latin-1").split("\r\n")
    headers = {k.lower(): v.strip() for k, v in (line.split(":", 1) for line in lines[1:])}
    while len(body) < int(headers.get("content-length", 0)):
        chunk = s.recv(65536)
        if not chunk:
            break
        body += chunk
    return int(lines[0].split()[1]), headers, body


def detail(r: httpx.Response) -> str:
    body = r.json()
    return body["detail"] if isinstance(body["detail"], str) else json.dumps(body["detail"])


@pytest.fixture(scope="module")
def battery(tmp_path_factory):
    b = Battery(tmp_path_factory.mktemp("hostile"))
    yield b
    b.stop()


# ---- auth -----------------------------------------------------------------------------------------
def test_the_role_table_covers_every_route_of_the_api(battery):
    spec = battery.get("/openapi.json", None).json()
    routes = {(m.upper(), p.removeprefix(API)) for p, ops in spec["paths"].items() for m in ops}
    assert routes == set(NEEDS), f"add to NEEDS: {routes - set(NEEDS)}; gone: {set(NEEDS) - routes}"


def concrete(path: str) -> str:
    for template, value in SAMPLE.items():
        path = path.replace(template, value)
    return path


@pytest.mark.parametrize("route", sorted(k for k, v in NEEDS.items() if v), ids=" ".join)
def test_no_token_and_a_role_too_low_are_refused_on_every_route(battery, route):
    method, path = route
    needed = NEEDS[route]
    r = battery.request(method, concrete(path), None)
    assert r.status_code == 401 and "bearer token is required" in detail(r), (r.status_code, r.text)
    assert r.headers["WWW-Authenticate"] == "Bearer"
    for role in ROLES[: ROLES.index(needed)]:
        r = battery.request(method, concrete(path), role)
        assert r.status_code == 403, (role, r.status_code, r.text)
        assert f"needs the {needed} role; the token has {role}" in detail(r)


def test_an_unknown_token_is_refused_naming_the_problem(battery):
    r = battery.get("/status", None, source="127.0.0.5", headers={"Authorization": "Bearer not-a-token"})
    assert r.status_code == 401 and detail(r) == "unknown token"
    r = battery.get("/status", None, source="127.0.0.5", headers={"Authorization": "Basic YWRtaW46YWRtaW4="})
    assert r.status_code == 401 and "bearer token is required" in detail(r)


def stream_closed(uri: str, first: str | None = None, sock=None, token: str | None = None) -> tuple[int, str]:
    """The close code and reason the stream gives a client that sends `first` (or nothing), with
    `token` in its handshake's Authorization header."""
    headers = {"Authorization": f"Bearer {token}"} if token else None
    with connect(uri, additional_headers=headers, sock=sock, open_timeout=ANSWER_S, close_timeout=1) as ws:
        if first is not None:
            ws.send(first)
        with pytest.raises(ConnectionClosed) as closed:
            while True:
                ws.recv(timeout=ANSWER_S)
    return closed.value.rcvd.code, closed.value.rcvd.reason


def bound_socket(source: str, port: int) -> socket.socket:
    s = socket.socket()
    s.bind((source, 0))
    s.connect(("127.0.0.1", port))
    return s


def test_the_stream_refuses_a_missing_or_unknown_token(battery):
    ws = f"ws://127.0.0.1:{battery.port}{API}/stream"
    code, reason = stream_closed(ws, json.dumps({"subscribe": ["knu.Robot.tick"]}))
    assert code == 4401 and "token is required" in reason
    code, reason = stream_closed(ws, "%s%n{0.__class__}\x1b[2J")  # not even JSON
    assert code == 4401 and "token is required" in reason
    code, reason = stream_closed(ws, token="wrong", sock=bound_socket("127.0.0.5", battery.port))
    assert code == 4401 and reason == "unknown token"
    code, reason = stream_closed(f"{ws}?token={battery.tokens['viewer']}")  # never in the URL, even a good one
    assert code == 4401 and "?token= is not accepted" in reason


def ws_refusal(uri: str) -> tuple[str, int]:
    """How a WebSocket is refused: ("http", status) at the handshake or ("close", code) after it."""
    try:
        code, _ = stream_closed(uri)
        return "close", code
    except InvalidStatus as e:
        return "http", e.response.status_code


def test_the_viewer_proxy_refuses_without_a_ticket_or_cookie(battery):
    for path in ("/robot/viewer/", "/robot/viewer/index.html"):
        r = battery.get(path, None)
        assert r.status_code == 401 and "viewer_url" in detail(r), (path, r.status_code, r.text)
    r = battery.get("/robot/viewer/?ticket=1.2.3", None)
    assert r.status_code == 401 and "not a viewer ticket" in detail(r)
    r = battery.get("/robot/viewer/", None, headers={"Cookie": "indurop_viewer=99999999999.000000000000." + "A" * 43})
    assert r.status_code == 401 and "signature" in detail(r)
    r = battery.get("/robot/viewer/", "admin")  # a bearer token is not a viewer ticket
    assert r.status_code == 401
    ws = f"ws://127.0.0.1:{battery.port}{API}/robot/viewer/websocket"
    assert ws_refusal(ws) in (("http", 403), ("close", 4401))
    assert ws_refusal(ws + "?ticket=forged") in (("http", 403), ("close", 4401))


# ---- lockout --------------------------------------------------------------------------------------
def test_guessing_tokens_locks_out_the_guessing_address_only(battery):
    attacker = "127.0.0.2"
    attempts = LIMITS["lockout_attempts"]
    codes = [
        battery.get("/status", None, source=attacker, headers={"Authorization": f"Bearer guess{i}"}).status_code
        for i in range(attempts + 2)
    ]
    assert codes == [401] * (attempts - 1) + [429] * 3, codes
    r = battery.get("/status", "admin", source=attacker)  # a correct token from there is refused too
    assert r.status_code == 429 and 0 < int(r.headers["Retry-After"]) <= LIMITS["lockout_window_s"]
    assert f"too many unknown tokens or wrong passwords from {attacker}" in detail(r) and "try again in" in detail(r)
    code, reason = stream_closed(
        f"ws://127.0.0.1:{battery.port}{API}/stream",
        sock=bound_socket(attacker, battery.port),
        token=battery.tokens["viewer"],
    )
    assert code == 4429 and "try again" in reason
    assert battery.get("/status", "viewer").status_code == 200  # everybody else is served
    assert battery.get("/status", "viewer", source="127.0.0.3").status_code == 200
    lockouts = [e for e in battery.get("/audit?limit=100").json() if e["action"] == "lockout"]
    assert lockouts and lockouts[-1]["client"] == attacker


def test_x_forwarded_for_does_not_let_a_client_pick_the_address_the_lockout_counts(battery):
    codes = [
        battery.get(
            "/status",
            None,
            source="127.0.0.4",
            headers={"Authorization": "Bearer guess", "X-Forwarded-For": f"10.0.0.{i}", "Forwarded": f"for=10.0.1.{i}"},
        ).status_code
        for i in range(LIMITS["lockout_attempts"] + 1)
    ]
    assert codes[-1] == 429, codes
    r = battery.get("/status", "viewer", source="127.0.0.4", headers={"X-Forwarded-For": "127.0.0.1"})
    assert r.status_code == 429 and "127.0.0.4" in detail(r)


# ---- sizes ----------------------------------------------------------------------------------------
def trickle(*parts: bytes, pause: float = 0.0):
    for p in parts:
        yield p
        if pause:
            time.sleep(pause)


def test_json_bodies_over_the_limit_are_413_with_and_without_content_length(battery):
    limit = LIMITS["max_body_bytes"]
    big = {"name": "x" * (2 * limit), "role": "viewer"}
    r = battery.request("POST", "/tokens", json=big)
    assert r.status_code == 413 and f"larger than {limit} bytes" in detail(r)
    r = battery.request(
        "POST",
        "/tokens",
        content=trickle(b'{"name": "', b"x" * (2 * limit), b'", "role": "viewer"}'),
        headers={"Content-Type": "application/json"},
    )  # chunked: no Content-Length
    assert r.status_code == 413 and f"larger than {limit} bytes" in detail(r)
    r = battery.request(
        "PUT",
        "/variables/knu.Robot.tick",
        "operator",
        content=b"[" + b"1," * limit + b"1]",
        headers={"Content-Type": "application/json"},
    )
    assert r.status_code == 413
    r = battery.request("POST", "/tokens", "viewer", json=big)  # refused for size before the role matters
    assert r.status_code == 413
    s = battery.raw(
        b"POST /api/v1/tokens HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
        b"Content-Length: 99999999999999999999\r\n\r\n{}"
    )
    status, _, body = read_response(s)
    s.close()
    assert status == 413 and b"larger than" in body


def test_uploads_over_the_limit_are_413_with_and_without_content_length(battery):
    big = b"\0" * (LIMITS["max_file_bytes"] + 1)
    body, ctype = files_body({"module.xml": module_xml(("a.so", "thread")), "big.txt": big})
    r = battery.request("POST", "/sets", content=body, headers={"Content-Type": ctype})
    assert r.status_code == 413 and "the limit per file" in detail(r)
    r = battery.request("POST", "/sets", content=trickle(body[:1000], body[1000:]), headers={"Content-Type": ctype})
    assert r.status_code == 413 and "the limit per file" in detail(r)
    huge = b"\0" * (LIMITS["max_upload_bytes"] + 1)
    r = battery.request(
        "POST", "/sets", content=trickle(huge[:50000], huge[50000:]), headers={"Content-Type": "application/gzip"}
    )
    assert r.status_code == 413 and "the limit per upload" in detail(r)
    s = battery.raw(
        b"POST /api/v1/sets HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer "
        + battery.tokens["admin"].encode()
        + b"\r\nContent-Type: application/gzip\r\nContent-Length: 10000000000\r\n\r\n"
    )
    status, _, body = read_response(s)
    s.close()
    assert status == 413 and b"the limit is" in body
    bomb = tar_gz(
        [("module.xml", module_xml(("a.so", "thread")))]
        + [(f"f{i}.txt", b"\0" * (LIMITS["max_file_bytes"] - 1)) for i in range(3)]
    )
    assert len(bomb) < 2000  # compresses to nothing, unpacks past the upload limit
    r = battery.request("POST", "/sets", content=bomb, headers={"Content-Type": "application/gzip"})
    assert r.status_code == 413 and "the limit per upload" in detail(r), r.text


def test_too_many_or_too_long_headers_are_refused(battery):
    s = battery.raw(b"")
    s.sendall(b"GET /api/v1/health HTTP/1.1\r\nHost: x\r\n")
    for _ in range(64):  # 1 MiB of headers, 16 KiB a line
        try:
            s.sendall(b"X-Pad: " + b"a" * (16 << 10) + b"\r\n")
        except OSError:
            break  # refused and closed
    status, _, _ = read_response(s)
    s.close()
    assert status == 400
    assert battery.get("/health", None).status_code == 200


# ---- slow clients ---------------------------------------------------------------------------------
def answered(s: socket.socket) -> bool:
    """Whether the agent has written to (or closed) a raw socket, without reading it."""
    s.setblocking(False)
    try:
        return s.recv(1, socket.MSG_PEEK) is not None
    except BlockingIOError:
        return False
    finally:
        s.setblocking(True)
        s.settimeout(ANSWER_S)


def test_slowloris_headers_get_408_and_the_others_are_served_meanwhile(battery):
    slow = [battery.raw(b"GET /api/v1/health HTTP/1.1\r\nHost: x\r\n") for _ in range(50)]
    silent = [battery.raw(b"") for _ in range(50)]
    deadline = time.monotonic() + ANSWER_S
    pending = list(slow)
    while pending and time.monotonic() < deadline:
        still = [s for s in pending if not answered(s)]
        for s in still:  # one more header line each, never to a socket the agent has answered
            s.sendall(b"X-Slow: 1\r\n")
        assert battery.get("/status", "viewer").status_code == 200  # served while they dribble
        pending = still
        time.sleep(0.5)
    assert not pending, f"{len(pending)} slowloris connections still open after {ANSWER_S} s"
    for s in slow:
        status, headers, body = read_response(s)
        assert status == 408 and b"header_timeout_s" in body
        assert headers["x-frame-options"] == "DENY" and "default-src 'self'" in headers["content-security-policy"]
        s.close()
    for s in silent:  # nothing sent: closed without an answer
        assert s.recv(100) == b""
        s.close()


def test_a_stalled_body_gets_408_and_a_trickled_one_too(battery):
    s = battery.raw(
        b"POST /api/v1/tokens HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
        b"Authorization: Bearer " + battery.tokens["admin"].encode() + b"\r\nContent-Length: 100\r\n\r\n{\"na"
    )
    status, headers, body = read_response(s)
    s.close()
    assert status == 408 and b"no byte for 2 s (body_idle_s)" in body
    assert headers["x-content-type-options"] == "nosniff"  # the security headers, as on every answer
    s = battery.raw(
        b"POST /api/v1/tokens HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
        b"Authorization: Bearer " + battery.tokens["admin"].encode() + b"\r\nContent-Length: 100\r\n\r\n"
    )
    answer = None
    for _ in range(100):  # one byte a second: never idle for body_idle_s, yet never done
        try:
            s.sendall(b" ")
        except OSError:
            break
        s.settimeout(1)
        try:
            answer = s.recv(65536, socket.MSG_PEEK)
            break
        except TimeoutError:
            pass
    s.settimeout(ANSWER_S)
    assert answer, "the trickled body was never answered"
    status, _, body = read_response(s)
    s.close()
    assert status == 408 and b"within 4 s (body_timeout_s)" in body


def test_a_stalled_upload_gets_408_and_stores_nothing(battery):
    body, ctype = files_body({"module.xml": module_xml(("a.so", "thread"))})
    s = battery.raw(
        f"POST /api/v1/sets HTTP/1.1\r\nHost: x\r\nContent-Type: {ctype}\r\nAuthorization: Bearer "
        f"{battery.tokens['admin']}\r\nContent-Length: {len(body) + 100}\r\n\r\n".encode()
        + body[:-20]
    )
    status, _, answer = read_response(s)
    s.close()
    assert status == 408 and b"body_idle_s" in answer
    assert not any((battery.data / "tmp").iterdir())
    refusals = ("refused", "refusals_suppressed")  # the battery's other refusals, interleaved
    last = [e for e in battery.get("/audit?limit=100").json() if e["action"] not in refusals][-1]
    assert last["action"] == "upload" and last["status"] == 408


# ---- many connections -----------------------------------------------------------------------------
def ws_handshake(port: int, path: str) -> bytes:
    return (
        f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"
    ).encode()


def test_a_thousand_idle_websockets_do_not_stop_the_agent_serving_others(battery):
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft < 1200:
        resource.setrlimit(resource.RLIMIT_NOFILE, (min(4096, hard), hard))
    idle = []
    try:
        for _ in range(1000):
            s = battery.raw(ws_handshake(battery.port, f"{API}/stream"))
            idle.append(s)
        for s in idle:
            head = b""
            while b"\r\n\r\n" not in head:
                chunk = s.recv(4096)
                assert chunk, "an idle WebSocket was refused at the handshake"
                head += chunk
            assert head.startswith(b"HTTP/1.1 101"), head[:100]
        # All 1000 are open and silent: the others are still served, and a stream still streams.
        assert battery.get("/health", None).json()["agent"] == "ok"
        assert battery.get("/status", "viewer").status_code == 200
        with connect(
            f"ws://127.0.0.1:{battery.port}{API}/stream",
            additional_headers=battery.h("viewer"),
            open_timeout=ANSWER_S,
            max_size=None,
        ) as ws:
            ws.send(json.dumps({"subscribe": ["knu.Robot.tick"]}))
            kinds = set()
            while bytes not in kinds:
                kinds.add(type(ws.recv(timeout=ANSWER_S)))
        # They never sent a token: each is closed with 4401 after the stream's AUTH_TIMEOUT_S.
        for s in idle:
            frame = b""
            while len(frame) < 4:
                chunk = s.recv(4096)
                assert chunk, "closed without a close frame"
                frame += chunk
            assert frame[0] == 0x88 and int.from_bytes(frame[2:4], "big") == 4401, frame[:40]
    finally:
        for s in idle:
            s.close()
    assert battery.get("/status", "viewer").status_code == 200


def test_beyond_max_connections_the_agent_answers_503_with_retry_after(tmp_path):
    config = tmp_path / "agent.json"
    config.write_text(json.dumps({"max_connections": 20, "header_timeout_s": 30}))
    port = free_port()
    agent = start_agent(port, tmp_path / "data", tmp_path / "no-irpd.sock", "--config", str(config))
    held = []
    try:
        for _ in range(20):
            s = socket.create_connection(("127.0.0.1", port))
            held.append(s)
        time.sleep(0.5)
        s = socket.create_connection(("127.0.0.1", port))
        s.settimeout(ANSWER_S)
        s.sendall(b"GET /api/v1/health HTTP/1.1\r\nHost: x\r\n\r\n")
        status, headers, body = read_response(s)
        s.close()
        assert status == 503 and headers["retry-after"] == "5" and b"max_connections" in body
        for s in held:
            s.close()
        held = []
        time.sleep(0.5)
        assert httpx.get(f"http://127.0.0.1:{port}{API}/health", timeout=ANSWER_S).status_code == 200
    finally:
        for s in held:
            s.close()
        stop(agent)


# ---- names ----------------------------------------------------------------------------------------
TRAVERSALS = [
    f"../{MARKER}",
    f"/tmp/{MARKER}-abs",
    f"%2e%2e/{MARKER}",
    f"%2E%2E%2F{MARKER}",
    f"lib/../../{MARKER}",
    f"..\\{MARKER}",
    f"lib/{MARKER}\0.so",
    f"{MARKER}\n.txt",
    f"\x1b[2J{MARKER}.txt",
    f"..%2f{MARKER}",
    f"....//{MARKER}/../../x",
]


@pytest.mark.parametrize("name", TRAVERSALS, ids=repr)
def test_traversal_names_in_uploads_are_400_naming_the_file(battery, name):
    body, ctype = multipart([("files", "module.xml", module_xml(("a.so", "thread"))), ("files", name, b"x")])
    r = battery.request("POST", "/sets", content=body, headers={"Content-Type": ctype})
    assert r.status_code == 400, (r.status_code, r.text)
    text = detail(r)
    assert "file name" in text and any(
        w in text for w in ("..", "absolute", "percent-escape", "backslash", "NUL", "control character")
    ), text


def link(name: str, target: str, kind=tarfile.SYMTYPE) -> tarfile.TarInfo:
    info = tarfile.TarInfo(name)
    info.type, info.linkname = kind, target
    return info


def device(name: str, kind) -> tarfile.TarInfo:
    info = tarfile.TarInfo(name)
    info.type, info.devmajor, info.devminor = kind, 1, 3
    return info


ARCHIVES = {
    "member ../": ([(f"../{MARKER}", b"x")], "'..'"),
    "absolute member": ([(f"/tmp/{MARKER}-abs", b"x")], "absolute"),
    "symlink out": ([link("lib", "/tmp"), (f"lib/{MARKER}", b"x")], "symbolic link"),
    "symlink to file": ([link("module.xml", "/etc/passwd")], "symbolic link"),
    "hard link": ([link("module.xml", "/etc/passwd", tarfile.LNKTYPE)], "hard link"),
    "char device": ([device("null", tarfile.CHRTYPE)], "device file"),
    "block device": ([device("disk", tarfile.BLKTYPE)], "device file"),
    "fifo": ([device("pipe", tarfile.FIFOTYPE)], "FIFO"),
    "percent member": ([(f"%2e%2e/{MARKER}", b"x")], "percent-escape"),
    "backslash member": ([(f"..\\{MARKER}", b"x")], "backslash"),
}


@pytest.mark.parametrize("case", sorted(ARCHIVES))
def test_links_devices_and_traversal_inside_archives_are_400(battery, case):
    members, words = ARCHIVES[case]
    archive = tar_gz([("module.xml", module_xml(("a.so", "thread")))] + members, format=tarfile.GNU_FORMAT)
    for content, ctype in ((archive, "application/gzip"), multipart([("archive", "set.tar.gz", archive)])):
        r = battery.request("POST", "/sets", content=content, headers={"Content-Type": ctype})
        assert r.status_code == 400 and words in detail(r), (case, r.status_code, r.text)


@pytest.mark.parametrize(
    "path",
    [
        "/sets/..%2f..%2f..%2fetc%2fpasswd",
        "/sets/%2e%2e",
        "/sets/x%00y",
        "/variables/..%2f..%2fetc%2fpasswd",
        "/modules/..%2f..",
        "/tokens/%2e%2e%2f",
        "/audit/../../etc/passwd",
        "/../../../etc/passwd",
        "/sets/%252e%252e",
        "/opcua/certificates/..%2f..%2fusers.json/trust",
        "/opcua/certificates/%2e%2e",
    ],
)
def test_traversal_in_url_paths_reaches_nothing(battery, path):
    r = battery.get(path, "admin", follow_redirects=False)
    if r.is_redirect:  # a trailing slash dropped: still under the API
        assert r.headers["location"].startswith(battery.url), r.headers["location"]
        return
    assert r.status_code in (400, 404, 405), (path, r.status_code, r.text)
    assert "root:" not in r.text


# ---- text that reaches a log ----------------------------------------------------------------------
HOSTILE_TEXT = [
    "%s%s%s%n%n",
    "{0.__class__}",
    "${jndi:ldap:x}",
    "\x1b[31mred\x1b[0m",
    "line\nforged: entry",
    "cr\rforged",
    "%x" * 20,
]


def audit_lines(battery) -> list[str]:
    return (battery.data / "audit.jsonl").read_text().split("\n")[:-1]


@pytest.mark.parametrize("text", HOSTILE_TEXT, ids=repr)
def test_hostile_text_in_token_names_is_422_naming_the_field(battery, text):
    r = battery.request("POST", "/tokens", json={"name": text, "role": "viewer"})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"] == ["body", "name"]


@pytest.mark.parametrize("text", HOSTILE_TEXT, ids=repr)
def test_hostile_user_names_are_422_naming_the_field_and_reach_the_audit_log_as_data_when_signing_in(battery, text):
    r = battery.request("POST", "/users", json={"name": text, "role": "viewer", "password": "long enough password"})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"] == ["body", "name"], r.text
    assert "lowercase letters" in r.json()["detail"][0]["msg"]
    before = len(audit_lines(battery))
    source = f"127.0.2.{HOSTILE_TEXT.index(text) + 1}"  # an address of its own: no lockout from the others
    r = battery.request("POST", "/session", None, source=source, json={"name": text, "password": "guess"})
    assert r.status_code == 401 and "wrong user name or password" in detail(r)
    assert "set-cookie" not in r.headers
    lines = audit_lines(battery)[before:]
    assert len(lines) == 1, lines  # one line, whatever newlines the name holds
    assert "\x1b" not in lines[0] and "\r" not in lines[0] and lines[0].isascii()
    entry = json.loads(lines[0])
    assert (entry["action"], entry["target"], entry["result"], entry["client"]) == ("sign_in", text, "error", source)


def test_a_password_guessing_flood_is_slowed_locked_out_and_never_a_5xx(battery):
    """Many addresses guessing one user's password at once: the name locks after signin_attempts,
    at most password_hash_slots checks run at once (the others wait, or get 503), every answer is
    401, 429 or 503, and the agent serves the others meanwhile; the user's right password is
    refused while the name is locked, another user signs in."""
    import concurrent.futures

    passwords = {"victim": "guarded secret 1", "bystander": "another secret 22"}
    for name, password in passwords.items():
        r = battery.request("POST", "/users", json={"name": name, "role": "viewer", "password": password})
        assert r.status_code == 201, r.text

    def guess(i: int) -> int:  # not in battery.answers: 503 is this flood's designed answer
        transport = httpx.HTTPTransport(local_address=f"127.0.3.{i % 50 + 1}")
        with httpx.Client(transport=transport, timeout=ANSWER_S) as c:
            return c.post(f"{battery.url}/session", json={"name": "victim", "password": f"guess-{i}"}).status_code

    with concurrent.futures.ThreadPoolExecutor(32) as pool:
        started = time.monotonic()
        codes = list(pool.map(guess, range(100)))
        assert battery.get("/status", "viewer").status_code == 200
    assert set(codes) <= {401, 429, 503}, codes
    assert codes.count(401) <= 5 + 32, codes  # signin_attempts, and those already checking when it locked
    assert codes.count(429) >= 50, codes
    r = battery.request(
        "POST", "/session", None, source="127.0.3.200", json={"name": "victim", "password": passwords["victim"]}
    )
    assert r.status_code == 429 and 0 < int(r.headers["Retry-After"]) <= 300, r.text
    r = battery.request(
        "POST", "/session", None, source="127.0.3.201", json={"name": "bystander", "password": passwords["bystander"]}
    )
    assert r.status_code == 200 and r.json()["signed_in"], r.text
    lockouts = [e for e in battery.get("/audit?limit=1000").json() if e["action"] == "lockout"]
    assert any(e["target"] == "victim" for e in lockouts)
    print(f"flood: {len(codes)} guesses in {time.monotonic() - started:.1f} s: {sorted(set(codes))}")


@pytest.mark.parametrize("text", HOSTILE_TEXT, ids=repr)
def test_hostile_text_in_variable_paths_and_module_names_is_answered_and_audited_escaped(battery, text):
    before = len(audit_lines(battery))
    quoted = urllib.parse.quote(text, safe="")
    r = battery.request("PUT", f"/variables/{quoted}", "operator", json={"value": 1})
    assert r.status_code in (404, 409) and detail(r), (r.status_code, r.text)
    r = battery.request("PATCH", f"/modules/{quoted}", "operator", json={"period_ns": 1000000})
    assert r.status_code in (404, 409) and detail(r), (r.status_code, r.text)
    r = battery.get("/jitter/histograms", "viewer", params={"name": text})
    assert r.status_code in (404, 422)
    lines = audit_lines(battery)
    # One line per audited refusal, however many newlines the text holds (a path with a newline
    # matches no route of PUT /variables: that 404 comes from the router, unaudited).
    assert len(lines) == before + (1 if "\n" in text else 2)
    for line in lines[before:]:
        assert "\x1b" not in line and "\r" not in line
        entry = json.loads(line)
        assert entry["target"] == text and entry["result"] == "error"


@pytest.mark.parametrize("text", ["%s%n{0.__class__}", "\x1b[31mred", "two\nlines", "nul\0byte"], ids=repr)
def test_hostile_module_names_in_an_uploaded_module_xml_are_400_or_kept_as_data(battery, text):
    escaped = "".join(f"&#{ord(c)};" if ord(c) < 0x20 or c in "<&" else c for c in text)
    xml = module_xml(("a.so", "thread")).replace(b"<filename>", f"<name>{escaped}</name><filename>".encode(), 1)
    body, ctype = files_body({"module.xml": xml})
    r = battery.request("POST", "/sets", content=body, headers={"Content-Type": ctype})
    assert 400 <= r.status_code < 500, (r.status_code, r.text)
    if "\0" in text or "\x1b" in text:  # not allowed in XML 1.0 even as &#N;
        assert r.status_code == 400 and "malformed XML" in detail(r), r.text
    elif any(ord(c) < 0x20 for c in text):
        assert r.status_code == 400 and "control character" in detail(r) and "<name>" in detail(r), r.text
    assert "\x1b" not in output(battery.irpd)


def test_a_set_with_format_strings_in_its_file_names_is_stored_and_its_names_stay_data(battery, elves):
    name = "%s%n{0.__class__}${x}.txt"
    body, ctype = files_body({"module.xml": module_xml(("ctl.so", "thread")), "ctl.so": elves.module, name: b"x"})
    r = battery.request("POST", "/sets", content=body, headers={"Content-Type": ctype})
    assert r.status_code == 201, r.text
    assert name in [f["path"] for f in r.json()["files"]]
    assert json.loads(audit_lines(battery)[-1])["files"][name]


SCOPE = {
    "capture": {"variables": ["knu.Robot.tick"], "trigger": {"kind": "manual"}, "pre": {"rows": 1}, "post": {"rows": 1}}
}


@pytest.mark.parametrize(
    "name",
    [f"..%2f{MARKER}", f"%2e%2e%2f%2e%2e%2f%2e%2e%2f{MARKER}", f"{MARKER}%00", f"..%5c{MARKER}", f"x/../../{MARKER}"],
    ids=repr,
)
def test_trace_configuration_names_that_could_be_paths_are_400_and_write_nothing(battery, name):
    set_id = battery.get("/sets").json()[0]["id"]  # the set the test above stored
    r = battery.request("PUT", f"/sets/{set_id}/scopes/{name}", "operator", json=SCOPE)
    assert r.status_code in (400, 404), (r.status_code, r.text)
    if r.status_code == 400:
        assert "is not allowed" in detail(r)
    r = battery.request("PUT", f"/sets/{set_id}/scopes/good", "operator", json=SCOPE)
    assert r.status_code == 200, r.text
    assert (battery.data / "sets" / set_id / "scopes" / "good.json").is_file()


@pytest.mark.parametrize(
    "thumbprint",
    [f"..%2f..%2f{MARKER}", "%2e%2e", "..%2fusers.json", f"{'a' * 40}%00", "a" * 41, "A" * 40 + "%2f.."],
    ids=repr,
)
def test_opcua_thumbprints_that_could_be_paths_are_400_or_404_and_move_nothing(battery, thumbprint):
    for method, path in (("POST", "trust"), ("POST", "reject"), ("DELETE", "")):
        r = battery.request(method, f"/opcua/certificates/{thumbprint}{'/' + path if path else ''}", "admin")
        assert r.status_code in (400, 404, 405), (method, path, r.status_code, r.text)
        if r.status_code == 400:
            assert "hexadecimal digits" in detail(r)
    assert not (battery.data / "opcua").exists()  # the agent makes no OPC UA folder of its own


# ---- afterwards -----------------------------------------------------------------------------------
def marked(roots: list[Path]) -> list[str]:
    """Paths under `roots` (not following links) whose name holds MARKER: what an attack wrote."""
    found = []
    for root in roots:
        for folder, dirs, files in os.walk(root, onerror=lambda e: None):
            dirs[:] = [d for d in dirs if d not in (".git", "node_modules", ".venv", "build")]
            found += [os.path.join(folder, n) for n in dirs + files if MARKER in n]
    return found


def test_after_the_battery_nothing_was_written_outside_the_data_dir_no_5xx_and_irpd_runs(battery):
    assert [a for a in battery.answers if a[1] >= 500] == []
    roots = [Path("/tmp"), ROOT / "agent", ROOT / "tests", battery.tmp, Path.cwd(), Path("/var/tmp")]
    assert marked(roots) == []
    assert not list((battery.data / "tmp").iterdir())  # no upload left half-received
    outside = {p.name for p in battery.data.iterdir()} - {
        "tokens.json",
        "admin-token",
        "audit.jsonl",
        "blobs",
        "sets",
        "tmp",
        "active.json",
        "active",
        "history.jsonl",
        "users.json",
        "sessions.json",
        "alarms.sqlite3",  # and SQLite's write-ahead log beside it
        "alarms.sqlite3-wal",
        "alarms.sqlite3-shm",
        "recordings",  # the recorder's folder (docs/recorder.md)
        "captures",  # the triggered captures' shots and captures.json (docs/recorder.md)
        "opcua-token",  # the OPC UA server's credential at the agent, made at its start (docs/opcua.md)
    }
    assert outside == set(), outside
    for line in audit_lines(battery):
        json.loads(line)  # every line whole
    assert battery.irpd.poll() is None and battery.agent.poll() is None
    status = battery.get("/status").json()
    assert status["running"] and status["basic_period_ns"] == battery.status_before["basic_period_ns"]
    after = battery.get("/jitter").json()
    figures = {}
    for key in ("executors", "modules"):
        for b, a in zip(battery.stats_before[key], after[key]):
            figures[a["name"]] = {k: (a.get(k) or 0) - (b.get(k) or 0) for k in ("runs", "overruns", "missed")}
    assert figures["dispatcher"]["runs"] > 0
    (battery.tmp / "rt-during-battery.json").write_text(
        json.dumps(
            {"during_battery": figures, "jitter_max_ns_after": after["executors"][0]["jitter_ns"]["max"]}, indent=1
        )
    )
    print("irpd during the battery:", json.dumps(figures["dispatcher"]))

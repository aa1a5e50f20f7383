# client_helpers.py -- what the client and irpctl tests run against: a real irpd + agent on loopback
# (Cell, as in tests/python/agent/test_agent.py), a WebSocket peer speaking the contract's stream
# protocol (StreamServer), and the contract's v2 routes with canned answers (FakeAgent).
from __future__ import annotations

import asyncio
import contextlib
import itertools
import json
import os
import shutil
import ssl
import struct
import subprocess
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from urllib.parse import urlsplit

import httpx
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import FIG1, IRPD, ROOT, free_port, start_agent, start_irpd, stop  # noqa: E402,F401

FIG1_DIR = FIG1.parent

sys.path.insert(0, str(ROOT / "agent"))  # the package, also when it is not pip-installed
from indurop_agent.api import stream_frame_spec as spec  # noqa: E402

_instances = itertools.count()


class Cell:
    """irpd on the paper's Figure 1 set and an agent in front of it, both on this machine."""

    def __init__(self, tmp: Path):
        if not IRPD.exists():
            pytest.skip(f"irpd is not built ({IRPD}); bash packaging/build.sh")
        self.tmp = tmp
        self.sock = tmp / "irpd.sock"
        self.data = tmp / "data"
        self.instance = f"client-test-{os.getpid()}-{next(_instances)}"
        self.irpd = self.start_irpd()
        port = free_port()
        self.url = f"http://127.0.0.1:{port}"
        try:
            self.agent = start_agent(port, self.data, self.sock)
        except AssertionError as e:
            self.close()
            pytest.fail(f"the agent did not start: {e}")
        self.token_file = self.data / "admin-token"
        self.token = self.token_file.read_text().strip()

    def start_irpd(self) -> subprocess.Popen:
        return start_irpd(self.sock, FIG1, self.instance)

    def args(self, *argv: str) -> list[str]:
        return ["--url", self.url, "--token-file", str(self.token_file), *argv]

    def close(self) -> None:
        for p in (getattr(self, "agent", None), self.irpd):
            if p is not None:
                stop(p)


# -- a stream server that speaks the contract (WebSocket /api/v1/stream) ------------------------------
GOOD_TOKEN = "good-token"
T0 = 1_000_000_000  # the first sample's time, ns
CHANNELS = {"knu.Robot.tick": "uint32_t", "joint[1].y": "double", "io.ready": "bool"}


def sample_frame(first_seq: int, t_ns: list[int], columns: list[list[float]], dropped: int, kind: int = 1) -> bytes:
    """A binary frame built independently of the client's codec, from the spec's generated constants
    (protocol/stream/frame.json): header, timestamps, then column by column."""
    n = len(t_ns)
    values = {
        "magic": spec.MAGIC,
        "version": spec.VERSION,
        "kind": kind,
        "first_seq": first_seq,
        "count": n,
        "channels": len(columns),
        "dropped": dropped,
    }
    return (
        struct.pack(spec.HEADER_FORMAT, *(values[f] for f in spec.HEADER_FIELDS))
        + struct.pack(f"<{n}q", *t_ns)
        + b"".join(struct.pack(f"<{n}d", *c) for c in columns)
    )


class StreamServer:
    """Answers Authorization: Bearer good-token; refuses other tokens at the handshake (403) or, for "close-me",
    with a 1008 close.  After the subscription it sends the channels, three frames of four samples
    (seq 100..111, t = T0 + (seq - 100) * 100 us * decimation, tick = 10 * seq, joint[1].y = seq / 4,
    io.ready = seq odd; dropped 0, 3, 9), a frame of an unknown kind, and closes normally; a path
    it does not know gets {"error": ...}.  Path "idle" gets channels only.

    It runs websockets' asyncio server on an event loop of its own thread, so that one thread
    reads and writes each connection (an SSL socket must not be used by two threads at once)."""

    def __init__(self, tls: ssl.SSLContext | None = None):
        from websockets.asyncio.server import serve

        self.port = free_port()
        self.subscriptions: list[dict] = []
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()

        async def start():
            return await serve(self.handle, "127.0.0.1", self.port, process_request=self.check, ssl=tls)

        self.server = asyncio.run_coroutine_threadsafe(start(), self.loop).result(10)
        self.url = f"{'https' if tls else 'http'}://127.0.0.1:{self.port}"

    @staticmethod
    def token(request) -> str:
        """The handshake's bearer token (the agent takes none from the URL)."""
        if "token=" in urlsplit(request.path).query:
            raise AssertionError(f"a token in the URL: {request.path}")
        return request.headers.get("Authorization", "").removeprefix("Bearer ")

    def check(self, connection, request):
        if urlsplit(request.path).path != "/api/v1/stream":
            return connection.respond(404, '{"detail": "Not Found"}')
        if self.token(request) not in (GOOD_TOKEN, "close-me"):
            return connection.respond(403, '{"detail": "unknown token"}')
        return None

    async def handle(self, ws):
        if self.token(ws.request) == "close-me":
            await ws.close(1008, "unknown token")
            return
        sub = json.loads(await ws.recv())
        self.subscriptions.append(sub)
        paths = sub["subscribe"]
        if paths == ["idle"]:
            await ws.send(json.dumps({"channels": [{"index": 0, "path": "idle", "type": "double"}]}))
            with contextlib.suppress(Exception):
                await ws.recv()  # until the client goes
            return
        unknown = [p for p in paths if p not in CHANNELS]
        if unknown:
            await ws.send(json.dumps({"error": f"no variable '{unknown[0]}'; GET /api/v1/variables lists them"}))
            await ws.close()
            return
        channels = [{"index": i, "path": p, "type": CHANNELS[p]} for i, p in enumerate(paths)]
        await ws.send(json.dumps({"channels": channels}))
        step = sub.get("decimation", 1)
        dropped = 0
        for f in range(3):
            seqs = [100 + 4 * f + i for i in range(4)]
            values = {
                "knu.Robot.tick": [10.0 * s for s in seqs],
                "joint[1].y": [s / 4 for s in seqs],
                "io.ready": [float(s % 2) for s in seqs],
            }
            dropped += 3 * f
            await ws.send(
                sample_frame(
                    seqs[0], [T0 + 100_000 * step * (s - 100) for s in seqs], [values[p] for p in paths], dropped
                )
            )
        await ws.send(sample_frame(0, [], [], dropped, kind=2))
        await ws.close()

    def close(self):
        async def stop():
            self.server.close()
            await self.server.wait_closed()

        with contextlib.suppress(Exception):
            asyncio.run_coroutine_threadsafe(stop(), self.loop).result(10)
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(5)
        self.loop.close()


# -- an agent of the contract's v2 routes on an httpx mock transport (canned answers) ------------------
SWAP = {
    "set": "/var/lib/indurop/sets/0123456789abcdef/module.xml",
    "set_id": "0123456789abcdef",
    "generation": 3,
    "swap_cycle": 123456,
    "swap_at_ns": 987654321000,
    "kept": ["cntr1", "cntr2", "cntr3"],
    "started": ["cntr4"],
    "stopped": [],
    "missed_periods": 0,
    "variables": {
        "layout": "ab" * 32,
        "added": [],
        "removed": [],
        "moved": [{"path": "cell.n", "from": 64, "to": 256, "reason": "cell.n: int32_t to int16_t may lose values"}],
        "converted": [
            {"path": "cell.fb", "from_type": "cell.fb_t", "to_type": "cell.fb_t", "dropped": ["cell.fb.old"]}
        ],
        "replaced": [],
    },
    "request_to_swap_ns": 12_300_000,
    "total_ns": 45_600_000,
}
WHO = {"id": "a1b2c3d4e5f6", "name": "admin", "role": "admin"}
SCHEDULE = {"basic_period_ns": 100000, "macro_period_ns": 500000, "slots": [{"index": i} for i in range(5)]}


class FakeAgent:
    """Answers the v2 routes as notes/contract-v2 and the agent's models describe them; records
    every request.  A set whose module.xml holds "<period>12<" is not valid."""

    def __init__(self):
        self.requests: list[httpx.Request] = []

    def __call__(self, request: httpx.Request) -> httpx.Response:
        request.read()
        self.requests.append(request)
        path, method = request.url.path.removeprefix("/api/v1"), request.method
        if (method, path) == ("POST", "/sets"):
            bad = b"<period>12<" in request.content
            files = [
                {"path": "module.xml", "sha256": "ab" * 32, "size": 1834, "kind": "module_xml"},
                {"path": "lib/cntr1.so", "sha256": "cd" * 32, "size": 16_400, "kind": "thread_module"},
            ]
            error = "module.xml:13: module 'cntr1': <period>: 12 ns is below the minimum basic period (10000 ns)"
            validation = (
                {"valid": False, "errors": [error], "warnings": [], "schedule": None}
                if bad
                else {"valid": True, "errors": [], "warnings": [], "schedule": SCHEDULE}
            )
            return httpx.Response(
                201,
                json={
                    "id": "0123456789abcdef",
                    "created": "2026-11-22T10:00:00Z",
                    "by": WHO,
                    "files": files,
                    "validation": validation,
                    "active": False,
                },
            )
        if (method, path) == ("GET", "/sets"):
            return httpx.Response(
                200,
                json=[
                    {
                        "id": "0123456789abcdef",
                        "created": "2026-11-22T10:00:00Z",
                        "by": WHO,
                        "files": 9,
                        "valid": True,
                        "active": True,
                    },
                    {
                        "id": "fedcba9876543210",
                        "created": "2026-11-21T09:00:00Z",
                        "by": None,
                        "files": 8,
                        "valid": None,
                        "active": False,
                    },
                ],
            )
        if method == "POST" and path in ("/sets/0123456789abcdef/activate", "/sets/rollback"):
            return httpx.Response(200, json=SWAP)
        if method == "POST" and path.endswith("/activate"):
            return httpx.Response(404, json={"detail": "no set 'nope'; GET /api/v1/sets lists them"})
        if method == "PATCH" and path.startswith("/modules/"):
            body = json.loads(request.content)
            if body.get("period_ns", 10**9) < 10_000:
                return httpx.Response(
                    409,
                    json={
                        "detail": "period_ns: module 'cntr1': period 10 ns is below the "
                        "minimum basic period (10000 ns); nothing was changed"
                    },
                )
            return httpx.Response(200, json={**SWAP, "reports": [SWAP]})
        if method == "PUT" and path.startswith("/variables/"):
            value = json.loads(request.content)["value"]
            return httpx.Response(200, json={"path": path.split("/", 2)[2], "value": value})
        if (method, path) == ("GET", "/events"):
            return httpx.Response(
                200,
                json={
                    "events": [
                        {
                            "source": "irpd",
                            "seq": 4,
                            "time": "2026-11-22T10:00:01Z",
                            "time_ns": 1,
                            "kind": "swap",
                            "module": None,
                            "message": "generation 3",
                        },
                        {
                            "source": "agent",
                            "seq": 7,
                            "time": "2026-11-22T10:00:02Z",
                            "time_ns": 2,
                            "kind": "upload",
                            "module": None,
                            "message": "set 0123456789abcdef uploaded by admin",
                        },
                    ],
                    "next": 5,
                    "agent_next": 8,
                    "dropped": 0,
                    "irpd": "ok",
                },
            )
        if (method, path) == ("GET", "/audit"):
            return httpx.Response(
                200,
                json=[
                    {
                        "time": "2026-11-22T10:00:02Z",
                        "who": WHO,
                        "client": "127.0.0.1",
                        "action": "upload",
                        "target": "0123456789abcdef",
                        "result": "ok",
                    },
                    {
                        "time": "2026-11-22T10:00:03Z",
                        "who": WHO,
                        "client": "127.0.0.1",
                        "action": "activate",
                        "target": "nope",
                        "result": "error",
                        "status": 404,
                        "detail": "no set 'nope'",
                    },
                ],
            )
        return httpx.Response(404, json={"detail": "Not Found"})


# -- TLS: a certificate for 127.0.0.1 and an https server with one route --------------------------------
def tls_context(tmp: Path) -> tuple[ssl.SSLContext, Path]:
    """A server context with a fresh self-signed certificate for 127.0.0.1, and the certificate's
    file (the CA a client needs).  Skips without the openssl command."""
    if not shutil.which("openssl"):
        pytest.skip("the openssl command is not installed (apt-get install openssl)")
    cert, key = tmp / "cert.pem", tmp / "key.pem"
    subprocess.run(
        [
            "openssl",
            "req",
            "-x509",
            "-newkey",
            "rsa:2048",
            "-nodes",
            "-keyout",
            str(key),
            "-out",
            str(cert),
            "-days",
            "1",
            "-subj",
            "/CN=127.0.0.1",
            "-addext",
            "subjectAltName=IP:127.0.0.1",
        ],
        check=True,
        capture_output=True,
    )
    ctx = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
    ctx.load_cert_chain(cert, key)
    return ctx, cert


class HttpsStatus:
    """GET /api/v1/status over https answers {"running": true}."""

    def __init__(self, tls: ssl.SSLContext):
        class Handler(BaseHTTPRequestHandler):
            def do_GET(self):
                found = self.path == "/api/v1/status"
                body = json.dumps({"running": True} if found else {"detail": "Not Found"}).encode()
                self.send_response(200 if found else 404)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *args):
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.server.socket = tls.wrap_socket(self.server.socket, server_side=True)
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)
        self.thread.start()
        self.url = f"https://127.0.0.1:{self.server.server_address[1]}"

    def close(self):
        self.server.shutdown()
        self.server.server_close()
        self.thread.join(5)

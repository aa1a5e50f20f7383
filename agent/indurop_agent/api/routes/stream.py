"""stream.py -- WebSocket /api/v1/stream: every sample of up to 64 shared variables, one per basic
period, from irpd's trace rings, in binary frames a plot can draw directly (docs/trace-and-stream.md).

One hub per agent: it asks irpd (`trace`) for the union of every client's subscription, polls the
rings every 20 ms and gives each client what is new for it.  A client that reads too slowly loses
frames, never the agent's memory: its queue is bounded, and every frame carries the number of
samples the client has lost so far.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import time
from collections import deque
from urllib.parse import urlsplit

from fastapi import APIRouter, WebSocket
from starlette.websockets import WebSocketDisconnect, WebSocketState

from ...access.sessions import COOKIE
from ...irpd.client import IrpdRefused, IrpdUnavailable
from ...irpd.trace import MAX_CHANNELS, TraceError, TraceRead, TraceRing
from .. import stream_frame
from ..deps import AuthFailure, check_session, check_token, session_ended, session_identity

router = APIRouter(tags=["stream"])

# Samples go out as the binary frame of protocol/stream/frame.json (stream_frame.py).

MAX_DECIMATION = 1_000_000
POLL_S = 0.020
MAX_SAMPLES_PER_FRAME = 1024
QUEUE_BYTES = 4 << 20  # frames waiting for one client; beyond it frames are dropped
MAX_CONTROL_MESSAGES = 64  # JSON messages waiting for one client; beyond it the client is closed
MAX_CLIENTS = 32
AUTH_TIMEOUT_S = 10.0
SESSION_RECHECK_S = 2.0  # how soon a WebSocket notices that its session ended
STATS_EVERY_S = 1.0
RECHECK_EVERY_S = 1.0  # irpd restarted, or the traced channels changed under us
CLOSE_UNAUTHENTICATED, CLOSE_FORBIDDEN, CLOSE_LOCKED_OUT, CLOSE_TOO_SLOW, CLOSE_BUSY = 4401, 4403, 4429, 1008, 1013


def error(code: str, message: str) -> dict:
    return {"error": {"code": code, "message": message}}


def multiples(a: int, b: int, n: int) -> int:
    """How many seq in [a, b] a client with decimation n would have received."""
    return b // n - (a - 1) // n if b >= a else 0


class Client:
    """One WebSocket: its subscription, its bounded queue, its drop counter."""

    def __init__(self, ws: WebSocket):
        self.ws = ws
        self.paths: list[str] = []
        self.decimation = 1
        self.stats = False
        self.started = False  # a row carrying all its channels has been seen since it subscribed
        self.dropped = 0
        self.sent_frames = self.sent_samples = 0
        self.queue: deque = deque()  # bytes (a frame) or dict (a JSON message), in send order
        self.queued_bytes = 0
        self.queued_messages = 0
        self.pending_stats: dict | None = None  # a stats message still queued: updated in place
        self.wake = asyncio.Event()
        self.closing: tuple[int, str] | None = None

    # ---- what the hub hands over (on the event loop, never blocking) --------------------------
    def post(self, message: dict) -> None:
        if self.queued_messages >= MAX_CONTROL_MESSAGES:
            self.closing = (CLOSE_TOO_SLOW, "the client does not read its messages")
        else:
            self.queue.append(message)
            self.queued_messages += 1
        self.wake.set()

    def post_stats(self, snapshot: dict) -> None:
        if self.pending_stats is not None:
            self.pending_stats["stats"] = snapshot
            return
        self.pending_stats = {"stats": snapshot}
        self.post(self.pending_stats)

    def lose(self, a: int, b: int) -> None:
        if self.started:
            self.dropped += multiples(a, b, self.decimation)

    def feed(self, read: TraceRead) -> None:
        if not self.paths:
            return
        if read.lost:
            self.lose(read.since + 1, read.since + read.lost)
        n = self.decimation
        for part in read.parts:
            last = part.first_seq + part.count - 1
            index = {c.path: c.index for c in part.config.channels}
            cols = [index.get(p) for p in self.paths]
            if None in cols:  # not (or no longer) traced: before its subscription took effect, or taken away
                self.lose(part.first_seq, last)
                continue
            self.started = True
            s0 = -(-part.first_seq // n) * n  # the first seq divisible by n: decimated streams stay aligned
            if s0 > last:
                continue
            k0 = s0 - part.first_seq
            t = part.t_ns[k0::n]
            columns = [part.columns[i][k0::n] for i in cols]
            for c0 in range(0, len(t), MAX_SAMPLES_PER_FRAME):
                c1 = c0 + MAX_SAMPLES_PER_FRAME
                self.offer(s0 + c0 * n, t[c0:c1], [col[c0:c1] for col in columns])

    def offer(self, first_seq: int, t, columns) -> None:
        if self.queued_bytes + stream_frame.size(len(t), len(columns)) > QUEUE_BYTES:
            self.dropped += len(t)  # the client is slower than the stream
            return
        frame = stream_frame.encode(first_seq, t, columns, self.dropped)
        self.queue.append(frame)
        self.queued_bytes += len(frame)
        self.wake.set()

    # ---- the sending task ---------------------------------------------------------------------
    async def pump(self) -> None:
        while True:
            while not self.queue and not self.closing:
                self.wake.clear()
                await self.wake.wait()
            if self.closing:
                await self.ws.close(*self.closing)
                return
            item = self.queue.popleft()
            if isinstance(item, bytes):
                self.queued_bytes -= len(item)
                await self.ws.send_bytes(item)
                self.sent_frames += 1
                self.sent_samples += stream_frame.count(item)
            else:
                self.queued_messages -= 1
                if item is self.pending_stats:
                    self.pending_stats = None
                await self.ws.send_text(json.dumps(item))


class Hub:
    """The agent's one reader of the trace rings, shared by every stream client."""

    @staticmethod
    def of(app) -> Hub:
        hub = getattr(app.state, "stream_hub", None)
        if hub is None:
            hub = app.state.stream_hub = Hub(app.state.irpd)
        return hub

    def __init__(self, irpd):
        self.irpd = irpd
        self.clients: set[Client] = set()
        self.union: list[str] = []  # what irpd was asked to trace, in channel order
        self.types: dict[str, str] = {}
        self.lock = asyncio.Lock()  # one reconfiguration at a time
        self.ring: TraceRing | None = None
        self.cursor = 0  # the last seq handed to the clients
        self.task: asyncio.Task | None = None
        self.background: set[asyncio.Task] = set()
        self.last_stats = self.last_recheck = 0.0

    # ---- clients --------------------------------------------------------------------------------
    def add(self, client: Client) -> None:
        self.clients.add(client)
        if self.task is None or self.task.done():
            self.task = asyncio.create_task(self.run())

    async def remove(self, client: Client) -> None:
        self.clients.discard(client)
        async with self.lock:
            wanted = self.wanted()
            if wanted != self.union:
                try:
                    await self.configure(wanted)
                except (IrpdRefused, IrpdUnavailable, TraceError):
                    pass  # irpd gone: nothing to narrow

    def wanted(self, client: Client | None = None, paths: list[str] | None = None) -> list[str]:
        """The union of every subscription (client's replaced by paths), keeping the current
        channel order and appending new paths."""
        want: list[str] = []
        for c in self.clients:
            for p in paths if c is client else c.paths:
                if p not in want:
                    want.append(p)
        if client is not None and client not in self.clients:
            want += [p for p in paths if p not in want]
        kept = [p for p in self.union if p in want]
        return kept + [p for p in want if p not in kept]

    def channels_message(self, client: Client, restarted: bool = False) -> dict:
        message = {
            "channels": [{"index": i, "path": p, "type": self.types.get(p)} for i, p in enumerate(client.paths)],
            "decimation": client.decimation,
            "stats": client.stats,
            "frame_version": stream_frame.VERSION,
            "basic_period_ns": self.ring.basic_period_ns if self.ring else None,
            "capacity": self.ring.capacity if self.ring else None,
        }
        if restarted:
            message["restarted"] = True
        return message

    async def subscribe(self, client: Client, message: dict) -> None:
        paths, decimation, stats = message.get("subscribe"), message.get("decimation", 1), message.get("stats", False)
        if not isinstance(paths, list) or not all(isinstance(p, str) for p in paths):
            return client.post(
                error(
                    "bad_request",
                    'send {"subscribe": ["variable path", ...], "decimation": n, '
                    '"stats": false}; "subscribe" must be a list of paths',
                )
            )
        if len(set(paths)) != len(paths):
            twice = next(p for p in paths if paths.count(p) > 1)
            return client.post(error("bad_request", f"'{twice}' is listed twice in \"subscribe\""))
        if isinstance(decimation, bool) or not isinstance(decimation, int) or not 1 <= decimation <= MAX_DECIMATION:
            return client.post(
                error(
                    "bad_request",
                    f'"decimation" must be an integer from 1 to {MAX_DECIMATION} '
                    f"(1: every basic period), not {json.dumps(decimation)}",
                )
            )
        if not isinstance(stats, bool):
            return client.post(error("bad_request", f'"stats" must be true or false, not {json.dumps(stats)}'))
        async with self.lock:
            union = self.wanted(client, paths)
            if len(union) > MAX_CHANNELS:
                return client.post(
                    error(
                        "too_many_channels",
                        f"this subscription would make {len(union)} channels traced for all stream "
                        f"clients together; irpd traces at most {MAX_CHANNELS}",
                    )
                )
            if union != self.union or self.ring is None:
                try:
                    await self.configure(union)
                except IrpdRefused as e:
                    return client.post(error("refused", str(e)))
                except (IrpdUnavailable, TraceError) as e:
                    return client.post(error("irpd_unavailable", str(e)))
            # No await from here on: the channels message precedes every frame of the new subscription.
            client.paths, client.decimation, client.stats, client.started = paths, decimation, stats, False
            client.post(self.channels_message(client))

    # ---- irpd ----------------------------------------------------------------------------------
    async def configure(self, union: list[str]) -> None:
        """Asks irpd to trace `union` (call with the lock held); opens the rings it names."""
        answer = await asyncio.to_thread(self.irpd.request, "trace", channels=union)
        if not isinstance(answer, dict) or not isinstance(answer.get("shm"), str):
            raise TraceError(f"irpd's answer to trace names no shared memory: {answer!r}")
        self.union = list(union)
        self.types = {c["path"]: c["type"] for c in answer.get("channels", [])}
        if self.ring is None or self.ring.name != answer["shm"] or self.ring.replaced():
            fresh = self.ring is not None
            if self.ring is not None:
                self.ring.close()
            self.ring = TraceRing(answer["shm"])
            self.cursor = self.ring.head()
            if fresh:  # irpd restarted: the seq starts again
                for c in self.clients:
                    if c.paths:
                        c.started = False
                        c.post(self.channels_message(c, restarted=True))

    async def recheck(self) -> None:
        """irpd restarted (new, empty rings) or someone else changed the channels: ask again."""
        async with self.lock:
            if not self.union:
                return
            try:
                await self.configure(self.union)
            except (IrpdRefused, IrpdUnavailable, TraceError):
                pass  # try again at the next recheck

    def needs_recheck(self) -> bool:
        if self.ring is None or self.ring.replaced():
            return True
        try:
            config = self.ring.in_force()
        except TraceError:
            return False
        return config is None or not set(self.union) <= set(config.paths)

    async def send_stats(self) -> None:
        try:
            status = await asyncio.to_thread(self.irpd.request, "status")
        except (IrpdRefused, IrpdUnavailable):
            status = None
        for c in self.clients:
            if c.stats:
                c.post_stats(
                    {
                        "stream": {
                            "dropped": c.dropped,
                            "sent_frames": c.sent_frames,
                            "sent_samples": c.sent_samples,
                            "queued_bytes": c.queued_bytes,
                            "decimation": c.decimation,
                            "channels": len(c.paths),
                        },
                        "trace": {
                            "head": self.ring.head() if self.ring else None,
                            "torn_skips": self.ring.torn_skips if self.ring else None,
                            "traced_channels": len(self.union),
                        },
                        "irpd": status,
                    }
                )

    # ---- the poll loop ----------------------------------------------------------------------------
    async def run(self) -> None:
        while self.clients:
            await asyncio.sleep(POLL_S)
            now = time.monotonic()
            ring = self.ring
            if ring is not None:  # synchronous: a reconfiguration cannot swap the rings meanwhile
                read = ring.read_since(self.cursor)
                self.cursor = read.next
                for c in self.clients:
                    c.feed(read)
            if now - self.last_recheck >= RECHECK_EVERY_S:
                self.last_recheck = now
                if self.union and not self.lock.locked() and self.needs_recheck():
                    self.spawn(self.recheck())
            if now - self.last_stats >= STATS_EVERY_S and any(c.stats for c in self.clients):
                self.last_stats = now
                self.spawn(self.send_stats())

    def spawn(self, coroutine) -> None:
        task = asyncio.create_task(coroutine)
        self.background.add(task)  # held until done (the loop keeps only weak references)
        task.add_done_callback(self.background.discard)


def same_origin(headers) -> bool:
    """The page that opened the WebSocket is one of this agent's own (its Origin names the host the
    browser connected to).  Browsers always send Origin with a WebSocket, and send the session
    cookie whichever site's page opens it: without this check another site could read the stream
    in the name of whoever is signed in (cross-site WebSocket hijacking)."""
    origin, host = headers.get("origin"), headers.get("host")
    if not origin or not host:
        return False
    parts = urlsplit(origin)
    return parts.scheme in ("http", "https") and parts.netloc.lower() == host.lower()


async def end_with_session(ws: WebSocket, session_id: str) -> None:
    """Closes a WebSocket signed in by a session cookie (4401) once the session ends: signed out,
    timed out, or its user disabled."""
    state = ws.app.state
    while ws.client_state == WebSocketState.CONNECTED and ws.application_state == WebSocketState.CONNECTED:
        s = state.sessions.find(session_id)
        if s is None or session_identity(state, s) is None:
            with contextlib.suppress(Exception):
                await ws.close(CLOSE_UNAUTHENTICATED, session_ended(state))
            return
        await asyncio.sleep(SESSION_RECHECK_S)


def stop_session_watch(ws: WebSocket) -> None:
    """Ends the watch of authenticate() (call it when the WebSocket's handler ends)."""
    watch = getattr(ws.state, "session_watch", None)
    if watch is not None:
        watch.cancel()


async def authenticate(ws: WebSocket) -> tuple[bool, dict | None]:
    """Who may stay: a viewer's bearer token in the handshake's Authorization header, the browser's
    session cookie (from a page of this agent's origin), or a first message {"token": ...} within
    AUTH_TIMEOUT_S.  Returns whether the client may stay, and that first message (it may carry a
    subscription too).  A token in the URL (?token=) is refused: URLs end up in logs and histories."""
    state = ws.app.state
    address = ws.client.host if ws.client else "unknown"
    if "token" in ws.query_params:
        await ws.close(
            CLOSE_UNAUTHENTICATED,
            '?token= is not accepted; send the token in the Authorization header or a first message {"token": "..."}',
        )
        return False, None
    header = ws.headers.get("authorization", "")
    token, first = (header[7:].strip() if header[:7].lower() == "bearer " else None), None
    session_id = ws.cookies.get(COOKIE) if token is None else None
    if session_id:
        if not same_origin(ws.headers):
            await ws.close(CLOSE_FORBIDDEN, "the session cookie is accepted only from this agent's own pages (Origin)")
            return False, None
        try:
            check_session(state, session_id, "GET", ws.headers, "viewer", touch=False)
        except AuthFailure as e:
            await ws.close(CLOSE_UNAUTHENTICATED if e.status == 401 else CLOSE_FORBIDDEN, e.message)
            return False, None
        ws.state.session_watch = asyncio.create_task(end_with_session(ws, session_id))  # see stop_session_watch
        return True, None
    if token is None:
        try:
            message = await asyncio.wait_for(ws.receive(), AUTH_TIMEOUT_S)
        except TimeoutError:
            message = {"type": "websocket.receive"}
        if message["type"] == "websocket.disconnect":
            return False, None
        try:
            first = json.loads(message.get("text") or "null")
        except ValueError:
            first = None
        token = first.get("token") if isinstance(first, dict) else None
        if not isinstance(token, str):
            await ws.close(
                CLOSE_UNAUTHENTICATED,
                'a viewer token is required: the Authorization header, a first message {"token": "..."}, '
                "or a browser session",
            )
            return False, None
    try:
        check_token(state, address, token, "viewer")
    except AuthFailure as e:
        code = {401: CLOSE_UNAUTHENTICATED, 403: CLOSE_FORBIDDEN}.get(e.status, CLOSE_LOCKED_OUT)
        await ws.close(code, e.message)
        return False, None
    return True, first


@router.websocket("/stream")
async def stream(ws: WebSocket) -> None:
    await ws.accept()
    allowed, first = await authenticate(ws)
    if not allowed:
        return
    hub = Hub.of(ws.app)
    if len(hub.clients) >= MAX_CLIENTS:
        stop_session_watch(ws)
        await ws.close(CLOSE_BUSY, f"at most {MAX_CLIENTS} stream clients at once; try again later")
        return
    client = Client(ws)
    hub.add(client)
    pump = asyncio.create_task(client.pump())
    pump.add_done_callback(lambda t: t.cancelled() or t.exception())  # a send to a closed socket ends it quietly
    try:
        pending = first if isinstance(first, dict) and set(first) - {"token"} else None
        while True:
            if pending is not None:
                if "subscribe" in pending:
                    await hub.subscribe(client, pending)
                else:
                    client.post(
                        error(
                            "bad_request", 'send {"subscribe": ["variable path", ...], "decimation": n, "stats": false}'
                        )
                    )
            message = await ws.receive()
            if message["type"] == "websocket.disconnect" or pump.done():
                break
            try:
                pending = json.loads(message.get("text") or "")
            except ValueError:
                pending = None
            if not isinstance(pending, dict):
                pending = {}
    except (WebSocketDisconnect, RuntimeError):
        pass  # the client went away (RuntimeError: receive after the pump closed it)
    finally:
        pump.cancel()
        stop_session_watch(ws)
        await hub.remove(client)

"""test_stream.py -- WebSocket /api/v1/stream against a real irpd running the paper's Figure 1 set
and a real agent: every sample of knu.Robot.tick (cntr2 adds 10 every 100 us period) arrives in
order without gaps, decimated streams stay aligned, a slow client's drops are counted exactly and
do not touch the others, bad subscriptions and bad tokens are answered, irpd restarting."""

from __future__ import annotations

import base64
import json
import os
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest
from agent_helpers import IRPD, free_port, start_agent, start_irpd, stop
from indurop_agent.api import stream_frame
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")

TICK = "knu.Robot.tick"
U32 = 1 << 32


def decode(frame: bytes) -> dict:
    """A samples frame (docs/trace-and-stream.md §4; the decoder is tested against the spec's vectors
    in test_stream_frame.py)."""
    f = stream_frame.decode(frame)
    return {
        "first": f.first_seq,
        "count": len(f.t_ns),
        "dropped": f.dropped,
        "t": tuple(f.t_ns),
        "columns": [tuple(c) for c in f.columns],
    }


@pytest.fixture
def cell(tmp_path):
    sock = tmp_path / "irpd.sock"
    state = {"irpd": start_irpd(sock), "sock": sock, "tmp": tmp_path}
    port = free_port()
    data = tmp_path / "data"
    agent = start_agent(port, data, sock)
    url = f"http://127.0.0.1:{port}/api/v1"
    admin = (data / "admin-token").read_text().strip()
    viewer = httpx.post(
        f"{url}/tokens", json={"name": "plots", "role": "viewer"}, headers={"Authorization": f"Bearer {admin}"}
    ).json()["token"]
    state.update(ws=f"ws://127.0.0.1:{port}/api/v1/stream", viewer=viewer)
    yield state
    stop(agent)
    stop(state["irpd"])


def bearer(token: str) -> dict:
    return {"Authorization": f"Bearer {token}"}


def open_stream(cell, token=True, sock=None):
    headers = bearer(cell["viewer"]) if token else None
    return connect(cell["ws"], additional_headers=headers, sock=sock, max_size=None, open_timeout=10, close_timeout=1)


def subscribe(ws, paths, decimation=1, stats=False) -> dict:
    """Sends a subscription and returns the agent's first JSON answer (channels or error)."""
    ws.send(json.dumps({"subscribe": paths, "decimation": decimation, "stats": stats}))
    while True:
        m = ws.recv(timeout=10)
        if isinstance(m, str):
            return json.loads(m)


def collect(ws, seconds: float, texts: list | None = None) -> list[dict]:
    frames = []
    until = time.monotonic() + seconds
    while time.monotonic() < until:
        m = ws.recv(timeout=10)
        if isinstance(m, bytes):
            frames.append(decode(m))
        elif texts is not None:
            texts.append(json.loads(m))
    return frames


def samples(frames: list[dict], decimation: int = 1) -> list[tuple[int, int, list[float]]]:
    """(seq, t_ns, values) of every sample, in arrival order."""
    out = []
    for f in frames:
        for k in range(f["count"]):
            out.append((f["first"] + k * decimation, f["t"][k], [c[k] for c in f["columns"]]))
    return out


def test_every_sample_arrives_in_order_without_gaps_at_the_basic_period(cell):
    with open_stream(cell) as ws:
        answer = subscribe(ws, [TICK, "joint[0].x"], stats=True)
        assert answer["channels"] == [
            {"index": 0, "path": TICK, "type": "uint32_t"},
            {"index": 1, "path": "joint[0].x", "type": "double"},
        ]
        basic = answer["basic_period_ns"]
        assert basic == 100_000 and answer["decimation"] == 1
        texts: list = []
        frames = collect(ws, 11.0, texts)
    assert frames and all(f["dropped"] == 0 for f in frames)
    for a, b in zip(frames, frames[1:]):
        assert b["first"] == a["first"] + a["count"], "a gap between frames"
    got = samples(frames)
    assert got[-1][1] - got[0][1] >= 10_000_000_000  # ten seconds of the grid, every period of it
    for (s0, t0, v0), (s1, t1, v1) in zip(got, got[1:]):
        assert s1 == s0 + 1
        periods, rest = divmod(t1 - t0, basic)
        assert periods >= 1 and rest == 0, "due times lie on the basic period's grid"
        # cntr2 ran once in each of those periods: tick tells that no sample is out of place.
        assert (int(v1[0]) - int(v0[0])) % U32 == 10 * periods
    stats = [t["stats"] for t in texts if "stats" in t]
    assert stats, "stats were asked for"
    assert stats[-1]["stream"]["dropped"] == 0 and stats[-1]["stream"]["channels"] == 2
    assert stats[-1]["irpd"]["running"] is True and stats[-1]["trace"]["traced_channels"] == 2


def test_decimated_streams_stay_aligned_with_the_full_one(cell):
    with open_stream(cell) as full, open_stream(cell) as every7:
        assert "channels" in subscribe(full, [TICK])
        assert subscribe(every7, [TICK], decimation=7)["decimation"] == 7
        deadline = time.monotonic() + 1.5
        frames_full, frames_7 = [], []
        while time.monotonic() < deadline:  # read both, so that neither falls behind
            frames_full += collect(full, 0.05)
            frames_7 += collect(every7, 0.05)
    assert frames_7 and all(f["dropped"] == 0 for f in frames_7)
    for a, b in zip(frames_7, frames_7[1:]):
        assert b["first"] == a["first"] + 7 * a["count"]
    decimated = samples(frames_7, 7)
    assert all(seq % 7 == 0 for seq, _, _ in decimated)
    full_by_seq = {seq: (t, v) for seq, t, v in samples(frames_full)}
    common = [(seq, t, v) for seq, t, v in decimated if seq in full_by_seq]
    assert len(common) > 100
    assert all(full_by_seq[seq] == (t, v) for seq, t, v in common)


class RawStream:
    """A WebSocket client on a plain socket with a tiny receive buffer, which reads only when told:
    a client that really stops reading (the websockets client reads ahead in a thread of its own)."""

    def __init__(self, cell):
        host, port = cell["ws"].split("//")[1].split("/")[0].split(":")
        self.sock = socket.socket()
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # before connect: a small window
        self.sock.settimeout(10)
        self.sock.connect((host, int(port)))
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall(
            (
                f"GET /api/v1/stream HTTP/1.1\r\nHost: {host}:{port}\r\nAuthorization: Bearer {cell['viewer']}\r\n"
                f"Upgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                "Sec-WebSocket-Version: 13\r\n\r\n"
            ).encode()
        )
        self.buffer = b""
        while b"\r\n\r\n" not in self.buffer:
            self.buffer += self.sock.recv(4096)
        head, self.buffer = self.buffer.split(b"\r\n\r\n", 1)
        assert head.startswith(b"HTTP/1.1 101"), head

    def send_text(self, text: str) -> None:
        data, mask = text.encode(), os.urandom(4)
        n = len(data)
        length = bytes([0x80 | n]) if n < 126 else bytes([0x80 | 126]) + struct.pack(">H", n)
        self.sock.sendall(bytes([0x81]) + length + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(data)))

    def _take(self, n: int) -> bytes:
        while len(self.buffer) < n:
            chunk = self.sock.recv(1 << 20)
            assert chunk, "the agent closed the connection"
            self.buffer += chunk
        out, self.buffer = self.buffer[:n], self.buffer[n:]
        return out

    def recv(self):
        """The next text (str) or binary (bytes) message (server frames are unmasked, unfragmented)."""
        while True:
            b0, b1 = self._take(2)
            n = b1 & 0x7F
            if n == 126:
                (n,) = struct.unpack(">H", self._take(2))
            elif n == 127:
                (n,) = struct.unpack(">Q", self._take(8))
            payload = self._take(n)
            if b0 & 0x0F == 1:
                return payload.decode()
            if b0 & 0x0F == 2:
                return payload
            assert b0 & 0x0F != 8, f"closed: {payload!r}"  # pings (9) are skipped

    def close(self) -> None:
        self.sock.close()


def test_a_slow_client_counts_exactly_what_it_lost_and_the_others_lose_nothing(cell):
    layout = (
        [TICK]
        + [f"knu.Robot.joints[{j}].{a}" for j in range(10) for a in "xyz"]
        + [f"joint[{j}].{a}" for j in range(6) for a in "xyz"]
    )  # 49 channels: 4 MB/s at 100 us
    slow = RawStream(cell)
    try:
        with open_stream(cell) as fast:
            slow.send_text(json.dumps({"subscribe": layout}))
            while not isinstance(answer := slow.recv(), str):
                pass
            assert len(json.loads(answer)["channels"]) == 49
            assert "channels" in subscribe(fast, [TICK])
            # The slow client reads nothing for 4 s (more than the agent queues and the kernel
            # buffers for it) while the fast one keeps up; then it reads what is left.
            fast_frames = collect(fast, 4.0)
            slow_frames = []
            until = time.monotonic() + 2.0
            while time.monotonic() < until:
                m = slow.recv()
                if isinstance(m, bytes):
                    slow_frames.append(decode(m))
            fast_frames += collect(fast, 0.2)
    finally:
        slow.close()
    assert all(f["dropped"] == 0 for f in fast_frames)
    for a, b in zip(fast_frames, fast_frames[1:]):
        assert b["first"] == a["first"] + a["count"]
    assert slow_frames[-1]["dropped"] > 0, "the slow client should have lost samples"
    # Every sample missing between two frames is in the counter, and nothing else is.
    for a, b in zip(slow_frames, slow_frames[1:]):
        assert b["first"] - (a["first"] + a["count"]) == b["dropped"] - a["dropped"]
    for f in slow_frames:
        ticks = f["columns"][0]
        assert all((int(y) - int(x)) % U32 == 10 for x, y in zip(ticks, ticks[1:]))  # frames themselves are whole


def test_a_token_is_required_in_the_header_or_the_first_message_never_in_the_url(cell):
    with connect(cell["ws"], additional_headers=bearer("not-a-token")) as ws:
        with pytest.raises(ConnectionClosed) as closed:
            ws.recv(timeout=10)
        assert closed.value.rcvd.code == 4401 and closed.value.rcvd.reason == "unknown token"
    with connect(cell["ws"] + f"?token={cell['viewer']}") as ws:  # a good token, in the URL
        with pytest.raises(ConnectionClosed) as closed:
            ws.recv(timeout=10)
        assert closed.value.rcvd.code == 4401 and "?token= is not accepted" in closed.value.rcvd.reason
    with open_stream(cell, token=False) as ws:
        ws.send(json.dumps({"subscribe": [TICK]}))  # no token
        with pytest.raises(ConnectionClosed) as closed:
            ws.recv(timeout=10)
        assert closed.value.rcvd.code == 4401
        assert "token" in closed.value.rcvd.reason
    with open_stream(cell, token=False) as ws:
        ws.send(json.dumps({"token": "wrong"}))
        with pytest.raises(ConnectionClosed) as closed:
            ws.recv(timeout=10)
        assert closed.value.rcvd.code == 4401
    with open_stream(cell, token=False) as ws:  # the token and the subscription in one first message
        ws.send(json.dumps({"token": cell["viewer"], "subscribe": [TICK], "decimation": 2}))
        answer = json.loads(ws.recv(timeout=10))
        assert answer["channels"][0]["path"] == TICK
        assert isinstance(ws.recv(timeout=10), bytes)


def test_guessing_tokens_on_the_stream_locks_the_address_out_as_on_http(cell):
    codes = []
    for _ in range(12):
        with connect(cell["ws"], additional_headers=bearer("guess"), close_timeout=1) as ws:
            with pytest.raises(ConnectionClosed) as closed:
                ws.recv(timeout=10)
            codes.append(closed.value.rcvd.code)
    assert codes[:9] == [4401] * 9 and codes[9:] == [4429] * 3, codes
    with connect(
        cell["ws"], additional_headers=bearer(cell["viewer"]), close_timeout=1
    ) as ws:  # locked out even with a good one
        with pytest.raises(ConnectionClosed) as closed:
            ws.recv(timeout=10)
        assert closed.value.rcvd.code == 4429 and "try again" in closed.value.rcvd.reason
    r = httpx.get(
        cell["ws"].replace("ws://", "http://").replace("/stream", "/status"),
        headers={"Authorization": f"Bearer {cell['viewer']}"},
    )
    assert r.status_code == 429 and int(r.headers["Retry-After"]) > 0


def test_bad_subscriptions_are_answered_and_the_stream_goes_on(cell):
    with open_stream(cell) as ws:
        unknown = subscribe(ws, [TICK, "knu.Robot.nothing"])
        assert unknown["error"]["code"] == "refused"
        assert "no variable 'knu.Robot.nothing'" in unknown["error"]["message"]
        struct_path = subscribe(ws, ["knu.Robot.joints"])
        assert "'knu.Robot.joints' is not a scalar" in struct_path["error"]["message"]
        too_many = subscribe(ws, [f"x{i}" for i in range(65)])
        assert too_many["error"]["code"] == "too_many_channels" and "at most 64" in too_many["error"]["message"]
        assert subscribe(ws, [TICK], decimation=0)["error"]["code"] == "bad_request"
        assert subscribe(ws, [TICK, TICK])["error"]["code"] == "bad_request"
        ws.send("not json")
        assert json.loads(ws.recv(timeout=10))["error"]["code"] == "bad_request"
        assert subscribe(ws, [TICK])["channels"][0]["path"] == TICK
        frames = collect(ws, 0.3)
        assert frames and frames[0]["dropped"] == 0


def test_the_stream_comes_back_when_irpd_restarts(cell):
    with open_stream(cell) as ws:
        assert "channels" in subscribe(ws, [TICK])
        assert collect(ws, 0.3)
        stop(cell["irpd"])
        cell["irpd"] = start_irpd(cell["sock"])
        deadline = time.monotonic() + 15
        while True:
            assert time.monotonic() < deadline, "no restarted channels message"
            m = ws.recv(timeout=10)
            if isinstance(m, str) and json.loads(m).get("restarted"):
                assert json.loads(m)["channels"][0]["path"] == TICK
                break
        frames = collect(ws, 0.5)
    assert frames and frames[0]["first"] < 100_000  # the new irpd's rows
    for a, b in zip(frames, frames[1:]):
        assert b["first"] == a["first"] + a["count"]

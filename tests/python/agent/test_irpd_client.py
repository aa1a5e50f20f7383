"""test_irpd_client.py -- the agent's control-socket client on its own: which hello versions it
accepts (1 and 2), the per-call timeout of long commands, and that a request that timed out is
not sent a second time (irpd may still be carrying out a `load`).  The peer is a small Unix-socket
server in the test that says a given hello and answers, or stays silent, as told."""

from __future__ import annotations

import json
import socket
import threading
import time

import pytest
from indurop_agent.irpd.client import IrpdClient, IrpdUnavailable


class Peer:
    """Serves one hello per connection and answers each request after `delay_s[cmd]` seconds."""

    def __init__(self, path, version=2, delay_s=None):
        self.path, self.version, self.delay_s = str(path), version, delay_s or {}
        self.received: list[str] = []
        self.server = socket.socket(socket.AF_UNIX)
        self.server.bind(self.path)
        self.server.listen()
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self):
        while True:
            try:
                conn, _ = self.server.accept()
            except OSError:
                return
            threading.Thread(target=self._serve, args=(conn,), daemon=True).start()

    def _serve(self, conn):
        try:
            with conn, conn.makefile("rw") as f:
                f.write(json.dumps({"protocol": "indurop-control", "version": self.version, "irpd": "test"}) + "\n")
                f.flush()
                for line in f:
                    req = json.loads(line)
                    self.received.append(req["cmd"])
                    time.sleep(self.delay_s.get(req["cmd"], 0))
                    f.write(json.dumps({"id": req["id"], "ok": True, "result": {"cmd": req["cmd"]}}) + "\n")
                    f.flush()
        except OSError:
            pass  # the client hung up (as after a timeout)

    def close(self):
        self.server.close()


@pytest.fixture
def peer(tmp_path):
    peers = []

    def make(**kw) -> Peer:
        p = Peer(tmp_path / f"irpd{len(peers)}.sock", **kw)
        peers.append(p)
        return p

    yield make
    for p in peers:
        p.close()


@pytest.mark.parametrize("version", [1, 2])
def test_protocol_versions_1_and_2_are_spoken(peer, version):
    p = peer(version=version)
    client = IrpdClient(p.path)
    assert client.request("status") == {"cmd": "status"}
    assert client.version == version


def test_another_version_is_refused_naming_the_ones_spoken(peer):
    p = peer(version=3)
    with pytest.raises(IrpdUnavailable) as e:
        IrpdClient(p.path).request("status")
    assert "version 1 or 2" in str(e.value)


def test_a_per_call_timeout_replaces_the_default_for_that_call(peer):
    p = peer(delay_s={"load": 0.6})
    client = IrpdClient(p.path, timeout_s=0.2)
    assert client.request("load", timeout=2.0) == {"cmd": "load"}  # longer than the default: waits
    start = time.monotonic()
    with pytest.raises(IrpdUnavailable) as e:
        client.request("load", timeout=0.3)
    assert 0.25 < time.monotonic() - start < 1.5
    assert "did not answer 'load' within 0.3 s" in str(e.value)


def test_a_request_that_timed_out_is_not_sent_again_and_the_next_one_works(peer):
    p = peer(delay_s={"load": 1.0})
    client = IrpdClient(p.path, timeout_s=2.0)
    assert client.request("status") == {"cmd": "status"}  # connected: the 0.2 s below is all the load's
    with pytest.raises(IrpdUnavailable):
        client.request("load", timeout=0.2)
    assert client.request("status") == {"cmd": "status"}  # a new connection; no late answer mixed in
    time.sleep(1.0)
    assert p.received.count("load") == 1


def test_a_stopped_irpd_fails_each_caller_after_its_own_timeout_not_after_the_queue(tmp_path):
    # a stopped irpd (SIGSTOP) still accepts connections into its backlog but never says hello
    path = str(tmp_path / "stopped.sock")
    silent = socket.socket(socket.AF_UNIX)
    silent.bind(path)
    silent.listen(16)
    client = IrpdClient(path, timeout_s=2.0)
    queued = [
        threading.Thread(target=lambda: pytest.raises(IrpdUnavailable, client.request, "stats")) for _ in range(5)
    ]
    for t in queued:
        t.start()
    time.sleep(0.1)  # the five hold or wait for the one connection: 10 s of waiting one after another
    start = time.monotonic()
    with pytest.raises(IrpdUnavailable) as e:
        client.request("status", timeout=0.5)
    assert time.monotonic() - start < 1.9, "the call waited behind the queued ones"
    assert "'status' within 0.5 s" in str(e.value)
    for t in queued:
        t.join()
    silent.close()

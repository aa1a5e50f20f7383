"""test_forces_requests.py -- what the agent asks irpd when it answers the variables API
(docs/forcing.md): a relay on irpd's control socket records every command the agent sends; GET
/variables and GET /variables/{path} ask irpd for its `forces` only when its `status` says some
are active, and then flag the forced leaf.  A write to a forced variable is refused by irpd with its
own error code, which the API answers 409 with irpd's reason.  POST /variables/read asks only `forces`."""

from __future__ import annotations

import json
import socket
import threading
from pathlib import Path

import httpx
import pytest
from agent_helpers import IRPD, free_port, start_agent, start_irpd, stop

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")
LEAF = "joint[1].y"


class Relay:
    """A Unix socket in front of irpd's control socket that passes every byte both ways and notes
    the `cmd` of each request line the client sends."""

    def __init__(self, path: Path, irpd_sock: Path):
        self.commands: list[str] = []
        self.server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.server.bind(str(path))
        self.server.listen()
        self.irpd_sock = irpd_sock
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        while True:
            try:
                client, _ = self.server.accept()
            except OSError:
                return
            upstream = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            upstream.connect(str(self.irpd_sock))
            threading.Thread(target=self._pipe, args=(upstream, client, False), daemon=True).start()
            threading.Thread(target=self._pipe, args=(client, upstream, True), daemon=True).start()

    def _pipe(self, src: socket.socket, dst: socket.socket, requests: bool) -> None:
        lines = src.makefile("rb")
        try:
            for line in lines:
                if requests:
                    self.commands.append(json.loads(line).get("cmd", ""))
                dst.sendall(line)
        except OSError:
            pass
        finally:
            dst.close()

    def close(self) -> None:
        self.server.close()


@pytest.fixture
def relayed(tmp_path):
    irpd_sock, relay_sock = tmp_path / "irpd.sock", tmp_path / "relay.sock"
    irpd = start_irpd(irpd_sock)
    relay = Relay(relay_sock, irpd_sock)
    port, data = free_port(), tmp_path / "data"
    agent = start_agent(port, data, relay_sock)
    token = (data / "admin-token").read_text().strip()
    client = httpx.Client(base_url=f"http://127.0.0.1:{port}/api/v1", headers={"Authorization": f"Bearer {token}"})
    yield client, relay
    client.close()
    stop(agent)
    relay.close()
    stop(irpd)


def test_the_variables_api_asks_irpd_for_forces_only_while_some_are_active(relayed):
    api, relay = relayed
    assert api.get("/variables").status_code == 200  # the agent's first requests (its connection)
    relay.commands.clear()
    for _ in range(3):
        listed = api.get("/variables").json()["variables"]
        assert not any(v["forced"] for v in listed)
        assert api.get(f"/variables/{LEAF}").json()["forced"] is False
    assert "status" in relay.commands and "forces" not in relay.commands, relay.commands

    assert api.put(f"/forces/{LEAF}", json={"value": 2.5}).status_code == 200
    relay.commands.clear()
    assert {v["path"]: v["forced"] for v in api.get("/variables").json()["variables"]}[LEAF] is True
    leaf = api.get(f"/variables/{LEAF}").json()
    assert leaf["forced"] is True and leaf["value"] == 2.5
    assert relay.commands.count("forces") == 2, relay.commands

    refused = api.put(f"/variables/{LEAF}", json={"value": 1.0})
    assert refused.status_code == 409, refused.text
    assert "is forced by" in refused.json()["detail"] and "unforce it first" in refused.json()["detail"]

    assert api.delete(f"/forces/{LEAF}", params={"restore": "true"}).status_code == 200
    relay.commands.clear()
    assert api.get(f"/variables/{LEAF}").json()["forced"] is False
    assert "forces" not in relay.commands, relay.commands


def test_a_read_of_many_values_asks_irpd_only_its_forces_and_flags_them(relayed):
    """POST /variables/read (the monitor's and the Watch page's 5 Hz read): one small request to irpd
    per read, `forces` (its flags, and that irpd runs), never `status`: the segment it names is held
    while the connection to irpd is the same one (docs/programming.md "Monitoring")."""
    api, relay = relayed
    paths = [LEAF, "knu.Robot.tick", "joint[0].x"]
    assert api.post("/variables/read", json={"paths": paths}).status_code == 200  # the segment named once
    relay.commands.clear()
    for _ in range(3):
        answer = api.post("/variables/read", json={"paths": paths}).json()
        assert [v["path"] for v in answer["values"]] == paths and not any(v["forced"] for v in answer["values"])
    assert relay.commands == ["forces"] * 3, relay.commands

    assert api.put(f"/forces/{LEAF}", json={"value": 2.5}).status_code == 200
    values = {v["path"]: v for v in api.post("/variables/read", json={"paths": paths}).json()["values"]}
    assert values[LEAF]["forced"] is True and values[LEAF]["value"] == 2.5 and values["joint[0].x"]["forced"] is False
    assert api.delete(f"/forces/{LEAF}", params={"restore": "true"}).status_code == 200
    assert api.post("/variables/read", json={"paths": [LEAF]}).json()["values"][0]["forced"] is False

"""test_system_live.py -- the System page's routes against a REAL irpd and real agent processes on
loopback: GET /system's figures; a restart of irpd from the API brings it back on the active set
(the same process, a managed restart with safe outputs first); the agent's restart ends it with
exit 75 for its supervisor, and is refused without one; a backup taken from one agent restores
onto another (empty) data folder, which the agent applies when it starts again.
docs/administration.md."""

from __future__ import annotations

import json
import time

import httpx
import pytest
from agent_helpers import API, IRPD, free_port, start_agent, start_irpd, stop
from test_sets_irpd import fig1_files

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")
SUPERVISED = {"INDUROP_SUPERVISOR": "test"}  # as packaging/demo.sh says it supervises the agent


class Agent:
    """An agent process on a free port in front of `sock`."""

    def __init__(self, data, sock, env: dict | None = None):
        self.data, self.sock, self.env = data, sock, env
        self.start()

    def start(self) -> None:
        self.port = free_port()
        config = self.data.parent / f"{self.data.name}.json"
        config.write_text(json.dumps({"irpd_poll_s": 0.2}))
        self.process = start_agent(self.port, self.data, self.sock, "--config", str(config), env=self.env)
        self.url = f"http://127.0.0.1:{self.port}{API}"

    def h(self, token: str | None = None) -> dict:
        return {"Authorization": f"Bearer {token or (self.data / 'admin-token').read_text().strip()}"}

    def get(self, path: str, **kw):
        return httpx.get(f"{self.url}{path}", headers=kw.pop("headers", None) or self.h(), timeout=60, **kw)

    def post(self, path: str, **kw):
        return httpx.post(f"{self.url}{path}", headers=kw.pop("headers", None) or self.h(), timeout=60, **kw)

    def exit_code(self, seconds: float = 20) -> int | None:
        try:
            return self.process.wait(seconds)
        except Exception:  # noqa: BLE001 -- still running
            return None


@pytest.fixture
def irpd(tmp_path):
    sock = tmp_path / "irpd.sock"
    p = start_irpd(sock)
    yield sock, p
    stop(p)


@pytest.fixture
def agents():
    started = []
    yield started
    for a in started:
        stop(a.process)


def upload_and_activate(agent: Agent) -> str:
    r = agent.post("/sets", files=fig1_files())
    assert r.status_code == 201, r.text
    set_id = r.json()["id"]
    r = agent.post(f"/sets/{set_id}/activate")
    assert r.status_code == 200, r.text
    return set_id


def test_system_shows_versions_uptimes_and_the_data_folder(irpd, agents, tmp_path):
    sock, _ = irpd
    agent = Agent(tmp_path / "data", sock)
    agents.append(agent)
    r = agent.get("/system")
    assert r.status_code == 200, r.text
    s = r.json()
    assert s["agent"]["pid"] == agent.process.pid and s["agent"]["scheme"] == "http" and s["agent"]["uptime_s"] > 0
    assert s["agent"]["supervisor"] is None  # nothing would start it again
    assert s["irpd"]["reachable"] is True and s["irpd"]["version"] and s["irpd"]["uptime_s"] > 0
    assert s["irpd"]["pid"] == agent.get("/status").json()["pid"]
    assert s["data"]["path"] == str((tmp_path / "data").resolve()) and s["data"]["used_bytes"] > 0
    assert 0 < s["data"]["free_bytes"] <= s["data"]["filesystem_bytes"]
    assert "tokens.json" in {p["name"] for p in s["data"]["parts"]}
    assert s["tls"] is None
    for role in ("viewer", "operator"):
        token = agent.post("/tokens", json={"name": f"t-{role}", "role": role}).json()["token"]
        assert agent.get("/system", headers=agent.h(token)).status_code == 403


def test_a_restart_from_the_api_brings_irpd_back_on_the_active_set(irpd, agents, tmp_path):
    sock, process = irpd
    agent = Agent(tmp_path / "data", sock)
    agents.append(agent)
    active = upload_and_activate(agent)
    before = agent.get("/status").json()
    r = agent.post("/system/restart/irpd")
    assert r.status_code == 200, r.text
    report = r.json()
    assert report["mode"] == "restart" and report["set_id"] == active and report["pid"] == process.pid
    assert report["downtime_ns"] > 0
    after = agent.get("/status").json()
    assert after["pid"] == before["pid"] == process.pid  # the same process: systemd keeps supervising it
    assert after["set_id"] == active and after["last_restart"]["set_id"] == active
    assert after["last_restart"]["fell_back"] is False
    assert after["uptime_ns"] < before["uptime_ns"] + 60e9  # a new image's clock
    assert agent.get("/sets/active").json()["id"] == active  # the store's active set is unchanged
    audit = [json.loads(x) for x in (tmp_path / "data" / "audit.jsonl").read_text().splitlines()]
    entry = [e for e in audit if e["action"] == "irpd_restart"][-1]
    assert entry["result"] == "ok" and entry["target"] == active and entry["downtime_ns"] == report["downtime_ns"]
    events = agent.get("/events").json()["events"]
    assert any(e["kind"] == "irpd_restart" for e in events)


def test_a_restart_before_any_activation_restarts_irpd_on_what_it_runs(irpd, agents, tmp_path):
    sock, process = irpd
    agent = Agent(tmp_path / "data", sock)
    agents.append(agent)
    config = agent.get("/status").json()["set"]
    r = agent.post("/system/restart/irpd")
    assert r.status_code == 200, r.text
    status = agent.get("/status").json()
    assert status["pid"] == process.pid and status["set"] == config and status["last_restart"] is not None


def test_the_agent_restarts_by_exiting_75_for_its_supervisor(irpd, agents, tmp_path):
    sock, _ = irpd
    agent = Agent(tmp_path / "data", sock, env=SUPERVISED)
    agents.append(agent)
    assert agent.get("/system").json()["agent"]["supervisor"] == "test"
    r = agent.post("/system/restart/agent")
    assert r.status_code == 202, r.text
    assert r.json()["restarting"] is True
    assert agent.exit_code() == 75
    entry = json.loads((tmp_path / "data" / "audit.jsonl").read_text().splitlines()[-1])
    assert entry["action"] == "agent_restart" and entry["result"] == "ok"
    agent.start()  # what the supervisor does
    assert agent.get("/health").json()["agent"] == "ok"


def test_the_agent_refuses_to_restart_without_a_supervisor(irpd, agents, tmp_path):
    sock, _ = irpd
    agent = Agent(tmp_path / "data", sock)
    agents.append(agent)
    r = agent.post("/system/restart/agent")
    assert r.status_code == 409 and "supervisor" in r.json()["detail"]
    time.sleep(1)
    assert agent.process.poll() is None


def test_a_backup_restores_onto_another_agents_empty_data_folder(irpd, agents, tmp_path):
    sock, _ = irpd
    source = Agent(tmp_path / "source", sock)
    agents.append(source)
    active = upload_and_activate(source)
    archive = source.get("/system/backup")
    assert archive.status_code == 200, archive.text
    stop(source.process)

    target = Agent(tmp_path / "target", sock, env=SUPERVISED)
    agents.append(target)
    headers = {**target.h(), "Content-Type": "application/gzip"}
    plan = target.post("/system/restore", params={"dry_run": "true"}, content=archive.content, headers=headers)
    assert plan.status_code == 200, plan.text
    assert plan.json()["sets"]["added"] == [active] and plan.json()["active_set"]["after"] == active
    assert target.get("/sets").json() == []  # the dry run changed nothing
    done = target.post("/system/restore", content=archive.content, headers=headers)
    assert done.status_code == 200, done.text
    assert done.json()["restarting"] is True
    assert target.exit_code() == 75
    target.start()  # the supervisor starts it again: the restore is applied first
    token = (tmp_path / "source" / "admin-token").read_text().strip()
    assert target.get("/sets/active", headers=target.h(token)).json()["id"] == active
    assert target.get("/status", headers=target.h(token)).json()["set_id"] == active

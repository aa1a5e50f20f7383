"""test_agent.py -- indurop-agent against a real irpd on loopback: health, token auth, status,
schedule and modules through the control socket, and irpd going away and coming back."""
from __future__ import annotations

import json
import os
import signal
import socket
import stat
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest

ROOT = Path(__file__).resolve().parents[3]
BUILD = Path(os.environ.get("INDUROP_BUILD", ROOT / "build"))
IRPD = BUILD / "bin" / "irpd"
FIG1 = BUILD / "sets" / "paper-fig1" / "module.xml"

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_irpd(tmp: Path, sock: Path) -> subprocess.Popen:
    p = subprocess.Popen([str(IRPD), "--config", str(FIG1), "--control-socket", str(sock),
                          "--instance", f"agent-test-{os.getpid()}"],
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 20
    while not sock.exists():
        assert p.poll() is None, p.stderr.read()
        assert time.monotonic() < deadline, "irpd did not open its control socket"
        time.sleep(0.02)
    return p


def stop(p: subprocess.Popen) -> None:
    if p.poll() is None:
        p.send_signal(signal.SIGTERM)  # by pid
        try:
            p.wait(10)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


@pytest.fixture
def cell(tmp_path):
    sock = tmp_path / "irpd.sock"
    irpd = start_irpd(tmp_path, sock)
    port = free_port()
    data = tmp_path / "data"
    agent = subprocess.Popen([sys.executable, "-m", "indurop_agent", "--host", "127.0.0.1", "--port", str(port),
                              "--data-dir", str(data), "--irpd-socket", str(sock)],
                             cwd=ROOT / "agent", stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    url = f"http://127.0.0.1:{port}/api/v1"
    deadline = time.monotonic() + 20
    while True:
        try:
            if httpx.get(f"{url}/health", timeout=1).status_code == 200:
                break
        except httpx.HTTPError:
            pass
        assert agent.poll() is None, agent.stdout.read()
        assert time.monotonic() < deadline, "the agent did not come up"
        time.sleep(0.05)
    token = (data / "admin-token").read_text().strip()
    state = {"irpd": irpd, "sock": sock, "tmp": tmp_path}
    yield url, token, data, state
    stop(agent)
    stop(state["irpd"])


def test_health_needs_no_token_and_sees_irpd(cell):
    url, *_ = cell
    r = httpx.get(f"{url}/health")
    assert r.status_code == 200
    assert r.json()["irpd"] == "ok" and r.json()["running"] is True


def test_the_first_start_writes_an_admin_token_readable_only_by_its_owner(cell):
    _, token, data, _ = cell
    assert len(token) >= 32
    assert stat.S_IMODE((data / "admin-token").stat().st_mode) == 0o600
    assert token not in (data / "tokens.json").read_text()  # stored hashed


@pytest.mark.parametrize("path", ["/status", "/schedule", "/modules"])
def test_every_route_but_health_needs_a_valid_token(cell, path):
    url, *_ = cell
    assert httpx.get(f"{url}{path}").status_code == 401
    assert httpx.get(f"{url}{path}", headers={"Authorization": "Bearer not-a-token"}).status_code == 401


def test_status_schedule_and_modules_come_from_irpd(cell):
    url, token, *_ = cell
    h = {"Authorization": f"Bearer {token}"}
    status = httpx.get(f"{url}/status", headers=h).json()
    assert status["basic_period_ns"] == 100000 and status["macro_period_ns"] == 500000
    assert status["running"] is True
    schedule = httpx.get(f"{url}/schedule", headers=h).json()
    assert schedule["slots"][0]["modules"] == ["cntr3", "cntr2", "cntr1", "cntr4"]
    assert [s["modules"] for s in schedule["slots"][1:]] == [["cntr3", "cntr2"]] * 4
    modules = httpx.get(f"{url}/modules", headers=h).json()
    assert [m["name"] for m in modules] == ["cntr1", "cntr2", "cntr3", "cntr4", "event1", "visionEvt", "nonReaTime"]
    assert modules[1]["runs"] > 0


def test_the_agent_survives_irpd_going_away_and_reconnects_by_itself(cell):
    url, token, _, state = cell
    h = {"Authorization": f"Bearer {token}"}
    stop(state["irpd"])
    assert httpx.get(f"{url}/health").json()["irpd"] == "unreachable"
    r = httpx.get(f"{url}/status", headers=h)
    assert r.status_code == 503 and "not reachable" in r.json()["detail"]
    state["irpd"] = start_irpd(state["tmp"], state["sock"])
    assert httpx.get(f"{url}/status", headers=h).json()["running"] is True


def test_openapi_is_served_under_api_v1(cell):
    url, *_ = cell
    spec = httpx.get(f"{url}/openapi.json").json()
    assert {"/api/v1/health", "/api/v1/status", "/api/v1/schedule", "/api/v1/modules"} <= set(spec["paths"])

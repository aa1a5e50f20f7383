"""test_alarms_irpd.py -- the alarms of a real agent in front of a REAL irpd on loopback: a process
module killed raises <module>/exited from irpd's events and its restart clears it; irpd stopped
raises agent/irpd_unreachable and irpd back clears it; alarms and their history survive an agent
restart; the alarm segment irpd names is read."""

from __future__ import annotations

import json
import os
import signal
import time
from pathlib import Path

import httpx
import pytest
from agent_helpers import API, FIG1, IRPD, free_port, start_agent, start_irpd, stop

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")


class Cell:
    """Figure 1's irpd and an agent that polls it every 0.2 s and calls irpd unreachable after 1 s."""

    def __init__(self, tmp: Path):
        self.tmp, self.sock, self.data = tmp, tmp / "irpd.sock", tmp / "data"
        self.instance = f"alarms-test-{os.getpid()}-{tmp.name}"
        self.irpd = start_irpd(self.sock, FIG1, self.instance)
        self.config = tmp / "agent.json"
        self.config.write_text(json.dumps({"irpd_poll_s": 0.2, "alarm_unreachable_s": 1.0}))
        self.start_agent()

    def start_agent(self) -> None:
        self.port = free_port()
        self.agent = start_agent(self.port, self.data, self.sock, "--config", str(self.config))
        self.url = f"http://127.0.0.1:{self.port}{API}"
        self.h = {"Authorization": f"Bearer {(self.data / 'admin-token').read_text().strip()}"}

    def alarms(self) -> dict:
        r = httpx.get(f"{self.url}/alarms", headers=self.h, timeout=30)
        assert r.status_code == 200, r.text
        return r.json()

    def history(self, key: str) -> list[dict]:
        r = httpx.get(f"{self.url}/alarms/history", headers=self.h, params={"key": key}, timeout=30)
        return list(reversed(r.json()["transitions"]))

    def wait_for(self, key: str, state: str, seconds: float = 60) -> dict:
        deadline = time.monotonic() + seconds
        while True:
            listed = self.alarms()
            found = {a["key"]: a for a in listed["alarms"]}
            if found.get(key, {}).get("state", "normal") == state:
                return found.get(key, {})
            assert time.monotonic() < deadline, f"{key} is not {state}: {found.get(key)}"
            time.sleep(0.1)

    def process(self, name: str) -> int:
        """The pid of irpd's child running `name`."""
        for task in Path(f"/proc/{self.irpd.pid}/task").iterdir():
            for pid in (task / "children").read_text().split():
                try:
                    if name in Path(f"/proc/{pid}/cmdline").read_bytes().decode(errors="replace"):
                        return int(pid)
                except OSError:
                    continue
        raise AssertionError(f"irpd has no child running {name}")

    def close(self) -> None:
        stop(self.agent)
        stop(self.irpd)
        for leftover in Path("/dev/shm").glob(f"indurop.{self.instance}.*"):
            leftover.unlink(missing_ok=True)


@pytest.fixture
def cell(tmp_path):
    c = Cell(tmp_path)
    yield c
    c.close()


def test_a_killed_process_module_raises_exited_and_its_restart_clears_it(cell):
    pid = cell.process("cntr4.exe")
    os.kill(pid, signal.SIGKILL)
    a = cell.wait_for("cntr4/exited", "cleared_unacknowledged")
    assert a["origin"] == "system" and a["severity"] == "high"
    events = [(t["event"], t["state"]) for t in cell.history("cntr4/exited")]
    assert events == [("raise", "active_unacknowledged"), ("clear", "cleared_unacknowledged")], events
    assert "restarted" in cell.history("cntr4/exited")[-1]["detail"]


def test_irpd_unreachable_is_raised_and_cleared_and_survives_an_agent_restart(cell):
    stop(cell.irpd)
    for leftover in Path("/dev/shm").glob(f"indurop.{cell.instance}.*"):
        leftover.unlink(missing_ok=True)
    a = cell.wait_for("agent/irpd_unreachable", "active_unacknowledged")
    assert cell.alarms()["counts"]["active"] >= 1 and "irpd.sock" in a["detail"]
    cell.irpd = start_irpd(cell.sock, FIG1, cell.instance)
    cell.wait_for("agent/irpd_unreachable", "cleared_unacknowledged")
    before = cell.history("agent/irpd_unreachable")
    stop(cell.agent)
    cell.start_agent()
    kept = {a["key"]: a["state"] for a in cell.alarms()["alarms"]}  # (a loaded machine adds deadline misses)
    assert kept["agent/irpd_unreachable"] == "cleared_unacknowledged"
    assert cell.history("agent/irpd_unreachable") == before
    r = httpx.post(f"{cell.url}/alarms/agent/irpd_unreachable/ack", headers=cell.h, timeout=30)
    assert r.status_code == 200 and r.json()["state"] == "normal", r.text

"""test_alarms_system.py -- the system alarms the agent raises (alarms/system.py): from irpd's
events (overruns and deadline misses beyond their threshold, a process module that exited and was
started again, a fault stop) and irpd unreachable, with clocks the test moves; and through the
watcher of a real agent process whose irpd is not there."""

from __future__ import annotations

import json
import time

import httpx
import pytest
from agent_helpers import API, free_port, start_agent, stop
from indurop_agent.alarms.manager import AlarmManager
from indurop_agent.alarms.store import AlarmStore, HistoryFilter
from indurop_agent.alarms.system import SystemAlarms, Thresholds, event_count

S = 1_000_000_000


class Clocks:
    def __init__(self):
        self.ns = 1_800_000_000 * S
        self.mono = 1000.0

    def advance(self, seconds: float) -> None:
        self.ns += int(seconds * S)
        self.mono += seconds


@pytest.fixture
def system(tmp_path):
    clocks = Clocks()
    manager = AlarmManager(AlarmStore(tmp_path / "alarms.sqlite3", 10_000), clock=lambda: clocks.ns)
    sa = SystemAlarms(manager, Thresholds(10, 5, 10.0, 5.0), clock=lambda: clocks.ns, monotonic=lambda: clocks.mono)
    sa.clocks = clocks
    return sa


def event(clocks: Clocks, kind: str, module: str | None, message: str) -> dict:
    return {"seq": 0, "time_ns": clocks.ns, "kind": kind, "module": module, "message": message}


def state(system: SystemAlarms, key: str) -> str:
    a = system.manager.alarms.get(key)
    return a.state(system.clocks.ns) if a else "normal"


def test_event_counts_are_read_from_irpds_messages():
    assert event_count("12 budget overruns (340 in all)") == 12
    assert event_count("3 deadline misses (3 in all)") == 3
    assert event_count("overran its budget by 120 us") == 1


def test_overruns_beyond_the_threshold_raise_and_a_quiet_spell_clears(system):
    c = system.clocks
    system.events([event(c, "overrun", "cntr1", "9 budget overruns (9 in all)")])
    assert state(system, "cntr1/overruns") == "normal"  # below 10 in a second
    c.advance(1)
    system.events([event(c, "overrun", "cntr1", "25 budget overruns (34 in all)")])
    a = system.manager.alarms["cntr1/overruns"]
    assert a.state(c.ns) == "active_unacknowledged" and a.severity == "medium" and a.value == 25
    assert a.origin == "system" and "25 budget overruns" in a.detail
    c.advance(5)
    system.tick()
    assert state(system, "cntr1/overruns") == "active_unacknowledged"
    c.advance(6)
    system.tick()
    assert state(system, "cntr1/overruns") == "cleared_unacknowledged"
    rows, _ = system.manager.store.query(HistoryFilter(key="cntr1/overruns"), 10)
    assert [r["event"] for r in rows] == ["clear", "raise"] and "below the threshold" in rows[0]["note"]


def test_watchdog_overruns_of_one_second_add_up(system):
    c = system.clocks
    for _ in range(9):
        system.events([event(c, "overrun", "ctl", "overran its budget")])
    assert state(system, "ctl/overruns") == "normal"
    system.events([event(c, "overrun", "ctl", "overran its budget")])
    assert state(system, "ctl/overruns") == "active_unacknowledged"


def test_deadline_misses_have_their_own_threshold(system):
    c = system.clocks
    system.events([event(c, "deadline", "cntr2", "5 deadline misses (5 in all)")])
    assert system.manager.alarms["cntr2/deadline_misses"].severity == "high"


def test_a_process_module_that_exited_and_was_started_again(system):
    c = system.clocks
    system.events([event(c, "process_exit", "cntr4", "killed by signal 9 (SIGKILL)")])
    a = system.manager.alarms["cntr4/exited"]
    assert a.state(c.ns) == "active_unacknowledged" and "SIGKILL" in a.detail
    c.advance(0.1)
    system.events([event(c, "process_restart", "cntr4", "restarted (1 restarts)")])
    assert state(system, "cntr4/exited") == "cleared_unacknowledged"  # an operator still has to see it


def test_a_fault_stop_from_the_event_and_the_status(system):
    c = system.clocks
    system.events([event(c, "stopped", "ctl", "set stopped by a fault of module 'ctl': ...")])
    assert system.manager.alarms["irpd/fault_stop"].severity == "critical"
    system.irpd_answered({"stopped_by_fault": "module 'ctl' overran"})
    assert state(system, "irpd/fault_stop") == "active_unacknowledged"
    system.irpd_answered({"stopped_by_fault": None})
    assert state(system, "irpd/fault_stop") == "cleared_unacknowledged"


def test_a_thread_modules_fault_is_an_alarm_naming_what_it_threw_until_it_runs_again(system):
    c = system.clocks
    text = "threw from run(): main.st:12:9: endless loop? (PROGRAM Main); disabled (enable it to run it again)"
    system.events([event(c, "fault", "Main", text)])
    a = system.manager.alarms["Main/fault"]
    assert a.state(c.ns) == "active_unacknowledged" and a.severity == "high" and a.origin == "system"
    assert "main.st:12:9" in a.detail
    system.modules_now([{"name": "Main", "state": "disabled"}, {"name": "keep", "state": "running"}])
    assert state(system, "Main/fault") == "active_unacknowledged"  # still out
    c.advance(1)
    system.modules_now([{"name": "Main", "state": "running"}])  # enabled again
    assert state(system, "Main/fault") == "cleared_unacknowledged"


def test_a_crash_taken_in_is_an_alarm_naming_the_source_line(system):
    c = system.clocks
    system.events([event(c, "crash", "Main", "irpd pid 7 died of SIGSEGV in module 'Main' ..., at main.st:12 (...)")])
    assert "main.st:12" in system.manager.alarms["Main/fault"].detail
    system.events([event(c, "crash", None, "irpd pid 7 died of SIGSEGV outside any module's code ...")])
    assert [k for k in system.manager.alarms if k.endswith("/fault")] == ["Main/fault"]  # no module: no alarm


def test_irpd_unreachable_after_the_threshold_and_back(system):
    c = system.clocks
    began = c.ns
    system.irpd_failed("irpd is not reachable on /run/indurop/irpd.sock: [Errno 111] Connection refused")
    c.advance(4)
    system.irpd_failed("irpd is not reachable ...")
    assert state(system, "agent/irpd_unreachable") == "normal"  # a restart's short gap is no alarm
    c.advance(1.5)
    system.irpd_failed("irpd is not reachable ...")
    a = system.manager.alarms["agent/irpd_unreachable"]
    assert a.state(c.ns) == "active_unacknowledged" and a.raised_ns == began and "Connection refused" in a.detail
    system.irpd_answered({"stopped_by_fault": None})
    assert state(system, "agent/irpd_unreachable") == "cleared_unacknowledged"


def test_a_restarted_irpd_clears_what_its_predecessor_raised(system):
    c = system.clocks
    system.events([event(c, "process_exit", "cntr4", "exit status 1")])
    system.irpd_restarted("irpd restarted (pid 4242)")
    a = system.manager.alarms["cntr4/exited"]
    assert a.state(c.ns) == "cleared_unacknowledged"
    rows, _ = system.manager.store.query(HistoryFilter(key="cntr4/exited"), 10)
    assert rows[0]["note"] == "irpd restarted (pid 4242)"


def test_a_real_agent_raises_irpd_unreachable_when_there_is_no_irpd(tmp_path):
    config = tmp_path / "agent.json"
    config.write_text(json.dumps({"alarm_unreachable_s": 0.5, "irpd_poll_s": 0.2}))
    port, data = free_port(), tmp_path / "data"
    agent = start_agent(port, data, tmp_path / "no-irpd.sock", "--config", str(config))
    try:
        h = {"Authorization": f"Bearer {(data / 'admin-token').read_text().strip()}"}
        deadline = time.monotonic() + 60
        while True:
            listed = httpx.get(f"http://127.0.0.1:{port}{API}/alarms", headers=h, timeout=10).json()
            keys = [a["key"] for a in listed["alarms"]]
            if "agent/irpd_unreachable" in keys:
                break
            assert time.monotonic() < deadline, listed
            time.sleep(0.1)
        a = listed["alarms"][keys.index("agent/irpd_unreachable")]
        assert a["state"] == "active_unacknowledged" and a["origin"] == "system", a
        assert "no-irpd.sock" in a["detail"] and listed["counts"]["active"] >= 1
    finally:
        stop(agent)

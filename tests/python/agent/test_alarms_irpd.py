"""test_alarms_irpd.py -- the alarms of a real agent in front of a REAL irpd on loopback: a process
module killed raises <module>/exited from irpd's events and its restart clears it; irpd stopped
raises agent/irpd_unreachable and irpd back clears it; alarms and their history survive an agent
restart.  With modules that raise alarms (the C++ tests' alarming.so and proc_alarm.exe): the
alarm segment irpd names is read, a module's alarm comes with its declared text and severity and
goes, what a restarted irpd no longer has active is cleared by reconciliation, and a flood of
transitions from one module is counted, not recorded one by one, and keeps the older history.  A
Structured Text set uploaded to the agent (compiled there) raises and clears its alarms with
st/lib/plcopen.st's ALARM_LEVEL block and RaiseAlarm / ClearAlarm, with the texts its module.xml
declares."""

from __future__ import annotations

import csv
import io
import json
import os
import shutil
import signal
import time
from pathlib import Path

import httpx
import pytest
from agent_helpers import API, BUILD, FIG1, IRPD, free_port, st_configuration, start_agent, start_irpd, stop
from live_processes import module_entry

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")


ALARMING = BUILD / "tests" / "cpp" / "modules" / "alarming.so"  # raises its `ids` while `trigger` exists
PROC_ALARM = BUILD / "tests" / "cpp" / "processes" / "bin" / "proc_alarm.exe"  # args: ID TRIGGER
CHATTER_IDS = 40


def alarm_set(folder: Path, flood: bool = False) -> Path:
    """conveyor (a thread module: alarm 5 while folder/jam exists, declared in module.xml), pump (a
    process module: alarm 7 while folder/pump.off exists) and, with `flood`, chatter: a thread
    module flipping 40 alarms every 1 ms period (40 000 transitions a second, 40 times its source's
    rate limit)."""
    shutil.copy(ALARMING, folder / "alarming.so")
    props = '<property><value name="ids">{}</value><value name="{}">{}</value></property>'
    if flood:
        ids = " ".join(str(i) for i in range(1, CHATTER_IDS + 1))
        modules = module_entry("chatter", "./alarming.so", 1_000_000, 1, props.format(ids, "toggle_every", 1))
    else:
        modules = module_entry(
            "conveyor",
            "./alarming.so",
            2_000_000,
            1,
            props.format(5, "trigger", folder / "jam") + '<alarm id="5" severity="high">Conveyor jammed</alarm>',
        )
    modules += module_entry(
        "pump",
        str(PROC_ALARM),
        2_000_000,
        2,
        f'<property><value name="args">7 {folder / "pump.off"}</value></property><alarm id="7">Pump off</alarm>',
        kind="process",
    )
    (folder / "module.xml").write_text(f"<root>\n{modules}</root>\n")
    return folder / "module.xml"


class Cell:
    """irpd (Figure 1, or `config`) and an agent that polls it every 0.2 s and calls irpd
    unreachable after 1 s; `settings` adds to the agent's."""

    def __init__(self, tmp: Path, config: Path = FIG1, **settings):
        self.tmp, self.sock, self.data = tmp, tmp / "irpd.sock", tmp / "data"
        self.instance = f"alarms-test-{os.getpid()}-{tmp.name}"
        self.set = config
        self.irpd = start_irpd(self.sock, config, self.instance)
        self.config = tmp / "agent.json"
        self.config.write_text(json.dumps({"irpd_poll_s": 0.2, "alarm_unreachable_s": 1.0, **settings}))
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

    def stop_irpd(self) -> None:
        stop(self.irpd)
        for leftover in Path("/dev/shm").glob(f"indurop.{self.instance}.*"):
            leftover.unlink(missing_ok=True)

    def close(self) -> None:
        stop(self.agent)
        self.stop_irpd()


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
    cell.stop_irpd()
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


OVERRUN = BUILD / "tests" / "cpp" / "modules" / "overrun.so"  # spins in run `hang_at`, polling the abort flag


@pytest.mark.skipif(not OVERRUN.exists(), reason=f"the overrun fixture is not built ({OVERRUN})")
def test_an_endless_loop_ended_by_the_watchdog_is_a_fault_alarm_naming_what_it_threw_until_enabled(tmp_path):
    folder = tmp_path / "set"
    folder.mkdir()
    shutil.copy(OVERRUN, folder / "overrun.so")
    loop = (
        "<on_overrun>disable</on_overrun><overrun_limit>2000000</overrun_limit><property>"
        '<value name="hang_at">10</value><value name="hang_ms">60000</value><value name="poll_abort">1</value>'
        "</property>"
    )
    (folder / "module.xml").write_text(f"<root>\n{module_entry('loop', './overrun.so', 10_000_000, 1, loop)}</root>\n")
    cell = Cell(tmp_path, folder / "module.xml")
    try:
        a = cell.wait_for("loop/fault", "active_unacknowledged")
        assert a["origin"] == "system" and a["severity"] == "high"
        assert "endless loop? run 10 ended at the watchdog's request" in a["detail"], a
        r = httpx.patch(f"{cell.url}/modules/loop", headers=cell.h, json={"enabled": True}, timeout=60)
        assert r.status_code == 200, r.text
        cleared = cell.wait_for("loop/fault", "cleared_unacknowledged")
        assert "enabled again" in cell.history("loop/fault")[-1]["note"], cleared
    finally:
        cell.close()


# ---- modules' alarms, from irpd's alarm segment --------------------------------------------------
needs_fixtures = pytest.mark.skipif(
    not (ALARMING.exists() and PROC_ALARM.exists()), reason=f"the alarm fixtures are not built ({ALARMING})"
)


@pytest.fixture
def alarm_cell(tmp_path):
    folder = tmp_path / "set"
    folder.mkdir()
    c = Cell(tmp_path, alarm_set(folder))
    c.folder = folder
    yield c
    c.close()


@needs_fixtures
def test_a_modules_alarm_comes_from_the_segment_with_its_declared_text_and_goes(alarm_cell):
    cell = alarm_cell
    deadline = time.monotonic() + 60
    while (segment := cell.alarms()["segment"])["name"] is None or segment["error"]:
        assert time.monotonic() < deadline, segment
        time.sleep(0.1)
    assert segment["name"] == f"/indurop.{cell.instance}.alarms"
    assert {s["module"] for s in segment["sources"]} >= {"irpd", "conveyor", "pump"}
    (cell.folder / "jam").touch()
    (cell.folder / "pump.off").touch()
    a = cell.wait_for("conveyor/5", "active_unacknowledged")
    assert (a["text"], a["severity"], a["origin"]) == ("Conveyor jammed", "high", "module")
    assert a["detail"].startswith("run ") and a["value"] > 0
    p = cell.wait_for("pump/7", "active_unacknowledged")
    assert (p["text"], p["severity"], p["detail"], p["value"]) == ("Pump off", "medium", "from a process", 42)
    (cell.folder / "jam").unlink()
    cell.wait_for("conveyor/5", "cleared_unacknowledged")
    history = cell.history("conveyor/5")
    assert [(t["event"], t["note"]) for t in history] == [("raise", ""), ("clear", "")]  # from records, in order
    assert history[0]["time_ns"] < history[1]["time_ns"]
    r = httpx.post(f"{cell.url}/alarms/conveyor/5/ack", headers=cell.h, timeout=30)
    assert r.status_code == 200 and r.json()["state"] == "normal", r.text


@needs_fixtures
def test_what_a_restarted_irpd_no_longer_has_active_is_reconciled(alarm_cell):
    cell = alarm_cell
    (cell.folder / "jam").touch()
    cell.wait_for("conveyor/5", "active_unacknowledged")
    cell.stop_irpd()
    (cell.folder / "jam").unlink()  # the new irpd's conveyor never raises it: no record to read
    cell.irpd = start_irpd(cell.sock, cell.set, cell.instance)
    cell.wait_for("conveyor/5", "cleared_unacknowledged")
    last = cell.history("conveyor/5")[-1]
    assert last["event"] == "clear" and last["note"].startswith("reconciled after irpd restarted"), last


@needs_fixtures
def test_a_flood_from_one_module_is_counted_and_keeps_the_older_history(tmp_path):
    folder = tmp_path / "set"
    folder.mkdir()
    (folder / "pump.off").touch()  # pump/7, raised before the flood starts
    cell = Cell(tmp_path, alarm_set(folder), alarm_history_per_s=50)
    try:
        cell.wait_for("pump/7", "active_unacknowledged")
        cell.stop_irpd()
        cell.irpd = start_irpd(cell.sock, alarm_set(folder, flood=True), cell.instance)
        deadline = time.monotonic() + 90
        while True:  # until the rate limit dropped transitions and the agent wrote flood rows
            listed = cell.alarms()
            chatter = [s for s in listed["segment"]["sources"] if s["module"] == "chatter"]
            floods = httpx.get(
                f"{cell.url}/alarms/history", headers=cell.h, params={"module": "chatter", "limit": 1000}, timeout=30
            ).json()["transitions"]
            if chatter and chatter[0]["rate_dropped"] > 0 and any(t["event"] == "flood" for t in floods):
                break
            assert time.monotonic() < deadline, (chatter, len(floods))
            time.sleep(0.5)
        export = httpx.get(f"{cell.url}/alarms/history.csv", headers=cell.h, params={"module": "chatter"}, timeout=60)
        per_second: dict[str, int] = {}
        for row in csv.DictReader(io.StringIO(export.text)):
            if row["event"] in ("raise", "clear"):
                per_second[row["time"][:19]] = per_second.get(row["time"][:19], 0) + 1
        assert per_second and max(per_second.values()) <= 50, per_second
        assert len([a for a in listed["alarms"] if a["module"] == "chatter"]) <= CHATTER_IDS
        assert cell.history("pump/7")[0]["event"] == "raise"  # the older history is still there
        assert listed["segment"]["suppressed"] > 0
    finally:
        cell.close()


# ---- alarms from Structured Text ------------------------------------------------------------------
ST_MAIN = """
PROGRAM Main
VAR
  hot : BOOL;          (* written through the agent: the condition of alarm 12 *)
  jam : BOOL;          (* the condition of alarm 13, raised and cleared by the functions *)
  temperature : LREAL := 81.5;
  Overheat : ALARM_LEVEL;
  overheated : BOOL;
  runs : DINT;
END_VAR
  runs := runs + 1;
  Overheat(IN := hot, Id := 12, Detail := 'over 80 C', Value := temperature, Q => overheated);
  IF jam THEN
    RaiseAlarm(id := 13, detail := 'conveyor', value := DINT_TO_LREAL(runs), severity := AlarmCritical);
  ELSE
    ClearAlarm(13);
  END_IF;
END_PROGRAM
"""
# the ST instance's alarm texts: module.xml's <alarm> declarations on the entry of its file (docs/st.md)
ST_ALARMS = '<alarm id="12" severity="high">Oven overheated</alarm><alarm id="13">Conveyor jammed</alarm>'


def test_an_st_program_raises_and_clears_its_alarms(cell):
    hand = f"<root>\n{module_entry('Main', './Main.so', 2_000_000, 1, ST_ALARMS)}</root>\n"
    files = {"main.st": ST_MAIN, "config.st": st_configuration("Main", "T#2ms"), "module.xml": hand}
    r = httpx.post(f"{cell.url}/sets", headers=cell.h, files=[("files", (p, c)) for p, c in files.items()], timeout=120)
    assert r.status_code == 201, r.text
    r = httpx.post(f"{cell.url}/sets/{r.json()['id']}/activate", headers=cell.h, json={"mode": "auto"}, timeout=120)
    assert r.status_code == 200, r.text

    def write(path: str, value: bool) -> None:
        w = httpx.put(f"{cell.url}/variables/{path}", headers=cell.h, json={"value": value}, timeout=30)
        assert w.status_code == 200, w.text

    write("Main.hot", True)
    a = cell.wait_for("Main/12", "active_unacknowledged")
    assert (a["text"], a["severity"], a["origin"]) == ("Oven overheated", "high", "module"), a
    assert (a["detail"], a["value"]) == ("over 80 C", 81.5), a
    write("Main.jam", True)
    j = cell.wait_for("Main/13", "active_unacknowledged")
    assert (j["text"], j["severity"], j["detail"]) == ("Conveyor jammed", "critical", "conveyor"), j
    assert j["value"] > 0, j
    write("Main.hot", False)
    cell.wait_for("Main/12", "cleared_unacknowledged")
    write("Main.jam", False)
    cell.wait_for("Main/13", "cleared_unacknowledged")
    assert [t["event"] for t in cell.history("Main/12")] == ["raise", "clear"]
    r = httpx.post(f"{cell.url}/alarms/Main/12/ack", headers=cell.h, timeout=30)
    assert r.status_code == 200 and r.json()["state"] == "normal", r.text

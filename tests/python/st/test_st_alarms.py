# test_st_alarms.py -- a Structured Text program raises and clears its module's alarms (st/lib/plcopen.st:
# the ALARM_LEVEL block and RaiseAlarm / ClearAlarm, bound to irp::raiseAlarm / clearAlarm), seen
# through a real agent's alarms API in front of a real irpd, with the texts and severities the set's
# module.xml declares for the ST instance.

from __future__ import annotations

import time

import httpx
from live_processes import API, free_port, module_entry, remove_shm, start_agent, start_irpd, stop
from st_live import stc_build

MAIN = """
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
CONFIG = """
CONFIGURATION Cell
  RESOURCE Cpu ON PLC
    TASK Fast (INTERVAL := T#2ms, PRIORITY := 1);
    PROGRAM Main WITH Fast : Main;
  END_RESOURCE
END_CONFIGURATION
"""
# the ST instance's alarms: module.xml's <alarm> declarations on the entry of its file (docs/st.md)
HAND = (
    "<root>\n"
    + module_entry(
        "Main",
        "Main.so",
        2_000_000,
        1,
        '<alarm id="12" severity="high">Oven overheated</alarm><alarm id="13">Conveyor jammed</alarm>',
    )
    + "</root>\n"
)


class Agent:
    def __init__(self, port: int, data) -> None:
        self.url = f"http://127.0.0.1:{port}{API}"
        self.h = {"Authorization": f"Bearer {(data / 'admin-token').read_text().strip()}"}

    def write(self, path: str, value) -> None:
        r = httpx.put(f"{self.url}/variables/{path}", headers=self.h, json={"value": value}, timeout=30)
        assert r.status_code == 200, r.text

    def wait_for(self, key: str, state: str, seconds: float = 60) -> dict:
        deadline = time.monotonic() + seconds
        while True:
            r = httpx.get(f"{self.url}/alarms", headers=self.h, timeout=30)
            assert r.status_code == 200, r.text
            found = {a["key"]: a for a in r.json()["alarms"]}
            if found.get(key, {}).get("state", "normal") == state:
                return found.get(key, {})
            assert time.monotonic() < deadline, f"{key} is not {state}: {found.get(key)}"
            time.sleep(0.1)


def test_an_st_program_raises_and_clears_its_alarms_seen_through_the_agent(tmp_path):
    (tmp_path / "hand.xml").write_text(HAND)
    r = stc_build(tmp_path, {"main.st": MAIN, "config.st": CONFIG}, "--module-xml", str(tmp_path / "hand.xml"))
    assert r.returncode == 0, r.stdout + r.stderr
    instance = f"st-alarms-{free_port()}"
    irpd = start_irpd(tmp_path / "irpd.sock", tmp_path / "set" / "module.xml", instance, "--no-rt")
    port = free_port()
    agent = None
    try:
        agent_process = start_agent(port, tmp_path / "data", tmp_path / "irpd.sock")
        agent = Agent(port, tmp_path / "data")
        agent.write("Main.hot", True)
        a = agent.wait_for("Main/12", "active_unacknowledged")
        assert (a["text"], a["severity"], a["origin"]) == ("Oven overheated", "high", "module"), a
        assert (a["detail"], a["value"]) == ("over 80 C", 81.5), a
        agent.write("Main.jam", True)
        j = agent.wait_for("Main/13", "active_unacknowledged")
        assert (j["text"], j["severity"], j["detail"]) == ("Conveyor jammed", "critical", "conveyor"), j
        assert j["value"] > 0, j

        agent.write("Main.hot", False)
        agent.wait_for("Main/12", "cleared_unacknowledged")
        agent.write("Main.jam", False)
        agent.wait_for("Main/13", "cleared_unacknowledged")
        r = httpx.post(f"{agent.url}/alarms/Main/12/ack", headers=agent.h, timeout=30)
        assert r.status_code == 200 and r.json()["state"] == "normal", r.text
    finally:
        if agent is not None:
            stop(agent_process)
        stop(irpd)
        remove_shm(instance)

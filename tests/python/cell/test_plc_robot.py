"""test_plc_robot.py -- the paper's §4 cell end to end through irpd: the drive simulator on Modbus
TCP (loopback), irpd running config/sets/plc-robot (libiodispat.so, Robot.so, main.so at 10 ms),
the PLC's inputs written and its outputs read through irpd's shared variables.  Enable -> the
drives power up; Start -> the pick-and-place cycle runs every step, the robot really moves (its
measured joints come back from the simulated drives over Modbus), O0 follows MotionDone and the
cycle counter counts; Stop halts it; the drives going silent -> comm_lost and the robot in error.
The simulator is the set's own non-real process module: irpd starts and stops it.  An agent in
front of the cell reads IO_STATUS, a struct, leaf by leaf (GET /variables/{path}, irpctl read)."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import httpx
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import (  # noqa: E402
    API,
    BUILD,
    ROOT,
    copy_cell,
    dispatching,
    free_port,
    start_agent,
    start_irpd,
    stop,
    wait_until,
)

sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.cli import irpctl as cli  # noqa: E402
from indurop_agent.irpd.client import IrpdClient, IrpdRefused  # noqa: E402
from indurop_agent.irpd.variables import Segment  # noqa: E402

SET = BUILD / "sets" / "plc-robot"
DRIVESIM = SET / "indurop-drivesim"
NS = "PLC_ROBOT."

pytestmark = pytest.mark.skipif(
    not (SET / "Robot.so").exists() or not DRIVESIM.exists(), reason=f"the plc-robot cell is not built ({SET})"
)


class Cell:
    def __init__(self, tmp: Path, extra_drivesim: list[str] | None = None, xml: str = "module.xml"):
        self.tmp = tmp
        self.folder = tmp / "plc-robot"
        self.xml, self.port = copy_cell(self.folder, xml, extra_drivesim)
        self.sock = tmp / "irpd.sock"
        self.irpd = start_irpd(self.sock, self.xml, f"cell-test-{id(self)}")
        self.control = IrpdClient(str(self.sock), timeout_s=30)
        status = self.wait(self.status_once_dispatching)
        self.vars = Segment(status["shared_memory"]["variables"])
        self.wait(lambda: self.read("IO_STATUS.comm_lost[0]") == 0 and self.read("IO_STATUS.cycles") > 0)

    def ask(self, cmd: str, **args):
        return self.control.request(cmd, **args)

    def status_once_dispatching(self) -> dict | None:
        return dispatching(self.control)

    def write(self, path: str, value) -> None:
        self.ask("write", path=NS + path, value=value)

    def read(self, path: str):
        return self.vars.read(NS + path)

    def joints(self, block: str) -> list[float]:
        return [self.read(f"ROBOT_MODULE_STATE.{block}[{i}]") for i in range(6)]

    def wait(self, what, seconds: float = 20.0, every: float = 0.01):
        """Polls what() until it is truthy; returns its value."""
        return wait_until(what, seconds, every)

    def close(self) -> None:
        self.control.close()
        self.vars.close()
        stop(self.irpd)


@pytest.fixture
def cell(tmp_path):
    c = Cell(tmp_path)
    yield c
    c.close()


def test_the_1ms_variant_runs_the_same_cell_every_millisecond(tmp_path):
    cell = Cell(tmp_path, xml="module-1ms.xml")
    try:
        status = cell.ask("status")
        assert status["basic_period_ns"] == 1_000_000
        assert [m["name"] for m in cell.ask("modules")] == ["main", "Robot", "libiodispat", "drivesim"]
        before = cell.read("IO_STATUS.cycles")
        time.sleep(0.5)
        assert cell.read("IO_STATUS.cycles") - before > 250  # every period's I/O round (about 500)
        assert cell.read("ROBOT_MODULE_STATE.nAXESGROUP") == 6
    finally:
        cell.close()


def test_enable_start_runs_the_whole_pick_and_place_cycle_through_modbus(cell):
    assert cell.read("ROBOT_MODULE_STATE.nAXESGROUP") == 6
    cell.write("PLC_IN.Enable", 1)
    cell.wait(lambda: cell.read("ROBOT_MODULE_STATE.Powered") == 1 and cell.read("PLC_OUT.Powered") == 1)
    cell.write("I0", 1)  # the paper's interlock: input 0 starts the motion sequence
    steps, lamp, travel = set(), set(), 0.0
    last = cell.joints("dCurJoint")
    deadline = time.monotonic() + 60
    while cell.read("PLC_OUT.Cycles") < 1:
        assert time.monotonic() < deadline, f"the cycle did not finish; steps seen {sorted(steps)}"
        steps.add(cell.read("PLC_OUT.Step"))
        lamp.add(cell.read("O0"))
        now = cell.joints("dCurJoint")
        travel += sum(abs(a - b) for a, b in zip(now, last))
        last = now
        assert cell.read("PLC_OUT.Error") == 0, cell.read("PLC_OUT.ErrorID")
        time.sleep(0.005)
    cell.write("I0", 0)
    assert len(steps) >= 8, sorted(steps)  # every step of the cycle was visited
    assert lamp == {0, 1}  # O0 followed MotionDone through the moves
    assert cell.read("PLC_OUT.Done") == 1
    # The robot moved: the joints the drives report over Modbus travelled, and ended where commanded.
    assert travel > 1.0, travel
    commanded, measured = cell.joints("dCmdJoint"), cell.joints("dCurJoint")
    assert max(abs(c - m) for c, m in zip(commanded, measured)) < 0.01
    io = cell.read("IO_STATUS.cycles")
    assert io > 100 and cell.read("IO_STATUS.comm_lost[0]") == 0


def test_stop_halts_the_cycle_and_the_robot(cell):
    cell.write("PLC_IN.Enable", 1)
    cell.wait(lambda: cell.read("PLC_OUT.Powered") == 1)
    cell.write("PLC_IN.Start", 1)
    cell.wait(lambda: cell.read("ROBOT_MODULE_STATE.Busy") == 1)
    time.sleep(0.2)
    cell.write("PLC_IN.Stop", 1)
    cell.wait(lambda: cell.read("PLC_OUT.Running") == 0 and cell.read("ROBOT_MODULE_STATE.Busy") == 0)
    halted = cell.joints("dCmdJoint")
    time.sleep(0.3)
    assert cell.joints("dCmdJoint") == halted  # standing still
    assert cell.read("PLC_OUT.Cycles") == 0


def test_silent_drives_raise_comm_lost_and_stop_the_robot(tmp_path):
    cell = Cell(tmp_path, ["--fail-after", "3"])
    try:
        cell.write("PLC_IN.Enable", 1)
        cell.wait(lambda: cell.read("PLC_OUT.Powered") == 1)
        cell.wait(lambda: cell.read("IO_STATUS.comm_lost[0]") == 1, seconds=10)
        cell.wait(lambda: cell.read("ROBOT_MODULE_STATE.Error") == 1)
        assert cell.read("ROBOT_MODULE_STATE.ErrorID") == 8
        assert cell.read("PLC_OUT.Error") == 1
    finally:
        cell.close()


def test_silent_drives_raise_alarm_8_with_its_text_and_it_clears_when_they_answer_again(tmp_path):
    """The drives stop answering for a while: the PLC's alarm 8 is active with module.xml's text
    beside libiodispat's comm-lost alarm 100; when they answer again both clear (cleared,
    unacknowledged), the PLC's error stays latched and alarm 1000 says the cell waits for a reset,
    which clears it.  Read through the agent, as the browser sees them."""
    cell = Cell(tmp_path, ["--fail-after", "12", "--fail-for", "4"])
    port, data = free_port(), tmp_path / "data"
    agent = start_agent(port, data, cell.sock)
    try:
        url = f"http://127.0.0.1:{port}{API}"
        headers = {"Authorization": f"Bearer {(data / 'admin-token').read_text().strip()}"}

        def alarm(key: str) -> dict:
            listed = httpx.get(f"{url}/alarms", headers=headers, timeout=30).json()["alarms"]
            return next((a for a in listed if a["key"] == key), {"active": False, "state": "normal"})

        cell.write("PLC_IN.Enable", 1)
        cell.wait(lambda: cell.read("PLC_OUT.Powered") == 1)
        assert not alarm("main/8")["active"], "the drives answer: no alarm yet"
        lost = cell.wait(lambda: (a := alarm("main/8"))["active"] and a, seconds=30, every=0.1)
        assert lost["text"] == "Drive communication lost: the drives' I/O device does not answer"
        assert (lost["severity"], lost["state"], lost["value"]) == ("high", "active_unacknowledged", 8)
        assert cell.read("PLC_OUT.ErrorID") == 8
        assert alarm("libiodispat/100")["active"], "the I/O alarm with the cause is beside it"

        back = cell.wait(lambda: (a := alarm("main/8"))["state"] == "cleared_unacknowledged" and a, seconds=30)
        assert back["cleared"] is not None and not back["active"]
        assert alarm("libiodispat/100")["state"] == "cleared_unacknowledged"
        assert cell.read("PLC_OUT.Error") == 1 and cell.read("PLC_OUT.ErrorID") == 8, "the PLC's error stays latched"
        waits = cell.wait(lambda: (a := alarm("main/1000"))["active"] and a, seconds=5)
        assert waits["value"] == 8 and "Reset" in waits["text"]

        cell.write("PLC_IN.Reset", 1)
        cell.wait(lambda: cell.read("PLC_OUT.Error") == 0)
        cell.write("PLC_IN.Reset", 0)
        assert cell.wait(lambda: alarm("main/1000")["state"] == "cleared_unacknowledged", seconds=5)
        assert alarm("main/8")["state"] == "cleared_unacknowledged", "a reset is no acknowledgement"
    finally:
        stop(agent)
        cell.close()


def test_the_agent_and_irpctl_read_the_io_status_struct_leaf_by_leaf(cell, tmp_path, capsys):
    """A struct's path (the I/O dispatcher's IO_STATUS) answers every leaf of it, in layout order."""
    port, data = free_port(), tmp_path / "data"
    agent = start_agent(port, data, cell.sock)
    try:
        url = f"http://127.0.0.1:{port}"
        token = (data / "admin-token").read_text().strip()
        r = httpx.get(f"{url}{API}/variables/{NS}IO_STATUS", headers={"Authorization": f"Bearer {token}"}, timeout=30)
        assert r.status_code == 200, r.text
        leaves = [f"{NS}IO_STATUS.{f}[{i}]" for f in ("comm_lost", "errors") for i in range(8)]
        leaves += [f"{NS}IO_STATUS.cycles", f"{NS}IO_STATUS.last_cycle_us"]
        values = r.json()["values"]
        assert [v["path"] for v in values] == leaves
        got = {v["path"]: v for v in values}
        assert got[f"{NS}IO_STATUS.cycles"]["type"] == "uint32_t" and got[f"{NS}IO_STATUS.cycles"]["value"] > 0
        assert got[f"{NS}IO_STATUS.comm_lost[0]"]["value"] == 0
        capsys.readouterr()
        code = cli.main(["--url", url, "--token-file", str(data / "admin-token"), "read", f"{NS}IO_STATUS"])
        out = capsys.readouterr().out.splitlines()
        assert code == 0 and out[0].split() == ["PATH", "VALUE"]
        assert [line.split()[0] for line in out[1:]] == leaves
    finally:
        stop(agent)

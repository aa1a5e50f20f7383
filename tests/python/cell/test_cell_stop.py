"""test_cell_stop.py -- powering the PLC + robot cell off, through irpd and the agent as an operator
does: PLC_IN.Enable = 0 while the cycle runs aborts it with the PLC's own fault, whose alarm says
what happened (power removed mid-cycle), not that a motion came before power-on; the clean stop
sequence of docs/plc-robot-cell.md (Stop, wait until the cycle and the robot are idle, then
Enable = 0) ends with the cell off and no fault latched."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cell_operator import Operator  # noqa: E402
from test_plc_robot import Cell  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import wait_until  # noqa: E402

POWER_REMOVED = 1010  # the PLC's ErrorID (module.xml's alarm, docs/plc.md "ErrorIDs")


@pytest.fixture
def running(tmp_path):
    """The cell powered and cycling (CycleMode 1), and the agent in front of it."""
    cell = Cell(tmp_path)
    op = Operator(cell.sock, tmp_path)
    try:
        cell.write("PLC_IN.CycleMode", 1)
        cell.write("PLC_IN.Enable", 1)
        cell.wait(lambda: cell.read("PLC_OUT.Powered") == 1)
        cell.write("PLC_IN.Start", 1)
        cell.wait(lambda: cell.read("PLC_OUT.Step") >= 2 and cell.read("ROBOT_MODULE_STATE.Busy") == 1)
        yield cell, op
    finally:
        op.close()
        cell.close()


MOMENTS = {
    "moving": lambda cell: cell.read("ROBOT_MODULE_STATE.Busy") == 1,
    # at the pick or place pose, the gripper's dwell (the step's move taken and done): the next
    # move would follow it
    "dwelling": lambda cell: (
        cell.read("PLC_OUT.Step") in (3, 6)
        and cell.read("ROBOT_MODULE_STATE.nAckSeq") == cell.read("ROBOT_MODULE_SERVICE.nSeq")
        and cell.read("ROBOT_MODULE_STATE.MotionDone") == 1
    ),
}


@pytest.mark.parametrize("moment", MOMENTS)
def test_enable_0_mid_cycle_raises_a_fault_that_says_power_was_removed(running, moment):
    cell, op = running
    cell.wait(lambda: MOMENTS[moment](cell), 60, 0.002)
    cell.write("PLC_IN.Enable", 0)
    cell.wait(lambda: cell.read("PLC_OUT.Error") == 1)
    assert cell.read("PLC_OUT.ErrorID") == POWER_REMOVED
    assert cell.read("PLC_OUT.Running") == 0
    cell.wait(lambda: cell.read("PLC_OUT.Powered") == 0 and cell.read("ROBOT_MODULE_STATE.Busy") == 0)

    alarm = wait_until(lambda: (a := op.alarm(f"main/{POWER_REMOVED}"))["active"] and a, 10, 0.1)
    assert alarm["text"].startswith("Cycle aborted: power removed (PLC_IN.Enable = 0)"), alarm["text"]
    assert not op.alarm("main/1")["active"], "not 'Robot not powered: a motion was requested before power-on'"
    assert cell.read("ROBOT_MODULE_STATE.Error") == 0, "the robot stopped and switched off as asked"

    # A Reset clears it; the cell powers on again with Enable.
    cell.write("PLC_IN.Reset", 1)
    cell.wait(lambda: cell.read("PLC_OUT.Error") == 0)
    cell.write("PLC_IN.Reset", 0)
    assert wait_until(lambda: not op.alarm(f"main/{POWER_REMOVED}")["active"], 10, 0.1)
    cell.write("PLC_IN.Enable", 1)
    cell.wait(lambda: cell.read("PLC_OUT.Powered") == 1 and cell.read("PLC_OUT.Error") == 0)


def test_the_documented_stop_sequence_ends_with_the_cell_off_and_no_fault(running):
    cell, op = running
    # docs/plc-robot-cell.md "Stopping the cell": Stop, wait for the cycle and the robot to be idle...
    cell.write("PLC_IN.Stop", 1)
    cell.wait(lambda: cell.read("PLC_OUT.Running") == 0 and cell.read("ROBOT_MODULE_STATE.Busy") == 0)
    # ... then power off, and release Stop (and Start).
    cell.write("PLC_IN.Enable", 0)
    cell.wait(lambda: cell.read("PLC_OUT.Powered") == 0 and cell.read("ROBOT_MODULE_STATE.Powered") == 0)
    cell.write("PLC_IN.Stop", 0)
    cell.write("PLC_IN.Start", 0)
    for _ in range(20):  # a few scans more: nothing latches afterwards either
        assert cell.read("PLC_OUT.Error") == 0, cell.read("PLC_OUT.ErrorID")
        assert cell.read("ROBOT_MODULE_STATE.Error") == 0, cell.read("ROBOT_MODULE_STATE.ErrorID")
        time.sleep(0.02)
    active = [a["key"] for a in op.get("/alarms")["alarms"] if a["active"] and a["key"].startswith("main/")]
    assert active == [], active

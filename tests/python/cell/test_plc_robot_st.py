"""test_plc_robot_st.py -- the cell's PLC in Structured Text (config/sets/plc-robot-st/main.st, built
by `stc build`) does what the C++ PLC (config/sets/plc-robot's main.so) does, period by period.

Both run in a real irpd of their own, each beside the same twin module (plc_twin.cpp, priority 2,
before the PLC): it gives the PLC the same operator panel (PLC_IN, I0, I1) and drives' IO_STATUS in
the same period, steps the simulated robot of the PLC tests on the PLC's requests, and records
every period what the PLC wrote: PLC_OUT, O0 and the robot request (eOpCode, nSeq, speeds,
targets).  Everything the twin does is a function of the number of its run, so the two records are
equal line for line when the two programs are; the script goes through a cycle, CycleMode with
Override changes (2.0, NaN), Stop, a drive fault and Reset, power removed mid-cycle (1010), and lost
drive communication (8, WaitingForDrives).  The alarms the PLC raises and clears (irpd's alarm
segment: id, period, value, detail) are compared too."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import ROOT, copy_cell, dispatching, start_irpd, stop, wait_until  # noqa: E402
from plc_cells import BUILT, NOT_BUILT, assert_same, cpp_cell, run_cells, st_cell, stc_build, twin  # noqa: E402

sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.irpd.client import IrpdClient  # noqa: E402
from indurop_agent.irpd.variables import Segment  # noqa: E402

ST_SET = ROOT / "config" / "sets" / "plc-robot-st"
LD_PLC = ROOT / "config" / "sets" / "plc-robot-ld" / "plc.xml"

pytestmark = pytest.mark.skipif(not BUILT, reason=NOT_BUILT)


def test_the_st_cell_writes_what_the_cpp_cell_writes_period_by_period(tmp_path):
    so = twin(tmp_path)
    runs = run_cells(
        tmp_path, {"cpp": cpp_cell(tmp_path / "cpp", so), "st": st_cell(tmp_path / "st", so, [ST_SET / "main.st"])}
    )
    assert_same(runs["cpp"], runs["st"], "ST")
    cpp, alarms = runs["cpp"]
    raised = {a[1] for a in alarms if a[2]}
    assert {4, 1010, 8, 1000} <= raised, alarms
    # the script went where it was meant to: cycles, the faults of the robot and of the program
    text = "\n".join(cpp)
    for seen in ("Cycles=2", "Step=8", "ErrorID=4 ", "ErrorID=1010", "ErrorID=8 ", "WaitingForDrives=1", "eOpCode=5"):
        assert seen in text, seen


@pytest.mark.parametrize("source", [ST_SET / "main.st", LD_PLC], ids=["st", "ld"])
def test_the_st_cell_runs_the_pick_and_place_cycle_with_the_robot_and_its_drives(tmp_path, source):
    """The ST PLC (and the one drawn in ladder, config/sets/plc-robot-ld) in the cell as it runs by
    default: Robot.so, the I/O dispatcher, the simulated drives on Modbus TCP, all the plc-robot set's
    own modules."""
    xml, _ = copy_cell(tmp_path / "cell")
    xml = stc_build(xml.parent, xml.rename(xml.with_name("hand.xml")), [source])
    irpd = start_irpd(tmp_path / "irpd.sock", xml, f"cell-st-live-{id(tmp_path)}")
    control = IrpdClient(str(tmp_path / "irpd.sock"), timeout_s=30)
    try:
        status = wait_until(lambda: dispatching(control), 30)
        assert [m["name"] for m in control.request("modules")] == ["Robot", "libiodispat", "drivesim", "main"]
        vars = Segment(status["shared_memory"]["variables"])
        read = vars.read
        wait_until(lambda: read("PLC_ROBOT.IO_STATUS.cycles") > 0 and read("PLC_ROBOT.IO_STATUS.comm_lost[0]") == 0)
        control.request("write", path="PLC_ROBOT.PLC_IN.Enable", value=1)
        wait_until(lambda: read("PLC_ROBOT.PLC_OUT.Powered") == 1, 30)
        control.request("write", path="PLC_ROBOT.I0", value=1)
        steps = set()

        def cycled():
            steps.add(read("main.Step"))
            assert read("PLC_ROBOT.PLC_OUT.Error") == 0, read("PLC_ROBOT.PLC_OUT.ErrorID")
            return read("PLC_ROBOT.PLC_OUT.Cycles") >= 1

        wait_until(cycled, 60, 0.005)
        assert steps >= set(range(1, 9)), steps  # every step, seen in the program's own variable
        assert read("PLC_ROBOT.PLC_OUT.Done") == 1 and read("main.Power.Status") is True
        commanded = [read(f"PLC_ROBOT.ROBOT_MODULE_STATE.dCmdJoint[{i}]") for i in range(6)]
        assert commanded == pytest.approx([0, 0, 0, 0, 1.5708, 0], abs=1e-6)  # HOME, where the cycle ends
        vars.close()
    finally:
        control.close()
        stop(irpd)

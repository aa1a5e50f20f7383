"""test_cell_restart.py -- the PLC + robot cell across a managed restart (irpctl activate ID --mode
restart: irpd executes itself again, same pid, and starts the set's drive simulator anew), as an
operator drives it through the agent: Enable = 1 written at once after the restart, while the
drives do not answer yet, makes the PLC wait for them (PLC_OUT.WaitingForDrives) and power on when
they answer -- no ErrorID latches -- and libiodispat's comm-loss alarm covers that window: raised
while the drives are unreachable after the start, cleared when they answer.  The restarted set's
simulator stays silent for its first seconds (--fail-after 0 --fail-for S), as drives still booting
would, so that the window is there whatever the machine's speed."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cell_operator import Operator  # noqa: E402
from test_plc_robot import Cell  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import wait_until  # noqa: E402

SILENT_S = 3  # the restarted drives answer this long after their simulator started


def slow_drives(cell: Cell, folder: Path) -> Path:
    """The running cell's set (its port) with drives that stay silent for SILENT_S after their start."""
    shutil.copytree(cell.folder, folder)
    xml = folder / cell.xml.name
    xml.write_text(xml.read_text().replace("--quiet", f"--quiet --fail-after 0 --fail-for {SILENT_S}"))
    return folder


@pytest.fixture
def cell_and_operator(tmp_path):
    cell = Cell(tmp_path)
    operator = Operator(cell.sock, tmp_path)
    yield cell, operator
    operator.close()
    cell.close()


def test_enable_right_after_a_restart_waits_for_the_drives_and_the_window_is_alarmed(cell_and_operator, tmp_path):
    cell, op = cell_and_operator
    set_id = op.upload(slow_drives(cell, tmp_path / "slow"))
    since = op.newest()
    report = op.restart_onto(set_id)
    assert report["mode"] == "restart" and report["pid"] == cell.irpd.pid, report

    op.write("PLC_IN.Enable", 1)  # at once, as a script or an impatient operator does
    assert op.read("IO_STATUS.comm_lost[0]") == 1, "the premise: the drives do not answer yet"
    waiting = set()

    def powered():
        """the cell powered on once the drives answer, without an error on the way"""
        assert op.read("PLC_OUT.Error") == 0, op.read("PLC_OUT.ErrorID")
        waiting.add(op.read("PLC_OUT.WaitingForDrives"))
        return op.read("PLC_OUT.Powered") == 1

    wait_until(powered, SILENT_S + 30, 0.05)
    assert 1 in waiting, "PLC_OUT said that the cell waited for its drives"
    assert op.read("PLC_OUT.ErrorID") == 0 and op.read("PLC_OUT.WaitingForDrives") == 0
    assert op.read("IO_STATUS.comm_lost[0]") == 0

    # The window is in the alarm history: libiodispat's comm loss raised, then cleared; the PLC's
    # own comm-loss alarm (main/8) was not raised, since the PLC waited instead of failing.
    def cleared():
        """libiodispat/100 raised and cleared after the restart"""
        events = op.transitions("libiodispat/100", since)
        return "raise" in events and "clear" in events[events.index("raise") :] and events

    events = wait_until(cleared, 10, 0.2)
    assert events[0] == "raise", events
    assert op.transitions("main/8", since) == []

    # The cell then runs as ever.
    op.write("I0", 1)
    wait_until(lambda: op.read("PLC_OUT.Step") > 0, 10)
    assert op.read("PLC_OUT.Error") == 0
    op.write("I0", 0)


def test_enable_right_after_a_plain_restart_powers_the_cell_on_without_a_fault(cell_and_operator, tmp_path):
    """The issue as found: the cell's own set restarted, Enable written at once."""
    cell, op = cell_and_operator
    folder = tmp_path / "same"
    shutil.copytree(cell.folder, folder)
    op.restart_onto(op.upload(folder))
    op.write("PLC_IN.Enable", 1)

    def powered():
        """the cell powered on, without an error on the way"""
        assert op.read("PLC_OUT.Error") == 0, op.read("PLC_OUT.ErrorID")
        return op.read("PLC_OUT.Powered") == 1

    wait_until(powered, 30, 0.05)
    assert op.read("IO_STATUS.comm_lost[0]") == 0 and op.read("PLC_OUT.WaitingForDrives") == 0

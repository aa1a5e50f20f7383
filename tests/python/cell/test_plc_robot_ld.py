"""test_plc_robot_ld.py -- the cell's PLC drawn in ladder (config/sets/plc-robot-ld/plc.xml, PLCopen
XML written by generate.py) does what the C++ PLC (config/sets/plc-robot's main.so) and the ST PLC
(config/sets/plc-robot-st/main.st) do, period by period: the three cells, each in a real irpd of its
own beside the same twin module (plc_cells.py, plc_twin.cpp), are given the same panel, drives and
robot, and what each PLC writes (PLC_OUT, O0, the robot's requests) and the alarms it raises are
equal line for line.  The drawing's meaning written as ST (as_st.py) runs the same script, so a
difference of the imported ladder is told apart from one of the drawing; plc.xml is what
generate.py writes today."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import ROOT  # noqa: E402
from plc_cells import BUILT, NOT_BUILT, assert_same, cpp_cell, run_cells, st_cell, twin  # noqa: E402

LD_SET = ROOT / "config" / "sets" / "plc-robot-ld"
ST_SET = ROOT / "config" / "sets" / "plc-robot-st"
sys.path.insert(0, str(LD_SET))


def test_plc_xml_is_what_generate_py_writes():
    r = subprocess.run([sys.executable, str(LD_SET / "generate.py"), "--check"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


@pytest.mark.skipif(not BUILT, reason=NOT_BUILT)
def test_the_ladder_as_st_writes_what_the_cpp_cell_writes(tmp_path):
    # by its path, under a name of its own: other tests' folders hold a generate.py too (a worker that
    # imported one of them first would hand it out for `import generate`)
    spec = importlib.util.spec_from_file_location("plc_robot_ld_generate", LD_SET / "generate.py")
    generate = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(generate)
    from as_st import body
    from cell_st import CONFIGURATION, INPUTS, OUTPUTS, PROGRAM

    source = tmp_path / "ladder.st"
    source.write_text(
        PROGRAM.replace("END_PROGRAM", body(generate.rungs()) + "END_PROGRAM") + INPUTS + OUTPUTS + CONFIGURATION
    )
    so = twin(tmp_path)
    runs = run_cells(
        tmp_path, {"cpp": cpp_cell(tmp_path / "cpp", so), "ladder": st_cell(tmp_path / "ladder", so, [source])}
    )
    assert_same(runs["cpp"], runs["ladder"], "ladder-as-ST")


@pytest.mark.skipif(not BUILT, reason=NOT_BUILT)
def test_the_ld_st_and_cpp_cells_write_the_same_period_by_period(tmp_path):
    so = twin(tmp_path)
    cells = {
        "cpp": cpp_cell(tmp_path / "cpp", so),
        "st": st_cell(tmp_path / "st", so, [ST_SET / "main.st"]),
        "ld": st_cell(tmp_path / "ld", so, [LD_SET / "plc.xml"]),
    }
    runs = run_cells(tmp_path, cells)
    assert_same(runs["cpp"], runs["st"], "ST")
    assert_same(runs["cpp"], runs["ld"], "LD")
    text = "\n".join(runs["cpp"][0])
    for seen in ("Cycles=2", "Step=8", "ErrorID=4 ", "ErrorID=1010", "ErrorID=8 ", "WaitingForDrives=1"):
        assert seen in text, seen  # the script went through cycles, the robot's and the program's faults

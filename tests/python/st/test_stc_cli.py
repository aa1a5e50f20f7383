# test_stc_cli.py -- the stc executable as a user runs it: `stc check` prints `file:line:col: error[code]:
# message` (or JSON with --json) and exits 1 on an error, 0 when clean, 2 on a usage error; --layout
# checks AT bindings and qualified access against a layout.json glbc wrote for the paper's Figure 11.

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from st_helpers import ROOT, run_stc

FIG11 = ROOT / "tests" / "python" / "glb" / "fixtures" / "fig11-plcRobot.glb"

CLEAN = """PROGRAM Main
VAR x : INT; t : TON; END_VAR
  t(IN := x > 3, PT := T#1s);
  x := x + 1;
END_PROGRAM
"""
BAD = """PROGRAM Main
VAR x : INT; b : BOOL; END_VAR
  b := x;
  y := 1;
END_PROGRAM
"""


def test_clean_source_exits_0(write, tmp_path):
    result = run_stc(["check", str(write("main.st", CLEAN))], tmp_path)
    assert (result.returncode, result.stdout, result.stderr) == (0, "", "")


def test_errors_in_text(write, tmp_path):
    write("main.st", BAD)
    result = run_stc(["check", "main.st"], tmp_path)
    assert result.returncode == 1
    assert result.stderr.splitlines() == [
        "main.st:3:8: error[type]: cannot assign INT to BOOL; use INT_TO_BOOL(...)",
        "main.st:4:3: error[undeclared]: 'y' is not declared; declare it in a VAR block",
    ]


def test_errors_as_json(write, tmp_path):
    write("main.st", BAD)
    result = run_stc(["check", "main.st", "--json"], tmp_path)
    assert result.returncode == 1
    assert json.loads(result.stdout)[0] == {
        "file": "main.st",
        "line": 3,
        "column": 8,
        "code": "type",
        "message": "cannot assign INT to BOOL; use INT_TO_BOOL(...)",
    }
    clean = run_stc(["check", str(write("ok.st", CLEAN)), "--json"], tmp_path)
    assert (clean.returncode, json.loads(clean.stdout)) == (0, [])


def test_several_files_make_one_program(write, tmp_path):
    write("types.st", "TYPE Mode : (Idle, Run); END_TYPE\nVAR_GLOBAL gMode : Mode; END_VAR\n")
    write("main.st", "PROGRAM Main\n  IF gMode = Run THEN gMode := Idle; END_IF;\nEND_PROGRAM\n")
    assert run_stc(["check", "types.st", "main.st"], tmp_path).returncode == 0


def test_one_syntax_error_per_file_from_every_file(write, tmp_path):
    write("a.st", "PROGRAM A\n  x := \nEND_PROGRAM\n")
    write("b.st", "PROGRAM B\n  y := 1\nEND_PROGRAM\n")
    result = run_stc(["check", "a.st", "b.st"], tmp_path)
    assert result.returncode == 1
    assert result.stderr.splitlines() == [
        "a.st:3:1: error[syntax]: expected an expression, found 'END_PROGRAM'",
        "b.st:2:9: error[syntax]: expected ';' after the assignment",
    ]


def test_usage_error_exits_2(tmp_path):
    assert run_stc(["check"], tmp_path).returncode == 2
    assert run_stc(["build", "x.st"], tmp_path).returncode == 2


def test_missing_file(tmp_path):
    result = run_stc(["check", "nothere.st"], tmp_path)
    assert result.returncode == 1
    assert result.stderr.strip() == "nothere.st:1:1: error[file]: cannot read the file: No such file or directory"


@pytest.fixture
def layout(tmp_path: Path) -> Path:
    subprocess.run([sys.executable, str(ROOT / "glb" / "glbc"), str(FIG11), "-o", str(tmp_path / "glb")], check=True)
    return tmp_path / "glb" / "layout.json"


def test_layout_bindings_and_qualified_access(write, tmp_path, layout):
    write(
        "main.st",
        """PROGRAM Main
VAR
  in0 AT %PLC_ROBOT.I0 : INT;
  out0 AT %PLC_ROBOT.O0 : INT;
  state : INT;
END_VAR
  out0 := in0;
  state := PLC_ROBOT.ROBOT_MODULE_STATE.eState;
  PLC_ROBOT.I1 := 1;
END_PROGRAM
""",
    )
    result = run_stc(["check", "main.st", "--layout", str(layout)], tmp_path)
    assert result.returncode == 0, result.stderr


def test_layout_binding_errors(write, tmp_path, layout):
    write(
        "main.st",
        """PROGRAM Main
VAR
  in0 AT %PLC_ROBOT.I0 : BOOL;
  nope AT %PLC_ROBOT.I9 : INT;
  x : INT;
END_VAR
  x := PLC_ROBOT.ROBOT_MODULE_STATE.eStat;
END_PROGRAM
CONFIGURATION C
  RESOURCE R ON PLC
    TASK T (INTERVAL := T#10ms, PRIORITY := 1);
    PROGRAM PLC_ROBOT WITH T : Main;
  END_RESOURCE
END_CONFIGURATION
""",
    )
    result = run_stc(["check", "main.st", "--layout", str(layout)], tmp_path)
    assert result.returncode == 1
    assert result.stderr.splitlines() == [
        "main.st:3:3: error[binding]: 'PLC_ROBOT.I0' is INT (short) in the layout but 'in0' is declared BOOL; declare it INT",
        f"main.st:4:3: error[binding]: no shared variable 'PLC_ROBOT.I9' in {layout}; did you mean 'PLC_ROBOT.I1'?",
        "main.st:7:8: error[undeclared]: ROBOT_MODULE_STATE_t has no field 'eStat'; did you mean 'eState'?",
        f"main.st:12:5: error[name]: 'PLC_ROBOT' is already a namespace of the shared variables ({layout}); rename the PROGRAM instance",
    ]


def test_layout_that_is_not_one(write, tmp_path):
    write("main.st", CLEAN)
    write("layout.json", "{}")
    result = run_stc(["check", "main.st", "--layout", "layout.json"], tmp_path)
    assert result.returncode == 1
    assert result.stderr.startswith("layout.json:1:1: error[layout]: not a glbc layout.json")

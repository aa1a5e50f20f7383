# test_conformance_faults.py -- ST at run time in a real irpd: TON/TOF/TP across periods (on the
# period's due time), faults that disable the module and name the ST file, line, column and POU
# (division by zero, an index out of range), an endless loop stopped by the overrun watchdog with
# the loop's line, while the other program of the set runs on; and bad input refused by stc build.

from __future__ import annotations

import pytest
from live_processes import wait_until
from st_live import Running, build_errors

TIMERS = """
PROGRAM Timers
VAR
  n : DINT;
  ton1 : TON; tof1 : TOF; tp1 : TP;
  tonQ : BOOL; tofQ : BOOL; tpQ : BOOL;
  tonAt : DINT := -1; tofAt : DINT := -1; tpEnd : DINT := -1;
END_VAR
  n := n + 1;
  ton1(IN := n >= 3, PT := T#50ms);
  IF ton1.Q AND tonAt < 0 THEN tonAt := n; END_IF;
  tof1(IN := n <= 2, PT := T#30ms);
  IF NOT tof1.Q AND tofAt < 0 THEN tofAt := n; END_IF;
  tp1(IN := n = 2, PT := T#40ms);
  IF NOT tp1.Q AND n > 2 AND tpEnd < 0 THEN tpEnd := n; END_IF;
END_PROGRAM
"""

FAULTS = """
PROGRAM Divide
VAR d : INT := 3; q : INT; END_VAR
VAR_OUTPUT motor : BOOL; END_VAR
  q := 100 / d;
  d := d - 1;
  motor := TRUE;
END_PROGRAM

PROGRAM Indexed
VAR a : ARRAY[1..3] OF INT; i : INT; END_VAR
  i := i + 1;
  a[i] := i;
END_PROGRAM

PROGRAM Spin
VAR x : DINT; go : BOOL; END_VAR
  x := x + 1;
  IF x > 5 THEN
    WHILE TRUE DO
      go := NOT go;
    END_WHILE;
  END_IF;
END_PROGRAM

TYPE Percent : INT (0..100); END_TYPE

FUNCTION_BLOCK Valve
VAR_INPUT open : Percent; END_VAR
VAR_OUTPUT flow : INT; END_VAR
  flow := open * 2;
END_FUNCTION_BLOCK

PROGRAM Ranged
VAR v : Valve; k : INT := 90; END_VAR
  k := k + 5;
  v(open := k);
END_PROGRAM

PROGRAM Alive
VAR n : DINT; END_VAR
  n := n + 1;
END_PROGRAM

CONFIGURATION Cell
  RESOURCE Cpu ON PLC
    TASK Fast (INTERVAL := T#10ms, PRIORITY := 1);
    PROGRAM Div WITH Fast : Divide;
    PROGRAM Idx WITH Fast : Indexed;
    PROGRAM Loop WITH Fast : Spin;
    PROGRAM Beat WITH Fast : Alive;
    PROGRAM Rng WITH Fast : Ranged;
  END_RESOURCE
END_CONFIGURATION
"""


def test_timers_count_periods_of_the_due_time(tmp_path):
    run = Running(tmp_path, {"timers.st": TIMERS})
    try:
        run.wait_value("Timers.tpEnd", 6)  # TP from period 2, 40 ms = 4 periods: Q in periods 2..5
        wait_until(lambda: run.value("Timers.tonAt") > 0 and run.value("Timers.tofAt") > 0)
        assert run.value("Timers.tonAt") == 8  # IN from period 3, PT 50 ms = 5 periods later
        assert run.value("Timers.tofAt") == 6  # IN falls in period 3, PT 30 ms: Q falls in period 6
        assert run.value("Timers.ton1.ET") == 50_000_000 and run.value("Timers.ton1.Q") == 1
    finally:
        run.close()


@pytest.fixture(scope="module")
def faults(tmp_path_factory):
    run = Running(tmp_path_factory.mktemp("faults"), {"faults.st": FAULTS})
    yield run
    run.close()


def fault_of(run, module: str) -> str:
    def found():
        """the module's fault event"""
        return [e["message"] for e in run.events("fault") if e["module"] == module]

    return wait_until(found, 30)[0]


def test_a_division_by_zero_disables_the_module_naming_the_st_place(faults):
    text = fault_of(faults, "Div")
    assert "faults.st:5:8: division by zero (PROGRAM Divide)" in text, text
    assert faults.value("Div.q") == 100  # 100/1, the last complete run; the faulting one wrote nothing
    assert faults.value("Div.d") == 0
    assert faults.value("Div.motor") == 0  # the outputs went to their safe (initial) values


def test_an_index_out_of_range_names_the_index_and_the_range(faults):
    text = fault_of(faults, "Idx")
    assert "faults.st:13:5: index 4 is outside the array's range 1..3 (PROGRAM Indexed)" in text, text
    assert [faults.value(f"Idx.a[{k}]") for k in range(3)] == [1, 2, 3]


def test_an_endless_loop_is_stopped_by_the_watchdog_naming_its_line(faults):
    text = fault_of(faults, "Loop")
    assert "faults.st:20:5" in text and "endless loop?" in text and "(PROGRAM Spin)" in text, text
    before = faults.value("Beat.n")
    wait_until(lambda: faults.value("Beat.n") > before + 5)  # the rest of the set runs on


def test_an_fb_input_outside_its_subrange_is_a_fault_at_the_argument(faults):
    text = fault_of(faults, "Rng")
    assert "faults.st:37:5: value 105 is outside the subrange 0..100 (PROGRAM Ranged)" in text, text
    assert faults.value("Rng.v.flow") == 200  # the last complete run: open = 100


@pytest.mark.parametrize(
    "text, code, words",
    [
        (
            "FUNCTION F : INT VAR_INPUT x : INT; END_VAR F := G(x); END_FUNCTION\n"
            "FUNCTION G : INT VAR_INPUT x : INT; END_VAR G := F(x); END_FUNCTION\n"
            "PROGRAM P VAR y : INT; END_VAR y := F(1); END_PROGRAM\n",
            "recursion",
            "recursive call chain",
        ),
        ("PROGRAM P VAR new : INT; END_VAR new := 1; END_PROGRAM\n", "name", "C++ keyword"),
        (
            "FUNCTION index : INT VAR_INPUT x : INT; END_VAR index := x; END_FUNCTION\n"
            "PROGRAM P VAR y : INT; END_VAR y := index(1); END_PROGRAM\n",
            "name",
            "generated C++ uses",
        ),
        (  # the function that keeps what the PLCopen library's AXES_GROUP_REF is made into (externs.py)
            "FUNCTION madeAXES_GROUP_REF : INT VAR_INPUT x : INT; END_VAR madeAXES_GROUP_REF := x; END_FUNCTION\n"
            "PROGRAM P VAR y : INT; END_VAR y := madeAXES_GROUP_REF(1); END_PROGRAM\n",
            "name",
            "generated C++ uses",
        ),
        ("PROGRAM P VAR_IN_OUT x : INT; END_VAR x := 1; END_PROGRAM\n", "unsupported", "by reference"),
        (  # a local of the body would hide the run's write flags (docs/st-compiler.md)
            "TYPE Pair : STRUCT n : INT; END_STRUCT; END_TYPE\n"
            "PROGRAM P VAR p : Pair; END_VAR VAR_TEMP written_ : BOOL; END_VAR p.n := 1; END_PROGRAM\n",
            "name",
            "generated C++ uses",
        ),
    ],
)
def test_bad_input_is_refused_at_build(tmp_path, text, code, words):
    errors = build_errors(tmp_path, {"bad.st": text})
    assert any(e["code"] == code and words in e["message"] and e["file"] == "bad.st" for e in errors), errors
    assert not (tmp_path / "set" / "module.xml").exists()


def test_a_name_colliding_with_a_shared_variable_is_refused(tmp_path):
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "cell.glb").write_text("namespace Cell;\nint16_t speed;\n")
    text = (
        "PROGRAM P VAR x : INT; END_VAR x := 1; END_PROGRAM\n"
        "CONFIGURATION C\n  VAR_GLOBAL speed : INT; END_VAR\n  RESOURCE R ON PLC\n"
        "    TASK T (INTERVAL := T#10ms);\n    PROGRAM Cell WITH T : P;\n  END_RESOURCE\nEND_CONFIGURATION\n"
    )
    errors = build_errors(tmp_path, {"bad.st": text}, "--glb", "cell.glb")
    assert any(e["file"] == "bad.st" and e["line"] == 6 and "namespace" in e["message"] for e in errors), errors

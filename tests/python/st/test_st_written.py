# test_st_written.py -- the generated run() compares with its snapshot only the structs and arrays a
# statement of the run may have written (docs/st-compiler.md, "The process image"): every way a
# statement writes one must still reach shared memory (a branch, a call in a condition through
# VAR_IN_OUT, an array element, an FB's own body, a FUNCTION through VAR_EXTERNAL, a value the
# program writes again after another writer changed it), and what another writer puts into a
# variable the run did not write stays.  In a real irpd; values written with irpd's `write`.

from __future__ import annotations

import pytest
from live_processes import wait_until
from st_live import Running

WRITES = """
TYPE Pair : STRUCT n : DINT; m : DINT; END_STRUCT; END_TYPE
TYPE Outer : STRUCT inner : Pair; flag : BOOL; END_STRUCT; END_TYPE

FUNCTION Bump : BOOL
VAR_IN_OUT p : Pair; END_VAR
  p.n := p.n + 1;
  Bump := TRUE;
END_FUNCTION

FUNCTION TouchGlobal : BOOL
VAR_EXTERNAL g : Pair; END_VAR
  g.m := g.m + 1;
  TouchGlobal := FALSE;
END_FUNCTION

FUNCTION_BLOCK Count
VAR_OUTPUT c : DINT; END_VAR
  c := c + 1;
END_FUNCTION_BLOCK

PROGRAM Main
VAR
  go : DINT;                          (* which branch runs: written from outside *)
  a, b, same, again : Pair;
  deep : Outer;
  arr : ARRAY[0..3] OF DINT;
  fb : Count;
  runs, hits : DINT;
END_VAR
  runs := runs + 1;
  IF go = 1 THEN
    a.n := a.n + 1;                   (* a struct written in one branch only *)
  END_IF;
  IF go = 2 THEN
    IF Bump(b) THEN                   (* written by a call in a condition, through VAR_IN_OUT *)
      hits := hits + 1;
    END_IF;
  END_IF;
  CASE go OF
    3: arr[go] := arr[go] + 1;        (* an array element at a computed index *)
    4: fb();                          (* an FB instance its own body writes *)
    5: WHILE TouchGlobal() DO END_WHILE;   (* a VAR_GLOBAL written by a FUNCTION in a condition *)
    6: deep.inner.m := deep.inner.m + 1;   (* a nested struct's field *)
  END_CASE;
  IF go = 7 THEN
    same.n := 7;                      (* the same value every period *)
    again.n := again.n + 1;           (* changed and changed back: the run ends as it began *)
    again.n := again.n - 1;
  END_IF;
END_PROGRAM

CONFIGURATION Plant
  VAR_GLOBAL g : Pair; END_VAR
  RESOURCE Cpu ON PLC
    TASK Fast (INTERVAL := T#10ms, PRIORITY := 1);
    PROGRAM Main WITH Fast : Main;
  END_RESOURCE
END_CONFIGURATION
"""


@pytest.fixture
def run(tmp_path):
    """WRITES running in irpd."""
    running = Running(tmp_path, {"writes.st": WRITES})
    yield running
    running.close()


def _runs_on(run: Running, count: int) -> None:
    """Waits until the program has run `count` more periods."""
    start = run.value("Main.runs")
    wait_until(lambda: run.value("Main.runs") > start + count)


def _go(run: Running, go: int, path: str | None = None) -> None:
    """Selects the program's branch `go`; path's value then goes on growing (the branch writes it)."""
    run.client.request("write", path="Main.go", value=go)
    if path is not None:
        start = run.value(path)
        wait_until(lambda: run.value(path) > start + 3)


def test_every_statement_that_writes_a_struct_or_array_reaches_shared_memory(run):
    wait_until(lambda: run.value("Main.runs") > 5)
    for go, path in [
        (1, "Main.a.n"),
        (2, "Main.b.n"),
        (3, "Main.arr[3]"),
        (4, "Main.fb.c"),
        (5, "Plant.g.m"),
        (6, "Main.deep.inner.m"),
    ]:
        _go(run, go, path)
    assert run.value("Main.hits") > 0
    assert run.value("Main.arr[2]") == 0 and run.value("Main.deep.flag") is False


def test_another_writers_value_stays_unless_the_run_writes_that_variable(run):
    _go(run, 1, "Main.a.n")
    # the branch no longer runs: what another writer puts into a (any field) stays
    _go(run, 0)
    _runs_on(run, 2)
    run.client.request("write", path="Main.a.n", value=100)
    run.client.request("write", path="Main.a.m", value=5)
    _runs_on(run, 5)
    assert (run.value("Main.a.n"), run.value("Main.a.m")) == (100, 5)
    # the branch runs again: it goes on from the other writer's value, and keeps its m
    _go(run, 1)
    wait_until(lambda: run.value("Main.a.n") > 103)
    assert run.value("Main.a.m") == 5

    # a value the program writes every period, equal to what it wrote before: written again
    # over another writer's; a field changed and changed back in one run: the other's stays
    _go(run, 7)
    run.wait_value("Main.same.n", 7)
    for value in (3, -1):
        run.client.request("write", path="Main.same.n", value=value)
        run.client.request("write", path="Main.again.n", value=value * 10)
        run.wait_value("Main.same.n", 7)
        _runs_on(run, 3)
        assert run.value("Main.again.n") == value * 10


def test_an_online_change_keeps_the_values_and_the_new_code_writes_back(run):
    _go(run, 3, "Main.arr[3]")
    _go(run, 6, "Main.deep.inner.m")
    _go(run, 0)
    # a variable added before the others: the image's entries move in the new code
    v2 = WRITES.replace("  a, b, same, again : Pair;", "  added : Pair := (n := 9);\n  a, b, same, again : Pair;")
    v2 = v2.replace("    a.n := a.n + 1;", "    a.n := a.n + 1;\n    added.m := added.m + 1;")
    report = run.load({"writes.st": v2}, "set2")
    assert "Main.added" in report["variables"]["added"], report
    arr, deep = run.value("Main.arr[3]"), run.value("Main.deep.inner.m")
    assert arr > 3 and deep > 3  # kept
    _go(run, 1, "Main.a.n")
    _go(run, 1, "Main.added.m")
    assert run.value("Main.added.n") == 9
    _go(run, 3)
    wait_until(lambda: run.value("Main.arr[3]") > arr + 3)
    assert run.value("Main.deep.inner.m") == deep

# test_in_place.py -- a PROGRAM whose variables the segment lays out as its C++ struct runs in place
# (st/runtime/include/indurop/st/in_place.hpp): no local copy, no snapshot, no write-back; its structs
# and arrays are written with their lock group's lock held and the sequence odd for the run.  What a
# reader sees must be what the process image gave: every struct and array of the instance as one run
# left it.  An online change that lays an added variable elsewhere runs through the process image
# again, with every value kept.

from __future__ import annotations

import time

from live_processes import wait_until
from st_live import Running, stc_build

PAIR = """
TYPE Pair : STRUCT a : DINT; b : DINT; END_STRUCT; END_TYPE
PROGRAM Counter
VAR n : DINT; p : Pair; hist : ARRAY[0..3] OF DINT; t : TON; i : DINT; k : DINT; END_VAR
  n := n + 1;
  p.a := p.a + 1;
  hist[0] := p.a;
  FOR i := 1 TO 20000 DO  (* a long run between the writes: a reader would meet it often *)
    k := k + i;
  END_FOR;
  hist[1] := hist[0] * 2;
  p.b := p.a;
  t(IN := TRUE, PT := T#1h);
END_PROGRAM
"""


def generated(folder, out: str = "set") -> str:
    return (folder / out / "Counter.cpp").read_text()


def test_a_program_laid_out_as_its_struct_runs_in_place(tmp_path):
    r = stc_build(tmp_path, {"counter.st": PAIR}, "--no-compile")
    assert r.returncode == 0, r.stdout + r.stderr
    cpp = generated(tmp_path)
    assert "auto &self = inPlace<Counter>(::Counter::n);" in cpp
    assert "openGroup(" in cpp and "closeGroup(" in cpp
    assert "Counter self, self0;" not in cpp and "kept(::Counter::" not in cpp  # no copy of its own


def test_a_reader_sees_each_struct_and_array_as_one_run_left_it(tmp_path):
    """p.b is written after p.a, hist[1] after hist[0], in place: a reader between the two writes
    would see them differ, unless it waits for the run's end (the group's sequence)."""
    run = Running(tmp_path, {"counter.st": PAIR})
    try:
        wait_until(lambda: run.value("Counter.n") > 5)
        seen, end = set(), time.monotonic() + 2
        while time.monotonic() < end:
            pair = run.values("Counter.p")
            hist = run.values("Counter.hist")
            assert pair["Counter.p.a"] == pair["Counter.p.b"], pair
            assert hist["Counter.hist[1]"] == 2 * hist["Counter.hist[0]"], hist
            seen.add(pair["Counter.p.a"])
        assert len(seen) > 20  # the reads spanned many runs
    finally:
        run.close()


def test_an_online_change_that_lays_a_variable_elsewhere_runs_through_the_image_with_values_kept(tmp_path):
    """A variable added before the others cannot go where the struct has it (the others keep their
    places): the changed program runs through the process image, every value kept; and a change back
    to a program laid out as its struct runs in place again."""
    run = Running(tmp_path, {"counter.st": PAIR})
    try:
        assert "inPlace<Counter>" in generated(tmp_path)
        wait_until(lambda: run.value("Counter.n") > 20)
        v2 = PAIR.replace("VAR n : DINT;", "VAR first : INT := 5; n : DINT;")
        report = run.load({"counter.st": v2}, "set2")
        assert "Counter.first" in report["variables"]["added"], report
        cpp = generated(tmp_path, "set2")
        assert "inPlace<" not in cpp and "Counter self, self0;" in cpp
        n = run.value("Counter.n")
        assert n > 20 and run.value("Counter.first") == 5
        a = run.value("Counter.p.a")
        wait_until(lambda: run.value("Counter.p.a") > a + 20)  # counts on from its value
        assert run.value("Counter.t.Q") == 0 and run.value("Counter.t.ET") > 0  # still timing
        pair = run.values("Counter.p")
        assert pair["Counter.p.a"] == pair["Counter.p.b"]
    finally:
        run.close()

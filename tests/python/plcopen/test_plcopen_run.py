# test_plcopen_run.py -- real PLCopen XML projects drawn in other tools (../shared/plcopen, SOURCES.md)
# imported by `stc build` and run in a real irpd: LD truth tables (in place), and where behaviour
# counts cycles, an ST harness that calls the drawn POU as a function block and records, cycle by
# cycle, when its outputs change (the program's clock is the period's due time: deterministic).

from __future__ import annotations

import itertools

import pytest
from live_processes import wait_until
from plcopen_live import Running, derived, recorded, shared


def _truth(run: Running, inputs: dict[str, int], outputs: dict[str, int]) -> None:
    for path, v in inputs.items():
        run.client.request("write", path=path, value=v)
    wait_until(lambda: all(run.value(p) == v for p, v in outputs.items()), 10)


def test_xor_and_xnor_rungs_give_their_truth_tables(tmp_path):
    run = Running(tmp_path, {"plc.xml": shared("tutorial_xor_xnor")})
    try:
        for a, b in itertools.product((0, 1), repeat=2):
            _truth(
                run,
                {"instance0.INPUT_0": a, "instance0.INPUT_1": b, "instance0.INPUT_2": a, "instance0.INPUT_3": b},
                {"instance0.OUTPUT_0": a ^ b, "instance0.OUTPUT_1": int(a == b)},
            )
    finally:
        run.close()


def test_not_or_nor_rungs_between_three_rail_pairs(tmp_path):
    run = Running(tmp_path, {"plc.xml": shared("tutorial_not_or_nor")})
    try:
        p = "instance0."
        _truth(run, {}, {p + "Output_0": 1, p + "Output_1": 0, p + "Output_2": 1})
        _truth(
            run,
            {p + "Input_0": 1, p + "Input_1": 1, p + "Input_3": 1},
            {p + "Output_0": 0, p + "Output_1": 1, p + "Output_2": 0},
        )
        _truth(
            run,
            {p + "Input_1": 0, p + "Input_2": 1, p + "Input_3": 0, p + "Input_4": 1},
            {p + "Output_1": 1, p + "Output_2": 0},
        )
        _truth(run, {p + "Input_2": 0, p + "Input_4": 0}, {p + "Output_1": 0, p + "Output_2": 1})
    finally:
        run.close()


# the harness: calls the drawn POU (made a function block) once a cycle, counts cycles, and records the
# cycles where the watched output changes (CHANGES of them).  A cycle's number comes from its due time
# (the task's 20 ms since the first), as the timers' time does: a slot a loaded machine skips is not
# run, but the drawn timers see its time pass, so counting runs would put the changes late.
EDGES = """
PROGRAM Harness
VAR
  b : {fb};
  clock : TON;
  n : DINT;
  last : {kind};
  cycle : ARRAY[1..{k}] OF DINT;
  seen : ARRAY[1..{k}] OF {kind};
  k : INT;
END_VAR
  clock(IN := TRUE, PT := T#1d);
  n := TIME_TO_DINT(clock.ET) / 20 + 1;
  b();
  IF (n = 1 OR {watch} <> last) AND k < {k} THEN
    k := k + 1; cycle[k] := n; seen[k] := {watch};
  END_IF;
  last := {watch};
END_PROGRAM
"""


def _changes(run: Running, k: int) -> list[tuple[int, int]]:
    run.wait_value("instance0.k", k, 60)
    at = run.values("instance0.cycle")
    seen = run.values("instance0.seen")
    return list(zip(at.values(), seen.values(), strict=True))


def test_blink_runs_in_place(tmp_path):
    run = Running(tmp_path, {"plc.xml": shared("openplc_blink")})
    try:
        run.wait_value("instance0.blink_led", 1)
        run.wait_value("instance0.blink_led", 0)
    finally:
        run.close()


def test_blink_is_on_26_cycles_and_off_26(tmp_path):
    xml = derived("openplc_blink", tmp_path / "xml" / "plc.xml", as_fb={"Blink": ("blink_led",)})
    harness = EDGES.format(fb="Blink", kind="BOOL", k=5, watch="b.blink_led")
    run = Running(tmp_path, {"plc.xml": xml, "harness.st": harness})
    try:
        changes = _changes(run, 5)
    finally:
        run.close()
    assert changes[0] == (1, 0)
    on = [n for n, v in changes if v]
    off = [n for n, v in changes[1:] if not v]
    assert abs(on[0] - 26) <= 1, changes  # first TRUE at t = 500 ms
    assert all(abs(b - a - 52) <= 1 for a, b in zip(on, on[1:])), changes  # a period of 52 cycles
    assert all(abs(b - a - 26) <= 1 for a, b in zip(on, off)), changes  # half of it on


def test_fbd_traffic_light_sequence(tmp_path):
    lights = ("O_LEDRed", "O_LEDOrange", "O_LEDGreen", "First_cycle")
    xml = derived("openplc_traffic_light_fbd", tmp_path / "xml" / "plc.xml", as_fb={"Trafic_light": lights})
    watch = "BOOL_TO_INT(b.O_LEDRed) + 2 * BOOL_TO_INT(b.O_LEDOrange) + 4 * BOOL_TO_INT(b.O_LEDGreen)"
    run = Running(
        tmp_path, {"plc.xml": xml, "harness.st": EDGES.format(fb="Trafic_light", kind="INT", k=7, watch=watch)}
    )
    try:
        changes = _changes(run, 7)
    finally:
        run.close()
    red, orange, green = 1, 2, 4
    want = [(1, red | orange), (202, red), (504, green), (805, 0), (806, orange), (1007, 0), (1008, red)]
    assert [v for _, v in changes] == [v for _, v in want], changes
    assert all(abs(n - m) <= 2 for (n, _), (m, _) in zip(changes, want)), changes


# the counters in ST, FBD, LD and IL of the five-language projects: Reset FALSE in cycles 1-10, TRUE
# in 11-13, FALSE in 14-17 (SOURCES.md's worked sequence); the program itself (plc_prg) calls the SFC
# counter too, so the harness calls the four others
COUNTERS = """
PROGRAM Harness
VAR
  cst : CounterST; cfbd : CounterFBD; cld : CounterLD; cil : CounterIL;
  n : DINT; Reset : BOOL;
  got : ARRAY[1..17, 1..4] OF INT;
END_VAR
  n := n + 1;
  Reset := n >= 11 AND n <= 13;
  cst(Reset := Reset); cfbd(Reset := Reset); cld(Reset := Reset); cil(Reset := Reset);
  IF n <= 17 THEN
    got[n, 1] := cst.OUT; got[n, 2] := cfbd.OUT; got[n, 3] := cld.OUT; got[n, 4] := cil.OUT;
  END_IF;
END_PROGRAM
"""


@pytest.mark.parametrize("project", ["beremiz_first_steps", "openplc_multi_language"])
def test_st_fbd_ld_and_il_counters(tmp_path, project):
    xml = derived(project, tmp_path / "xml" / "plc.xml", drop=("CounterSFC", "plc_prg"))
    files = {"plc.xml": xml, "harness.st": COUNTERS}
    got = recorded(tmp_path, files, "plc_task_instance.n", 17, "plc_task_instance.got")
    want = [*range(1, 11), 17, 17, 17, 18, 19, 20, 21]
    assert [got[i : i + 4] for i in range(0, 68, 4)] == [[w] * 4 for w in want]

# test_sfc_projects.py -- the SFC POUs of real PLCopen projects drawn in other tools (../shared/plcopen,
# SOURCES.md sections 2 and 4) imported by `stc build` and run in a real irpd: first_steps' (and
# OpenPLC's Multi_Language) CounterSFC through the worked Reset sequence, cycle by cycle with its
# active step, and Beremiz4uC's traffic_light_sequence through its steps with their durations.

from __future__ import annotations

import pytest
from live_processes import wait_until
from plcopen_live import Running, derived

# Steps the counter one cycle at a time: the test writes `go`, the harness calls the drawn function
# block until it has been called `go` times, so every value read is that of a known cycle.
COUNTER = """
PROGRAM Harness
VAR
  go : DINT;
  n : DINT;
  c : CounterSFC;
  out : INT;
END_VAR
  IF n < go THEN
    n := n + 1;
    c(Reset := n >= 11 AND n <= 13);
    out := c.OUT;
  END_IF;
END_PROGRAM
"""

# SOURCES.md section 2: Reset FALSE for cycles 1-10, TRUE for 11-13, FALSE for 14-17
WORKED = {n: (n, "Count") for n in range(1, 11)} | {
    11: (10, "Start"),
    12: (17, "ResetCounter"),
    13: (17, "ResetCounter"),
    14: (17, "Start"),
    15: (18, "Count"),
    16: (19, "Count"),
    17: (20, "Count"),
}


@pytest.mark.parametrize("project", ["beremiz_first_steps", "openplc_multi_language"])
def test_counter_sfc_follows_the_worked_reset_sequence(tmp_path, project):
    # the whole project, its instance made one of the harness, which calls CounterSFC
    xml = derived(project, tmp_path / "xml" / "plc.xml")
    run = Running(tmp_path, {"plc.xml": xml, "harness.st": COUNTER})
    try:
        seen = {}
        for n in WORKED:
            run.client.request("write", path="plc_task_instance.go", value=n)
            wait_until(lambda n=n: run.value("plc_task_instance.n") == n, 20)
            active = [s for s in ("Start", "ResetCounter", "Count") if run.value(f"plc_task_instance.c.{s}.X")]
            seen[n] = (run.value("plc_task_instance.out"), *active)
    finally:
        run.close()
    assert seen == {n: (cnt, step) for n, (cnt, step) in WORKED.items()}


# Records every cycle where a light changes, with the cycle's number.
LIGHTS = """
PROGRAM Harness
VAR
  seq : traffic_light_sequence;
  n : DINT;
  code : INT;
  last : INT := -1;
  k : INT;
  cycle : ARRAY[1..16] OF DINT;
  seen : ARRAY[1..16] OF INT;
END_VAR
  n := n + 1;
  seq(SWITCH_BUTTON := n > 10 AND n < 58, PEDESTRIAN_BUTTON := n = 50);
  code := 16 * BOOL_TO_INT(seq.RED_LIGHT) + 8 * BOOL_TO_INT(seq.ORANGE_LIGHT) + 4 * BOOL_TO_INT(seq.GREEN_LIGHT)
          + 2 * BOOL_TO_INT(seq.PEDESTRIAN_RED_LIGHT) + BOOL_TO_INT(seq.PEDESTRIAN_GREEN_LIGHT);
  IF code <> last AND k < 16 THEN
    k := k + 1; cycle[k] := n; seen[k] := code;
  END_IF;
  last := code;
END_PROGRAM
"""


def lights(red, orange, green, ped_red, ped_green) -> int:
    return 16 * red + 8 * orange + 4 * green + 2 * ped_red + ped_green


def test_traffic_light_sequence_steps_through_its_lights(tmp_path):
    """SOURCES.md section 4: Standstill blinks the orange light (a named LD action) one cycle in three;
    SwitchButton TRUE from cycle 11: ORANGE 11, RED 16, PEDESTRIAN_GREEN 21, PEDESTRIAN_RED 42, GREEN 47
    (each its D time plus a cycle); PedestrianButton pressed in cycle 50: ORANGE again at 55 (a
    condition drawn as an FBD network); SwitchButton FALSE in 58: Standstill at once (the named FBD
    transition STOP), its P action lighting orange, the other lights reset."""
    xml = derived("beremiz4uc_traffic_lights", tmp_path / "xml" / "plc.xml")
    run = Running(tmp_path, {"plc.xml": xml, "harness.st": LIGHTS})
    try:
        run.wait_value("main_instance.k", 14, 90)
        at = list(run.values("main_instance.cycle").values())[:14]
        codes = list(run.values("main_instance.seen").values())[:14]
    finally:
        run.close()
    orange = lights(0, 1, 0, 0, 0)
    want = [(1, 0), (2, orange), (3, 0), (5, orange), (6, 0), (8, orange), (9, 0)]  # Standstill
    want += [
        (11, lights(0, 1, 0, 1, 0)),  # ORANGE
        (16, lights(1, 0, 0, 1, 0)),  # RED
        (21, lights(1, 0, 0, 0, 1)),  # PEDESTRIAN_GREEN
        (42, lights(1, 0, 0, 1, 0)),  # PEDESTRIAN_RED
        (47, lights(0, 0, 1, 1, 0)),  # GREEN
        (55, lights(0, 1, 0, 1, 0)),  # ORANGE, 2 s after the pedestrian button
        (58, orange),  # Standstill
    ]
    assert codes == [c for _, c in want], list(zip(at, codes))
    assert all(abs(n - m) <= 2 for n, (m, _) in zip(at, want)), list(zip(at, codes))

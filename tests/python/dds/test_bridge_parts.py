"""test_bridge_parts.py -- the DDS bridge's pieces without DDS traffic: what a received value must be
to be written, how traced doubles become message fields, the timing statuses of the diagnostics
(their level from the overruns and misses of the last 10 s, the totals kept as values)."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.dds.bridge import _fits, cast  # noqa: E402
from indurop_agent.dds.diagnostics import LEVEL_ERROR, LEVEL_OK, LEVEL_WARN, WINDOW_S, Timing  # noqa: E402


def test_a_received_value_must_fit_its_message_type():
    assert _fits("std_msgs/msg/Float64", 0.5)
    assert not _fits("std_msgs/msg/Float64", float("nan")) and not _fits("std_msgs/msg/Float32", float("inf"))
    assert _fits("std_msgs/msg/Int8", -128) and not _fits("std_msgs/msg/Int8", 128)
    assert _fits("std_msgs/msg/UInt64", (1 << 64) - 1) and not _fits("std_msgs/msg/UInt8", -1)
    assert _fits("std_msgs/msg/Int32MultiArray", 7) and not _fits("std_msgs/msg/Int32MultiArray", 1 << 31)
    assert _fits("std_msgs/msg/Bool", True)


def test_traced_doubles_become_the_message_field_type():
    assert cast("std_msgs/msg/Bool", 1.0) is True and cast("std_msgs/msg/Bool", 0.0) is False
    assert cast("std_msgs/msg/UInt32", 41.0) == 41 and isinstance(cast("std_msgs/msg/Int64MultiArray", 3.0), int)
    assert cast("std_msgs/msg/Int16", float("nan")) == 0  # a channel that never had a good read
    assert cast("std_msgs/msg/Float32", 2) == 2.0


def test_timing_statuses_name_dispatchers_by_executor_and_grade_their_records():
    figures = {"count": 10, "min": 1, "max": 9, "mean": 5, "p50": 5, "p99": 9, "p999": 9}
    dispatcher = {"name": "dispatcher", "executor": "main", "kind": "dispatcher", "period_ns": 1000000, "runs": 10}
    dispatcher.update(jitter_ns=figures, latency_ns=figures, exec_ns=figures, overruns=0, missed=0)
    module = {"name": "Robot", "executor": "main", "kind": "module", "runs": 5, "overruns": 0, "missed": 0}
    timing = Timing("c1")
    s, m = timing.statuses({"executors": [dispatcher], "modules": [module]}, 100.0)
    assert (s.name, s.level, s.hardware_id) == ("c1: dispatcher main", LEVEL_OK, "c1")
    values = {kv.key: kv.value for kv in s.values}
    assert values["latency_ns p99"] == "9" and values["period_ns"] == "1000000"
    assert m.name == "c1: module Robot" and m.level == LEVEL_OK
    (m,) = timing.statuses({"modules": [{**module, "runs": 6, "overruns": 2}]}, 101.0)
    assert m.level == LEVEL_WARN
    (m,) = timing.statuses({"modules": [{**module, "runs": 7, "overruns": 2, "state": "disabled"}]}, 102.0)
    assert m.level == LEVEL_ERROR


def levels(timing: Timing, samples: list[tuple[float, int, int]]) -> list[tuple[int, str, str]]:
    """(level, total missed, missed in the window) of the dispatcher's status at each (time, runs,
    missed) sample of irpd's totals."""
    out = []
    for now_s, runs, missed in samples:
        record = {"name": "dispatcher", "executor": "main", "kind": "dispatcher", "runs": runs, "overruns": 0}
        (s,) = timing.statuses({"executors": [{**record, "missed": missed}]}, now_s)
        values = {kv.key: kv.value for kv in s.values}
        out.append((s.level, values["missed"], values[f"missed in the last {WINDOW_S:g} s"]))
    return out


def test_one_missed_period_is_warn_for_the_window_then_ok_again_with_the_total_kept():
    assert WINDOW_S == 10
    timing = Timing("c1")
    # a sample a second (the diagnostics' default rate); one missed period between t=2 and t=3
    seen = levels(timing, [(float(t), 1000 * t, 0 if t < 3 else 1) for t in range(30)])
    assert seen[:3] == [(LEVEL_OK, "0", "0")] * 3
    assert seen[3:13] == [(LEVEL_WARN, "1", "1")] * 10  # the window (10 s back from each sample) holds it
    assert seen[13:] == [(LEVEL_OK, "1", "0")] * 17  # healthy again; the total stays a value
    # irpd restarted (runs from zero) with one miss since: counted from zero, not against the old totals
    assert levels(timing, [(30.0, 500, 1), (31.0, 1500, 1), (41.0, 11500, 1)]) == [
        (LEVEL_WARN, "1", "1"),
        (LEVEL_WARN, "1", "1"),
        (LEVEL_OK, "1", "0"),
    ]


def test_what_the_totals_held_before_the_first_look_is_not_recent():
    timing = Timing("c1")
    assert levels(timing, [(0.0, 10**6, 4), (1.0, 10**6 + 1000, 4), (2.0, 10**6 + 2000, 5)]) == [
        (LEVEL_OK, "4", "0"),
        (LEVEL_OK, "4", "0"),
        (LEVEL_WARN, "5", "1"),
    ]

"""test_bridge_parts.py -- the DDS bridge's pieces without DDS traffic: what a received value must be
to be written, how traced doubles become message fields, the timing statuses of the diagnostics."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.dds.bridge import LEVEL_ERROR, LEVEL_OK, LEVEL_WARN, _fits, cast, timing_status  # noqa: E402


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
    s = timing_status("c1", dispatcher)
    assert (s.name, s.level, s.hardware_id) == ("c1: dispatcher main", LEVEL_OK, "c1")
    values = {kv.key: kv.value for kv in s.values}
    assert values["latency_ns p99"] == "9" and values["period_ns"] == "1000000"
    module = {"name": "Robot", "executor": "main", "kind": "module", "runs": 5, "overruns": 2, "missed": 0}
    assert timing_status("c1", module).level == LEVEL_WARN
    assert timing_status("c1", {**module, "state": "disabled"}).level == LEVEL_ERROR
    assert timing_status("c1", module).name == "c1: module Robot"

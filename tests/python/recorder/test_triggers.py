"""test_triggers.py -- the trigger conditions on synthetic rows (agent/indurop_agent/recorder/triggers.py):
every kind, AND and OR, edges and holds across block boundaries and gaps, NaN never triggering,
and which events fire which triggers."""

from __future__ import annotations

import numpy as np
import pytest
from indurop_agent.recorder.triggers import (
    Conditions,
    Event,
    TriggerError,
    alarm_events,
    event_matches,
    irpd_events,
    row_at,
)

NAN = float("nan")


def hits(trigger: dict, blocks: list[list[float]], columns=("x",), first_seq: int = 1, gaps=()) -> list[int]:
    """The seqs at which `trigger` holds, the blocks given one after the other (a gap of n rows after
    block k for (k, n) in gaps); one column per channel, or one value per row for a single channel."""
    cond = Conditions(trigger, list(columns))
    found, seq = [], first_seq
    for k, block in enumerate(blocks):
        values = np.array(block, dtype=float)
        values = values.reshape(1, -1) if values.ndim == 1 else values
        s = np.arange(seq, seq + values.shape[1], dtype=np.int64)
        found += [int(x) for x in s[cond.step(s, values)]]
        seq += values.shape[1] + dict(gaps).get(k, 0)
    return found


def one(**condition) -> dict:
    return {"kind": "condition", "conditions": [{"variable": "x", **condition}]}


def test_rising_falling_and_either_edges_land_on_the_row_that_crosses():
    x = [[0, 0, 1, 1, 0, 0.5, 0.49, 2]]
    assert hits(one(kind="edge", direction="rising", threshold=0.5), x) == [3, 6, 8]
    assert hits(one(kind="edge", direction="falling", threshold=0.5), x) == [5, 7]
    assert hits(one(kind="edge", direction="either", threshold=0.5), x) == [3, 5, 6, 7, 8]


def test_an_edge_whose_previous_row_is_in_the_last_block_is_found_at_its_row():
    rising = one(kind="edge", direction="rising", threshold=0)
    assert hits(rising, [[-1, -1, -1], [1, 1]]) == [4]
    assert hits(rising, [[-1], [-1], [1], [1], [-1], [1]]) == [3, 6]  # one row per block


def test_no_edge_across_a_gap_or_at_the_first_row():
    rising = one(kind="edge", direction="rising", threshold=0)
    assert hits(rising, [[-1, -1], [1, 1]], gaps=[(0, 3)]) == []  # the row before the 1 was lost
    assert hits(rising, [[1, -1, 1]]) == [3]  # the first row has no row before it


def test_levels_hold_across_blocks_and_start_again_after_a_gap():
    above = one(kind="level", compare="above", value=0.5, hold_rows=3)
    assert hits(above, [[1, 1], [1, 0, 1, 1, 1, 1]]) == [3, 7, 8]
    assert hits(above, [[1, 1], [1, 1, 1]], gaps=[(0, 1)]) == [6]  # seqs 1, 2, (3 lost), 4, 5, 6
    assert hits(one(kind="level", compare="below", value=0), [[1, -1, 0, -2]]) == [2, 4]
    assert hits(one(kind="level", compare="equal", value=3), [[3, 3.0001, 2, 3]]) == [1, 4]
    assert hits(one(kind="level", compare="equal", value=3, tolerance=0.01), [[3, 3.0001, 2, 3]]) == [1, 2, 4]


def test_windows_inside_and_outside():
    x = [[-2, -1, 0, 1, 2]]
    assert hits(one(kind="window", where="inside", low=-1, high=1), x) == [2, 3, 4]
    assert hits(one(kind="window", where="outside", low=-1, high=1), x) == [1, 5]
    assert hits(one(kind="window", where="inside", low=-1, high=1, hold_rows=2), x) == [3, 4]


@pytest.mark.parametrize(
    "condition",
    [
        {"kind": "edge", "direction": "rising", "threshold": 0},
        {"kind": "edge", "direction": "falling", "threshold": 0},
        {"kind": "edge", "direction": "either", "threshold": 0},
        {"kind": "level", "compare": "above", "value": -1e300},
        {"kind": "level", "compare": "below", "value": 1e300},
        {"kind": "level", "compare": "equal", "value": 0, "tolerance": 1e300},
        {"kind": "window", "where": "inside", "low": -1e300, "high": 1e300},
        {"kind": "window", "where": "outside", "low": 0, "high": 0},
    ],
)
def test_a_nan_never_triggers(condition):
    # around every NaN: a row that would trigger with any number in its place
    assert hits(one(**condition), [[NAN], [NAN, NAN], [NAN]]) == []
    found = hits(one(**condition), [[NAN, -1, NAN, 1, NAN, NAN, -1, NAN]])
    assert all(s not in found for s in (1, 3, 5, 6, 8))
    if condition["kind"] == "edge":  # every row after a NaN has no row before it to cross from
        assert found == []


def test_and_takes_the_edge_row_where_the_level_holds_or_the_first_of_either():
    a = [0, 1, 0, 1, 0, 1, 0, 1]  # rising at 2, 4, 6, 8
    b = [0, 0, 0, 0, 1, 1, 1, 1]  # above 0.5 from 5
    both = {
        "kind": "condition",
        "combine": "and",
        "conditions": [
            {"kind": "edge", "variable": "a", "direction": "rising", "threshold": 0.5},
            {"kind": "level", "variable": "b", "compare": "above", "value": 0.5},
        ],
    }
    assert hits(both, [[a, b]], columns=("a", "b")) == [6, 8]
    assert hits(both, [[a[:5], b[:5]], [a[5:], b[5:]]], columns=("a", "b")) == [6, 8]
    either = {**both, "combine": "or"}
    assert hits(either, [[a, b]], columns=("a", "b")) == [2, 4, 5, 6, 7, 8]


def test_up_to_four_conditions_and_only_on_the_captures_channels():
    edge = {"kind": "edge", "variable": "x", "threshold": 0}
    Conditions({"kind": "condition", "conditions": [edge] * 4}, ["x"])
    with pytest.raises(TriggerError, match="5 conditions given; a trigger combines 1 to 4"):
        Conditions({"kind": "condition", "conditions": [edge] * 5}, ["x"])
    with pytest.raises(TriggerError, match="'y' is not one of the capture's channels"):
        Conditions({"kind": "condition", "conditions": [{**edge, "variable": "y"}]}, ["x"])


def test_events_fire_the_triggers_of_their_kind_key_and_severity():
    raised = alarm_events(
        {
            "transitions": [
                {"event": "raise", "key": "main/8", "severity": "high", "time_ns": 5, "text": "drives lost"},
                {"event": "clear", "key": "main/8", "severity": "high", "time_ns": 6, "text": "drives lost"},
            ]
        }
    )
    assert len(raised) == 1 and raised[0].key == "main/8" and raised[0].time_ns == 5
    e = raised[0]
    assert event_matches({"kind": "alarm"}, e)
    assert event_matches({"kind": "alarm", "key": "main/8"}, e)
    assert not event_matches({"kind": "alarm", "key": "main/9"}, e)
    assert event_matches({"kind": "alarm", "severity": "medium"}, e)
    assert not event_matches({"kind": "alarm", "severity": "critical"}, e)
    assert not event_matches({"kind": "fault"}, e)
    faults = irpd_events(
        [
            {"kind": "stopped", "time_ns": 7, "module": "cntr1", "message": "overrun"},
            {"kind": "swap", "time_ns": 8, "module": None, "message": "generation 3"},
            {"kind": "overrun", "time_ns": 9, "module": "cntr1", "message": "1 overrun"},
        ]
    )
    assert [(f.kind, f.time_ns) for f in faults] == [("fault", 7), ("swap", 8)]
    assert event_matches({"kind": "fault"}, faults[0]) and event_matches({"kind": "swap"}, faults[1])
    assert not event_matches({"kind": "manual"}, Event("alarm", 1, "x"))


def test_the_row_of_a_time_is_the_last_row_due_at_or_before_it():
    seq = np.array([10, 11, 12, 14], dtype=np.int64)
    t = np.array([1000, 2000, 3000, 5000], dtype=np.int64)
    assert row_at(seq, t, 999) is None
    assert row_at(seq, t, 1000) == 10
    assert row_at(seq, t, 2999) == 11
    assert row_at(seq, t, 4999) == 12
    assert row_at(seq, t, 10**9) == 14

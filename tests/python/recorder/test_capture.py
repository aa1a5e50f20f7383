"""test_capture.py -- one capture on synthetic rows (agent/indurop_agent/recorder/capture.py): the
trigger row and its pre and post rows exact, a trigger ignored until the pre-trigger buffer is full,
pre rows that came from the rings before arming, post rows over many blocks, repeated shots
re-armed after each, drops counted in the shot, NaN never triggering, events matched to the row of
their time (also late, and when the rows stopped), stalls and disarming saving what there is."""

from __future__ import annotations

import numpy as np
import pytest
from indurop_agent.recorder.capture import ARMED, DONE, IDLE, TRIGGERED, Capture, History
from indurop_agent.recorder.capture_limits import BLOCK_ROWS, STALL_S
from indurop_agent.recorder.triggers import Event

BASIC = 1_000_000  # 1 ms
T0 = 10**12  # the due time of row 0


def square(seq: np.ndarray, period: int = 100) -> np.ndarray:
    """-1 for the first half of each period, +1 for the second: rising at seq % period == 50."""
    return np.where(seq % period < period // 2, -1.0, 1.0)


class Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def make(trigger=None, pre=10, post=5, repeat=1, channels=("x", "y")):
    shots = []
    clock = Clock()
    spec = {
        "name": "t",
        "variables": list(channels),
        "trigger": trigger
        or {
            "kind": "condition",
            "conditions": [{"kind": "edge", "variable": "x", "direction": "rising", "threshold": 0}],
        },
        "pre": {"rows": pre},
        "post": {"rows": post},
        "repeat": repeat,
    }
    c = Capture("c1", spec, list(channels), BASIC, lambda cap, shot: shots.append(shot), monotonic=clock)
    c.test_clock = clock
    return c, shots


def feed(c: Capture, first: int, last: int, block: int = 37, skip=()) -> None:
    """Rows first..last (but those in skip) in blocks: x the square wave, y = seq."""
    seq = np.array([s for s in range(first, last + 1) if s not in skip], dtype=np.int64)
    for k in range(0, len(seq), block):
        s = seq[k : k + block]
        # the engine gives contiguous parts; split at the skipped rows as it would
        breaks = np.flatnonzero(np.diff(s) != 1) + 1
        for part in np.split(s, breaks):
            if len(part):
                c.feed(part, T0 + part * BASIC, np.stack([square(part), part.astype(float)]))


def test_a_rising_edge_makes_a_shot_with_its_exact_row_and_pre_and_post_rows():
    c, shots = make(pre=10, post=5)
    c.arm(head=0)
    feed(c, 1, 200)
    assert c.state == DONE and len(shots) == 1
    shot = shots[0]
    seq, t, values = shot.arrays()
    assert shot.trigger_seq == 50 and values[0][list(seq).index(50)] == 1 and values[0][list(seq).index(49)] == -1
    assert list(seq) == list(range(40, 56)) and list(t) == [T0 + s * BASIC for s in range(40, 56)]
    assert list(values[1]) == [float(s) for s in range(40, 56)]  # every value is its row's
    summary = shot.summary()
    assert (summary["pre_rows"], summary["post_rows"], summary["drops"]) == (10, 5, 0)


def test_no_trigger_before_the_pre_trigger_buffer_is_full_nor_on_rows_before_arming():
    c, shots = make(pre=60, post=5)
    c.arm(head=0)
    feed(c, 1, 100)  # the edge at 50 has only 49 rows before it
    assert c.state == ARMED and c.pre_filled() == 60 and shots == []
    feed(c, 101, 200)
    assert shots[0].trigger_seq == 150 and shots[0].summary()["pre_rows"] == 60
    # rows the rings held from before it was armed fill the buffer, but never trigger
    c, shots = make(pre=60, post=5)
    c.arm(head=120)
    feed(c, 1, 160)  # the edge at 50 is before the arming
    assert shots[0].trigger_seq == 150 and shots[0].summary()["pre_rows"] == 60


def test_pre_rows_at_the_edge_of_what_the_rings_and_the_history_hold():
    c, shots = make(pre=BLOCK_ROWS // 2 * 4 - 100, post=3)  # about two history sizes of rows go by first
    c.arm(head=0)
    feed(c, 1, 5000, block=BLOCK_ROWS)
    first = shots[0]
    assert first.trigger_seq - c.pre >= 1
    seq, _, values = first.arrays()
    assert list(seq) == list(range(first.trigger_seq - c.pre, first.trigger_seq + 4))
    assert list(values[1]) == list(map(float, seq))
    h = History(8, 1)  # the history keeps the newest rows only, each at its own index
    h.put(np.arange(1, 21), np.arange(1, 21), np.arange(1, 21, dtype=float).reshape(1, -1))
    assert list(h.rows(1, 20)[0]) == list(range(13, 21))


def test_post_rows_over_many_blocks_and_a_trigger_in_the_last_row_of_a_block():
    c, shots = make(pre=10, post=3000)
    c.arm(head=0)
    feed(c, 1, 49, block=49)  # the edge's previous row ends a block
    feed(c, 50, 4000, block=100)
    assert shots[0].trigger_seq == 50
    assert shots[0].summary()["post_rows"] == 3000 and shots[0].summary()["drops"] == 0


def test_repeated_shots_rearm_after_each_until_the_count():
    c, shots = make(pre=10, post=60, repeat=3)
    c.arm(head=0)
    feed(c, 1, 1000)
    # post 60 runs past the next edge (150 - 50 = 100 > 60): each edge makes a shot
    assert [s.trigger_seq for s in shots] == [50, 150, 250] and c.state == DONE
    assert [s.number for s in shots] == [1, 2, 3]
    c, shots = make(pre=10, post=120, repeat=0)
    c.arm(head=0)
    feed(c, 1, 1000)
    # a shot's rows are its own: the next trigger comes after its last row (50 + 120 = 170)
    assert [s.trigger_seq for s in shots] == [50, 250, 450, 650, 850] and c.state == ARMED
    c.arm(head=1000)  # armed again: the count starts again, the numbers go on
    feed(c, 1001, 1200)
    assert shots[-1].trigger_seq == 1050 and shots[-1].number == 6


def test_rows_lost_before_they_were_read_are_the_shots_drops():
    c, shots = make(pre=10, post=10)
    c.arm(head=0)
    feed(c, 1, 100, skip={43, 44, 55})
    s = shots[0].summary()
    assert (s["trigger_seq"], s["pre_rows"], s["post_rows"], s["drops"], s["rows"]) == (50, 8, 9, 3, 18)
    assert c.lost_rows == 3


def test_a_nan_never_triggers_a_capture():
    c, shots = make(pre=2, post=2)
    c.arm(head=0)
    seq = np.arange(1, 11, dtype=np.int64)
    x = np.array([-1, -1, -1, np.nan, 1, 1, np.nan, -1, np.nan, 1])
    c.feed(seq, T0 + seq * BASIC, np.stack([x, seq.astype(float)]))
    assert shots == [] and c.state == ARMED


def alarm(time_ns: int, key="main/8", severity="high") -> Event:
    return Event("alarm", time_ns, f"alarm {key} raised", key=key, severity=severity)


def test_an_event_takes_the_row_whose_due_time_is_its_time():
    c, shots = make({"kind": "alarm", "key": "main/8"}, pre=20, post=5)
    c.arm(head=0)
    feed(c, 1, 82)
    t_event = T0 + 80 * BASIC + BASIC // 2  # halfway through row 80's period
    assert not c.on_event(alarm(c.armed_at_ns + 1, key="main/9"), t_event)  # another alarm
    assert c.on_event(alarm(c.armed_at_ns + 1), t_event)
    assert c.state == TRIGGERED
    feed(c, 83, 120)
    s = shots[0].summary()
    assert (s["trigger_seq"], s["pre_rows"], s["post_rows"], s["cause"]) == (80, 20, 5, "alarm")
    # an event before the arming (irpd's event log is read from its start) does not trigger
    c, shots = make({"kind": "fault"}, pre=5, post=5)
    c.arm(head=0)
    assert not c.on_event(Event("fault", c.armed_at_ns - 1, "old"), T0)


def test_an_event_waits_for_its_row_and_a_late_one_counts_what_is_gone():
    c, shots = make({"kind": "swap"}, pre=20, post=5)
    c.arm(head=0)
    feed(c, 1, 50)
    assert c.on_event(Event("swap", c.armed_at_ns + 1, "swap"), T0 + 70 * BASIC)  # not sampled yet
    assert c.state == ARMED
    feed(c, 51, 100)
    assert shots[0].trigger_seq == 70 and shots[0].summary()["pre_rows"] == 20
    c, shots = make({"kind": "swap"}, pre=20, post=5)
    c.arm(head=0)
    feed(c, 1, 10_000)
    c.on_event(Event("swap", c.armed_at_ns + 1, "swap"), T0 + 100 * BASIC)  # older than the history
    s = shots[0].summary()
    assert s["trigger_seq"] == 100 and s["rows"] == 0 and s["drops"] == 26
    assert "too late" in s["notes"][0]


def test_when_the_rows_stop_a_pending_event_and_a_shot_are_saved_with_what_there_is():
    c, shots = make({"kind": "fault"}, pre=20, post=50)
    c.arm(head=0)
    feed(c, 1, 100)
    c.on_event(Event("fault", c.armed_at_ns + 1, "stopped"), T0 + 500 * BASIC)  # the set stopped at 100
    c.tick()
    assert c.state == ARMED  # not yet STALL_S without rows
    c.test_clock.now += STALL_S + 0.1
    c.tick()
    s = shots[0].summary()
    assert (s["trigger_seq"], s["pre_rows"], s["post_rows"]) == (100, 20, 0)
    assert any("rings stopped at seq 100" in n for n in s["notes"]) and c.state == DONE


def test_disarming_keeps_the_rows_of_a_shot_being_collected():
    c, shots = make(pre=10, post=100)
    c.arm(head=0)
    feed(c, 1, 80)
    assert c.state == TRIGGERED
    c.disarm()
    assert c.state == IDLE and shots[0].summary()["post_rows"] == 30
    assert "disarmed while collecting" in shots[0].notes[-1]


def test_manual_trigger_forces_any_armed_capture():
    c, shots = make(pre=5, post=5)
    c.arm(head=0)
    feed(c, 1, 30)
    assert c.on_event(Event("manual", c.armed_at_ns + 1, "now"), T0 + 20 * BASIC, force=True)
    feed(c, 31, 40)
    assert shots[0].trigger_seq == 20 and shots[0].cause == "manual"


@pytest.mark.parametrize("seconds,rows", [(0.01, 10), (0.0105, 11), (0, 0)])
def test_lengths_in_seconds_are_rows_of_the_basic_period(seconds, rows):
    from indurop_agent.recorder.capture import rows_of

    assert rows_of({"seconds": seconds}, BASIC) == rows


def test_when_the_rings_restart_a_pending_event_takes_the_old_rings_last_rows_and_it_goes_on():
    c, shots = make({"kind": "fault"}, pre=20, post=50, repeat=0)
    c.arm(head=0)
    feed(c, 1, 100)
    c.on_event(Event("fault", c.armed_at_ns + 1, "irpd died"), T0 + 500 * BASIC)
    c.restart("irpd restarted")
    s = shots[0].summary()
    assert (s["trigger_seq"], s["pre_rows"], s["post_rows"]) == (100, 20, 0) and "irpd restarted" in s["notes"]
    assert c.state == ARMED and c.pre_filled() == 0
    feed(c, 1, 30)  # the new rings' rows, from seq 1 again
    assert c.pre_filled() == 20 and c.on_event(Event("manual", c.armed_at_ns + 1, "now"), T0 + 25 * BASIC, force=True)
    feed(c, 31, 80)
    assert shots[1].trigger_seq == 25 and shots[1].summary()["pre_rows"] == 20 and shots[1].number == 2


def test_now_on_a_capture_of_conditions_waits_for_its_row():
    c, shots = make(pre=5, post=5, repeat=0)  # rising at 50, 150, ...
    c.arm(head=0)
    feed(c, 1, 30)
    assert c.on_event(Event("manual", c.armed_at_ns + 1, "now"), T0 + 40 * BASIC, force=True)  # not sampled yet
    feed(c, 31, 60)
    assert [(s.trigger_seq, s.cause) for s in shots] == [(40, "manual"), (50, "condition")]


def test_a_pre_trigger_buffer_as_long_as_the_rings():
    c, shots = make(pre=16384, post=10)
    c.arm(head=0)
    seq = np.arange(1, 40_001, dtype=np.int64)
    x = np.where((seq // 10_000) % 2 == 1, 1.0, -1.0)  # rising at 10 000 (too early) and 30 000
    for k in range(0, len(seq), 200):
        s = seq[k : k + 200]
        c.feed(s, T0 + s * BASIC, np.stack([x[k : k + 200], s.astype(float)]))
    assert len(shots) == 1 and shots[0].trigger_seq == 30_000
    got, _, values = shots[0].arrays()
    s = shots[0].summary()
    assert (s["pre_rows"], s["post_rows"], s["drops"]) == (16384, 10, 0)
    assert got[0] == 30_000 - 16384 and list(values[1]) == list(map(float, got))

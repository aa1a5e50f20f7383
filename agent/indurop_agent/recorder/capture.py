"""capture.py -- one triggered capture: its state (idle, armed, triggered, done), the history of its
rows that holds the pre-trigger buffer, and the shots it takes (docs/recorder.md).

The engine (capture_engine.py) feeds every capture the rows of the trace rings that carry all its
channels, in seq order, a block at a time; a capture never reads the rings itself, so that the
tests give it synthetic rows.  A shot is the rows trigger_seq - pre ... trigger_seq + post; the
rows of that range a capture should have had but did not get (overwritten before the engine read
them, or sampled without its channels) are the shot's drops.

    idle --arm--> armed --trigger row found--> triggered --post rows in--> armed (repeat) | done
                    \\------------------disarm (from armed or triggered)-----------> idle
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .capture_limits import BLOCK_ROWS, EVENT_LAG_S, STALL_S
from .triggers import Conditions, Event, event_matches, row_at

IDLE, ARMED, TRIGGERED, DONE = "idle", "armed", "triggered", "done"
STATES = (IDLE, ARMED, TRIGGERED, DONE)


def rows_of(length: dict, basic_period_ns: int) -> int:
    """A pre- or post-trigger length ({"rows": n} or {"seconds": s}) in rows of the basic period."""
    if length.get("rows") is not None:
        return int(length["rows"])
    return math.ceil(float(length["seconds"]) * 1e9 / basic_period_ns - 1e-9)


def history_rows(pre: int, event_trigger: bool, basic_period_ns: int) -> int:
    """Rows a capture's history holds: its pre-trigger rows and a block, and for a trigger by an
    event the rows the event may come late by (EVENT_LAG_S)."""
    lag = math.ceil(EVENT_LAG_S * 1e9 / basic_period_ns) if event_trigger else 0
    return pre + lag + BLOCK_ROWS + 1


def capture_bytes(channels: int, pre: int, post: int, event_trigger: bool, basic_period_ns: int) -> int:
    """The memory an armed capture takes: its history and one shot, 8 bytes per value, due time and seq."""
    per_row = 8 * channels + 16
    return per_row * (history_rows(pre, event_trigger, basic_period_ns) + pre + 1 + post)


class History:
    """The newest rows, row s at index s % size with its seq kept, so that a missing row is seen."""

    def __init__(self, size: int, channels: int):
        self.size = size
        self.seq = np.full(size, -1, dtype=np.int64)
        self.t_ns = np.zeros(size, dtype=np.int64)
        self.values = np.full((channels, size), np.nan)
        self.newest = 0

    def put(self, seq: np.ndarray, t_ns: np.ndarray, values: np.ndarray) -> None:
        if len(seq) > self.size:
            seq, t_ns, values = seq[-self.size :], t_ns[-self.size :], values[:, -self.size :]
        i = seq % self.size
        self.seq[i], self.t_ns[i], self.values[:, i] = seq, t_ns, values
        self.newest = max(self.newest, int(seq[-1]))

    def rows(self, a: int, b: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The rows a..b it holds (seq, t_ns, values), in seq order."""
        a = max(a, self.newest - self.size + 1, 1)
        if b < a:
            return np.zeros(0, np.int64), np.zeros(0, np.int64), self.values[:, :0]
        want = np.arange(a, b + 1, dtype=np.int64)
        i = want % self.size
        held = self.seq[i] == want
        i = i[held]
        return self.seq[i], self.t_ns[i], self.values[:, i]


@dataclass
class Shot:
    """One trigger's rows: trigger_seq - pre .. trigger_seq + post, as they come in."""

    number: int
    trigger_seq: int
    first: int  # trigger_seq - pre
    last: int  # trigger_seq + post
    cause: str  # what triggered it, for people
    trigger_time_ns: int  # CLOCK_REALTIME when it was triggered (the event's time for an event)
    start_seq: int  # the first row the capture had (rows before it were never its: not drops)
    seq: list[np.ndarray] = field(default_factory=list)
    t_ns: list[np.ndarray] = field(default_factory=list)
    values: list[np.ndarray] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    seen: int = 0  # the newest seq the capture was given while collecting

    def add(self, seq: np.ndarray, t_ns: np.ndarray, values: np.ndarray) -> None:
        if len(seq):
            self.seq.append(seq)
            self.t_ns.append(t_ns)
            self.values.append(values)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if not self.seq:
            return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 0))
        return np.concatenate(self.seq), np.concatenate(self.t_ns), np.concatenate(self.values, axis=1)

    def summary(self) -> dict:
        seq = np.concatenate(self.seq) if self.seq else np.zeros(0, np.int64)
        expected_from = max(self.first, self.start_seq)
        expected_to = min(self.last, self.seen)
        expected = max(0, expected_to - expected_from + 1)
        held = int(np.count_nonzero((seq >= expected_from) & (seq <= expected_to)))
        return {
            "shot": self.number,
            "trigger_seq": self.trigger_seq,
            "first_seq": self.first,
            "last_seq": self.last,
            "pre_rows": int(np.count_nonzero(seq < self.trigger_seq)),
            "post_rows": int(np.count_nonzero(seq > self.trigger_seq)),
            "rows": len(seq),
            "drops": expected - held,
            "cause": self.cause,
            "trigger_time_ns": self.trigger_time_ns,
            "notes": list(self.notes),
        }


class Capture:
    """An armed capture's state and rows.  `spec` is the request (name, variables, trigger, pre,
    post, repeat; capture_models.CaptureRequest as JSON); `channels` its variables and then the
    trigger's, the order of the values it is fed; `on_shot(capture, shot)` takes each finished shot."""

    def __init__(
        self,
        capture_id: str,
        spec: dict,
        channels: list[str],
        basic_period_ns: int,
        on_shot: Callable[[Capture, Shot], None],
        clock: Callable[[], int] = time.time_ns,
        monotonic: Callable[[], float] = time.monotonic,
    ):
        self.id, self.spec, self.channels = capture_id, spec, list(channels)
        self.basic_period_ns = basic_period_ns
        self.on_shot, self.clock, self.monotonic = on_shot, clock, monotonic
        self.trigger = spec["trigger"]
        self.event_trigger = self.trigger["kind"] != "condition"
        self.pre = rows_of(spec["pre"], basic_period_ns)
        self.post = rows_of(spec["post"], basic_period_ns)
        self.repeat = int(spec.get("repeat", 1))
        self.conditions = None if self.event_trigger else Conditions(self.trigger, self.channels)
        self.state = IDLE
        self.shots_taken = 0  # since it was last armed
        self.next_number = 1  # numbers shots for good (a re-armed capture goes on counting)
        self.lost_rows = 0  # rows after its first one that it did not get, while armed
        self.armed_at_ns: int | None = None
        self.history: History | None = None
        self.shot: Shot | None = None
        self.pending: list[tuple[Event, int]] = []  # (event, its CLOCK_MONOTONIC time) waiting for its row
        self.last_rows_at = 0.0

    # ---- arming ----------------------------------------------------------------------------------
    def arm(self, head: int, fresh: bool = True) -> None:
        """Armed from now: triggers are looked for in rows after `head` (the ring's newest row); the
        rows before it that the ring still holds may fill the pre-trigger buffer.  `fresh`: the
        count of shots starts again (not so when the rings restarted under an armed capture)."""
        self.history = History(history_rows(self.pre, self.event_trigger, self.basic_period_ns), len(self.channels))
        if self.conditions is not None:
            self.conditions.reset()
        if fresh:
            self.shots_taken = 0
        self.state, self.shot, self.pending = ARMED, None, []
        self.armed_seq = head  # triggers only at rows after it
        self.start_seq: int | None = None  # the first row it was given
        self.last_seq: int | None = None
        self.armed_at_ns = self.clock()
        self.last_rows_at = self.monotonic()

    def disarm(self, why: str = "disarmed") -> None:
        """Idle; a shot being collected is kept with the rows it has."""
        if self.shot is not None:
            self._finish(f"{why} while collecting the post-trigger rows: saved with the rows it had")
        self.state, self.history, self.pending = IDLE, None, []

    def restart(self, note: str) -> None:
        """The rings began again (irpd restarted): the history is gone.  An event waiting for its row
        takes the old rings' newest (what led up to the restart), a shot being collected is saved
        with what it has; the capture stays armed, from the new rings' first rows."""
        if self.state == ARMED and self.pending:
            self._resolve_pending(stalled=True)
        if self.shot is not None:
            self._finish(note)
        if self.state in (ARMED, TRIGGERED):
            self.arm(0, fresh=False)

    @property
    def armed(self) -> bool:
        return self.state in (ARMED, TRIGGERED)

    def pre_filled(self) -> int:
        """Rows of the pre-trigger buffer held now (at most pre)."""
        if self.start_seq is None or self.last_seq is None:
            return 0
        return min(self.pre, self.last_seq - self.start_seq + 1)

    # ---- rows --------------------------------------------------------------------------------------
    def feed(self, seq: np.ndarray, t_ns: np.ndarray, values: np.ndarray) -> None:
        """A block of rows (seq ascending, each after the rows given before; values: one row per
        channel), at most BLOCK_ROWS of them."""
        if not self.armed or len(seq) == 0:
            return
        self.last_rows_at = self.monotonic()
        if self.start_seq is None:
            self.start_seq = int(seq[0])
        elif int(seq[0]) > self.last_seq + 1:
            self.lost_rows += int(seq[0]) - self.last_seq - 1
        self.last_seq = int(seq[-1])
        self.history.put(seq, t_ns, values)
        hits = self.conditions.step(seq, values) if self.conditions is not None else None
        start = 0  # rows of the block before it belong to a shot already
        while self.armed:
            if self.state == TRIGGERED:
                start = self._collect(seq, t_ns, values, start)
                if self.state == TRIGGERED:
                    return
                continue
            if self._resolve_pending():  # an event (or an operator's "now") whose row has come
                continue
            k = self._first_trigger(seq, hits, start) if hits is not None else None
            if k is None:
                return
            self._trigger(int(seq[k]), "condition", self.clock())

    def _first_trigger(self, seq: np.ndarray, hits: np.ndarray, start: int) -> int | None:
        """The first row at or after `start` where the condition holds, after the arming and after
        the pre-trigger buffer is full."""
        eligible = hits[start:] & (seq[start:] > self.armed_seq) & (seq[start:] - self.pre >= self.start_seq)
        k = int(np.argmax(eligible)) if len(eligible) else 0
        return start + k if len(eligible) and eligible[k] else None

    def _trigger(self, trigger_seq: int, cause: str, when_ns: int, note: str | None = None) -> None:
        first, last = trigger_seq - self.pre, trigger_seq + self.post
        self.shot = Shot(self.next_number, trigger_seq, first, last, cause, when_ns, self.start_seq or trigger_seq)
        self.next_number += 1
        if note:
            self.shot.notes.append(note)
        if first < (self.start_seq or first):
            self.shot.notes.append(
                f"triggered {trigger_seq - self.start_seq} rows after the capture's first row: "
                f"{trigger_seq - self.start_seq} pre-trigger rows of {self.pre}"
            )
        self.shot.add(*self.history.rows(first, min(last, self.last_seq)))
        self.shot.seen = self.last_seq
        self.state = TRIGGERED
        if last <= self.last_seq:
            self._finish()

    def _collect(self, seq: np.ndarray, t_ns: np.ndarray, values: np.ndarray, start: int) -> int:
        """Adds the block's rows after the shot's newest up to its last; finishes it when they are
        all in.  Returns the index of the first row of the block after the shot."""
        shot = self.shot
        lo = int(np.searchsorted(seq, shot.seen, side="right"))
        hi = int(np.searchsorted(seq, shot.last, side="right"))
        lo = max(lo, start)
        if hi > lo:
            shot.add(seq[lo:hi], t_ns[lo:hi], values[:, lo:hi])
        shot.seen = max(shot.seen, int(seq[-1]) if hi == len(seq) else shot.last)
        if shot.seen >= shot.last:
            self._finish()
        return hi

    def _finish(self, note: str | None = None) -> None:
        shot, self.shot = self.shot, None
        if note:
            shot.notes.append(note)
        self.shots_taken += 1
        after = shot.last if note is None else max(shot.seen, shot.trigger_seq)
        self.armed_seq = max(self.armed_seq, after)  # the next trigger comes after this shot
        self.pending = [(e, t) for e, t in self.pending if t > self._t_of(after)]
        if self.repeat and self.shots_taken >= self.repeat:
            self.state, self.history, self.pending = DONE, None, []
        else:
            self.state = ARMED
        self.on_shot(self, shot)

    def _t_of(self, seq_: int) -> int:
        """The due time of a row the history holds (else of its newest)."""
        if self.history is None:
            return 0
        s, t, _ = self.history.rows(seq_, seq_)
        return int(t[0]) if len(t) else int(self.history.t_ns[self.history.newest % self.history.size])

    # ---- events ----------------------------------------------------------------------------------
    def on_event(self, event: Event, mono_ns: int, force: bool = False) -> bool:
        """An event (its time also as CLOCK_MONOTONIC: `mono_ns`); True when it will trigger this
        capture.  `force`: an operator's "now" on a capture of any trigger."""
        if self.state != ARMED or (not force and not event_matches(self.trigger, event)):
            return False
        if event.time_ns < (self.armed_at_ns or 0):
            return False  # it happened before the capture was armed (irpd's log read from the start)
        if self.pending:
            return False  # the first one pending triggers; later ones fall in its rows
        self.pending.append((event, mono_ns))
        self._resolve_pending()
        return True

    def _resolve_pending(self, stalled: bool = False) -> bool:
        """Triggers at the row of the first pending event once the rows reach its time (or, when
        `stalled`, at the newest row); True when it triggered."""
        if not self.pending or self.state != ARMED or self.history is None or self.last_seq is None:
            return False
        event, mono_ns = self.pending[0]
        seq, t_ns, _ = self.history.rows(self.last_seq - self.history.size + 1, self.last_seq)
        if len(seq) == 0:
            return False
        if t_ns[-1] < mono_ns and not stalled:
            return False  # its row is not sampled yet (or not read yet)
        self.pending.pop(0)
        note = f"triggered by {event.what}"
        at = row_at(seq, t_ns, mono_ns)
        if at is None:  # older than every row held: it came later than EVENT_LAG_S
            at = int(seq[0]) - math.ceil((int(t_ns[0]) - mono_ns) / self.basic_period_ns)
            note += f"; it reached the capture too late for the rows before seq {int(seq[0])}"
        elif t_ns[-1] < mono_ns:
            note += f"; no row at its time (the rings stopped at seq {int(seq[-1])})"
        self._trigger(at, event.kind, event.time_ns, note)
        return True

    def tick(self) -> None:
        """Every poll of the engine: a pending event or a shot whose rows stopped coming for STALL_S
        is dealt with (triggered at the newest row; saved with the rows it has)."""
        if not self.armed or self.monotonic() - self.last_rows_at < STALL_S:
            return
        if self.state == ARMED and self.pending:
            self._resolve_pending(stalled=True)
        if self.state == TRIGGERED:
            self._finish(f"no rows for {STALL_S:g} s after seq {self.shot.seen}: saved with the rows it had")

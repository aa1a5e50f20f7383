"""triggers.py -- what starts a capture (docs/recorder.md "Triggered captures"): conditions on
variables, evaluated with numpy on every row of the trace rings, and events (an alarm raised, a
fault, a hot swap, an operator's "now"), matched to the row whose due time is theirs.

A condition is evaluated on each block of rows the capture is given, carrying what it needs from
the block before (the previous row's side of an edge's threshold, how long a level has held), so
that an edge whose previous row came in the last block is found at its exact row.  A row whose
previous row is missing (rows lost, or the first row seen) starts again: no edge is found at it
and a hold starts counting at it.  NaN is on neither side of anything: it never makes a
condition true, and no edge is found into or out of it.

    edge    rising: the previous row < threshold <= this row; falling: the previous row >= threshold
            > this row; either: one of the two
    level   above: x > value; below: x < value; equal: |x - value| <= tolerance; held for
            hold_rows rows in a row (the trigger row is the one that completes the hold)
    window  inside: low <= x <= high; outside: x < low or x > high; held as a level
    and/or  of up to MAX_CONDITIONS conditions, row by row: with AND, the trigger row is the first
            row at which every condition is true (for an edge and a level: the edge's row, when
            the level holds there)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .capture_limits import MAX_CONDITIONS

SEVERITIES = ("low", "medium", "high", "critical")
EVENT_KINDS = ("alarm", "fault", "swap", "manual")
FAULT_EVENTS = ("fault", "stopped")  # irpd's event kinds: a module threw; a fault stopped the set
SWAP_EVENTS = ("swap",)


class TriggerError(ValueError):
    """A trigger that cannot be evaluated as given: the message names what to fix."""


def trigger_variables(trigger: dict) -> list[str]:
    """The variables a trigger reads, in its order, each once."""
    out: list[str] = []
    for c in trigger.get("conditions") or []:
        if c["variable"] not in out:
            out.append(c["variable"])
    return out


class _Condition:
    """One condition on one column; step() answers, for each row of a block, whether it holds."""

    def __init__(self, spec: dict, column: int):
        self.spec, self.column = spec, column
        self.reset()

    def reset(self) -> None:
        """Forget the row before (after a gap, or before the first block)."""
        self.prev_above: bool = False
        self.prev_valid: bool = False
        self.run: int = 0

    def step(self, x: np.ndarray, gap_before: np.ndarray) -> np.ndarray:
        raise NotImplementedError


class _Edge(_Condition):
    def step(self, x: np.ndarray, gap_before: np.ndarray) -> np.ndarray:
        threshold = float(self.spec.get("threshold", 0.0))
        valid = ~np.isnan(x)
        above = valid & (x >= threshold)
        prev_above = np.empty_like(above)
        prev_valid = np.empty_like(valid)
        prev_above[0], prev_valid[0] = self.prev_above, self.prev_valid
        prev_above[1:], prev_valid[1:] = above[:-1], valid[:-1]
        prev_valid &= ~gap_before
        both = valid & prev_valid
        direction = self.spec.get("direction", "rising")
        if direction == "rising":
            hit = both & ~prev_above & above
        elif direction == "falling":
            hit = both & prev_above & ~above
        else:
            hit = both & (prev_above != above)
        self.prev_above, self.prev_valid = bool(above[-1]), bool(valid[-1])
        return hit


class _Held(_Condition):
    """A state (a level, a window) that must hold for hold_rows consecutive rows."""

    def state(self, x: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def step(self, x: np.ndarray, gap_before: np.ndarray) -> np.ndarray:
        true = self.state(x)  # NaN compares false everywhere
        n = len(x)
        idx = np.arange(n, dtype=np.int64)
        none = np.int64(-(1 << 62))
        # The last row at or before each row where a run was broken: a false row breaks at itself,
        # a gap before a true row breaks just before it.
        marker = np.full(n, none, dtype=np.int64)
        marker[~true] = idx[~true]
        restart = true & gap_before
        marker[restart] = idx[restart] - 1
        last = np.maximum.accumulate(marker)
        run = np.where(last == none, idx + 1 + self.run, idx - last)
        self.run = int(run[-1])
        return run >= int(self.spec.get("hold_rows", 1))


class _Level(_Held):
    def state(self, x: np.ndarray) -> np.ndarray:
        value, compare = float(self.spec["value"]), self.spec["compare"]
        if compare == "above":
            return x > value
        if compare == "below":
            return x < value
        return np.abs(x - value) <= float(self.spec.get("tolerance", 0.0))


class _Window(_Held):
    def state(self, x: np.ndarray) -> np.ndarray:
        low, high = float(self.spec["low"]), float(self.spec["high"])
        if self.spec.get("where", "inside") == "inside":
            return (x >= low) & (x <= high)
        return (x < low) | (x > high)


KINDS = {"edge": _Edge, "level": _Level, "window": _Window}


class Conditions:
    """A condition trigger ({"kind": "condition", "combine": "and"|"or", "conditions": [...]}) over
    a capture's columns (`columns`: its channel paths, in the order of the values it is given)."""

    def __init__(self, trigger: dict, columns: Sequence[str]):
        specs = trigger.get("conditions") or []
        if not 1 <= len(specs) <= MAX_CONDITIONS:
            raise TriggerError(f"{len(specs)} conditions given; a trigger combines 1 to {MAX_CONDITIONS}")
        self.combine = trigger.get("combine", "and")
        if self.combine not in ("and", "or"):
            raise TriggerError(f"combine must be 'and' or 'or', not {self.combine!r}")
        self.conditions: list[_Condition] = []
        for n, spec in enumerate(specs, 1):
            kind = KINDS.get(spec.get("kind"))
            if kind is None:
                raise TriggerError(f"condition {n}: kind must be one of {', '.join(KINDS)}, not {spec.get('kind')!r}")
            if spec.get("variable") not in columns:
                raise TriggerError(f"condition {n}: '{spec.get('variable')}' is not one of the capture's channels")
            if kind is _Window and float(spec["low"]) > float(spec["high"]):
                raise TriggerError(
                    f"condition {n}: the window's low ({spec['low']}) is above its high ({spec['high']})"
                )
            self.conditions.append(kind(spec, list(columns).index(spec["variable"])))
        self.last_seq: int | None = None

    def reset(self) -> None:
        for c in self.conditions:
            c.reset()
        self.last_seq = None

    def step(self, seq: np.ndarray, values: np.ndarray) -> np.ndarray:
        """For each row of a block (seq ascending; values: one row per channel of the capture),
        whether the combined condition holds there.  Every block must be given, in order, armed
        or not: the carry (the row before, a level's run) is kept across them."""
        n = len(seq)
        if n == 0:
            return np.zeros(0, dtype=bool)
        gap_before = np.empty(n, dtype=bool)
        gap_before[0] = self.last_seq is None or int(seq[0]) != self.last_seq + 1
        gap_before[1:] = seq[1:] != seq[:-1] + 1
        hits = [c.step(values[c.column], gap_before) for c in self.conditions]
        self.last_seq = int(seq[-1])
        return np.logical_and.reduce(hits) if self.combine == "and" else np.logical_or.reduce(hits)


# ---- events: alarms, faults, swaps, "now" ----------------------------------------------------------
@dataclass(frozen=True)
class Event:
    """Something that happened at `time_ns` (CLOCK_REALTIME, as alarms and irpd's events carry)."""

    kind: str  # alarm, fault, swap, manual
    time_ns: int
    what: str  # for the shot's notes: "alarm main/8 raised (high)", "irpd event stopped: ..."
    key: str | None = None  # an alarm's
    severity: str | None = None  # an alarm's
    capture: str | None = None  # a manual trigger's capture


def event_matches(trigger: dict, event: Event) -> bool:
    """Whether `event` fires `trigger` (a trigger of kind alarm, fault, swap or manual)."""
    kind = trigger.get("kind")
    if kind != event.kind:
        return False
    if kind == "alarm":
        if trigger.get("key") and trigger["key"] != event.key:
            return False
        least = trigger.get("severity")
        if least and SEVERITIES.index(event.severity or "medium") < SEVERITIES.index(least):
            return False
    return True


def alarm_events(message: dict) -> list[Event]:
    """The raises of one alarm-manager message (its `transitions`) as events."""
    out = []
    for row in message.get("transitions") or []:
        if row.get("event") == "raise":
            out.append(
                Event(
                    "alarm",
                    int(row["time_ns"]),
                    f"alarm {row['key']} raised ({row.get('severity')}): {row.get('text', '')}",
                    key=row["key"],
                    severity=row.get("severity"),
                )
            )
    return out


def irpd_events(events: list[dict]) -> list[Event]:
    """irpd's events (its `events` command) that are faults or swaps, as events."""
    out = []
    for e in events:
        kind = "fault" if e.get("kind") in FAULT_EVENTS else "swap" if e.get("kind") in SWAP_EVENTS else None
        if kind is not None:
            module = f" ({e['module']})" if e.get("module") else ""
            out.append(Event(kind, int(e["time_ns"]), f"irpd event {e['kind']}{module}: {e.get('message', '')}"))
    return out


def row_at(seq: np.ndarray, t_ns: np.ndarray, when_mono_ns: int) -> int | None:
    """The seq of the last row (of rows sorted by seq) whose due time is at or before `when`, or
    None when every row is after it."""
    k = int(np.searchsorted(t_ns, when_mono_ns, side="right"))
    return int(seq[k - 1]) if k else None

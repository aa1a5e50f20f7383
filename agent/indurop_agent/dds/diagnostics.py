"""diagnostics.py -- the bridge's timing statuses (docs/dds.md "Diagnostics"): one DiagnosticStatus
per dispatcher and module of irpd's `stats`, graded by the overruns and missed periods of a recent
window rather than by irpd's totals since the set started, so that one missed period turns the
status WARN for WINDOW_S (10 s) and not for ever.  The totals stay among the status's values.

    timing = Timing("cell-1")
    statuses = timing.statuses(irpd.request("stats"), time.monotonic())   # every diagnostics period

The window is counted from consecutive samples of the totals: what the totals gained since the
newest sample at least WINDOW_S old (so 10 s, plus at most one diagnostics period).  A record seen
for the first time is its own baseline (what came before the bridge looked is not "recent"); one
whose runs or counts went down (irpd restarted, the module replaced) starts again from zero at the
sample before.
"""

from __future__ import annotations

from collections import deque

from . import ros2_types

LEVEL_OK, LEVEL_WARN, LEVEL_ERROR, LEVEL_STALE = 0, 1, 2, 3
WINDOW_S = 10.0
COUNTED = ("overruns", "missed")  # what turns a status WARN while the window holds some
TOTALS = ("runs", *COUNTED)  # sampled; runs tells that the counts started again


def status_name(name: str, record: dict) -> str:
    # A dispatcher's record is named "dispatcher": it is told apart by its executor.
    kind = record.get("kind", "module")
    return f"{name}: {kind} {record.get('executor') if kind == 'dispatcher' else record.get('name')}"


class Timing:
    """The timing statuses of one controller, with the samples of each record's totals."""

    def __init__(self, name: str):
        self.name = name
        self._samples: dict[str, deque[tuple[float, tuple[int, ...]]]] = {}

    def statuses(self, stats: dict, now_s: float) -> list[ros2_types.DiagnosticStatus]:
        """A status per record of irpd's `stats` answer; now_s: CLOCK_MONOTONIC seconds."""
        records = stats.get("executors", []) + stats.get("modules", [])
        out = [timing_status(self.name, r, self.recent(status_name(self.name, r), r, now_s)) for r in records]
        if records:  # records gone (a module removed) take their samples with them
            kept = {status_name(self.name, r) for r in records}
            for key in set(self._samples) - kept:
                del self._samples[key]
        return out

    def recent(self, key: str, record: dict, now_s: float) -> dict[str, int]:
        """What each of COUNTED gained in the window, from this sample of `record`'s totals."""
        totals = tuple(int(record.get(k) or 0) for k in TOTALS)
        samples = self._samples.get(key)
        if samples is None:
            samples = self._samples[key] = deque()
        elif any(t < p for t, p in zip(totals, samples[-1][1])):  # counted again from zero
            samples = self._samples[key] = deque([(samples[-1][0], (0,) * len(TOTALS))])
        samples.append((now_s, totals))
        while len(samples) > 1 and samples[1][0] <= now_s - WINDOW_S:
            samples.popleft()
        base = samples[0][1]
        return {k: totals[i] - base[i] for i, k in enumerate(TOTALS) if k in COUNTED}


def timing_status(name: str, record: dict, recent: dict[str, int]) -> ros2_types.DiagnosticStatus:
    """One dispatcher's or module's stats record (irpd `stats`) as a DiagnosticStatus: WARN while
    `recent` (Timing.recent) holds overruns or misses, ERROR when disabled, stopped or exited."""
    level = LEVEL_OK
    if any(recent.get(k) for k in COUNTED):
        level = LEVEL_WARN
    if record.get("state") in ("disabled", "stopped", "exited"):
        level = LEVEL_ERROR
    values = [
        ros2_types.KeyValue(key=k, value=str(record.get(k)))
        for k in ("executor", "period_ns", "runs", "overruns", "missed", "skipped", "errors", "state")
        if k in record
    ]
    window = f"{WINDOW_S:g} s"
    values += [ros2_types.KeyValue(key=f"{k} in the last {window}", value=str(recent.get(k, 0))) for k in COUNTED]
    for figure in ("jitter_ns", "latency_ns", "exec_ns"):
        f = record.get(figure) or {}
        for q in ("p50", "p99", "max"):
            if q in f:
                values.append(ros2_types.KeyValue(key=f"{figure} {q}", value=str(f[q])))
    totals = f"{record.get('runs', 0)} runs, {record.get('overruns', 0)} overruns, {record.get('missed', 0)} missed"
    last = ", ".join(f"{recent.get(k, 0)} {k}" for k in COUNTED)
    return ros2_types.DiagnosticStatus(
        level=level,
        name=status_name(name, record),
        message=f"{totals}; in the last {window}: {last}",
        hardware_id=name,
        values=values,
    )

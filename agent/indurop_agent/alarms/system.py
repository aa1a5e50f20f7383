"""system.py -- the alarms the agent raises itself, from what irpd says (its status and event log)
and from whether irpd answers at all (docs/alarms.md, "System alarms").

| key | severity | raised when | cleared when |
| --- | --- | --- | --- |
| `<module>/overruns` | medium | irpd's `overrun` events of the module count at least `alarm_overruns_per_s` in one second | `alarm_clear_s` without such a second |
| `<module>/deadline_misses` | high | irpd's `deadline` events count at least `alarm_misses_per_s` in one second | the same |
| `<module>/exited` | high | a process module exited (`process_exit`) | it was started again (`process_restart`), or irpd restarted |
| `<module>/fault` | high | a thread module threw from run() (`fault`: the detail is what it threw, e.g. "main.st:12:9: endless loop?") or a crash in it was taken in at irpd's start (`crash`: the detail names the source line) | a swap after which irpd's `modules` shows it no longer disabled (enabled again, or not in the set), or irpd restarted |
| `irpd/fault_stop` | critical | a fault stopped the set (`stopped`, status `stopped_by_fault`) | irpd runs a set again (`stopped_by_fault` null) |
| `agent/irpd_unreachable` | high | irpd has not answered for `alarm_unreachable_s` | it answers |

irpd sends overrun and deadline events at most once a second per module, with the count of that
second ("12 budget overruns (340 in all)"); a module with <on_overrun> has each overrun reported
by the watchdog (count 1 each).  The counts of one module and kind within one second add up.
Times: the event's for what comes from events, the first failed poll's for irpd unreachable.
When irpd restarts, everything it raised through events is cleared with a note: its processes
start anew and its counters begin again.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable
from dataclasses import dataclass

from .manager import SYSTEM, AlarmManager

UNREACHABLE = ("agent", "irpd_unreachable")
FAULT_STOP = ("irpd", "fault_stop")
RATES = {"overrun": "overruns", "deadline": "deadline_misses"}  # event kind -> alarm id
TEXTS = {
    "overruns": ("medium", "overruns beyond the threshold ({} in a second)"),
    "deadline_misses": ("high", "deadline misses beyond the threshold ({} in a second)"),
    "exited": ("high", "the process module exited"),
    "fault": ("high", "the module faulted and is disabled"),
    "fault_stop": ("critical", "a fault stopped the set: outputs at their safe values"),
    "irpd_unreachable": ("high", "irpd does not answer on its control socket"),
}
COUNT = re.compile(r"\s*(\d+)\s")


@dataclass
class Thresholds:
    """The agent's settings alarm_* (config.py has their defaults and meanings)."""

    overruns_per_s: int = 10
    misses_per_s: int = 10
    clear_s: float = 10.0
    unreachable_s: float = 5.0


def event_count(message: str) -> int:
    """The count an overrun or deadline event gives ("12 budget overruns (340 in all)"), else 1."""
    m = COUNT.match(message or "")
    return int(m.group(1)) if m else 1


class SystemAlarms:
    def __init__(
        self,
        manager: AlarmManager,
        thresholds: Thresholds,
        clock: Callable[[], int] = time.time_ns,
        monotonic: Callable[[], float] = time.monotonic,
    ):
        self.manager = manager
        self.t = thresholds
        self.clock, self.monotonic = clock, monotonic
        self.failing_since: tuple[float, int, str] | None = None  # (monotonic, realtime ns, first error)
        self._second: dict[tuple[str, str], tuple[int, int]] = {}  # (module, alarm id) -> (second, count)
        self._over: dict[
            tuple[str, str], int
        ] = {}  # (module, alarm id) -> time ns of its last second over the threshold

    def _raise(self, module: str, alarm_id: str, time_ns: int, detail: str, value: float = 0.0, *fmt) -> None:
        severity, text = TEXTS[alarm_id]
        self.manager.raise_alarm(
            module,
            alarm_id,
            time_ns,
            detail=detail,
            value=value,
            severity=severity,
            text=text.format(*fmt),
            origin=SYSTEM,
        )

    # ---- irpd's reachability ---------------------------------------------------------------------
    def irpd_failed(self, error: str) -> None:
        """A poll of irpd failed; raises agent/irpd_unreachable once it has failed for unreachable_s."""
        now = self.monotonic()
        if self.failing_since is None:
            self.failing_since = (now, self.clock(), error)
        began, began_ns, first = self.failing_since
        if now - began >= self.t.unreachable_s:
            self._raise(*UNREACHABLE, began_ns, first)

    def irpd_answered(self, status: dict) -> None:
        """irpd answered `status`: clears irpd unreachable, and follows its fault stop."""
        self.failing_since = None
        now = self.clock()
        self.manager.clear_alarm(*UNREACHABLE, now, note="irpd answers again")
        fault = status.get("stopped_by_fault")
        if fault:
            a = self.manager.alarms.get("irpd/fault_stop")
            if a is None or not a.active:
                self._raise(*FAULT_STOP, now, str(fault))
        else:
            self.manager.clear_alarm(*FAULT_STOP, now, note="irpd runs a set again")

    def irpd_restarted(self, note: str) -> None:
        """A new irpd (or a managed restart): what its predecessor's events raised is over."""
        now = self.clock()
        with self.manager.batch():
            for a in list(self.manager.alarms.values()):
                if a.origin == SYSTEM and a.active and (a.module, a.id) != UNREACHABLE:
                    self.manager.clear_alarm(a.module, a.id, now, note=note)
        self._second.clear()
        self._over.clear()

    # ---- irpd's events ----------------------------------------------------------------------------
    def events(self, events: list[dict]) -> None:
        """irpd's new events, oldest first."""
        with self.manager.batch():
            for e in events:
                kind, module, t = e.get("kind"), e.get("module") or "irpd", int(e.get("time_ns") or self.clock())
                message = str(e.get("message") or "")
                if kind in RATES:
                    self._rate(module, RATES[kind], t, event_count(message), message)
                elif kind == "process_exit":
                    self._raise(module, "exited", t, message)
                elif kind == "process_restart":
                    self.manager.clear_alarm(module, "exited", t, detail=message, note="started again")
                elif kind == "stopped":
                    self._raise(*FAULT_STOP, t, message)
                elif kind in ("fault", "crash") and e.get("module"):
                    self._raise(module, "fault", t, message)

    def modules_now(self, modules: list[dict]) -> None:
        """irpd's `modules` after a swap: a module no longer disabled (or gone) is past its fault."""
        disabled = {m.get("name") for m in modules if m.get("state") == "disabled"}
        now = self.clock()
        with self.manager.batch():
            for a in list(self.manager.alarms.values()):
                if a.origin == SYSTEM and a.id == "fault" and a.active and a.module not in disabled:
                    self.manager.clear_alarm(a.module, "fault", now, note="enabled again, or no longer in the set")

    def _rate(self, module: str, alarm_id: str, t: int, n: int, message: str) -> None:
        key = (module, alarm_id)
        second = t // 1_000_000_000
        start, count = self._second.get(key, (second, 0))
        count = count + n if start == second else n
        self._second[key] = (second, count)
        threshold = self.t.overruns_per_s if alarm_id == "overruns" else self.t.misses_per_s
        if count >= threshold:
            self._over[key] = t
            self._raise(module, alarm_id, t, message, count, threshold)

    def tick(self) -> None:
        """Clears the rate alarms whose module has stayed below the threshold for clear_s."""
        now = self.clock()
        for a in list(self.manager.alarms.values()):  # active from before the agent started
            if a.origin == SYSTEM and a.active and a.id in RATES.values():
                self._over.setdefault((a.module, a.id), a.changed_ns)
        for key, last in list(self._over.items()):
            if now - last >= self.t.clear_s * 1e9:
                del self._over[key]
                self.manager.clear_alarm(
                    *key, last + int(self.t.clear_s * 1e9), note=f"below the threshold for {self.t.clear_s:g} s"
                )

"""manager.py -- every alarm's state per ISA-18.2, its transitions, and who acknowledged or shelved it.

An alarm is `<module>/<id>`: a module's (or irpd's) alarm from the segment, id 1 .. 1023
(`PLC/8`), or a system alarm the agent raises, with a word for an id (`cntr1/overruns`,
`irpd/fault_stop`, `agent/irpd_unreachable`: system.py).  Its state:

    normal --raise--> active_unacknowledged --acknowledge--> active_acknowledged
                          |                                      |
                        clear                                  clear
                          v                                      v
                 cleared_unacknowledged --acknowledge-------> normal

and `shelved` over any of them: an operator set it aside until a time, with a reason; the state
underneath goes on changing, and shows again when the shelf time is up (or on unshelve).  A raise
of a cleared, unacknowledged alarm makes it active and unacknowledged again.

Every transition is one history row (store.py) with its time: the record's time for the
segment's alarms, the event's for system alarms, the request's for acknowledgements.  Floods are
bounded: beyond `history_per_s` rows in one second for one module, transitions still change the
state but are counted instead of recorded one by one, and one `flood` row says how many.  Normal
alarms are not kept in memory (their past is in the history), so memory holds at most the alarms
that are not normal: bounded by the sources' ids.

Thread-safe: the watcher thread, the system alarms and the API's routes call in; listeners (the
WebSocket push) are called after each committed change with the transitions and the counts.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field, fields
from datetime import UTC, datetime

from .segment import Record, Source
from .store import AlarmStore

SEVERITIES = ("low", "medium", "high", "critical")
UNDECLARED_SEVERITY = "medium"
NORMAL = "normal"
ACTIVE_UNACKNOWLEDGED = "active_unacknowledged"
ACTIVE_ACKNOWLEDGED = "active_acknowledged"
CLEARED_UNACKNOWLEDGED = "cleared_unacknowledged"
SHELVED = "shelved"
STATES = (NORMAL, ACTIVE_UNACKNOWLEDGED, ACTIVE_ACKNOWLEDGED, CLEARED_UNACKNOWLEDGED, SHELVED)
EVENTS = ("raise", "clear", "acknowledge", "confirm", "shelve", "unshelve", "shelve_expired", "flood")
MODULE, SYSTEM = "module", "system"  # where an alarm comes from: the segment, or the agent's system alarms


class AlarmError(Exception):
    """A request the alarms cannot take: status 404 (no such alarm) or 409 (not in a state for it)."""

    def __init__(self, status: int, message: str):
        super().__init__(message)
        self.status = status


def iso(ns: int | None) -> str | None:
    """A CLOCK_REALTIME time in ns as ISO 8601 UTC with microseconds (None stays None)."""
    if ns is None:
        return None
    return datetime.fromtimestamp(ns / 1e9, UTC).isoformat(timespec="microseconds").replace("+00:00", "Z")


@dataclass
class Alarm:
    key: str
    module: str
    id: str
    origin: str
    severity: str
    text: str
    active: bool = False
    acknowledged: bool = True
    detail: str = ""
    value: float = 0.0
    flags: list[str] = field(default_factory=list)
    severity_given: bool = False  # the raise gave its severity (else the declared one applies)
    raises: int = 0  # raises since it was last normal
    changed_ns: int = 0
    raised_ns: int | None = None
    cleared_ns: int | None = None
    acknowledged_ns: int | None = None
    acknowledged_by: dict | None = None
    confirmed: bool = True  # OPC UA's Confirm after the acknowledgement (docs/alarms.md)
    confirmed_ns: int | None = None
    confirmed_by: dict | None = None
    shelved_ns: int | None = None
    shelved_until_ns: int | None = None
    shelved_by: dict | None = None
    shelve_reason: str | None = None

    @staticmethod
    def from_json(body: dict) -> Alarm:
        known = {f.name for f in fields(Alarm)}
        return Alarm(**{k: v for k, v in body.items() if k in known})

    def shelved(self, now_ns: int) -> bool:
        return self.shelved_until_ns is not None and now_ns < self.shelved_until_ns

    @property
    def condition_state(self) -> str:
        """The state without the shelf."""
        if self.active:
            return ACTIVE_ACKNOWLEDGED if self.acknowledged else ACTIVE_UNACKNOWLEDGED
        return NORMAL if self.acknowledged else CLEARED_UNACKNOWLEDGED

    def state(self, now_ns: int) -> str:
        return SHELVED if self.shelved(now_ns) else self.condition_state

    def public(self, now_ns: int) -> dict:
        """The API's shape (models.AlarmPublic)."""
        return {
            "key": self.key,
            "module": self.module,
            "id": self.id,
            "origin": self.origin,
            "state": self.state(now_ns),
            "condition": self.condition_state,
            "severity": self.severity,
            "text": self.text,
            "detail": self.detail,
            "value": self.value,
            "flags": list(self.flags),
            "active": self.active,
            "acknowledged": self.acknowledged,
            "raises": self.raises,
            "changed": iso(self.changed_ns),
            "changed_ns": self.changed_ns,
            "raised": iso(self.raised_ns),
            "cleared": iso(self.cleared_ns),
            "acknowledged_at": iso(self.acknowledged_ns),
            "acknowledged_by": self.acknowledged_by,
            "confirmed": self.confirmed,
            "confirmed_at": iso(self.confirmed_ns),
            "confirmed_by": self.confirmed_by,
            "shelved_at": iso(self.shelved_ns) if self.shelved(now_ns) else None,
            "shelved_until": iso(self.shelved_until_ns) if self.shelved(now_ns) else None,
            "shelved_by": self.shelved_by if self.shelved(now_ns) else None,
            "shelve_reason": self.shelve_reason if self.shelved(now_ns) else None,
        }


def public_row(row: dict) -> dict:
    """A history row in the API's shape (models.AlarmTransition)."""
    return {
        "seq": row["seq"],
        "time": iso(row["time_ns"]),
        "time_ns": row["time_ns"],
        "key": row["key"],
        "module": row["module"],
        "id": row["alarm_id"],
        "event": row["event"],
        "state": row["state"],
        "severity": row["severity"],
        "text": row["text"],
        "detail": row.get("detail") or "",
        "value": row.get("value") or 0.0,
        "who": row.get("who"),
        "note": row.get("note") or "",
        "flags": list(row.get("flags") or []),
        "count": row.get("count", 1),
    }


class AlarmManager:
    def __init__(self, store: AlarmStore, history_per_s: int = 100, clock: Callable[[], int] = time.time_ns):
        self.store = store
        self.history_per_s = history_per_s
        self.clock = clock
        self._lock = threading.RLock()
        saved, self.meta = store.load()
        self.alarms: dict[str, Alarm] = {a.key: a for a in map(Alarm.from_json, saved)}
        self.declared: dict[str, dict[str, tuple[str, str]]] = {}  # module -> id -> (severity, text)
        self.listeners: list[Callable[[dict], None]] = []
        # how the watcher reads the segment (every key there from the start: readers copy it unlocked)
        self.segment: dict = {
            "name": None,
            "error": "not read yet",
            "lost": 0,
            "abandoned": 0,
            "capacity": None,
            "rate_limit": None,
            "declarations": None,
            "sources": [],
        }
        self._budget: dict[str, tuple[int, int]] = {}  # module -> (second, rows written in it)
        self._flooded: dict[str, tuple[int, int]] = {}  # module -> (transitions not recorded, time of the last)
        self.suppressed = int(self.meta.get("suppressed", 0))  # transitions not recorded one by one, in all
        self._rows: list[dict] = []
        self._changed: dict[str, dict | None] = {}
        self._meta: dict = {}
        self._depth = 0

    # ---- batching: one transaction and one notification per batch ----------------------------------
    @contextmanager
    def batch(self):
        with self._lock:
            self._depth += 1
            try:
                yield self
            finally:
                self._depth -= 1
                if self._depth == 0:
                    self._commit()

    def _commit(self) -> None:
        rows, changed, meta = self._rows, self._changed, self._meta
        self._rows, self._changed, self._meta = [], {}, {}
        if not rows and not changed and not meta:
            return
        self.store.write(rows, changed, meta)
        self.meta.update(meta)
        if (rows or changed) and self.listeners:
            now = self.clock()
            message = {
                "transitions": [public_row(r) for r in rows],
                "changed": [
                    self.alarms[k].public(now) if k in self.alarms else {"key": k, "state": NORMAL} for k in changed
                ],
                "counts": self.counts(),
            }
            for listener in list(self.listeners):
                listener(message)

    def subscribe(self, listener: Callable[[dict], None]) -> Callable[[], None]:
        """Calls listener(message) after every committed change, from the thread that made it;
        returns the function that stops it."""
        with self._lock:
            self.listeners.append(listener)

        def stop() -> None:
            with self._lock:
                if listener in self.listeners:
                    self.listeners.remove(listener)

        return stop

    def set_meta(self, **values) -> None:
        with self.batch():
            self._meta.update(values)

    # ---- what a change writes ------------------------------------------------------------------------
    def _keep(self, a: Alarm, now_ns: int) -> None:
        """Holds (and persists) an alarm that is not normal or is shelved; forgets a normal one."""
        if a.condition_state == NORMAL and not a.shelved(now_ns):
            self.alarms.pop(a.key, None)
            self._changed[a.key] = None
        else:
            self.alarms[a.key] = a
            self._changed[a.key] = asdict(a)

    def _row(self, a: Alarm, event: str, time_ns: int, *, who: dict | None = None, note: str = "") -> None:
        """One history row, unless the module's rows in this second are used up (a flood)."""
        second = time_ns // 1_000_000_000
        if event in ("raise", "clear"):
            start, used = self._budget.get(a.module, (second, 0))
            if start != second:
                self._flush_flood(a.module)
                start, used = second, 0
            if used >= self.history_per_s:
                missed, _ = self._flooded.get(a.module, (0, 0))
                self._flooded[a.module] = (missed + 1, time_ns)
                self.suppressed += 1
                self._meta["suppressed"] = self.suppressed
                return
            self._budget[a.module] = (start, used + 1)
        self._rows.append(
            {
                "time_ns": time_ns,
                "key": a.key,
                "module": a.module,
                "alarm_id": a.id,
                "event": event,
                "state": a.state(self.clock()),
                "severity": a.severity,
                "text": a.text,
                "detail": a.detail if event in ("raise", "clear") else "",
                "value": a.value if event == "raise" else 0.0,
                "who": who,
                "note": note,
                "flags": list(a.flags) if event == "raise" else [],
            }
        )

    def _flush_flood(self, module: str) -> None:
        missed, last_ns = self._flooded.pop(module, (0, 0))
        if missed:
            self._rows.append(
                {
                    "time_ns": last_ns,
                    "key": f"{module}/*",
                    "module": module,
                    "alarm_id": "*",
                    "event": "flood",
                    "state": "",
                    "severity": "",
                    "text": f"{missed} transitions of {module}'s alarms not recorded one by one "
                    f"(more than {self.history_per_s} in a second); their states are kept",
                    "count": missed,
                }
            )

    def flush_floods(self) -> None:
        """Writes the flood rows of the seconds that are over (the watcher calls it every poll)."""
        second = self.clock() // 1_000_000_000
        with self.batch():
            for module in [m for m, (start, _) in self._budget.items() if start != second]:
                self._flush_flood(module)
                del self._budget[module]

    # ---- declarations ------------------------------------------------------------------------------
    def declare(self, sources: Iterable[dict]) -> None:
        """Takes the texts and severities of irpd's `alarms` answer (its `sources`), and gives them
        to the alarms held that have none of their own yet."""
        with self.batch():
            for s in sources:
                self.declared[s["module"]] = {str(d["id"]): (d["severity"], d["text"]) for d in s.get("declared", [])}
            now = self.clock()
            for a in list(self.alarms.values()):
                known = self.declared.get(a.module, {}).get(a.id) if a.origin == MODULE else None
                if known and (a.text, a.severity) != (known[1], a.severity if a.severity_given else known[0]):
                    a.text = known[1]
                    a.severity = a.severity if a.severity_given else known[0]
                    self._keep(a, now)

    def _describe(self, module: str, alarm_id: str, severity: str | None) -> tuple[str, str]:
        declared = self.declared.get(module, {}).get(alarm_id)
        if declared:
            return severity or declared[0], declared[1]
        return severity or UNDECLARED_SEVERITY, f"alarm {alarm_id} of {module} (not declared)"

    # ---- transitions -------------------------------------------------------------------------------
    def raise_alarm(
        self,
        module: str,
        alarm_id: str,
        time_ns: int,
        *,
        detail: str = "",
        value: float = 0.0,
        severity: str | None = None,
        text: str | None = None,
        origin: str = MODULE,
        flags: Iterable[str] = (),
        note: str = "",
    ) -> None:
        """The condition is there.  A raise of an active alarm changes only its detail and value."""
        key = f"{module}/{alarm_id}"
        with self.batch():
            now = self.clock()
            a = self.alarms.get(key)
            declared_severity, declared_text = self._describe(module, alarm_id, severity)
            if a is None:
                a = Alarm(key, module, alarm_id, origin, declared_severity, text or declared_text)
            a.detail, a.value = detail, value
            a.flags = sorted(set(flags))
            a.severity, a.text, a.severity_given = declared_severity, text or declared_text, severity is not None
            if a.active:
                self._keep(a, now)
                return
            a.active, a.acknowledged, a.confirmed = True, False, False
            a.raised_ns = a.changed_ns = time_ns
            a.raises += 1
            self._keep(a, now)
            self._row(a, "raise", time_ns, note=note)

    def clear_alarm(
        self, module: str, alarm_id: str, time_ns: int, *, detail: str | None = None, note: str = ""
    ) -> None:
        """The condition is gone (nothing happens for an alarm that is not active)."""
        with self.batch():
            a = self.alarms.get(f"{module}/{alarm_id}")
            if a is None or not a.active:
                return
            a.active = False
            if detail is not None:
                a.detail = detail
            a.cleared_ns = a.changed_ns = time_ns
            self._keep(a, self.clock())
            self._row(a, "clear", time_ns, note=note)

    def apply(self, records: Iterable[Record], names: Callable[[Record], str | None]) -> None:
        """The segment's records, in seq order; `names` gives a record's module (None: a source
        that no longer exists and was never seen: the record is named by its source number)."""
        with self.batch():
            for r in records:
                module = names(r) or f"source{r.source}"
                alarm_id = str(r.id)
                if r.raised:
                    flags = [f for f, on in (("undeclared", r.undeclared), ("truncated", r.truncated)) if on]
                    self.raise_alarm(
                        module, alarm_id, r.time_ns, detail=r.text, value=r.value, severity=r.severity, flags=flags
                    )
                else:
                    self.clear_alarm(module, alarm_id, r.time_ns, detail=r.text or None)

    def reconcile(self, sources: Iterable[Source], note: str) -> int:
        """Makes the segment's alarms held agree with the sources' active bitmaps: an alarm held
        active that no source has active is cleared, an active bit held as not active is raised,
        each with `note`.  Returns how many changed."""
        sources = list(sources)
        active = {(s.name, str(i)) for s in sources for i in s.active}
        changed = 0
        with self.batch():
            now = self.clock()
            for a in list(self.alarms.values()):
                if a.origin == MODULE and a.active and (a.module, a.id) not in active:
                    self.clear_alarm(a.module, a.id, now, note=f"{note}: not active in irpd's alarm segment")
                    changed += 1
            for module, alarm_id in sorted(active):
                a = self.alarms.get(f"{module}/{alarm_id}")
                if a is None or not a.active:
                    self.raise_alarm(
                        module, alarm_id, now, note=f"{note}: active in irpd's alarm segment, its raise not read"
                    )
                    changed += 1
        return changed

    # ---- what operators do ---------------------------------------------------------------------------
    def _get(self, key: str) -> Alarm:
        a = self.alarms.get(key)
        if a is None:
            raise AlarmError(404, f"no alarm {key} needs attention (GET /api/v1/alarms lists them)")
        return a

    def acknowledge(self, key: str, who: dict, note: str = "") -> dict:
        with self.batch():
            a = self._get(key)
            now = self.clock()
            if a.acknowledged:
                raise AlarmError(409, f"{key} is acknowledged already ({a.condition_state})")
            self._acknowledge(a, who, now, note)
            return a.public(now)

    def _acknowledge(self, a: Alarm, who: dict, now: int, note: str = "") -> None:
        a.acknowledged, a.acknowledged_ns, a.acknowledged_by, a.changed_ns = True, now, who, now
        self._keep(a, now)
        self._row(a, "acknowledge", now, who=who, note=note)

    def confirm(self, key: str, who: dict, note: str = "") -> dict:
        """OPC UA's Confirm: a person says the cause is dealt with, after acknowledging.  Held by the
        alarm until its next raise; it does not change the state (an acknowledged alarm that is
        cleared is normal, confirmed or not)."""
        with self.batch():
            a = self._get(key)
            now = self.clock()
            if not a.acknowledged:
                raise AlarmError(409, f"{key} is not acknowledged: acknowledge it first ({a.condition_state})")
            if a.confirmed:
                raise AlarmError(409, f"{key} is confirmed already")
            a.confirmed, a.confirmed_ns, a.confirmed_by, a.changed_ns = True, now, who, now
            self._keep(a, now)
            self._row(a, "confirm", now, who=who, note=note)
            return a.public(now)

    def acknowledge_all(self, who: dict, module: str | None = None) -> list[str]:
        """Acknowledges every unacknowledged alarm (of `module`), shelved ones too; their keys."""
        with self.batch():
            now = self.clock()
            keys = []
            for a in sorted(self.alarms.values(), key=lambda x: x.key):
                if not a.acknowledged and (module is None or a.module == module):
                    self._acknowledge(a, who, now)
                    keys.append(a.key)
            return keys

    def shelve(self, key: str, minutes: float, reason: str, who: dict) -> dict:
        """Sets an alarm aside for `minutes`: held, or declared by a module of the running set."""
        with self.batch():
            now = self.clock()
            a = self.alarms.get(key)
            if a is None:
                module, _, alarm_id = key.rpartition("/")
                if alarm_id not in self.declared.get(module, {}):
                    raise AlarmError(404, f"no alarm {key}: neither held nor declared by a module of the running set")
                severity, text = self._describe(module, alarm_id, None)
                a = Alarm(key, module, alarm_id, MODULE, severity, text)
            a.shelved_ns, a.shelved_until_ns = now, now + int(minutes * 60e9)
            a.shelved_by, a.shelve_reason = who, reason
            self._keep(a, now)
            self._row(a, "shelve", now, who=who, note=f"for {minutes:g} min: {reason}")
            return a.public(now)

    def unshelve(self, key: str, who: dict | None) -> dict:
        with self.batch():
            now = self.clock()
            a = self._get(key)
            if not a.shelved(now):
                raise AlarmError(409, f"{key} is not shelved")
            self._unshelve(a, now, "unshelve", who)
            return a.public(now)

    def _unshelve(self, a: Alarm, now: int, event: str, who: dict | None) -> None:
        a.shelved_until_ns = None
        a.shelved_ns = a.shelved_by = a.shelve_reason = None
        self._keep(a, now)
        self._row(a, event, now, who=who)

    def expire_shelves(self) -> None:
        """Alarms whose shelf time is up show again."""
        with self.batch():
            now = self.clock()
            for a in [a for a in self.alarms.values() if a.shelved_until_ns is not None and not a.shelved(now)]:
                self._unshelve(a, now, "shelve_expired", None)

    # ---- what the API shows ----------------------------------------------------------------------------
    def counts(self) -> dict:
        with self._lock:
            now = self.clock()
            shown = [a for a in self.alarms.values() if not a.shelved(now)]
            total = len(self.alarms)
        unacknowledged = [a for a in shown if not a.acknowledged]
        return {
            "active": sum(a.active for a in shown),
            "unacknowledged": len(unacknowledged),
            "shelved": total - len(shown),
            "highest": max(
                (a.severity for a in shown if a.active or not a.acknowledged),
                key=lambda s: SEVERITIES.index(s) if s in SEVERITIES else -1,
                default=None,
            ),
        }

    def snapshot(self) -> dict:
        """GET /alarms: the alarms that are not normal (active, unacknowledged, shelved), those that
        need attention first (unacknowledged, then by severity, newest first), the counts, the
        newest one and how the segment is read."""
        with self._lock:
            now = self.clock()
            alarms = sorted(
                self.alarms.values(),
                key=lambda a: (
                    a.shelved(now),
                    a.acknowledged,
                    not a.active,
                    -(SEVERITIES.index(a.severity) if a.severity in SEVERITIES else -1),
                    -a.changed_ns,
                ),
            )
            listed = [a for a in alarms if a.condition_state != NORMAL or a.shelved(now)]
            raised = [a for a in listed if not a.shelved(now) and a.raised_ns is not None]
            newest = max(raised, key=lambda a: a.raised_ns, default=None)
            return {
                "alarms": [a.public(now) for a in listed],
                "counts": self.counts(),
                "newest": newest.public(now) if newest else None,
                "segment": {**self.segment, "suppressed": self.suppressed},
            }

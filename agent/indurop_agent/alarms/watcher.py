"""watcher.py -- the agent's thread that keeps the alarms current: every `poll_s` it reads the new
records of irpd's alarm segment; every `irpd_poll_s` it asks irpd for its status and new events
(the system alarms, system.py), and for its declarations when the set changed.

    each poll (poll_s, 0.1 s):
        irpd's turn (irpd_poll_s)? status -> reachable or not, restarted or not (forces it held
                                   lost: an agent event), fault stop;
                                   events since the cursor -> system alarms, and to the
                                   on_events listeners (the captures' fault and swap triggers);
                                   the set's generation changed -> `alarms` (texts, severities)
        the segment: opened (again) if irpd names another one or it was replaced;
                     the sources changed -> `alarms` again;
                     new records -> transitions, in seq order;
                     reconciled from the sources' active bitmaps when it was (re)opened, a source
                     changed, or records were lost, skipped or not written (rate limit)
        the running set's DDS imports: stale or not (dds_imports.py)
        shelves whose time is up; rate alarms below their threshold; flood rows
        the cursors (irpd's event log, the ring) saved with the transitions, in one transaction

It has an irpd connection of its own.  Anything that goes wrong is an agent event and the next
poll tries again; the watcher outlives whatever irpd does.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from ..events import AgentEvents
from ..irpd import protocol
from ..irpd.client import IrpdClient, IrpdRefused, IrpdUnavailable
from ..irpd.shm_layout import LayoutError
from .dds_imports import ImportAlarms
from .manager import AlarmManager
from .segment import AlarmSegment, AlarmSegmentError, Record, RingReader
from .system import SystemAlarms

RESTART_TOLERANCE_NS = 5_000_000_000  # irpd's start time as (now - uptime) wanders by the polls' latency
NAMES_KEPT = 4096  # (source, generation) -> module name, for records written before a swap


class AlarmWatcher(threading.Thread):
    def __init__(
        self,
        manager: AlarmManager,
        system: SystemAlarms,
        socket_path: str,
        events: AgentEvents,
        poll_s: float = 0.1,
        irpd_poll_s: float = 1.0,
        imports: ImportAlarms | None = None,
        on_events: list[Callable[[list[dict]], None]] | None = None,
    ):
        super().__init__(name="alarm-watcher", daemon=True)
        self.manager, self.system, self.events = manager, system, events
        self.imports = imports or ImportAlarms(manager)
        self.poll_s, self.irpd_poll_s = poll_s, irpd_poll_s
        self.client = IrpdClient(socket_path, timeout_s=2.0)
        self._stop_event = threading.Event()
        self.next_irpd = self.retry_open = 0.0
        self.generation: int | None = None
        self.segment_name: str | None = None
        self.segment: AlarmSegment | None = None
        self.reader: RingReader | None = None
        self.sources: dict[int, tuple[int, str]] = {}  # index -> (generation, name)
        self.names: dict[tuple[int, int], str] = {}
        self.unrecorded = 0  # the sources' transitions not recorded (rate limit, ring slot taken), summed
        self.reconcile_note: str | None = "reconciled when the agent started"
        self.last_error: str | None = None
        self.on_events = on_events if on_events is not None else []  # irpd's new events, as read (captures)

    def stop(self) -> None:
        self._stop_event.set()
        self.join(timeout=5)
        self.client.close()
        if self.segment is not None:
            self.segment.close()
        self.imports.close()

    def run(self) -> None:
        while not self._stop_event.wait(self.poll_s):
            try:
                self.poll_once()
                self.last_error = None
            except Exception as e:  # noqa: BLE001 -- the watcher must outlive anything irpd does
                error = f"the alarm watcher: {type(e).__name__}: {e}"
                if error != self.last_error:  # once, not every 0.1 s
                    self.events.add("agent_error", error)
                self.last_error = error

    def poll_once(self) -> None:
        now = time.monotonic()
        if now >= self.next_irpd:
            self.next_irpd = now + self.irpd_poll_s
            self.poll_irpd()
        self.read_segment()
        self.imports.poll()
        self.manager.expire_shelves()
        self.system.tick()
        self.manager.flush_floods()

    # ---- irpd: status, events, declarations ---------------------------------------------------------
    def poll_irpd(self) -> None:
        try:
            status = self.client.request("status")
        except (IrpdUnavailable, IrpdRefused) as e:
            self.system.irpd_failed(str(e))
            return
        seen = self.manager.meta.get("irpd") or {}
        started = time.time_ns() - int(status.get("uptime_ns") or 0)
        last_event = int(status.get("events") or 0)
        same = (
            seen.get("pid") == status.get("pid")
            and abs(seen.get("started_ns", 0) - started) < RESTART_TOLERANCE_NS
            and last_event >= seen.get("events", 0)
        )
        cursor = seen.get("events", 0) if same else 0
        with self.manager.batch():
            if seen and not same:
                self.system.irpd_restarted(f"irpd restarted (pid {status.get('pid')})")
                if seen.get("forces"):  # irpd starts with none (docs/forcing.md)
                    self.events.add("forces_lost", f"irpd restarted: the {seen['forces']} forces it held are gone")
            self.system.irpd_answered(status)
            for _ in range(16):  # the whole log at most (its capacity), a page at a time
                page = self.client.request("events", since=cursor, limit=protocol.EVENT_LOG_CAPACITY) or {}
                events = page.get("events") or []
                self.system.events(events)
                for listener in self.on_events:
                    listener(events)
                cursor = int(page.get("next", cursor))
                if len(events) < protocol.EVENT_LOG_CAPACITY:
                    break
            now_seen = {
                "pid": status.get("pid"),
                "started_ns": seen["started_ns"] if same else started,
                "events": cursor,
                "forces": int(status.get("forces") or 0),
            }
            if now_seen != seen:  # (not a synced write every second for nothing)
                self.manager.set_meta(irpd=now_seen)
        self.segment_name = (status.get("shared_memory") or {}).get("alarms")
        self.imports.follow(status)
        if status.get("generation") != self.generation:
            self.generation = status.get("generation")
            self.declare()
            self.follow_modules()  # a swap (enable, load, change): modules it enabled again are past their fault

    def follow_modules(self) -> None:
        try:
            modules = self.client.request("modules") or []
        except (IrpdUnavailable, IrpdRefused):
            return  # the next swap looks again
        self.system.modules_now(modules)

    def declare(self) -> None:
        """The texts and severities of every source's alarms, from irpd's `alarms` command."""
        try:
            answer = self.client.request("alarms") or {}
        except (IrpdUnavailable, IrpdRefused) as e:
            self.manager.segment["declarations"] = f"not read: {e}"
            return
        self.manager.declare(answer.get("sources") or [])
        self.manager.segment["declarations"] = "ok"

    # ---- the segment --------------------------------------------------------------------------------
    def open_segment(self) -> None:
        if self.segment is not None:
            self.segment.close()
            self.segment = self.reader = None
            self.reconcile_note = "reconciled after irpd restarted"
        if self.segment_name is None:
            self.manager.segment.update(name=None, error="irpd names no alarm segment (status.shared_memory.alarms)")
            return
        try:
            seg = AlarmSegment(self.segment_name)
        except (AlarmSegmentError, LayoutError) as e:
            self.manager.segment.update(name=self.segment_name, error=str(e))
            return
        ring = self.manager.meta.get("ring") or {}
        same = (ring.get("name"), ring.get("inode"), ring.get("owner_pid")) == (seg.name, seg.inode, seg.owner_pid)
        self.segment, self.reader = seg, RingReader(seg, ring.get("cursor", 0) if same else 0)
        self.sources, self.unrecorded = {}, 0
        self.manager.segment.update(name=seg.name, error=None, capacity=seg.capacity, rate_limit=seg.rate_limit)

    def name_of(self, r: Record) -> str | None:
        return self.names.get((r.source, r.source_generation))

    def read_segment(self) -> None:
        seg = self.segment
        if seg is None or seg.replaced() or seg.name != self.segment_name:
            if seg is not None or time.monotonic() >= self.retry_open:  # a missing one: once per irpd poll
                self.retry_open = time.monotonic() + self.irpd_poll_s
                self.open_segment()
            seg = self.segment
            if seg is None:
                return
        sources = seg.sources()
        current = {s.index: (s.generation, s.name) for s in sources}
        if current != self.sources:
            if self.sources:
                self.declare()
                self.reconcile_note = self.reconcile_note or "reconciled after the set changed"
            self.sources = current
            if len(self.names) > NAMES_KEPT:
                self.names.clear()
            self.names.update({(i, g): name for i, (g, name) in current.items()})
        read = self.reader.read(limit=seg.capacity)
        unrecorded = sum(s.unrecorded for s in sources)
        if read.lost or read.abandoned:
            self.reconcile_note = self.reconcile_note or (
                f"reconciled after {read.lost + read.abandoned} records were lost or skipped"
            )
        if unrecorded != self.unrecorded:
            self.reconcile_note = (
                self.reconcile_note or "reconciled after transitions went unrecorded (rate limit, ring)"
            )
            self.unrecorded = unrecorded
        with self.manager.batch():
            self.manager.apply(read.records, self.name_of)
            if self.reconcile_note:
                self.manager.reconcile(seg.sources(), self.reconcile_note)
                self.reconcile_note = None
            ring = {"name": seg.name, "inode": seg.inode, "owner_pid": seg.owner_pid, "cursor": self.reader.cursor}
            if ring != self.manager.meta.get("ring"):
                self.manager.set_meta(ring=ring)
        self.manager.segment.update(
            lost=self.reader.lost,
            abandoned=self.reader.abandoned,
            sources=[
                {"source": s.index, "module": s.name, "generation": s.generation, **s.counters()} for s in sources
            ],
        )

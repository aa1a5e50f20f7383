"""line.py -- the line of controllers (docs/dds.md "The line"): the bridge announces its controller
on the domain and reads every controller's announcement, its own included, for its agent.

- Announcing: indurop::dds::LineController (protocol/dds/indurop/dds/LineController.idl) on the
  topic "indurop/line", keyed by the controller's name, every line_period_s: the agent's URL, the
  running set, health, the main dispatcher's wake-up jitter p99 over the last 10 s (its wake-up
  latency, woke - due, from irpd's cumulative `histograms`), the active alarms (irpd's `alarms`),
  irpd's uptime.  Reliable, transient-local, keep-last 1 (a new reader gets everyone's last
  announcement at once), liveliness AUTOMATIC with line_lease_s.  Its writer does not dispose an
  instance it unregisters by dying: a killed controller's instance is left without writers when its
  lease runs out (lost, with when it was last seen); a clean stop disposes it (it leaves the line).
- Reading: every announcement on the domain, taken each period into a table by name; the table
  goes to the agent as a JSON file (line_file, replaced atomically: line_view.py), which the agent
  serves as GET /line.
"""

from __future__ import annotations

import math
import sys
import time
from collections import deque
from pathlib import Path

from cyclonedds.core import InstanceState, Policy, Qos
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from .. import __version__
from ..irpd.client import IrpdClient, IrpdRefused, IrpdUnavailable
from ..irpd.variables import Segment, VariableError
from .indurop_types import LineAlarm as Alarm
from .indurop_types import LineController as Controller
from .line_view import FORMAT, SEVERITIES, LineAlarm, LineEntry, LineFile, write_view
from .settings import NAME, BridgeSettings

TOPIC = "indurop/line"
MAX_ALARMS = 5
JITTER_WINDOW_S = 10.0
HEALTHS = ("running", "stopped", "fault", "irpd_unreachable")
READ_MAX = 256  # announcements taken per read (a line is a few dozen controllers)
MAX_CONTROLLERS = 256  # listed at most; announcements of more names are ignored (counted)
TEXT_MAX = 500  # characters kept of any announced text
READ_S = 0.1  # how often the others' announcements are read between two of this controller's


def writer_qos(lease_s: float) -> Qos:
    return Qos(
        Policy.Reliability.Reliable(duration(milliseconds=100)),
        Policy.Durability.TransientLocal,
        Policy.History.KeepLast(1),
        Policy.Liveliness.Automatic(duration(seconds=lease_s)),
        # A writer that goes away unregisters its instances; with autodispose they would read as
        # disposed (left the line) rather than without writers (lost).
        Policy.WriterDataLifecycle(autodispose=False),
    )


# The reader asks for no liveliness (it matches every writer, whatever its lease).
READER_QOS = Qos(
    Policy.Reliability.Reliable(duration(milliseconds=100)),
    Policy.Durability.TransientLocal,
    Policy.History.KeepLast(1),
)


class JitterWindow:
    """The p99 of a cumulative histogram over the last `window_s`: the difference between irpd's
    histogram now and the one taken about `window_s` ago (since irpd started until then)."""

    def __init__(self, window_s: float = JITTER_WINDOW_S):
        self.window_s = window_s
        self.snapshots: deque[tuple[float, dict[tuple[int, int], int]]] = deque()
        self.owner = None  # irpd's pid: a restarted irpd starts its histograms again

    def add(self, now: float, owner, buckets: list[list[int]]) -> int | None:
        if owner != self.owner:
            self.snapshots.clear()
            self.owner = owner
        counts = {(low, width): n for low, width, n in buckets}
        self.snapshots.append((now, counts))
        while len(self.snapshots) > 2 and self.snapshots[1][0] <= now - self.window_s:
            self.snapshots.popleft()
        base = self.snapshots[0][1] if len(self.snapshots) > 1 else {}
        return p99({k: n - base.get(k, 0) for k, n in counts.items() if n > base.get(k, 0)})


def p99(counts: dict[tuple[int, int], int]) -> int | None:
    """The upper edge of the bucket holding the 99th percentile; None for no samples."""
    total = sum(counts.values())
    if total == 0:
        return None
    need, seen = math.ceil(0.99 * total), 0
    for (low, width), n in sorted(counts.items()):
        seen += n
        if seen >= need:
            return low + width
    return None


def set_name(path: str) -> str:
    """/var/lib/indurop/sets/<id>/files/module.xml -> <id>/module.xml; config/sets/x/module.xml -> x/module.xml."""
    if not path:
        return ""
    p = Path(path)
    folder = p.parent.parent if p.parent.name == "files" else p.parent
    return f"{folder.name}/{p.name}"


class Line:
    """The announcement of one controller and its view of all of them."""

    def __init__(self, participant, settings: BridgeSettings, irpd: IrpdClient):
        self.s = settings
        self.irpd = irpd
        topic = Topic(participant, TOPIC, Controller)
        self.writer = DataWriter(participant, topic, writer_qos(settings.line_lease_s))
        self.reader = DataReader(participant, topic, READER_QOS)
        self.entries: dict[str, LineEntry] = {}
        self.names: dict[int, str] = {}  # instance handle -> name
        self.writers: dict[str, dict[int, float]] = {}  # name -> {publication handle: when last heard}
        self.jitter = JitterWindow()
        self.layout: tuple = (None, "")  # (the segment's name, its layout hash)
        self.seq = 0
        self.ignored = 0  # announcements not listed: a name that is none, or one over MAX_CONTROLLERS
        self.next = 0.0
        self.next_read = 0.0
        self.file = Path(settings.line_file) if settings.line_file else None
        self.file_problem = ""

    # ---- announcing ----------------------------------------------------------------------------
    def step(self, now: float, status: dict) -> None:
        """Every line_period_s: announce, read the others, write the view; in between, every
        READ_S, read them and write the view at once when one came, went or was lost."""
        if now >= self.next:
            self.next = now + self.s.line_period_s
            self.next_read = now + READ_S
            self.writer.write(self.announcement(status))
            self.take(time.time())
            self.write_file()
        elif now >= self.next_read:
            self.next_read = now + READ_S
            if self.take(time.time()):
                self.write_file()

    def announcement(self, status: dict) -> Controller:
        self.seq += 1
        a = Controller(
            name=self.s.name,
            agent_url=self.s.agent_url,
            version=__version__,
            period_ms=round(self.s.line_period_s * 1000),
            lease_ms=round(self.s.line_lease_s * 1000),
            seq=self.seq,
            jitter_p99_ns=-1,
        )
        if not status:
            a.health, a.health_detail = "irpd_unreachable", f"irpd does not answer at {self.s.irpd_socket}"
            return a
        a.set_name = set_name(status.get("set") or "")
        a.set_id = status.get("set_id") or ""
        a.layout_hash = self.layout_hash(status)
        a.basic_period_ns = int(status.get("basic_period_ns") or 0)
        a.uptime_ns = int(status.get("uptime_ns") or 0)
        if status.get("stopped_by_fault"):
            a.health, a.health_detail = "fault", str(status["stopped_by_fault"])[:500]
        elif not status.get("running"):
            a.health = "stopped"
        else:
            a.health = "running"
        try:
            a.jitter_p99_ns = self.jitter_p99(status)
            active = active_alarms(self.irpd.request("alarms"))
        except IrpdUnavailable as e:
            a.health_detail = a.health_detail or f"irpd: {e}"
            return a
        except IrpdRefused as e:
            print(f"indurop-dds-bridge: the line: irpd refused: {e}", file=sys.stderr, flush=True)
            return a
        a.alarms_active = len(active)
        a.alarms = active[:MAX_ALARMS]
        return a

    def jitter_p99(self, status: dict) -> int:
        """The main dispatcher's wake-up latency (woke - due, never negative; not Eq. (1)'s signed
        start jitter) p99 over the window, or -1."""
        try:
            # its record only: all of them are tens of kB, asked every period
            answer = self.irpd.request("histograms", name="dispatcher")
        except IrpdRefused:
            return -1  # a set with a module named so, or an irpd without it
        dispatchers = [r for r in answer.get("records", []) if r.get("kind") == "dispatcher"]
        if not dispatchers:
            return -1
        buckets = dispatchers[0].get("latency_ns", {}).get("buckets", [])
        value = self.jitter.add(time.monotonic(), status.get("pid"), buckets)
        return -1 if value is None else value

    def layout_hash(self, status: dict) -> str:
        name = (status.get("shared_memory") or {}).get("variables")
        if name and (name, status.get("generation")) != self.layout[0]:
            try:
                segment = Segment(name)
                self.layout = ((name, status.get("generation")), segment.hash)
                segment.mm.close()
            except (VariableError, OSError, ValueError):
                self.layout = (None, "")
        return self.layout[1]

    # ---- reading ---------------------------------------------------------------------------------
    def take(self, now: float) -> bool:
        """Takes what arrived; True when a controller came, went, or was lost."""
        before = {name: e.alive for name, e in self.entries.items()}
        for sample in self.reader.take(N=READ_MAX):
            info = sample.sample_info
            handle = info.instance_handle
            if info.valid_data and self.heard(sample, info, now):
                self.names[handle] = sample.name
            name = self.names.get(handle)
            if name is None or name not in self.entries:
                continue
            if info.instance_state == InstanceState.NotAliveDisposed:
                self.forget(name)  # it stopped cleanly: it leaves the line
            elif info.instance_state == InstanceState.NotAliveNoWriters:
                lease = self.entries[name].lease_s
                self.lost(name, now, f"its liveliness lease ({lease:g} s) ran out: no writer is left")
        for name, e in list(self.entries.items()):
            if e.alive and now - e.last_seen > e.lease_s + 2 * e.period_s:
                # alive for DDS (its process keeps the lease: Cyclone's own threads) but silent: a
                # stuck bridge.  Later than the lease, so that a dead one is told by its lease.
                self.lost(name, now, f"alive on DDS but silent for {now - e.last_seen:.0f} s")
            elif not e.alive and now - (e.lost_since or now) > self.s.line_forget_s:
                self.forget(name)
        return before != {name: e.alive for name, e in self.entries.items()}

    def heard(self, c: Controller, info, now: float) -> bool:
        """Lists an announcement; False when it is ignored (any participant on the domain may write
        anything: the names, their number and every text are bounded)."""
        full = c.name not in self.entries and c.name != self.s.name and len(self.entries) >= MAX_CONTROLLERS
        if full or not NAME.fullmatch(c.name):  # this controller is always listed
            self.ignored += 1
            return False
        writers = self.writers.setdefault(c.name, {})
        writers[info.publication_handle] = now
        lease = max(c.lease_ms / 1000.0, 0.001)
        for handle, when in list(writers.items()):
            if now - when > lease:
                del writers[handle]
        health, detail = c.health, c.health_detail
        if health not in HEALTHS:
            health, detail = "fault", f"an unknown health {c.health!r}"
        self.entries[c.name] = LineEntry(
            name=c.name,
            agent_url=c.agent_url[:TEXT_MAX],
            version=c.version[:TEXT_MAX],
            set_name=c.set_name[:TEXT_MAX],
            set_id=c.set_id[:TEXT_MAX],
            layout_hash=c.layout_hash[:TEXT_MAX],
            health=health,
            health_detail=detail[:TEXT_MAX],
            basic_period_ns=c.basic_period_ns,
            jitter_p99_ns=None if c.jitter_p99_ns < 0 else c.jitter_p99_ns,
            alarms_active=c.alarms_active,
            alarms=[
                LineAlarm(source=a.source[:TEXT_MAX], id=a.id, severity=a.severity[:TEXT_MAX], text=a.text[:TEXT_MAX])
                for a in c.alarms[:MAX_ALARMS]
            ],
            uptime_ns=c.uptime_ns,
            period_s=c.period_ms / 1000.0,
            lease_s=lease,
            alive=True,
            last_seen=now,
            duplicate=len(writers) > 1,
        )
        return True

    def lost(self, name: str, now: float, reason: str) -> None:
        e = self.entries[name]
        if e.alive:
            self.entries[name] = e.model_copy(update={"alive": False, "lost_since": now, "lost_reason": reason})
        self.writers.pop(name, None)

    def forget(self, name: str) -> None:
        self.entries.pop(name, None)
        self.writers.pop(name, None)
        for handle in [h for h, n in self.names.items() if n == name]:
            del self.names[handle]

    # ---- the agent's view ----------------------------------------------------------------------
    def view(self) -> LineFile:
        return LineFile(
            format=FORMAT,
            written=time.time(),
            period_s=self.s.line_period_s,
            name=self.s.name,
            domain_id=self.s.domain_id,
            interface=self.s.interface,
            ignored=self.ignored,
            controllers=list(self.entries.values()),
        )

    def write_file(self) -> None:
        if self.file is None:
            return
        try:
            write_view(self.file, self.view())
            if self.file_problem:
                print(
                    f"indurop-dds-bridge: the line's view is written to {self.file} again", file=sys.stderr, flush=True
                )
            self.file_problem = ""
        except OSError as e:
            if not self.file_problem:  # said once, not every period
                print(f"indurop-dds-bridge: the line's view cannot be written: {e}", file=sys.stderr, flush=True)
            self.file_problem = str(e)

    def close(self) -> None:
        """A clean stop: the controller leaves the line (its instance disposed) and its agent sees
        the bridge off (the view removed)."""
        try:
            self.writer.dispose(Controller(name=self.s.name))
            self.writer.wait_for_acks(duration(seconds=1))  # before the process and its sockets go
        except Exception as e:  # noqa: BLE001 -- stopping: say it, go on
            print(f"indurop-dds-bridge: leaving the line: {e}", file=sys.stderr, flush=True)
        if self.file is not None:
            self.file.unlink(missing_ok=True)


def active_alarms(answer: dict) -> list[Alarm]:
    """Every active alarm of irpd's `alarms` answer, the most severe first."""
    out = []
    for source in answer.get("sources", []):
        declared = {d.get("id"): d for d in source.get("declared", [])}
        for alarm_id in source.get("active", []):
            d = declared.get(alarm_id, {})
            out.append(
                Alarm(
                    source=str(source.get("module", "")),
                    id=int(alarm_id),
                    severity=d.get("severity", "medium"),
                    text=str(d.get("text", ""))[:200],
                )
            )
    out.sort(key=lambda a: -(SEVERITIES.index(a.severity) if a.severity in SEVERITIES else -1))
    return out

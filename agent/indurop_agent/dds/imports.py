"""imports.py -- controllers sharing variables over DDS (docs/dds.md "Controllers sharing variables"):
the bridge's exports and imports of the running set's dds.json.

Exports: every `export`ed variable is traced with the joints (owner "dds"); each traced row whose
seq is a multiple of the export's decimation becomes one indurop::dds::SharedVariable sample on
the topic indurop/shared_variables, keyed by (this controller's name, the path), with the row's
seq, its due time on the wall clock and the values.  When irpd stops answering, or the set stops
exporting a variable, the bridge unregisters its instance: importers see it gone at once.  The
writer's liveliness is automatic with a lease of LEASE_MS: a bridge that dies without a word is
seen gone within the lease.  Each export has a writer of its own whose USER_DATA names the
variable with its type as the web UI shows it (`indurop.variables=Main.count DINT (int32_t);`, as
the publish mappings' writers do): DDS hands it to every matched reader with the writer; USER_DATA
cannot change after a writer is made, so a retyped export gets a new writer.

Imports: one reader of the topic (keep-last 1 per instance: a late poll takes the newest sample
only).  Each poll the bridge takes the samples of the instances it imports; every status period it
takes whatever else arrived and counts it (`ignored`).  An import is fresh while samples come, of
the type its variable has; it turns stale when DDS says the instance has no writer (unregistered,
or its writer's liveliness lost), or after `timeout_ms` without a sample.  At most `rate_hz`
times a second the bridge writes through irpd's `write` -- fresh: the value(s), the stamp, the age,
then stale = 0; turning stale: stale = 1, then the fallback -- so that a module never reads the
fallback as fresh, nor a value with the flag of another.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field

from cyclonedds.core import DDSException, InstanceState, Policy, Qos
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from ..irpd.client import IrpdRefused, IrpdUnavailable
from ..irpd.variables import Segment, VariableError, shown
from . import ros2_types, sharing
from .indurop_types import SharedVariable
from .sharing import Export, Import, Shape

TOPIC = "indurop/shared_variables"
LEASE_MS = 500  # the exporters' writer liveliness lease: a dead bridge is seen gone within it
MAX_INSTANCES = 1024  # instances the reader keeps (every exporter's variables on the domain)
MAX_SWEEP = 256  # samples of instances not imported taken (and counted) per status period
WRITER_QOS = Qos(
    Policy.Reliability.Reliable(duration(milliseconds=100)),
    Policy.Durability.Volatile,
    Policy.History.KeepLast(1),
    Policy.Liveliness.Automatic(duration(milliseconds=LEASE_MS)),
)
READER_QOS = Qos(
    Policy.Reliability.Reliable(duration(milliseconds=100)),
    Policy.Durability.Volatile,
    Policy.History.KeepLast(1),
    Policy.ResourceLimits(max_samples=MAX_INSTANCES, max_instances=MAX_INSTANCES, max_samples_per_instance=1),
)
STALE_AGE_PERIOD_S = 0.1  # while stale, the age goes on growing: written this often at most
GONE = InstanceState.NotAliveNoWriters | InstanceState.NotAliveDisposed
LEVEL_OK, LEVEL_WARN = 0, 1


def log(message: str) -> None:
    print(f"indurop-dds-bridge: {message}", file=sys.stderr, flush=True)


@dataclass
class ExportState:
    spec: Export
    shape: Shape
    decimation: int
    described: str  # the writer's USER_DATA (sharing.user_data)
    writer: DataWriter | None = None  # its own, kept while the export and its description are
    registered: bool = False  # a sample was written since the last unregister


@dataclass
class ImportState:
    spec: Import
    shape: Shape
    fallback: list
    period_s: float
    age_max: float = 0  # the age variable's largest value: a longer age is written as it
    pending: tuple | None = None  # the newest good sample not written yet: (its stamp, its values)
    last_seq: int = 0
    last_stamp_ns: int = 0  # the last good sample's due time (wall clock)
    received_at: float | None = None  # monotonic time of the last good sample
    gone: bool = False  # DDS said: no writer (unregistered, disposed, liveliness lost)
    bad: str = ""  # why the last sample was not taken (another type, not a value), until a good one
    stale: bool | None = None  # as written in the segment (None: not written yet)
    reason: str = "no sample yet"  # what the diagnostics say
    next_write: float = 0.0
    counts: dict = field(
        default_factory=lambda: dict.fromkeys(
            ("received", "written", "superseded", "mismatched", "malformed", "refused", "turned_stale"), 0
        )
    )


class Sharing:
    """The running set's exports and imports; the bridge calls it from its one thread."""

    def __init__(self, participant, name: str, irpd):
        self.participant, self.name, self.irpd = participant, name, irpd
        self._topic: Topic | None = None
        self.reader: DataReader | None = None  # made with the first import, kept for the bridge's life
        self.exports: list[ExportState] = []
        self.imports: list[ImportState] = []
        self.by_key: dict[tuple[str, str], list[ImportState]] = {}
        self.handles: dict[tuple[str, str], int] = {}
        self.segment: Segment | None = None
        self.exported = 0  # samples written
        self.ignored = 0  # samples of instances no import names
        self.irpd_errors = 0

    # ---- loading a set -------------------------------------------------------------------------
    def topic(self) -> Topic:
        if self._topic is None:
            self._topic = Topic(self.participant, TOPIC, SharedVariable)
        return self._topic

    def layout(self, status: dict) -> dict | None:
        """The running layout, from the variables segment irpd names (None without one)."""
        name = (status.get("shared_memory") or {}).get("variables")
        if not name:
            return None
        try:
            if self.segment is None or self.segment.replaced() or self.segment.path.name != name.lstrip("/"):
                if self.segment is not None:
                    self.segment.close()
                self.segment = Segment(name)
            self.segment.refresh()
        except VariableError as e:
            log(f"the variables segment: {e}")
            self.segment = None
            return None
        return self.segment.layout

    def load(self, exports: tuple[Export, ...], imports: tuple[Import, ...], layout: dict | None, decimation):
        """Takes the set's exports and imports; returns (the channels to trace for the exports,
        a problem or "").  Variables that do not fit the running layout refuse both lists."""
        problem = ""
        if exports and not sharing.CONTROLLER.search(self.name):
            problem = (
                f"the controller's name {self.name!r} cannot be imported (letters, digits, _ . -): nothing exported"
            )
            exports = ()
        if exports or imports:
            try:
                if layout is None:
                    raise sharing.SharingError("irpd names no shared-variable segment", None)
                sharing.check_layout(exports, imports, layout, sharing.SharingError)
            except sharing.SharingError as e:
                problem = "; ".join(filter(None, [problem, f"dds.json:{e.line}: {e}" if e.line else f"dds.json: {e}"]))
                exports, imports = (), ()
        now_exported = {x.variable for x in exports}
        for x in self.exports:
            if x.spec.variable not in now_exported:
                self.unregister(x)
        previous = {x.spec.variable: x for x in self.exports}
        self.exports = []
        leaves = {leaf["path"]: leaf for leaf in shown(layout.get("leaves", []))} if exports else {}
        for x in exports:
            shape = sharing.shape(layout, x.variable)
            of = [leaves[p] for p in shape.leaves]
            described = sharing.user_data([sharing.described(x.variable, of, shape.array)])
            state = ExportState(x, shape, decimation(x.rate_hz), described)
            before = previous.get(x.variable)
            if before is not None and before.described == described:
                state.writer, state.registered = before.writer, before.registered
            else:  # new, or its type changed: a writer saying so (the previous one goes with its state)
                qos = Qos(*WRITER_QOS, Policy.Userdata(described.encode()))
                state.writer = DataWriter(self.participant, self.topic(), qos)
            self.exports.append(state)
        old = {(s.spec, s.shape): s for s in self.imports}
        self.imports = []
        for imp in imports:
            local = sharing.shape(layout, imp.variable)
            state = old.get((imp, local)) or ImportState(
                imp, local, sharing.fallback_values(imp, local), 1.0 / imp.rate_hz
            )
            state.stale = None  # written again into this (perhaps new) segment
            if imp.age_us:
                state.age_max = sharing.max_value(sharing.shape(layout, imp.age_us).type)
            self.imports.append(state)
        self.by_key = {}
        for s in self.imports:
            self.by_key.setdefault((s.spec.source, s.spec.path), []).append(s)
        self.handles = {k: h for k, h in self.handles.items() if k in self.by_key}
        if self.imports and self.reader is None:
            self.reader = DataReader(self.participant, self.topic(), READER_QOS)
        return [leaf for x in self.exports for leaf in x.shape.leaves], problem

    # ---- exports -------------------------------------------------------------------------------
    def publish(self, part, column: dict, clock_offset_ns: int) -> None:
        """The exported variables of one part of the trace rows read."""
        for x in self.exports:
            cols = [column.get(leaf) for leaf in x.shape.leaves]
            if None in cols:
                continue  # not (yet) traced
            for k in range(part.count):
                seq = part.first_seq + k
                if seq % x.decimation:
                    continue
                x.writer.write(
                    SharedVariable(
                        controller=self.name,
                        path=x.spec.variable,
                        seq=seq,
                        stamp_ns=part.t_ns[k] + clock_offset_ns,
                        every=x.decimation,
                        type=x.shape.name,
                        values=[c[k] for c in cols],
                    )
                )
                x.registered = True
                self.exported += 1

    def unregister(self, x: ExportState) -> None:
        if x.registered and x.writer is not None:
            x.writer.unregister_instance(SharedVariable(controller=self.name, path=x.spec.variable))
            x.registered = False

    def withdraw(self) -> None:
        """irpd is gone: the exports have no source any more; importers see them gone at once."""
        for x in self.exports:
            self.unregister(x)

    # ---- imports -------------------------------------------------------------------------------
    def step(self, now: float, clock_offset_ns: int, sweep: bool) -> None:
        """Takes the imported instances' samples (and, with `sweep`, everything else that came),
        and writes what is due."""
        if self.reader is None or not self.imports:
            return
        for key in self.by_key:
            handle = self.handles.get(key)
            if handle is None:
                handle = self.reader.lookup_instance(SharedVariable(controller=key[0], path=key[1]))
                if handle is None:
                    continue  # nothing of it came yet
                self.handles[key] = handle
            try:
                samples = self.reader.take(N=4, instance_handle=handle)
            except DDSException:
                del self.handles[key]  # the instance was freed (no writer, no sample): looked up again
                continue
            self.receive(key, samples, now)
        if sweep:
            samples = self.reader.take(N=MAX_SWEEP)
            for s in samples:
                k = s if isinstance(s, SharedVariable) else getattr(s, "key_sample", None)  # a notice: its key
                key = (getattr(k, "controller", None), getattr(k, "path", None))
                if key in self.by_key:
                    self.receive(key, [s], now)
                else:
                    self.ignored += 1
        for s in self.imports:
            self.update(s, now, clock_offset_ns)

    def receive(self, key: tuple[str, str], samples: list, now: float) -> None:
        for sample in samples:
            for s in self.by_key[key]:
                if not isinstance(sample, SharedVariable):  # an instance-state notice
                    if sample.sample_info.instance_state & GONE:
                        s.gone = True
                    continue
                s.gone = False
                s.counts["received"] += 1
                if sample.type != s.shape.name:
                    s.counts["mismatched"] += 1
                    self.refuse(
                        s,
                        f"{s.spec.source} exports {s.spec.path} as {sample.type}, {s.spec.variable} is a {s.shape.name}",
                    )
                    continue
                values = [sharing.as_written(s.shape.type, v) for v in sample.values]
                if len(values) != len(s.shape.leaves) or not all(sharing.fits(s.shape.type, v) for v in values):
                    s.counts["malformed"] += 1
                    self.refuse(s, f"a sample of {s.spec.path} that is no {s.shape.name}: {sample.values[:4]}")
                    continue
                if s.last_seq and sample.seq > s.last_seq:
                    s.counts["superseded"] += max(0, (sample.seq - s.last_seq) // max(1, sample.every) - 1)
                s.last_seq, s.last_stamp_ns, s.bad = sample.seq, sample.stamp_ns, ""
                s.pending, s.received_at = (sample.stamp_ns, values), now

    def refuse(self, s: ImportState, why: str) -> None:
        """A sample not written: said once while the same reason repeats."""
        if why != s.bad:
            log(f"import {s.spec.key} -> {s.spec.variable}: not written: {why}")
        s.bad = why

    def stale_reason(self, s: ImportState, now: float) -> str:
        """Why the import is stale now, or "" while it follows its source."""
        if s.gone:
            return f"{s.spec.source} has no writer of {s.spec.path} (it stopped, or its lease of {LEASE_MS} ms lapsed)"
        if s.received_at is None:
            return s.bad or "no sample yet"
        if now - s.received_at > s.spec.timeout_ms / 1000:
            return s.bad or f"no sample for {s.spec.timeout_ms:g} ms"
        return ""

    def update(self, s: ImportState, now: float, clock_offset_ns: int) -> None:
        stale = self.stale_reason(s, now)
        if now < s.next_write:
            return
        if stale:
            s.pending = None
            if s.stale is True:
                s.reason = stale
                if s.spec.age_us and s.last_stamp_ns:  # the age of the last value goes on growing
                    self.write(s, [(s.spec.age_us, self.age_us(s, s.last_stamp_ns - clock_offset_ns))])
                    s.next_write = now + max(s.period_s, STALE_AGE_PERIOD_S)
            else:
                if self.write(s, [(s.spec.stale, 1)] + list(zip(s.shape.leaves, s.fallback))):
                    s.counts["turned_stale"] += s.stale is False
                    s.stale, s.reason = True, stale
                    log(f"import {s.spec.key} -> {s.spec.variable}: stale ({stale}): the fallback is written")
                s.next_write = max(s.next_write + s.period_s, now - s.period_s)
            return
        if s.pending is None:
            return
        (stamp_ns, values), s.pending = s.pending, None
        writes = list(zip(s.shape.leaves, values))
        stamp_mono = stamp_ns - clock_offset_ns
        if s.spec.stamp_ns:
            writes.append((s.spec.stamp_ns, max(0, stamp_mono)))
        if s.spec.age_us:
            writes.append((s.spec.age_us, self.age_us(s, stamp_mono)))
        if s.stale is not False:
            writes.append((s.spec.stale, 0))
        if self.write(s, writes):
            s.counts["written"] += 1
            if s.stale is not False:
                log(f"import {s.spec.key} -> {s.spec.variable}: fresh")
            s.stale, s.reason = False, f"following {s.spec.key}"
        s.next_write = max(s.next_write + s.period_s, now - s.period_s)

    @staticmethod
    def age_us(s: ImportState, stamp_mono_ns: int) -> int:
        """The age of a sample due at `stamp_mono_ns` (this host's CLOCK_MONOTONIC), now, in µs,
        at most what the age variable holds."""
        return int(min(s.age_max, max(0, (time.monotonic_ns() - stamp_mono_ns) // 1000)))

    def write(self, s: ImportState, writes: list[tuple[str, object]]) -> bool:
        for path, value in writes:
            try:
                self.irpd.request("write", path=path, value=value)
            except IrpdRefused as e:
                s.counts["refused"] += 1
                self.refuse(s, f"irpd refused {path} = {value!r}: {e}")
                return False
            except IrpdUnavailable:
                self.irpd_errors += 1
                return False
        return True

    # ---- diagnostics and the end ---------------------------------------------------------------
    def values(self) -> list[ros2_types.KeyValue]:
        """The bridge status's counters of sharing."""
        return [
            ros2_types.KeyValue(key="exported", value=str(self.exported)),
            ros2_types.KeyValue(key="imports_ignored", value=str(self.ignored)),
        ]

    def statuses(self, name: str) -> list[ros2_types.DiagnosticStatus]:
        """One DiagnosticStatus per import: OK while it follows its source, WARN while stale."""
        out = []
        for s in self.imports:
            values = [
                ros2_types.KeyValue(key="from", value=s.spec.source),
                ros2_types.KeyValue(key="path", value=s.spec.path),
                ros2_types.KeyValue(key="variable", value=s.spec.variable),
                ros2_types.KeyValue(key="stale", value=str(s.stale is not False).lower()),
                ros2_types.KeyValue(key="last_seq", value=str(s.last_seq)),
                *(ros2_types.KeyValue(key=k, value=str(v)) for k, v in s.counts.items()),
            ]
            out.append(
                ros2_types.DiagnosticStatus(
                    level=LEVEL_OK if s.stale is False else LEVEL_WARN,
                    name=f"{name}: import {s.spec.variable}",
                    message=s.reason[:1000],
                    hardware_id=name,
                    values=values,
                )
            )
        return out

    def close(self) -> None:
        """The bridge stops: its imports are stale from now on, its exports gone."""
        for s in self.imports:
            if s.stale is not True:
                self.write(s, [(s.spec.stale, 1)] + list(zip(s.shape.leaves, s.fallback)))
        self.withdraw()
        if self.segment is not None:
            self.segment.close()

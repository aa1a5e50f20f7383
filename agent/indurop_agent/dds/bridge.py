"""bridge.py -- indurop-dds-bridge: the controller on Cyclone DDS, as ROS 2 sees it (docs/dds.md).

A non-RT process beside the agent.  It reads what the agent reads and never blocks irpd:

- irpd's control socket (its own connection): `status` every status_s, `trace` with the owner
  "dds" (irpd traces the union of every owner's channels), `stats` and `alarms` for the
  diagnostics, and `write` for the variables its subscriptions and imports map — the only writes
  it makes;
- the trace rings, mapped read-only: every sample of the joint, mapped and exported variables;
- the variables segment, mapped read-only, for the running layout (the exports' and imports' types).

Each poll (poll_ms): the rows sampled since the last poll are published — sensor_msgs/JointState
on rt/<ns>/joint_states from robot.json's joint map (position = value x scale + offset), stamped
with the row's due time on the wall clock, the mapped variables (std_msgs types, or the message
types dds.json declares, declared.py) and the exported variables (imports.py) — then the
subscriptions are taken and written, each topic at most max_rate_hz, and the imports, each at most
rate_hz.  Every diagnostics period: one
diagnostic_msgs/DiagnosticArray on rt/<ns>/diagnostics.  Every line period: the controller's
announcement on the line, and the line's view for the agent (line.py).

    indurop-dds-bridge --irpd-socket /run/indurop/irpd.sock [--domain-id 0] [--interface lo]
"""

from __future__ import annotations

import signal
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication
from cyclonedds.core import DDSException, Policy, Qos
from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from ..irpd.client import IrpdClient, IrpdRefused, IrpdUnavailable
from ..irpd.trace import TraceError, TraceFollower
from ..irpd.variables import Segment, VariableError, shown
from ..viewer.mapping import ROBOT_JSON, MappingError, parse_config
from . import bridge_file, declared, ros2_types, sharing
from .bridge_file import BRIDGE_JSON, BridgeFile, BridgeFileError, Mapping, std_basic
from .diagnostics import LEVEL_ERROR, LEVEL_OK, LEVEL_STALE, LEVEL_WARN, Timing
from .imports import Sharing
from .line import Line
from .settings import BridgeSettings, cyclone_config, parse_args

# ROS 2's QoS profiles (rmw_qos_profile_default, rmw_qos_profile_sensor_data).
QOS = {
    "default": Qos(
        Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.Durability.Volatile, Policy.History.KeepLast(10)
    ),
    "sensor_data": Qos(Policy.Reliability.BestEffort, Policy.Durability.Volatile, Policy.History.KeepLast(5)),
}
MAX_TAKE = 64  # samples taken from one subscription per poll; the reader keeps the newest (keep-last)


def ros_time(ns: int) -> ros2_types.Time:
    return ros2_types.Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


@dataclass
class Counters:
    """What the bridge did since it started; sent in the diagnostics (docs/dds.md "Counters")."""

    joint_states: int = 0  # JointState samples published
    published: int = 0  # mapped-variable samples published
    rows_lost: int = 0  # trace rows overwritten before the bridge read them
    received: int = 0  # samples taken from subscriptions
    written: int = 0  # variables written through irpd
    refused: int = 0  # writes irpd refused (a value out of the variable's range or type)
    malformed: int = 0  # samples that do not fit their mapping (an array of another length, NaN for an integer)
    dropped: int = 0  # samples over a subscription's max_rate_hz, not written
    foreign_writers: int = 0  # writers on a subscribed topic with another type: DDS never matches them
    incompatible_qos: int = 0  # writers on a subscribed topic whose QoS cannot match (e.g. best effort)
    irpd_errors: int = 0  # requests irpd did not answer

    def as_values(self) -> list[ros2_types.KeyValue]:
        return [ros2_types.KeyValue(key=k, value=str(v)) for k, v in self.__dict__.items()]


@dataclass
class Subscription:
    mapping: Mapping
    reader: DataReader
    tokens: float = 0.0  # a token bucket of max_rate_hz, at most one second's worth
    last: float = field(default_factory=time.monotonic)


@dataclass
class Publication:
    mapping: Mapping
    writer: DataWriter
    decimation: int = 1


class Bridge:
    def __init__(self, settings: BridgeSettings):
        self.s = settings
        self.counters = Counters()
        self.irpd = IrpdClient(settings.irpd_socket, timeout_s=2.0)
        self.domain = Domain(settings.domain_id, cyclone_config(settings))
        self.participant = DomainParticipant(settings.domain_id)
        self._topics: dict[str, Topic] = {}  # by wire name; replaced when a set maps it with another type
        self.trace = TraceFollower()
        self.set_key: tuple | None = None
        self.set_path = ""
        self.problem = ""  # why the set's files are not (all) published, for the diagnostics
        self.bridge = BridgeFile()
        self.joints: list[tuple[str, str, float, float]] = []  # (joint, variable, scale, offset)
        self.joint_writer: DataWriter | None = None
        self.joint_decimation = 1
        # Every writer on the domain, to count those on a subscribed topic with a foreign type.
        self.publications_seen = BuiltinDataReader(self.participant, BuiltinTopicDcpsPublication)
        self.foreign: set = set()
        self.diag_writer = DataWriter(
            self.participant, self.topic("diagnostics", ros2_types.DiagnosticArray), QOS["default"]
        )
        self.publications: list[Publication] = []
        self.sharing = Sharing(self.participant, settings.name, self.irpd)  # export and imports (imports.py)
        self.subscriptions: list[Subscription] = []
        self.incompatible_before = 0
        self.basic_period_ns = 0
        self.clock_offset_ns = time.time_ns() - time.monotonic_ns()
        self.status: dict = {}
        self.leaves: dict[str, dict] = {}  # the running layout's leaves by path (their types)
        self.next_status = 0.0
        self.next_diag = 0.0
        self.timing = Timing(settings.name)  # the dispatchers' and modules' statuses (diagnostics.py)
        self.stopping = False
        self.line = Line(self.participant, settings, self.irpd)

    # ---- DDS ---------------------------------------------------------------------------------
    def wire_name(self, topic: str) -> str:
        """A ROS 2 topic as ROS 2 names it on DDS: rt/<namespace>/<topic>."""
        return "rt/" + "/".join(p for p in (self.s.namespace, topic) if p)

    def topic(self, name: str, cls) -> Topic:
        wire = self.wire_name(name)
        if wire not in self._topics or self._topics[wire].data_type is not cls:
            self._topics[wire] = Topic(self.participant, wire, cls)
        return self._topics[wire]

    # ---- the running set ---------------------------------------------------------------------
    def poll_status(self) -> None:
        try:
            status = self.irpd.request("status")
        except (IrpdUnavailable, IrpdRefused) as e:
            if self.status:
                print(f"indurop-dds-bridge: irpd: {e}", file=sys.stderr, flush=True)
            self.counters.irpd_errors += 1
            self.status = {}
            self.sharing.withdraw()
            return
        self.status = status
        key = (status.get("pid"), status.get("set"), status.get("generation"))
        if key != self.set_key or self.trace.stale():
            self.set_key = key
            self.load_set(status)

    def load_set(self, status: dict) -> None:
        """Reads the running set's robot.json and dds.json and asks irpd to trace their variables."""
        self.set_path = status.get("set") or ""
        folder = Path(self.set_path).parent
        self.basic_period_ns = int(status.get("basic_period_ns") or 0)
        problems = []
        bridge = BridgeFile()
        if (folder / BRIDGE_JSON).is_file():
            try:
                bridge = bridge_file.parse((folder / BRIDGE_JSON).read_bytes())
                bridge_file.check_writers(bridge, module_writes(Path(self.set_path)))
                check_against_layout(bridge, status)
            except (BridgeFileError, OSError) as e:
                problems.append(str(e))
                bridge = BridgeFile(publish=(), subscribe=())
        joints = []
        if bridge.joint_states and (folder / ROBOT_JSON).is_file():
            try:
                config = parse_config((folder / ROBOT_JSON).read_bytes())
                joints = [(j.joint, j.variable, j.scale, j.offset) for j in config.joints if j.variable]
            except (MappingError, OSError) as e:
                problems.append(str(e))
        layout = self.sharing.layout(status)
        self.leaves = {leaf["path"]: leaf for leaf in shown((layout or {}).get("leaves", []))}
        exported, problem = self.sharing.load(bridge.export, bridge.imports, layout, self.decimation)
        problems += [problem] if problem else []
        channels = [v for _, v, _, _ in joints] + [v for m in bridge.publish for v in m.variables] + exported
        channels = list(dict.fromkeys(channels))
        try:
            try:
                answer = self.irpd.request("trace", channels=channels, owner=self.s.trace_owner)
            except IrpdRefused as e:
                problems.append(f"irpd refused to trace the mapped variables: {e}")
                joints = []
                bridge = BridgeFile(joint_states=False, publish=(), subscribe=bridge.subscribe, imports=bridge.imports)
                self.sharing.load((), bridge.imports, layout, self.decimation)
                answer = self.irpd.request("trace", channels=[], owner=self.s.trace_owner)
            self.trace.open(answer["shm"])
        except (IrpdUnavailable, IrpdRefused, TraceError, KeyError) as e:
            self.counters.irpd_errors += 1
            self.set_key = None  # try again at the next status
            print(f"indurop-dds-bridge: the trace rings: {e}", file=sys.stderr, flush=True)
            return
        self.bridge, self.joints, self.problem = bridge, joints, "; ".join(problems)
        self.setup_writers()
        if self.problem:
            print(f"indurop-dds-bridge: {self.problem}", file=sys.stderr, flush=True)
        print(
            f"indurop-dds-bridge: set {self.set_path}: {len(joints)} joints on "
            f"{self.wire_name(bridge.joint_states_topic)} every {self.joint_decimation} basic period(s), "
            f"{len(bridge.publish)} published and {len(bridge.subscribe)} subscribed mappings, "
            f"{len(self.sharing.exports)} exports and {len(self.sharing.imports)} imports",
            file=sys.stderr,
            flush=True,
        )

    def decimation(self, rate_hz: float) -> int:
        if self.basic_period_ns <= 0:
            return 1
        return max(1, round(1e9 / (rate_hz * self.basic_period_ns)))

    def setup_writers(self) -> None:
        # The previous set's writers and readers go with their last reference (cyclonedds deletes
        # an entity when it is collected); their counts stay.
        self.incompatible_before = self.counters.incompatible_qos
        self.publications, self.subscriptions = [], []
        b = self.bridge
        self.joint_writer = None
        if b.joint_states and self.joints:
            self.joint_writer = DataWriter(
                self.participant, self.topic(b.joint_states_topic, ros2_types.JointState), QOS["default"]
            )
            self.joint_decimation = self.decimation(b.joint_states_hz)
        self.publications = [
            Publication(
                m,
                DataWriter(self.participant, self.topic(m.topic, m.cls), self.mapping_qos(m)),
                self.decimation(m.rate_hz),
            )
            for m in b.publish
        ]
        self.subscriptions = [
            Subscription(
                m,
                DataReader(self.participant, self.topic(m.topic, m.cls), self.mapping_qos(m)),
                tokens=m.rate_hz,
            )
            for m in b.subscribe
        ]

    def mapping_qos(self, m: Mapping) -> Qos:
        """A mapping's QoS profile, with the variables it maps and their types in its USER_DATA,
        which DDS hands every matched peer with the endpoint (ROS 2's `key=value;` form, as
        rmw puts its typehash there): `indurop.variables=data: Main.count DINT (int32_t);`, a
        Structured Text variable's IEC type beside the C++ one (layout.json's iec_type)."""
        described = [
            f"{field_name}: {sharing.described(variable, [self.leaves[variable]] if variable in self.leaves else [])}"
            for field_name, _, variable in m.leaves()
        ]
        return Qos(*QOS[m.qos], Policy.Userdata(sharing.user_data(described).encode()))

    # ---- samples out -------------------------------------------------------------------------
    def publish_rows(self) -> None:
        read = self.trace.read()
        if read is None:
            return
        self.counters.rows_lost += read.lost
        for part in read.parts:
            column = {p: part.columns[i] for i, p in enumerate(part.config.paths)}
            self.publish_joints(part, column)
            self.sharing.publish(part, column, self.clock_offset_ns)
            for pub in self.publications:
                m = pub.mapping
                cols = [column.get(v) for v in m.variables]
                if None in cols:
                    continue
                for k in range(part.count):
                    if (part.first_seq + k) % pub.decimation:
                        continue
                    if m.plan:
                        message = m.plan.build([c[k] for c in cols], part.t_ns[k] + self.clock_offset_ns)
                    else:
                        values = [cast(m.type, c[k]) for c in cols]
                        message = m.cls(data=values) if m.is_array else m.cls(data=values[0])
                    pub.writer.write(message)
                    self.counters.published += 1

    def publish_joints(self, part, column: dict) -> None:
        if self.joint_writer is None:
            return
        cols = [column.get(v) for _, v, _, _ in self.joints]
        if None in cols:
            return  # not (yet) traced
        names = [j for j, _, _, _ in self.joints]
        for k in range(part.count):
            if (part.first_seq + k) % self.joint_decimation:
                continue
            stamp = ros_time(part.t_ns[k] + self.clock_offset_ns)
            self.joint_writer.write(
                ros2_types.JointState(
                    header=ros2_types.Header(stamp=stamp, frame_id=self.bridge.frame_id),
                    name=names,
                    position=[c[k] * scale + offset for c, (_, _, scale, offset) in zip(cols, self.joints)],
                )
            )
            self.counters.joint_states += 1

    # ---- samples in --------------------------------------------------------------------------
    def take_subscriptions(self) -> None:
        now = time.monotonic()
        for sub in self.subscriptions:
            m = sub.mapping
            sub.tokens = min(m.rate_hz, sub.tokens + (now - sub.last) * m.rate_hz)
            sub.last = now
            try:
                samples = sub.reader.take(N=MAX_TAKE)
            except Exception as e:  # a sample cyclonedds cannot deserialize
                self.counters.malformed += 1
                print(f"indurop-dds-bridge: {self.wire_name(m.topic)}: {e}", file=sys.stderr, flush=True)
                continue
            for sample in samples:
                if not isinstance(sample, m.cls):
                    continue  # an instance-state notice, not data
                self.counters.received += 1
                if sub.tokens < 1:
                    self.counters.dropped += 1
                    continue
                sub.tokens -= 1
                self.write(m, sample)

    def watch_writers(self) -> None:
        """Counts writers on a subscribed topic whose type is not the mapping's (Cyclone does not
        match them and counts nothing itself), and the readers' incompatible-QoS notices."""
        wanted = {self.wire_name(s.mapping.topic): s.mapping.cls.__idl_typename__ for s in self.subscriptions}
        for w in self.publications_seen.take(N=256):
            name = getattr(w, "topic_name", None)
            if name in wanted and getattr(w, "type_name", None) != wanted[name] and w.key not in self.foreign:
                self.foreign.add(w.key)
                self.counters.foreign_writers += 1
                print(
                    f"indurop-dds-bridge: a writer of {w.type_name} on {name} (mapped as {wanted[name]}) is ignored",
                    file=sys.stderr,
                    flush=True,
                )
        self.counters.incompatible_qos = self.incompatible_before + sum(
            s.reader.get_requested_incompatible_qos_status().total_count for s in self.subscriptions
        )

    def write(self, m: Mapping, sample) -> None:
        if m.plan:
            try:
                values = m.plan.read(sample)
            except declared.Malformed:
                values = []
        else:
            values = list(sample.data) if m.is_array else [sample.data]
        leaves = m.leaves()
        if len(values) != len(leaves) or any(not declared.fits(b, v) for (_, b, _), v in zip(leaves, values)):
            self.counters.malformed += 1
            return
        for variable, value in zip(m.variables, values):
            try:
                self.irpd.request("write", path=variable, value=value)
                self.counters.written += 1
            except IrpdRefused:
                self.counters.refused += 1
            except IrpdUnavailable:
                self.counters.irpd_errors += 1

    # ---- diagnostics -------------------------------------------------------------------------
    def publish_diagnostics(self) -> None:
        now_ns = time.time_ns()
        statuses = [self.bridge_status(), *self.sharing.statuses(self.s.name)]
        if self.status:
            try:
                stats = self.irpd.request("stats")
                alarms = self.irpd.request("alarms")
            except (IrpdUnavailable, IrpdRefused):
                self.counters.irpd_errors += 1
                stats, alarms = {}, {}
            statuses.append(self.set_status(alarms))
            statuses += self.timing.statuses(stats, time.monotonic())
        self.diag_writer.write(
            ros2_types.DiagnosticArray(header=ros2_types.Header(stamp=ros_time(now_ns)), status=statuses)
        )

    def bridge_status(self) -> ros2_types.DiagnosticStatus:
        level, message = LEVEL_OK, "publishing"
        if not self.status:
            level, message = LEVEL_STALE, "irpd does not answer"
        elif self.problem:
            level, message = LEVEL_ERROR, self.problem
        values = [
            ros2_types.KeyValue(key="domain_id", value=str(self.s.domain_id)),
            ros2_types.KeyValue(key="interface", value=self.s.interface),
            *self.counters.as_values(),
            *self.sharing.values(),
        ]
        return ros2_types.DiagnosticStatus(
            level=level,
            name=f"{self.s.name}: dds bridge",
            message=message[:1000],
            hardware_id=self.s.name,
            values=values,
        )

    def set_status(self, alarms: dict) -> ros2_types.DiagnosticStatus:
        st = self.status
        active = []
        for source in alarms.get("sources", []):
            texts = {d.get("id"): d for d in source.get("declared", [])}
            for alarm_id in source.get("active", []):
                d = texts.get(alarm_id, {})
                active.append(
                    ros2_types.KeyValue(
                        key=f"alarm {source.get('module')}/{alarm_id}",
                        value=f"{d.get('severity', '')}: {d.get('text', '')}".strip(": "),
                    )
                )
        level = LEVEL_OK if st.get("running") and not st.get("stopped_by_fault") else LEVEL_ERROR
        if active and level == LEVEL_OK:
            level = LEVEL_WARN
        message = "running" if st.get("running") else "not running"
        if st.get("stopped_by_fault"):
            message = f"stopped by a fault: {st['stopped_by_fault']}"
        elif active:
            message += f", {len(active)} alarm(s) active"
        values = [
            ros2_types.KeyValue(key=k, value=str(st.get(k)))
            for k in ("set", "set_id", "generation", "basic_period_ns", "cycles", "overruns", "missed", "pid")
        ]
        return ros2_types.DiagnosticStatus(
            level=level, name=f"{self.s.name}: set", message=message, hardware_id=self.s.name, values=values + active
        )

    # ---- the loop ----------------------------------------------------------------------------
    def step(self) -> None:
        now = time.monotonic()
        sweep = now >= self.next_status
        if sweep:
            self.next_status = now + self.s.status_s
            self.follow_wall_clock()
            self.poll_status()
            self.watch_writers()
        if self.status:
            self.publish_rows()
            self.take_subscriptions()
            self.sharing.step(now, self.clock_offset_ns, sweep)
        if self.bridge.diagnostics and now >= self.next_diag:
            self.next_diag = now + 1.0 / self.bridge.diagnostics_hz
            self.publish_diagnostics()
        self.line.step(now, self.status)

    def follow_wall_clock(self) -> None:
        """The stamps' offset from CLOCK_MONOTONIC to the wall clock, taken again only when the
        wall clock was stepped (by more than 1 ms): between steps, stamps stay on the period grid."""
        offset = time.time_ns() - time.monotonic_ns()
        if abs(offset - self.clock_offset_ns) > 1_000_000:
            self.clock_offset_ns = offset

    def run(self) -> None:
        period = self.s.poll_ms / 1000.0
        while not self.stopping:
            start = time.monotonic()
            self.step()
            time.sleep(max(0.0, period - (time.monotonic() - start)))

    def close(self) -> None:
        self.line.close()
        self.sharing.close()
        try:
            self.irpd.request("trace", channels=[], owner=self.s.trace_owner)
        except (IrpdUnavailable, IrpdRefused):
            pass
        self.trace.close()
        self.irpd.close()


def cast(type_name: str, value: float):
    """A traced double as a std_msgs type's data: bool, int (in its range), or float."""
    return declared.cast(std_basic(type_name), value)


def _fits(type_name: str, value) -> bool:
    """A received value a std_msgs type allows (irpd checks it against the variable's own type)."""
    return declared.fits(std_basic(type_name), value)


def check_against_layout(bridge: BridgeFile, status: dict) -> None:
    """dds.json's variables against the running layout (as the upload checks them against the set's
    layout.json): each a scalar leaf, of a type its field fits.  Skipped when the segment cannot be
    read; irpd then refuses an unknown variable itself."""
    try:
        segment = Segment(status["shared_memory"]["variables"])
    except (KeyError, TypeError, VariableError, OSError):
        return
    try:
        layout = segment.layout
        bridge_file.check_variables(bridge, bridge_file.layout_scalars(layout), kinds=bridge_file.layout_kinds(layout))
    finally:
        segment.close()


def module_writes(module_xml: Path) -> dict[str, list[str]]:
    """{module: [variables]} of module.xml's <writes> (docs/module-xml.md)."""
    from ..sets.uploads import UploadError, parse_module_xml

    try:
        return {m.name: m.writes for m in parse_module_xml(module_xml).modules}
    except (UploadError, OSError) as e:
        raise BridgeFileError(f"module.xml cannot be read for its <writes>: {e}") from None


def main(argv: list[str] | None = None) -> int:
    settings = parse_args(argv)
    try:
        bridge = Bridge(settings)
    except DDSException as e:
        why = f"Cyclone DDS refused its configuration: {e}"
        if settings.security:
            why += (
                "; DDS Security is configured, and the cyclonedds wheel's libddsc is built without it "
                '(docs/dds.md "Security"): the bridge does not run unsecured instead'
            )
        print(f"indurop-dds-bridge: {why}", file=sys.stderr, flush=True)
        return 2
    signal.signal(signal.SIGTERM, lambda *_: setattr(bridge, "stopping", True))
    signal.signal(signal.SIGINT, lambda *_: setattr(bridge, "stopping", True))
    print(
        f"indurop-dds-bridge: domain {settings.domain_id} on {settings.interface}, irpd {settings.irpd_socket}",
        file=sys.stderr,
        flush=True,
    )
    try:
        bridge.run()
    finally:
        bridge.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())

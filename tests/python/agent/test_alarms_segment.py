"""test_alarms_segment.py -- the agent's reader of irpd's alarm segment (alarms/segment.py) against
a segment laid out from shm_layout.json by a test writer (alarm_writer.py): intact records in seq
order with every field, a lapped ring (losses counted, a copy torn by a writer caught by the seq
check after it), a writer that died in a record (waited for, then skipped), the sources' bitmaps
and counters; and the watcher on top of it: transitions, reconciliation from the bitmaps at start
and after losses, and a restarted agent that does not read the same records twice."""

from __future__ import annotations

import itertools
import os
import time

import pytest
from alarm_writer import AlarmWriter
from indurop_agent.alarms.manager import AlarmManager
from indurop_agent.alarms.segment import AlarmSegment, Record, RingReader, layout
from indurop_agent.alarms.store import AlarmStore, HistoryFilter
from indurop_agent.alarms.system import SystemAlarms, Thresholds
from indurop_agent.alarms.watcher import AlarmWatcher
from indurop_agent.events import AgentEvents

_names = itertools.count()


@pytest.fixture
def writer():
    """A segment of capacity 8 with irpd and two modules; removed afterwards."""
    w = AlarmWriter(f"indurop.alarm-test-{os.getpid()}-{next(_names)}.alarms", layout(), capacity=8)
    w.source(0, "irpd")
    w.source(1, "PLC", declared=[1, 8])
    w.source(2, "ROBOT", generation=3)
    yield w
    w.close()


def test_intact_records_come_in_seq_order_with_every_field(writer):
    t = time.time_ns()
    writer.transition(1, 8, text="comm lost: Invalid data", value=22, time_ns=t)
    writer.transition(
        2, 3, severity="critical", flags=writer.layout.enum("indurop_alarm_flags")["truncated"], text="x" * 135
    )
    writer.transition(1, 8, raised=False, time_ns=t + 5)
    seg = AlarmSegment(writer.name)
    read = RingReader(seg).read()
    assert (read.lost, read.abandoned) == (0, 0)
    first, second, third = read.records
    assert first == Record(
        seq=1,
        time_ns=t,
        cycle=0,
        source=1,
        source_generation=1,
        id=8,
        raised=True,
        severity=None,
        undeclared=False,
        truncated=False,
        value=22.0,
        text="comm lost: Invalid data",
    )
    assert (second.source, second.source_generation, second.severity, second.truncated) == (2, 3, "critical", True)
    assert (third.seq, third.raised, third.time_ns) == (3, False, t + 5)
    assert seg.capacity == 8 and seg.owner_pid == os.getpid()
    seg.close()


def test_the_sources_bitmaps_and_counters(writer):
    writer.set_active(1, {1, 64, 1023})
    writer.count(1, "rate_dropped", 5)
    writer.count(1, "bad_ids", 2)
    seg = AlarmSegment(writer.name)
    irpd, plc, robot = seg.sources()
    assert (irpd.index, irpd.name, plc.name, robot.name, robot.generation) == (0, "irpd", "PLC", "ROBOT", 3)
    assert plc.declared == {1, 8} and plc.active == {1, 64, 1023}
    assert plc.counters() == {
        "recorded": 0,
        "rate_dropped": 5,
        "undeclared": 0,
        "bad_ids": 2,
        "truncated": 0,
        "collided": 0,
    }
    assert [s.index for s in seg.sources()] == [0, 1, 2]  # source 3 unused (generation 0)
    seg.close()


def test_a_lapped_ring_counts_what_was_overwritten(writer):
    seg = AlarmSegment(writer.name)
    reader = RingReader(seg)
    for i in range(20):
        writer.transition(1, 1 + i % 2, raised=i % 4 < 2)
    read = reader.read()
    assert [r.seq for r in read.records] == list(range(13, 21))
    assert (read.lost, reader.cursor) == (12, 20)
    assert reader.read().records == []  # nothing new
    seg.close()


def test_a_copy_torn_by_a_writer_is_caught_by_the_seq_check_after_it(writer):
    writer.transition(1, 8, text="the first")
    seg = AlarmSegment(writer.name)

    class Lapping:
        """The mapping, with a writer that laps the ring while the reader copies record 1."""

        def __init__(self, mm):
            self.mm, self.done = mm, False

        def __getitem__(self, key):
            if isinstance(key, slice) and not self.done:
                self.done = True
                for _ in range(8):
                    writer.transition(1, 1, text="the lap")
            return self.mm[key]

    seg.mm = Lapping(seg.mm)
    reader = RingReader(seg)
    read = reader.read(limit=1)
    assert read.records == [] and read.lost == 1  # record 1's copy was not taken
    rest = reader.read()
    assert [r.text for r in rest.records] == ["the lap"] * 8
    seg.mm = seg.mm.mm
    seg.close()


def test_a_writer_that_died_in_a_record_is_waited_for_then_skipped(writer):
    writer.transition(1, 8)
    dead = writer.claim()
    writer.write(dead, 1, 1, publish=False)  # died before storing seq
    writer.transition(1, 1, raised=False)
    seg = AlarmSegment(writer.name)
    now = [0.0]
    reader = RingReader(seg, stall_s=1e9, clock=lambda: now[0])  # never for being slow
    assert [r.seq for r in reader.read().records] == [1]
    assert reader.read().records == [] and reader.cursor == 1  # record 2 may still be written: wait
    for _ in range(8):  # head moves capacity past it
        writer.transition(2, 5)
    read = reader.read()
    assert dead not in [r.seq for r in read.records] and read.records[-1].seq == writer.head
    assert read.lost == 2  # the dead one and the clear after it, overwritten meanwhile
    seg.close()


def test_a_record_unwritten_past_the_stall_time_is_skipped_and_counted(writer):
    dead = writer.claim()
    writer.write(dead, 1, 1, publish=False)
    writer.transition(1, 8)
    seg = AlarmSegment(writer.name)
    now = [0.0]
    reader = RingReader(seg, stall_s=2.0, clock=lambda: now[0])
    assert reader.read().records == []
    now[0] = 1.0
    assert reader.read().records == []
    now[0] = 2.5
    read = reader.read()
    assert [r.seq for r in read.records] == [dead + 1] and (read.abandoned, reader.abandoned) == (1, 1)
    seg.close()


def test_a_segment_of_another_version_is_refused_naming_it(writer):
    from indurop_agent.alarms.segment import AlarmSegmentError

    writer._put(writer.header, 0, "version", 99)
    with pytest.raises(AlarmSegmentError, match="version 99"):
        AlarmSegment(writer.name)


# ---- the watcher on a segment ---------------------------------------------------------------------
class Watched:
    """A watcher on `writer`'s segment with an agent's data folder, polled by hand (no irpd)."""

    def __init__(self, writer: AlarmWriter, data):
        self.writer, self.data = writer, data
        self.start()

    def start(self):
        self.manager = AlarmManager(AlarmStore(self.data / "alarms.sqlite3", 10_000))
        self.watcher = AlarmWatcher(
            self.manager, SystemAlarms(self.manager, Thresholds()), "/nonexistent.sock", AgentEvents()
        )
        self.watcher.segment_name = self.writer.name

    def poll(self):
        self.watcher.read_segment()

    def restart(self):
        self.watcher.segment.close()
        self.manager.store.close()
        self.start()

    def state(self, key: str) -> str:
        a = self.manager.alarms.get(key)
        return a.state(time.time_ns()) if a else "normal"

    def history(self, key: str) -> list[tuple[str, str]]:
        rows, _ = self.manager.store.query(HistoryFilter(key=key), 100)
        return [(r["event"], r["note"]) for r in reversed(rows)]


def test_the_watcher_turns_records_into_transitions(writer, tmp_path):
    w = Watched(writer, tmp_path)
    writer.transition(1, 8, text="comm lost", value=22)
    w.poll()
    a = w.manager.alarms["PLC/8"]
    assert (a.state(time.time_ns()), a.detail, a.value) == ("active_unacknowledged", "comm lost", 22)
    writer.transition(1, 8, raised=False)
    w.poll()
    assert w.state("PLC/8") == "cleared_unacknowledged"
    assert w.history("PLC/8") == [("raise", ""), ("clear", "")]


def test_reconciled_at_start_from_the_bitmaps(writer, tmp_path):
    w = Watched(writer, tmp_path)
    writer.transition(1, 8)
    writer.transition(2, 3)
    w.poll()
    w.restart()
    # while the agent was away: PLC/8 went, ROBOT/4 came, and the ring lost both records
    writer.set_active(1, set())
    writer.set_active(2, {3, 4})
    for _ in range(writer.capacity + 2):
        s = writer.claim()
        writer.write(s, 0, 1, raised=False)
    w.poll()
    assert w.state("PLC/8") == "cleared_unacknowledged"
    assert w.history("PLC/8")[-1] == ("clear", "reconciled when the agent started: not active in irpd's alarm segment")
    assert w.state("ROBOT/4") == "active_unacknowledged"
    assert "its raise not read" in w.history("ROBOT/4")[-1][1]
    assert w.state("ROBOT/3") == "active_unacknowledged" and len(w.history("ROBOT/3")) == 1


def test_a_restarted_agent_does_not_read_the_same_records_twice(writer, tmp_path):
    w = Watched(writer, tmp_path)
    writer.transition(1, 8)
    writer.transition(1, 8, raised=False)
    w.poll()
    w.restart()
    w.poll()
    assert w.history("PLC/8") == [("raise", ""), ("clear", "")]
    writer.transition(1, 8)
    w.poll()
    assert [e for e, _ in w.history("PLC/8")] == ["raise", "clear", "raise"]


def test_records_lost_to_a_lap_are_made_good_from_the_bitmaps(writer, tmp_path):
    w = Watched(writer, tmp_path)
    w.poll()
    writer.transition(1, 8)  # lost below
    for i in range(writer.capacity):
        writer.transition(2, 1 + i % 2, raised=i % 4 < 2)
    w.poll()
    assert w.state("PLC/8") == "active_unacknowledged"
    assert w.history("PLC/8")[-1][1].startswith("reconciled after 1 records were lost or skipped")

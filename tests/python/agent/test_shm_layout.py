"""test_shm_layout.py -- the agent reads irpd's segments by irpd's own description of them
(agent/indurop_agent/irpd/shm_layout.json, docs/shared-memory.md): the copy and the docs' tables are
current; the segments of a live irpd read through it give what irpd put there; a reader
refuses a segment whose header the description does not match, naming what differs."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from agent_helpers import FIG1, IRPD, ROOT, start_irpd, stop
from indurop_agent.irpd import shm_layout
from indurop_agent.irpd.shm_layout import LayoutError, segment
from indurop_agent.irpd.trace import TraceError, TraceFollower, TraceRing
from indurop_agent.irpd.variables import Segment

GENERATE = ROOT / "protocol" / "shm" / "generate.py"
REGENERATE = "ninja -C build shm-layout"
needs_irpd = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")
SEGMENTS = ("variables", "stats", "trace", "control", "alarms")


@needs_irpd
def test_the_description_and_the_tables_of_docs_shared_memory_are_current():
    r = subprocess.run([sys.executable, str(GENERATE), "--irpd", str(IRPD), "--check"], capture_output=True, text=True)
    assert r.returncode == 0, f"{r.stderr.strip()}\n(run `{REGENERATE}` and review the diff)"


def test_every_struct_is_described_byte_by_byte_with_known_types():
    """What the readers rely on: fields in order without gaps, types that are scalars, text or
    another described struct, and the same opening for every segment."""
    for name in SEGMENTS:
        s = segment(name)
        assert [(f, s.header.offset(f), s.header.format(f)) for f in ("magic", "version", "header_size")] == [
            ("magic", 0, "<Q"),
            ("version", 8, "<I"),
            ("header_size", 12, "<I"),
        ]
        for st in s.structs.values():
            at = 0
            for field_name, f in st.fields.items():
                assert f["offset"] == at, f"{name}: {st.name}.{field_name}"
                assert (
                    f["type"] in shm_layout.SCALARS
                    or f["type"] in ("char", "pthread_mutex_t")
                    or f["type"] in s.structs
                ), f"{name}: {st.name}.{field_name} is a {f['type']}"
                at += f["size"]
            assert 0 <= st.size - at < 64, st.name


def test_a_field_the_description_does_not_have_is_named_with_those_it_has():
    with pytest.raises(LayoutError, match=r"indurop_trace_header has no field 'tail'.*it lists magic, version"):
        segment("trace").header.offset("tail")
    with pytest.raises(LayoutError, match="no segment 'events'"):
        segment("events")


def doctored(tmp_path: Path, change) -> Path:
    """A copy of the description with `change` made, in a file of its own (descriptions are read once per file)."""
    d = json.loads(shm_layout.DESCRIPTION.read_text())
    change(d)
    path = tmp_path / f"shm_layout-{len(list(tmp_path.glob('shm_layout-*.json')))}.json"
    path.write_text(json.dumps(d))
    return path


def test_a_description_of_another_format_is_refused(tmp_path):
    path = doctored(tmp_path, lambda d: d.update(format=2))
    with pytest.raises(LayoutError, match="format 2 .*this agent reads format 1"):
        segment("trace", path)


# ---- a live irpd ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def live(tmp_path_factory):
    if not IRPD.exists():
        pytest.skip(f"irpd is not built ({IRPD})")
    tmp = tmp_path_factory.mktemp("shm")
    instance = f"shm-layout-test-{os.getpid()}"
    p = start_irpd(tmp / "irpd.sock", FIG1, instance)
    names = {s: segment(s).shm_name(instance) for s in SEGMENTS}
    deadline = time.monotonic() + 60
    while not all((Path("/dev/shm") / n.lstrip("/")).exists() for n in names.values()):  # ctl: after the threads start
        assert p.poll() is None and time.monotonic() < deadline, "irpd did not create its segments"
        time.sleep(0.05)
    yield p, names
    stop(p)
    for leftover in Path("/dev/shm").glob(f"indurop.{instance}.*"):  # only if it had to be killed
        leftover.unlink()


def opened(name: str, live) -> tuple:
    s = segment(name)
    mm, _inode = s.open(live[1][name])
    return s, mm


def test_each_live_segment_opens_and_names_its_irpd(live):
    pid_field = {"variables": "owner_pid", "stats": "pid", "trace": "owner_pid", "control": "owner_pid"}
    pid_field["alarms"] = "owner_pid"
    for name in SEGMENTS:
        s, mm = opened(name, live)
        try:
            assert s.header.read(mm, pid_field[name]) == live[0].pid, name
            assert s.header.read(mm, "header_size") == s.header.size
        finally:
            mm.close()


def test_the_live_variable_segment_holds_the_layout_its_header_points_at(live):
    s, mm = opened("variables", live)
    h = s.header
    try:
        text = mm[h.read(mm, "layout_offset") : h.read(mm, "layout_offset") + h.read(mm, "layout_size")]
        layout = json.loads(text)
        assert layout["hash"] == h.text(mm, "layout_hash")
        assert h.read(mm, "lock_size") == s.struct("indurop_var_lock").size
        assert h.read(mm, "data_offset") + h.read(mm, "data_capacity") <= h.read(mm, "total_size") == len(mm)
        assert h.read(mm, "layout_seq") % 2 == 0
    finally:
        mm.close()
    vars_ = Segment(live[1]["variables"])  # the agent's reader
    try:
        assert vars_.hash == layout["hash"]
        first = vars_.read("knu.Robot.tick")
        deadline = time.monotonic() + 30
        while vars_.read("knu.Robot.tick") == first:  # cntr2 adds 10 every period
            assert time.monotonic() < deadline, "knu.Robot.tick does not move"
            time.sleep(0.01)
    finally:
        vars_.close()


def test_the_live_stats_records_name_the_dispatcher_and_the_modules(live):
    s, mm = opened("stats", live)
    h, record = s.header, s.struct("timing_record")
    kinds, unused = s.enum("record_kind"), s.enum("record_kind")["unused"]
    try:
        assert h.read(mm, "record_size") == record.size
        assert h.text(mm, "set_path").endswith("paper-fig1/module.xml")
        names = {}
        for i in range(h.read(mm, "record_count")):
            base = h.read(mm, "header_size") + i * record.size
            if record.read(mm, "kind", base) != unused:
                names[record.text(mm, "name", base)] = record.read(mm, "kind", base)
    finally:
        mm.close()
    assert {n for n, k in names.items() if k == kinds["module"]} >= {"cntr1", "cntr2", "cntr3", "cntr4"}
    assert kinds["dispatcher"] in names.values()


def test_the_live_control_slots_name_the_process_modules(live):
    s, mm = opened("control", live)
    h, slot = s.header, s.struct("indurop_process_slot")
    try:
        assert h.read(mm, "slot_size") == slot.size
        assert h.read(mm, "call_bytes") == s.constant("call_bytes")
        first = h.read(mm, "header_size")
        names = {slot.text(mm, "name", first + i * slot.size) for i in range(h.read(mm, "slot_count"))}
    finally:
        mm.close()
    assert {"cntr4", "visionEvt", "nonReaTime"} <= names


def test_the_live_alarm_sources_name_irpd_and_the_modules(live):
    s, mm = opened("alarms", live)
    h, source = s.header, s.struct("indurop_alarm_source")
    try:
        assert h.read(mm, "source_size") == source.size
        assert h.read(mm, "record_size") == s.struct("indurop_alarm_record").size
        assert h.read(mm, "capacity") & (h.read(mm, "capacity") - 1) == 0
        first = h.read(mm, "sources_offset")
        names = [source.text(mm, "name", first + i * source.size) for i in range(8)]
        generations = [source.read(mm, "generation", first + i * source.size) for i in range(8)]
    finally:
        mm.close()
    assert names[0] == "irpd" and generations[0] > 0
    # module i of the set's first generation has source 1 + i
    assert names[1:5] == ["cntr1", "cntr2", "cntr3", "cntr4"] and all(g > 0 for g in generations[1:5])


def test_the_live_trace_rings_read_by_the_agent(live):
    ring = TraceRing(live[1]["trace"])
    try:
        t = segment("trace")
        assert ring.channel_max == t.constant("channels")
        assert ring.capacity > 1 and ring.capacity & (ring.capacity - 1) == 0
        assert ring.owner_pid == live[0].pid
        assert [c.generation > 0 for c in ring.configs()] == [True, True]
    finally:
        ring.close()


def test_a_follower_reads_the_live_rings_on_from_where_it_stopped(live):
    name = live[1]["trace"]
    f = TraceFollower()
    assert f.open(None) is False and f.stale() and f.read() is None
    assert f.open(name) is True and f.open(name) is False and not f.stale()
    start = f.cursor
    try:
        assert start <= f.head()
        time.sleep(0.2)  # irpd's rows go on every basic period
        first = f.read()
        assert first is not None and first.since == start and first.next > start and f.cursor == first.next
        second = f.read()
        assert second.since == first.next and f.cursor == second.next >= first.next
        time.sleep(0.05)
        f.skip()
        assert f.cursor >= second.next and f.cursor <= f.head()
    finally:
        f.close()
    assert f.ring is None and f.stale() and f.read() is None
    with pytest.raises(TraceError):
        f.open("/indurop.no-such-instance.trace")
    assert f.ring is None


def test_a_header_the_description_does_not_match_is_refused_naming_both_sizes(live, tmp_path):
    """An agent whose description is not the running irpd's (a changed header) reads nothing."""
    size, version = segment("trace").header.size, segment("variables").version
    path = doctored(tmp_path, lambda d: d["segments"]["trace"]["structs"]["indurop_trace_header"].update(size=size + 8))
    with pytest.raises(LayoutError, match=rf"has a {size}-byte indurop_trace_header; .* says {size + 8}"):
        segment("trace", path).open(live[1]["trace"])
    path = doctored(tmp_path, lambda d: d["segments"]["variables"].update(version=version + 1))
    with pytest.raises(LayoutError, match=f"segment version {version}; this agent reads version {version + 1}"):
        segment("variables", path).open(live[1]["variables"])


def test_a_segment_that_is_not_there_or_of_another_kind_is_refused(live):
    with pytest.raises(TraceError, match="trace segment /indurop.no-such-instance.trace"):
        TraceRing("/indurop.no-such-instance.trace")
    with pytest.raises(LayoutError, match="is not an indurop trace segment"):
        segment("trace").open(live[1]["stats"])

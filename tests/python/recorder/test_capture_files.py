"""test_capture_files.py -- where shots go (agent/indurop_agent/recorder/capture_files.py): a shot is
an MCAP file in the recordings folder and reads back row for row (NaN included), with the trigger's
seq in the file for any MCAP reader; a shot the agent died writing is never listed and is cleared at
the next start; the quota evicts shots like recordings; the engine keeps the newest MAX_SHOTS_KEPT;
a shot that cannot be written (a full disk, its name taken) is reported on the capture without
stopping the writer or touching what is on disk."""

from __future__ import annotations

import errno
import json
import time

import numpy as np
import pytest
from indurop_agent.recorder import capture_limits as L
from indurop_agent.recorder.capture import Shot
from indurop_agent.recorder.capture_engine import CaptureEngine, Entry
from indurop_agent.recorder.capture_files import CaptureFiles
from indurop_agent.recorder.capture_sink import MemorySink
from indurop_agent.recorder.store import Store
from mcap.reader import make_reader
from recorder_helpers import assert_in_time_order


def header(capture="abc123", shot=1) -> dict:
    return {
        "capture": capture,
        "name": "n",
        "by": "olga",
        "shot": shot,
        "channels": [{"path": "a", "type": "double"}, {"path": "b", "type": "bool"}],
        "basic_period_ns": 1000,
        "trigger": {"kind": "manual"},
        "pre": 2,
        "post": 1,
        "trigger_seq": 12,
        "cause": "manual",
        "trigger_time_ns": 5,
    }


def rows(first: int, n: int):
    seq = np.arange(first, first + n, dtype=np.int64)
    values = np.stack([seq * 0.5, (seq % 2).astype(float)])
    return seq, seq * 1000, values


def store_at(tmp_path, quota=1 << 30) -> Store:
    return Store(tmp_path / "recordings", quota, reserve_bytes=0)


@pytest.mark.parametrize("kind", ["mcap", "memory"])
def test_a_shot_reads_back_row_for_row(tmp_path, kind):
    shots = CaptureFiles(store_at(tmp_path)) if kind == "mcap" else MemorySink()
    w = shots.open(header())
    seq, t, values = rows(10, 4)
    values[0, 1] = np.nan
    w.rows(seq[:2], t[:2], values[:, :2])
    w.note("half way")
    w.rows(seq[2:], t[2:], values[:, 2:])
    summary = {"trigger_seq": 12, "pre_rows": 2, "post_rows": 1, "drops": 0, "notes": ["half way"]}
    w.close(summary)
    back = shots.read("abc123", 1)
    assert list(back.seq) == [10, 11, 12, 13] and list(back.t_ns) == [10000, 11000, 12000, 13000]
    assert np.array_equal(back.values, values, equal_nan=True) and np.isnan(back.values[0, 1])
    assert back.notes == ["half way"] and back.paths == ["a", "b"]
    assert shots.summaries("abc123") == [{**summary, "shot": 1}]
    shots.delete("abc123", 1)
    assert shots.read("abc123", 1) is None and shots.summaries("abc123") == []


def test_the_shot_is_an_entry_of_the_recordings_and_its_file_names_the_trigger(tmp_path):
    store = store_at(tmp_path)
    shots = CaptureFiles(store)
    w = shots.open(header())
    w.rows(*rows(10, 4))
    w.close({"trigger_seq": 12, "drops": 0})
    (entry,) = store.entries()
    assert entry.name == "abc123.shot-1" and entry.meta["kind"] == "capture" and entry.meta["state"] == "stopped"
    assert entry.meta["rows"] == 4 and entry.meta["created_by"] == "olga"
    assert entry.meta["parts"][0]["first_seq"] == 10 and entry.meta["parts"][0]["last_seq"] == 13
    with open(entry.parts()[0], "rb") as f:  # the mcap library's own reader
        reader = make_reader(f)
        notes = [json.loads(m.data) for _, c, m in reader.iter_messages(topics=["/indurop/notes"])]
        trigger = [n for n in notes if n["kind"] == "trigger"]
        assert trigger == [{"kind": "trigger", "text": "manual", "seq": 12}]
        samples = [json.loads(m.data) for _, c, m in reader.iter_messages(topics=["/indurop/samples"])]
        assert [s["seq"] for s in samples] == [10, 11, 12, 13] and samples[2]["a"] == 6.0
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
        assert json.loads(metadata["indurop.capture"]["trigger_seq"]) == 12


def test_a_shots_trigger_note_sits_at_its_row_so_that_a_strict_reader_takes_the_file(tmp_path):
    store = store_at(tmp_path)
    shots = CaptureFiles(store)
    w = shots.open(header())  # the trigger at row 12
    seq, t, values = rows(10, 6)
    w.rows(seq[:1], t[:1], values[:, :1])
    w.rows(seq[1:], t[1:], values[:, 1:])
    w.note("the rows stopped coming")
    w.close({"trigger_seq": 12, "drops": 0})
    (path,) = store.get("abc123.shot-1").parts()
    assert assert_in_time_order(path) == 6 + 2
    with open(path, "rb") as f:
        in_file = [json.loads(m.data) for _, _, m in make_reader(f).iter_messages(log_time_order=False)]
    assert [m.get("seq") for m in in_file[:5]] == [10, 11, 12, 12, 13]  # the trigger, then its row
    assert in_file[2]["kind"] == "trigger" and in_file[-1] == {"kind": "info", "text": "the rows stopped coming"}


def test_a_shot_the_agent_died_writing_is_never_listed_and_is_cleared(tmp_path):
    store = store_at(tmp_path)
    shots = CaptureFiles(store)
    shots.open(header(shot=2)).rows(*rows(1, 3))  # never closed: the agent died meanwhile
    shots.open(header(shot=1)).close({"drops": 0})
    assert [s["shot"] for s in shots.summaries("abc123")] == [1]
    store.done_writing("abc123.shot-2")  # a new agent: nothing is being written
    again = CaptureFiles(store)
    assert again.cleared == ["abc123.shot-2"]
    assert [e.name for e in store.entries()] == ["abc123.shot-1"]
    assert again.read("abc123", 1).summary["drops"] == 0
    assert again.read("../etc", 1) is None


def test_the_quota_evicts_shots_and_they_leave_the_list(tmp_path):
    store = store_at(tmp_path)
    shots = CaptureFiles(store)
    for n in (1, 2, 3):
        w = shots.open(header(shot=n))
        w.rows(*rows(10, 4))
        w.close({"drops": 0})
    assert [s["shot"] for s in shots.summaries("abc123")] == [1, 2, 3]
    store.quota_bytes = store.used() - 1  # one shot too many
    gone = store.evict()
    assert gone == ["abc123.shot-1"]
    assert [s["shot"] for s in shots.summaries("abc123")] == [2, 3]


def shot(number: int) -> Shot:
    s = Shot(number, 12, 10, 13, "manual", 5, 1)
    s.add(*rows(10, 4))
    s.seen = 13
    return s


def engine_with(tmp_path, shots) -> CaptureEngine:
    engine = CaptureEngine(str(tmp_path / "no-irpd.sock"), tmp_path / "captures", shots)
    engine.entries["abc123"] = Entry("abc123", {"name": "n", "trigger": {"kind": "manual"}}, "now")
    engine.writer.start()
    return engine


def test_the_engine_keeps_the_newest_shots(tmp_path):
    shots = CaptureFiles(store_at(tmp_path))
    engine = engine_with(tmp_path, shots)
    for n in range(1, L.MAX_SHOTS_KEPT + 3):
        engine.finished.put((header(shot=n), shot(n)))
    engine.flush()
    kept = [s["shot"] for s in shots.summaries("abc123")]
    assert kept == list(range(3, L.MAX_SHOTS_KEPT + 3))
    assert shots.read("abc123", kept[-1]).summary["rows"] == 4


class FullDisk(CaptureFiles):
    """The disk fills up while shot 2 is written."""

    def open(self, header: dict):
        writer = super().open(header)
        if header["shot"] == 2:

            def rows(*_):
                raise OSError(errno.ENOSPC, "No space left on device")

            writer.rows = rows
        return writer


def test_a_shot_that_cannot_be_written_is_reported_and_the_others_are_kept(tmp_path):
    store = store_at(tmp_path)
    shots = FullDisk(store)
    store.create("abc123.shot-4", "recording", {"state": "stopped"})  # a recording took shot 4's name
    engine = engine_with(tmp_path, shots)
    for n in (1, 2, 3, 4):
        engine.finished.put((header(shot=n), shot(n)))
    engine.flush()
    assert [s["shot"] for s in shots.summaries("abc123")] == [1, 3]
    assert sorted(e.name for e in store.entries()) == ["abc123.shot-1", "abc123.shot-3", "abc123.shot-4"]
    assert store.get("abc123.shot-4").meta["kind"] == "recording"  # untouched
    assert shots.read("abc123", 1).summary["rows"] == 4
    events = [e["message"] for e in engine.events.since(0, 10)["events"]]
    assert any("shot 2 not saved" in m and "No space left" in m for m in events), events
    assert any("shot 4 not saved" in m and "named 'abc123.shot-4' already" in m for m in events), events
    assert "shot 4 not saved" in engine.entries["abc123"].message


def test_the_engine_starts_and_stops_cleanly(tmp_path):
    """The agent's shutdown joins the engine's threads (a name of threading.Thread's own once broke it)."""
    engine = CaptureEngine(str(tmp_path / "no-irpd.sock"), tmp_path / "captures", MemorySink(), poll_s=0.01)
    engine.start()
    time.sleep(0.1)
    engine.stop()
    assert not engine.is_alive() and not engine.writer.is_alive()

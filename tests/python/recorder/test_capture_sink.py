"""test_capture_sink.py -- where shots go (agent/indurop_agent/recorder/capture_sink.py): a shot
written as JSON lines reads back row for row (NaN as null and back), a shot a crash left half
written is never listed and is cleared at the next start, deleting works by shot and by capture;
the engine keeps the newest MAX_SHOTS_KEPT shots, and a shot that cannot be written (a full disk)
is reported on the capture without stopping the writer or touching the shots on disk."""

from __future__ import annotations

import errno
import json

import numpy as np
import pytest
from indurop_agent.recorder import capture_limits as L
from indurop_agent.recorder.capture import Shot
from indurop_agent.recorder.capture_engine import CaptureEngine, Entry
from indurop_agent.recorder.capture_sink import JsonLinesSink, MemorySink


def header(capture="abc123", shot=1) -> dict:
    return {
        "capture": capture,
        "name": "n",
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


@pytest.mark.parametrize("kind", ["json", "memory"])
def test_a_shot_reads_back_row_for_row(tmp_path, kind):
    sink = JsonLinesSink(tmp_path) if kind == "json" else MemorySink()
    w = sink.open(header())
    seq, t, values = rows(10, 4)
    values[0, 1] = np.nan
    w.rows(seq[:2], t[:2], values[:, :2])
    w.note("half way")
    w.rows(seq[2:], t[2:], values[:, 2:])
    w.close({"trigger_seq": 12, "pre_rows": 2, "post_rows": 1, "drops": 0})
    back = sink.read("abc123", 1)
    assert list(back.seq) == [10, 11, 12, 13] and list(back.t_ns) == [10000, 11000, 12000, 13000]
    assert np.array_equal(back.values, values, equal_nan=True) and np.isnan(back.values[0, 1])
    assert back.notes == ["half way"] and back.paths == ["a", "b"]
    assert sink.summaries("abc123") == [{"trigger_seq": 12, "pre_rows": 2, "post_rows": 1, "drops": 0, "shot": 1}]
    sink.delete("abc123", 1)
    assert sink.read("abc123", 1) is None and sink.summaries("abc123") == []


def test_a_half_written_shot_is_never_listed_and_is_cleared(tmp_path):
    sink = JsonLinesSink(tmp_path)
    sink.open(header(shot=2)).rows(*rows(1, 3))  # never closed: the agent died meanwhile
    done = sink.open(header(shot=1))
    done.close({"drops": 0})
    assert [s["shot"] for s in sink.summaries("abc123")] == [1]
    assert (tmp_path / "abc123" / "shot-2.jsonl.part").exists()
    JsonLinesSink(tmp_path)  # the next start
    assert not (tmp_path / "abc123" / "shot-2.jsonl.part").exists()
    assert sink.read("abc123", 1).summary["drops"] == 0
    first = (tmp_path / "abc123" / "shot-1.jsonl").read_text().splitlines()[0]
    assert json.loads(first)["header"]["trigger_seq"] == 12
    with pytest.raises(ValueError, match="not a capture id"):
        sink.read("../etc", 1)


def shot(number: int) -> Shot:
    s = Shot(number, 12, 10, 13, "manual", 5, 1)
    s.add(*rows(10, 4))
    s.seen = 13
    return s


def engine_with(tmp_path, sink, store) -> CaptureEngine:
    engine = CaptureEngine(str(tmp_path / "no-irpd.sock"), tmp_path / "captures", sink=sink, store=store)
    engine.entries["abc123"] = Entry("abc123", {"name": "n", "trigger": {"kind": "manual"}}, "now")
    engine.writer.start()
    return engine


def test_the_engine_keeps_the_newest_shots(tmp_path):
    sink = JsonLinesSink(tmp_path / "shots")
    engine = engine_with(tmp_path, sink, sink)
    for n in range(1, L.MAX_SHOTS_KEPT + 3):
        engine.shots.put((header(shot=n), shot(n)))
    engine.flush()
    kept = [s["shot"] for s in sink.summaries("abc123")]
    assert kept == list(range(3, L.MAX_SHOTS_KEPT + 3))
    assert sink.read("abc123", kept[-1]).summary["rows"] == 4


class FullDisk(JsonLinesSink):
    """The disk fills up while shot 2 is written."""

    def open(self, header: dict):
        writer = super().open(header)
        if header["shot"] == 2:

            def rows(*_):
                raise OSError(errno.ENOSPC, "No space left on device")

            writer.rows = rows
        return writer


def test_a_shot_that_cannot_be_written_is_reported_and_the_others_are_kept(tmp_path):
    sink = FullDisk(tmp_path / "shots")
    engine = engine_with(tmp_path, sink, sink)
    for n in (1, 2, 3):
        engine.shots.put((header(shot=n), shot(n)))
    engine.flush()
    assert [s["shot"] for s in sink.summaries("abc123")] == [1, 3]
    assert sorted(p.name for p in (tmp_path / "shots" / "abc123").iterdir()) == ["shot-1.jsonl", "shot-3.jsonl"]
    assert sink.read("abc123", 1).summary["rows"] == 4
    assert (
        "shot 2 not saved" in engine.entries["abc123"].message and "No space left" in engine.entries["abc123"].message
    )
    events = engine.events.since(0, 10)["events"]
    assert any("shot 2 not saved" in e["message"] for e in events)

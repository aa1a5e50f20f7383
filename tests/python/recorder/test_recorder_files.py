"""test_recorder_files.py -- the recorder's MCAP files without irpd (docs/recorder.md "The file"):
what McapOut writes reads back with the mcap library's own readers (indexed and streaming) and, for
/joint_states, with rosbags (an independent reader and CDR decoder); a file cut anywhere by a crash
keeps every flushed row and is completed by recover(); CSV and Parquet exports hold the same rows."""

from __future__ import annotations

import csv
import io
import math
import os
import shutil
import sys
from pathlib import Path

import orjson
import pyarrow.parquet as pq
import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.recorder import mcap_read  # noqa: E402
from indurop_agent.recorder.export import csv_chunks, parquet_chunks  # noqa: E402
from indurop_agent.recorder.mcap_out import (
    JOINT_STATES_TOPIC,
    NOTES_TOPIC,
    SAMPLES_TOPIC,
    Joint,
    McapOut,
    Variable,
    field_names,
)
from mcap.reader import make_reader  # noqa: E402
from recorder_helpers import assert_in_time_order  # noqa: E402
from rosbags.rosbag2.storage_mcap import McapReader as RosbagsMcap  # noqa: E402
from rosbags.typesys import Stores, get_types_from_msg, get_typestore  # noqa: E402

VARIABLES = [
    Variable("SIG.sample", "uint32_t"),
    Variable("joint[0].x", "double", "rad"),
    Variable("joint[1].x", "double", "rad"),
    Variable("a.b", "float"),
    Variable("a_b", "int16_t"),
]


def rows(first: int, count: int, step: int = 1) -> tuple[range, list[int], list[list[float]]]:
    """Rows whose values tell their seq: SIG.sample = seq, joints seq/1000 and -seq/1000."""
    seqs = range(first, first + count * step, step)
    return (
        seqs,
        [s * 1_000_000 for s in seqs],
        [[float(s) for s in seqs], [s / 1000 for s in seqs], [-s / 1000 for s in seqs], [0.5] * count, [-3.0] * count],
    )


def write(path: Path, blocks: list[tuple[int, int]], **kw) -> McapOut:
    out = McapOut(path, VARIABLES, title="test", basic_period_ns=1_000_000, **kw)
    for first, count in blocks:
        out.add_rows(*rows(first, count))
    return out


def test_field_names_are_identifiers_unique_and_never_seq_or_t_ns():
    assert field_names(["SIG.wave[0]", "knu.Robot.joints[3].x", "a.b", "a_b", "seq", "t_ns", "[0]"]) == [
        "SIG_wave_0",
        "knu_Robot_joints_3_x",
        "a_b",
        "a_b_2",
        "seq_2",
        "t_ns_2",
        "0",
    ]


def test_rows_notes_and_variables_read_back_with_the_mcap_reader(tmp_path):
    path = tmp_path / "a.mcap"
    out = write(path, [(1, 500)])
    out.note("drop", "rows overwritten", first_seq=501, last_seq=510, count=10)
    out.add_rows(*rows(511, 300))
    out.close({"why": "done"})
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        samples = [c for c in summary.channels.values() if c.topic == SAMPLES_TOPIC]
        assert len(samples) == 1
        described = orjson.loads(samples[0].metadata["indurop.variables"])
        assert [(d["path"], d["type"], d["unit"]) for d in described] == [(v.path, v.type, v.unit) for v in VARIABLES]
        schema = orjson.loads(summary.schemas[samples[0].schema_id].data)
        assert schema["properties"]["joint_0_x"]["x-indurop-unit"] == "rad"
        assert schema["properties"]["a_b_2"]["title"] == "a_b"
        got, notes = [], []
        for _, channel, message in reader.iter_messages():
            m = orjson.loads(message.data)
            if channel.topic == SAMPLES_TOPIC:
                got.append(m)
                assert message.sequence == m["seq"]
                assert message.log_time == m["t_ns"] + out.clock_offset_ns
            elif channel.topic == NOTES_TOPIC:
                notes.append(m)
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
    assert [m["seq"] for m in got] == [*range(1, 501), *range(511, 811)]
    for m in got:
        assert m["SIG_sample"] == m["seq"] and m["joint_0_x"] == m["seq"] / 1000 and m["a_b_2"] == -3.0
    assert notes == [{"kind": "drop", "text": "rows overwritten", "first_seq": 501, "last_seq": 510, "count": 10}]
    assert metadata["indurop.summary"]["rows"] == "800" and metadata["indurop.summary"]["why"] == "done"
    assert metadata["indurop.part"]["basic_period_ns"] == "1000000"


def test_notes_take_their_place_in_time_so_that_a_strict_reader_takes_both_files(tmp_path):
    """Notes come as the recorder and the captures write them: a drop before the part's first row,
    a drop between two reads (noted after rows whose due times are past), a gap timed by the first
    row after it, a trigger timed by a row not written yet, a stop at the end.  Both files read in
    strict log_time order; each note sits at its place among the rows."""
    path = tmp_path / "part-0001.mcap"
    out = McapOut(path, VARIABLES, title="t", basic_period_ns=1_000_000, joints=[Joint("joint_1", "joint[0].x")])
    out.note("drop", "rows dropped before the part opened", first_seq=1, last_seq=9, count=9)
    out.add_rows(*rows(10, 100))
    out.flush()
    out.note("drop", "rows overwritten", first_seq=110, last_seq=119, count=10)
    out.add_rows(*rows(120, 100))
    out.note("gap", "gap: irpd restarted", t_ns=230 * 1_000_000, last_seq=219, first_seq=230)
    out.add_rows(*rows(230, 50))
    out.note("trigger", "the trigger's row is still to come", t_ns=300 * 1_000_000, seq=300)
    out.add_rows(*rows(280, 70))
    with pytest.raises(ValueError, match="log_time"):
        out.note("trigger", "a time before rows written already", t_ns=340 * 1_000_000, seq=340)
    out.note("stop", "stopped by hand")
    out.close()
    assert assert_in_time_order(path) == 320 + 5
    assert assert_in_time_order(out.joint_file) == 320
    with open(path, "rb") as f:
        messages = [orjson.loads(m.data) for _, _, m in make_reader(f).iter_messages(log_time_order=False)]
    after = {m["text"]: messages[k - 1].get("seq") for k, m in enumerate(messages) if "kind" in m and k}
    before = {
        m["text"]: messages[k + 1].get("seq") for k, m in enumerate(messages) if "kind" in m and k + 1 < len(messages)
    }
    assert messages[0]["kind"] == "drop" and before["rows dropped before the part opened"] == 10
    assert after["rows overwritten"] == 109 and before["rows overwritten"] == 120
    assert after["gap: irpd restarted"] == 219 and before["gap: irpd restarted"] == 230
    assert after["the trigger's row is still to come"] == 299 and before["the trigger's row is still to come"] == 300
    assert messages[-1]["kind"] == "stop" and after["stopped by hand"] == 349


def test_values_that_are_not_finite_are_null():
    path = Path(os.environ.get("TMPDIR", "/tmp")) / f"nan-{os.getpid()}.mcap"
    path.unlink(missing_ok=True)
    try:
        out = McapOut(path, [Variable("x", "double")], title="t", basic_period_ns=1)
        out.add_rows([1, 2, 3], [1, 2, 3], [[math.nan, math.inf, 1.5]])
        out.close()
        ((_, block),) = mcap_read.iter_rows([path])
        assert block.columns == [[None, None, 1.5]]
    finally:
        path.unlink(missing_ok=True)


def test_rows_out_of_order_or_of_another_shape_are_refused(tmp_path):
    out = write(tmp_path / "b.mcap", [(10, 5)])
    with pytest.raises(ValueError, match="increasing seq"):
        out.add_rows(*rows(12, 2))
    with pytest.raises(ValueError, match="5 columns"):
        out.add_rows([20], [20], [[1.0]])
    out.close()
    with pytest.raises(FileExistsError):
        McapOut(tmp_path / "b.mcap", VARIABLES, title="t", basic_period_ns=1)  # never over a file


def test_joint_states_are_read_by_rosbags_as_sensor_msgs_joint_state(tmp_path):
    path = tmp_path / "j.mcap"
    joints = [Joint("joint_1", "joint[0].x", 2.0, 0.5), Joint("joint_2", "joint[1].x")]
    out = write(path, [(1, 100), (101, 50)], joints=joints, joint_every=4)
    out.close()
    assert out.joint_file == tmp_path / "j.joint_states.mcap"
    assert [c.topic for c in make_reader(open(path, "rb")).get_summary().channels.values()] == [
        SAMPLES_TOPIC,
        NOTES_TOPIC,
    ]
    reader = RosbagsMcap(out.joint_file)
    reader.open()
    try:
        (connection,) = [c for c in reader.connections if c.topic == JOINT_STATES_TOPIC]
        assert connection.msgtype == "sensor_msgs/msg/JointState"
        store = get_typestore(Stores.EMPTY)
        store.register(get_types_from_msg(connection.msgdef.data, connection.msgtype))
        messages = [(t, store.deserialize_cdr(raw, connection.msgtype)) for _, t, raw in reader.messages([connection])]
    finally:
        reader.close()
    seqs = list(range(1, 151, 4))  # every 4th row, counted across add_rows calls
    assert len(messages) == len(seqs)
    for seq, (t, m) in zip(seqs, messages):
        assert list(m.name) == ["joint_1", "joint_2"]
        assert list(m.position) == pytest.approx([seq / 1000 * 2.0 + 0.5, -seq / 1000])
        assert m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec == t == seq * 1_000_000 + out.clock_offset_ns


@pytest.mark.parametrize("cut", ["footer", "mid-record", "mid-chunk", "header-only"])
def test_a_file_cut_by_a_crash_keeps_its_flushed_rows_and_is_completed(tmp_path, cut):
    path = tmp_path / "crash.mcap"
    out = write(path, [(1, 300)], chunk_bytes=8 << 10)
    out.flush()
    flushed = os.path.getsize(path)
    out.add_rows(*rows(301, 100))  # written as chunks fill (8 KiB), the rest lost with the writer
    out._file.flush()  # what the OS has when the process dies
    size = os.path.getsize(path)
    cut_at = {"footer": size, "mid-record": size - 5, "mid-chunk": flushed + (size - flushed) // 2, "header-only": 40}
    shutil.copy(path, tmp_path / "copy.mcap")
    os.truncate(tmp_path / "copy.mcap", cut_at[cut])
    broken = tmp_path / "copy.mcap"
    found = mcap_read.scan(broken)
    assert not found.complete and found.error
    expected_rows = found.rows
    if cut != "header-only":
        assert expected_rows >= 300  # every flushed row
    fixed = mcap_read.recover(broken)
    assert fixed.complete and fixed.rows == expected_rows and fixed.error == found.error
    with open(broken, "rb") as f:  # now complete: the indexed reader reads it
        reader = make_reader(f)
        assert reader.get_summary() is not None
        seqs = [orjson.loads(m.data)["seq"] for _, c, m in reader.iter_messages() if c.topic == SAMPLES_TOPIC]
    assert seqs == list(range(1, expected_rows + 1))
    assert mcap_read.recover(broken).rows == expected_rows  # complete files are left alone


def test_csv_and_parquet_exports_hold_the_rows_of_the_mcap_files(tmp_path):
    first, second = tmp_path / "part-0001.mcap", tmp_path / "part-0002.mcap"
    write(first, [(1, 5000), (5011, 3000)]).close()
    write(second, [(9001, 1000)]).close()
    expected = [
        (s, t, u, c)
        for _, block in mcap_read.iter_rows([first, second])
        for s, t, u, *c in zip(block.seq, block.t_ns, block.unix_ns, *block.columns)
    ]
    assert len(expected) == 9000
    text = b"".join(csv_chunks([first, second], VARIABLES)).decode()
    table = list(csv.reader(io.StringIO(text)))
    assert table[0] == ["seq", "t_ns", "unix_ns", *(v.path for v in VARIABLES)]
    assert [(int(r[0]), int(r[1]), int(r[2]), [float(x) for x in r[3:]]) for r in table[1:]] == [
        (s, t, u, c) for s, t, u, c in expected
    ]
    parquet = pq.read_table(io.BytesIO(b"".join(parquet_chunks([first, second], VARIABLES, "test"))))
    assert parquet.column_names == ["seq", "t_ns", "unix_ns", *(v.path for v in VARIABLES)]
    assert parquet.schema.field("joint[0].x").metadata == {b"type": b"double", b"unit": b"rad"}
    columns = parquet.to_pydict()
    assert list(zip(columns["seq"], columns["t_ns"], columns["unix_ns"])) == [(s, t, u) for s, t, u, _ in expected]
    assert [list(r) for r in zip(*(columns[v.path] for v in VARIABLES))] == [c for *_, c in expected]
    assert (
        parquet.num_rows == 9000
        and pq.ParquetFile(io.BytesIO(b"".join(parquet_chunks([first, second], VARIABLES, "t")))).num_row_groups == 2
    )

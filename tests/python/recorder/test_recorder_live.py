"""test_recorder_live.py -- recordings through the API against a real irpd and agent (docs/recorder.md):
the signal generator's set (config/sets/signals, 1 ms) with a robot.json that maps six joints to
SIG.wave[0..5].  A 30 s recording of 16 variables at every basic period runs while the other tests
of this file use the same agent (bad input, roles, exports), and is checked last: every row, in seq
order without a gap, its values those the generator wrote (SIG.sample tells the row), read back with
the mcap reader, and its /joint_states file with rosbags."""

from __future__ import annotations

import csv
import io
import json
import math
import os
import shutil
import time

import pyarrow.parquet as pq
import pytest
from indurop_agent.cli import irpctl as cli
from indurop_agent.irpd.trace import TraceRing
from indurop_agent.recorder.manager import Wanted
from indurop_agent.recorder.store import Store
from recorder_helpers import (
    BUILD,
    IRPD,
    assert_in_time_order,
    digests,
    irpd_ready,
    notes_of,
    recorder_of,
    samples_of,
    start_cell,
    stop,
)
from rosbags.rosbag2.storage_mcap import McapReader as RosbagsMcap
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")

SIGNALS = BUILD / "sets" / "signals"
LONG_S = 30  # long enough to span the other tests of this file, which run while it records
SIXTEEN = ["SIG.sample", *(f"SIG.wave[{k}]" for k in range(15))]
JOINTS = [{"joint": f"joint_{k + 1}", "variable": f"SIG.wave[{k}]", "scale": 2.0, "offset": 0.25} for k in range(6)]


def expected_wave(k: int, sample: int) -> float:
    """generator.cpp's SIG.wave[k] in the period that set SIG.sample to `sample` (base_hz 1, 1 ms)."""
    phase = 1.0 * (1 + k % 4) * ((sample - 1) * 1e-3) + 0.0625 * k
    x = phase - math.floor(phase)
    shape = k // 4
    if shape == 0:
        return math.sin(2 * math.pi * x)
    if shape == 1:
        return 1.0 if x < 0.5 else -1.0
    if shape == 2:
        return 4 * x - 1 if x < 0.5 else 3 - 4 * x
    return 0.6 * math.sin(2 * math.pi * x) + 0.4 * math.sin(2 * math.pi * 7 * x)


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("recorder-live")
    folder = tmp / "signals"
    shutil.copytree(SIGNALS, folder)
    (folder / "robot.json").write_text(json.dumps({"urdf": "indurop6.urdf", "joints": JOINTS}))
    irpd, agent, api, sock = start_cell(tmp, folder / "module.xml", f"rec-live-{os.getpid()}")
    state = {"api": api, "tmp": tmp, "sock": sock}
    yield state
    stop(agent)
    stop(irpd)


def test_a_30_s_recording_of_16_variables_starts(cell):
    api = cell["api"]
    r = api.start("long", [*SIXTEEN[:2], {"path": SIXTEEN[2], "unit": "V"}, *SIXTEEN[3:]], stop={"duration_s": LONG_S})
    assert r.status_code == 201, r.text
    got = r.json()
    assert got["state"] == "recording" and got["kind"] == "recording"
    assert [v["path"] for v in got["variables"]] == SIXTEEN
    assert got["variables"][0]["type"] == "uint32_t" and got["variables"][2] == {
        "path": "SIG.wave[1]",
        "type": "double",
        "iec_type": None,  # a .glb variable's; a Structured Text one's: test_recorder_st.py
        "unit": "V",
        "field": "SIG_wave_1",
    }
    assert got["joint_states"] == [f"joint_{k + 1}" for k in range(6)]
    cell["long_started"] = time.monotonic()


def refused(r, status: int, *words: str) -> str:
    assert r.status_code == status, r.text
    detail = r.json()["detail"]
    text = json.dumps(detail)
    for w in words:
        assert w in text, text
    return text


def test_bad_input_is_refused_naming_what_to_fix_and_nothing_on_disk_changes(cell):
    api = cell["api"]
    short = api.start("kept", ["SIG.sample"], stop={"duration_s": 0.5})
    assert short.status_code == 201, short.text
    api.wait_state("kept", "stopped")
    before = digests(api.data / "recordings" / "kept")
    refused(api.start("x1", ["SIG.nothing"]), 400, "variables[0]", "SIG.nothing", "GET /api/v1/variables")
    refused(api.start("x2", ["SIG.sample", "SIG.wave"]), 400, "variables[1]", "not a scalar")
    refused(api.start("x3", ["SIG.sample", "SIG.sample"]), 400, "listed twice")
    for name in ("../evil", "a/b", ".hidden", "", "x" * 65, "spa ce"):
        refused(api.start(name, ["SIG.sample"]), 400, "letters, digits")
    for name in ("..%2F..%2Fetc", "%2E%2E"):
        assert api.call("GET", f"/recordings/{name}", "viewer").status_code in (400, 404)
    refused(api.start("x4", ["SIG.sample"], decimation=0), 422, "decimation")
    refused(api.start("x5", ["SIG.sample"], decimation=2_000_000), 422, "decimation")
    refused(api.start("x6", []), 422, "variables")
    refused(api.start("x7", [f"v{k}" for k in range(65)]), 422, "variables", "64")
    refused(api.start("x8", ["SIG.sample"], stop={"max_bytes": 1 << 50}), 400, "max_bytes", "quota")
    refused(api.start("x9", ["SIG.sample"], stop={"duration_s": -1}), 422, "duration_s")
    refused(api.start("kept", ["SIG.sample"]), 409, "'kept'", "already")
    refused(api.start("a1b2c3.shot-1", ["SIG.sample"]), 400, "'a1b2c3.shot-1'", "capture's shot", "another name")
    refused(api.call("POST", "/recordings/kept/stop"), 409, "not recording")
    refused(api.call("DELETE", "/recordings/long"), 409, "being written", "stop it first")
    refused(api.call("POST", "/recordings/none/stop"), 404, "no recording")
    refused(api.call("GET", "/recordings/kept/download", "viewer", params={"part": 3}), 404, "part 3")
    refused(api.call("GET", "/recordings/kept/export", "viewer", params={"format": "xlsx"}), 422, "format")
    assert not any((api.data / "recordings" / n).exists() for n in ("x1", "x2", "x3", "x4", "x9", "a1b2c3.shot-1"))
    assert digests(api.data / "recordings" / "kept") == before
    assert api.get("long")["state"] == "recording"


def test_roles_start_and_delete_need_an_operator_reading_any_role(cell):
    api = cell["api"]
    assert api.start("v", ["SIG.sample"], role="viewer").status_code == 403
    assert api.start("v", ["SIG.sample"], role="nobody").status_code == 401
    assert api.call("DELETE", "/recordings/kept", "viewer").status_code == 403
    assert api.call("POST", "/recordings/long/stop", "viewer").status_code == 403
    listing = api.call("GET", "/recordings", "viewer").json()
    assert {r["name"] for r in listing["recordings"]} >= {"long", "kept"}
    assert listing["channels"]["limit"] == 64 and listing["channels"]["owners"]["recorder"] == 16
    assert listing["quota_bytes"] > listing["used_bytes"] > 0
    assert api.call("GET", "/recordings/kept/download", "viewer").status_code == 200
    audit = [json.loads(line) for line in (api.data / "audit.jsonl").read_text().splitlines()]
    assert any(a["action"] == "recording_start" and a["target"] == "long" and a["result"] == "ok" for a in audit)


def test_a_decimated_recording_exports_the_rows_of_its_file_as_csv_and_parquet(cell, tmp_path):
    api = cell["api"]
    r = api.start("every10", ["SIG.sample", "SIG.wave[4]"], decimation=10, stop={"duration_s": 2})
    assert r.status_code == 201, r.text
    done = api.wait_state("every10", "stopped")
    assert done["cause"] == "duration" and done["rows"] == 200 and done["drops"] == 0
    rows = samples_of(api.download("every10", tmp_path / "files"))
    assert len(rows) == 200 and all(m["seq"] % 10 == 0 for m in rows)
    assert [b["seq"] - a["seq"] for a, b in zip(rows, rows[1:])] == [10] * 199
    text = api.call("GET", "/recordings/every10/export", "viewer", params={"format": "csv"}).text
    table = list(csv.reader(io.StringIO(text)))
    assert table[0] == ["seq", "t_ns", "unix_ns", "SIG.sample", "SIG.wave[4]"]
    assert [(int(r[0]), int(r[1]), float(r[3]), float(r[4])) for r in table[1:]] == [
        (m["seq"], m["t_ns"], m["SIG_sample"], m["SIG_wave_4"]) for m in rows
    ]
    raw = api.call("GET", "/recordings/every10/export", "viewer", params={"format": "parquet"}).content
    columns = pq.read_table(io.BytesIO(raw)).to_pydict()
    assert columns["seq"] == [m["seq"] for m in rows] and columns["SIG.wave[4]"] == [m["SIG_wave_4"] for m in rows]
    assert columns["unix_ns"] == [int(r[2]) for r in table[1:]]
    assert api.call("DELETE", "/recordings/every10").status_code == 204
    assert not (api.data / "recordings" / "every10").exists()


def test_a_recording_stopped_by_hand_is_closed_and_kept(cell, tmp_path):
    api = cell["api"]
    ring = TraceRing(irpd_ready(cell["sock"])["shared_memory"]["trace"])
    try:
        assert api.start("manual", ["SIG.sample"]).status_code == 201
        time.sleep(1.5)
        seen = ring.head()  # a row the rings hold before the stop is sent
        r = api.call("POST", "/recordings/manual/stop")
        after = ring.head()
    finally:
        ring.close()
    assert r.status_code == 200, r.text
    got = r.json()
    assert got["state"] == "stopped" and got["cause"] == "manual" and "stopped by" in got["reason"]
    files = api.download("manual", tmp_path)
    seqs = [m["seq"] for m in samples_of(files)]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs))), "a row is missing inside the file"
    assert seen <= seqs[-1] <= after  # every row up to the stop's moment
    assert got["parts"][0]["closed"] and got["rows"] == len(seqs) > 500
    assert notes_of(files)[-1]["kind"] == "stop"
    assert assert_in_time_order(files[0]) == len(seqs) + len(notes_of(files))


def test_a_stop_reads_the_rings_once_more_up_to_the_stops_moment(cell, tmp_path):
    """The recorder's thread reads the rings every poll_s; a stop between two reads still takes
    every row up to the rings' head when the stop is handled (made plain here with a 1 s poll:
    the stop comes half a second after the thread's last read).  SIG.sample tells the row."""
    store = Store(tmp_path / "recordings", quota_bytes=1 << 30)
    rec = recorder_of(store, cell["sock"], poll_s=1.0)
    ring = TraceRing(irpd_ready(cell["sock"])["shared_memory"]["trace"])
    try:
        rec.begin(Wanted("stopped-between-reads", [("SIG.sample", "")]), "test")
        time.sleep(1.5)
        seen = ring.head()
        got = rec.end("stopped-between-reads", "test")
        after = ring.head()
    finally:
        rec.stop()
        ring.close()
    assert got["state"] == "stopped" and got["cause"] == "manual"
    rows = samples_of(store.get("stopped-between-reads").parts())
    seqs = [m["seq"] for m in rows]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs))), "a row is missing inside the file"
    assert seqs[-1] >= seen, f"rows {seqs[-1] + 1}..{seen} were in the rings at the stop, not in the file"
    assert seqs[-1] <= after and got["parts"][0]["last_seq"] == seqs[-1] and got["rows"] == len(seqs)
    assert len({m["SIG_sample"] - m["seq"] for m in rows}) == 1  # each row its own period's sample


def test_irpctl_record_starts_lists_stops_exports_downloads_and_removes(cell, tmp_path, capsys, monkeypatch):
    api = cell["api"]
    for name in ("INDUROP_URL", "INDUROP_TOKEN", "INDUROP_TOKEN_FILE"):
        monkeypatch.delenv(name, raising=False)

    def irpctl(role: str, *argv: str) -> tuple[int, str, str]:
        capsys.readouterr()
        code = cli.main(["--url", api.url.removesuffix("/api/v1"), "--token", api.tokens[role], *argv])
        out, err = capsys.readouterr()
        return code, out, err

    code, out, _ = irpctl("operator", "record", "start", "cli-run", "SIG.sample", "SIG.wave[9]=V", "--decimation", "2")
    assert code == 0 and "state" in out and "SIG.wave[9] [V]" in out
    code, out, _ = irpctl("viewer", "record", "list")
    assert code == 0 and "cli-run" in out and "trace channels:" in out and "recorder" in out
    assert irpctl("viewer", "record", "stop", "cli-run")[0] == 1  # a viewer may not
    time.sleep(1)
    code, out, _ = irpctl("operator", "record", "stop", "cli-run")
    assert code == 0 and "stopped by" in out and "part-0001.mcap" in out
    code, out, _ = irpctl("viewer", "--json", "record", "get", "cli-run")
    got = json.loads(out)
    assert code == 0 and got["state"] == "stopped" and got["decimation"] == 2
    code, _, err = irpctl("viewer", "record", "export", "cli-run", "--format", "csv", "-o", str(tmp_path / "rows.csv"))
    assert code == 0 and "rows as csv" in err
    lines = (tmp_path / "rows.csv").read_text().splitlines()
    assert lines[0] == "seq,t_ns,unix_ns,SIG.sample,SIG.wave[9]" and len(lines) == got["rows"] + 1
    code, _, err = irpctl("viewer", "record", "download", "cli-run", "-o", str(tmp_path / "run.mcap"))
    assert code == 0 and len(samples_of([tmp_path / "run.mcap"])) == got["rows"]
    code, _, err = irpctl("operator", "record", "start", "../x", "SIG.sample")
    assert code == 1 and "letters, digits" in err
    assert irpctl("operator", "record", "rm", "cli-run")[0] == 0
    assert irpctl("viewer", "record", "get", "cli-run")[0] == 1


def test_the_30_s_recording_has_every_row_with_the_values_the_generator_wrote(cell, tmp_path):
    api = cell["api"]
    assert "long_started" in cell, "the recording did not start"
    done = api.wait_state("long", "stopped", seconds=LONG_S + 60)
    assert done["cause"] == "duration" and done["drops"] == 0 and done["gaps"] == []
    assert len(done["parts"]) == 1 and done["parts"][0]["closed"]
    files = api.download("long", tmp_path)
    assert sorted(p.name for p in files) == ["part-0001.joint_states.mcap", "part-0001.mcap"]
    rows = samples_of(files)
    assert len(rows) == done["rows"] == LONG_S * 1000  # LONG_S of due times at 1 ms
    for path in files:
        assert assert_in_time_order(path) >= len(rows)
    seqs = [m["seq"] for m in rows]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))
    assert rows[-1]["t_ns"] - rows[0]["t_ns"] == (len(rows) - 1) * 1_000_000
    offset = rows[0]["SIG_sample"] - rows[0]["seq"]
    for m in rows:
        assert m["SIG_sample"] - m["seq"] == offset, f"row {m['seq']} holds another period's sample"
        for k in range(15):
            assert m[f"SIG_wave_{k}"] == pytest.approx(expected_wave(k, int(m["SIG_sample"])), abs=1e-12)
    # /joint_states, read by rosbags: one JointState per row, position = wave x 2 + 0.25
    (joint_file,) = [p for p in files if p.name.endswith(".joint_states.mcap")]
    reader = RosbagsMcap(joint_file)
    reader.open()
    try:
        (connection,) = reader.connections
        store = get_typestore(Stores.EMPTY)
        store.register(get_types_from_msg(connection.msgdef.data, connection.msgtype))
        states = [store.deserialize_cdr(raw, connection.msgtype) for _, _, raw in reader.messages([connection])]
    finally:
        reader.close()
    assert connection.topic == "/joint_states" and connection.msgtype == "sensor_msgs/msg/JointState"
    assert len(states) == len(rows)
    for m, state in zip(rows[::997], states[::997]):
        assert list(state.name) == [j["joint"] for j in JOINTS]
        assert list(state.position) == pytest.approx([m[f"SIG_wave_{k}"] * 2.0 + 0.25 for k in range(6)], abs=1e-12)

"""test_recorder_limits.py -- the recorder's limits against the PLC + robot cell (1 ms, 124 scalar
variables; docs/recorder.md): the 64 channels irpd traces for all its owners together (a refusal
names each owner's count), the quota (the oldest recordings deleted first, never the one being
written, which stops when only it is left), and a full disk (a real one, a small tmpfs: the
recording ends as failed and every file on disk stays readable and unchanged; and the free-space
floor: starts refused, running recordings stopped cleanly).  The cell's own robot.json gives the
/joint_states file.  The quota and disk tests run a recorder of their own in this process (trace
owner "recorder-test") beside the agent's."""

from __future__ import annotations

import json
import os
import subprocess
import time

import pytest
from indurop_agent.recorder import mcap_read
from indurop_agent.recorder.manager import RecorderError, Wanted
from indurop_agent.recorder.store import Store
from live_processes import copy_cell
from recorder_helpers import IRPD, digests, recorder_of, samples_of, start_cell, stop, wait_done
from websockets.sync.client import connect

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")

JOINTS = [f"PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[{k}]" for k in range(6)]


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("recorder-limits")
    config, _ = copy_cell(tmp / "cell", xml="module-1ms.xml")
    irpd, agent, api, sock = start_cell(tmp, config, f"rec-limits-{os.getpid()}")
    leaves = api.call("GET", "/variables", "viewer").json()["variables"]
    scalars = [v["path"] for v in leaves]
    assert len(scalars) > 100
    yield {"api": api, "sock": sock, "scalars": scalars, "tmp": tmp}
    stop(agent)
    stop(irpd)


def test_the_64_channels_are_shared_by_every_owner_and_a_refusal_names_their_counts(cell):
    api, scalars = cell["api"], cell["scalars"]
    stream = connect(
        api.url.replace("http", "ws") + "/stream",
        additional_headers=api.h("viewer"),
        max_size=None,
        open_timeout=10,
        close_timeout=1,
    )
    with stream:
        stream.send(json.dumps({"subscribe": scalars[:40]}))
        assert "channels" in json.loads(stream.recv(timeout=10))  # the stream traces 40, as owner "agent"
        r = api.start("too-many", scalars[30:60])  # 10 shared, 20 more: 60 in all, fits
        assert r.status_code == 201, r.text
        r = api.start("one-more", scalars[60:65])  # 65 would be traced
        assert r.status_code == 409, r.text
        detail = r.json()["detail"]
        assert "agent: 40" in detail and "recorder: 35" in detail and "65 would be traced, at most 64" in detail
        assert not (api.data / "recordings" / "one-more").exists()
        assert api.call("POST", "/recordings/too-many/stop").status_code == 200
    channels = api.call("GET", "/recordings", "viewer").json()["channels"]
    assert channels["limit"] == 64 and channels["owners"].get("recorder", 0) == 0


def test_the_cells_robot_json_gives_a_joint_states_file(cell, tmp_path):
    api = cell["api"]
    r = api.start("joints", [*JOINTS, "PLC_ROBOT.PLC_OUT.Cycles"], stop={"duration_s": 1})
    assert r.status_code == 201, r.text
    assert r.json()["joint_states"] == [f"joint_{k + 1}" for k in range(6)]
    done = api.wait_state("joints", "stopped")
    files = api.download("joints", tmp_path)
    assert sorted(p.name for p in files) == ["part-0001.joint_states.mcap", "part-0001.mcap"]
    assert len(samples_of(files)) == done["rows"] == 1000


def test_the_quota_deletes_the_oldest_recordings_first_and_stops_the_one_being_written_last(cell, tmp_path):
    store = Store(tmp_path / "recordings", quota_bytes=1 << 30)
    rec = recorder_of(store, cell["sock"])
    try:
        for name in ("old-1", "old-2"):
            rec.begin(Wanted(name, [(p, "") for p in cell["scalars"][:8]], duration_s=0.3), "test")
            wait_done(store, name)
        kept = digests(store.root / "old-2")
        store.quota_bytes = store.used() + 60_000  # a second of the next recording passes it
        rec.begin(Wanted("live", [(p, "") for p in cell["scalars"][:40]]), "test")
        done = wait_done(store, "live")
    finally:
        rec.stop()
    assert done["state"] == "stopped" and done["cause"] == "quota" and "quota" in done["reason"]
    assert [e.name for e in store.entries()] == ["live"]
    messages = [e["message"] for e in rec.events.since(0, 100)["events"]]
    deleted = [m.split("'")[1] for m in messages if "deleted to keep" in m]
    assert deleted == ["old-1", "old-2"] and kept  # oldest first; "live" was never a candidate
    found = mcap_read.scan(store.get("live").parts()[0])
    assert found.complete and found.rows == done["rows"] > 0


def test_the_free_space_floor_refuses_starts_and_stops_running_recordings_cleanly(cell, tmp_path):
    store = Store(tmp_path / "recordings", quota_bytes=1 << 30, min_free_bytes=0)
    rec = recorder_of(store, cell["sock"])
    try:
        rec.begin(Wanted("running", [(cell["scalars"][0], "")]), "test")
        time.sleep(1)
        store.min_free_bytes = store.disk_free() + (1 << 30)  # the disk "fills up"
        done = wait_done(store, "running")
        with pytest.raises(RecorderError) as e:
            rec.begin(Wanted("another", [(cell["scalars"][0], "")]), "test")
    finally:
        rec.stop()
    assert e.value.status == 507 and "recordings_min_free_bytes" in e.value.message
    assert done["state"] == "stopped" and done["cause"] == "disk_full" and "MiB free" in done["reason"]
    assert mcap_read.scan(store.get("running").parts()[0]).complete


@pytest.fixture
def small_disk(tmp_path):
    """A 2 MiB tmpfs (mounted as root), unmounted after."""
    where = tmp_path / "disk"
    where.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(where)], capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip(f"a small tmpfs cannot be mounted here (root only): {r.stderr.strip()}")
    yield where
    subprocess.run(["umount", "-l", str(where)], check=False)


def test_a_full_disk_fails_the_recording_and_keeps_every_file_on_it_readable(cell, small_disk):
    store = Store(small_disk / "recordings", quota_bytes=1 << 30, min_free_bytes=0)
    rec = recorder_of(store, cell["sock"])
    try:
        rec.begin(Wanted("before", [(p, "") for p in cell["scalars"][:4]], duration_s=0.3), "test")
        wait_done(store, "before")
        kept = digests(store.root / "before")
        room = store.disk_free() - store.reserve_bytes - (256 << 10)
        with open(small_disk / "other-files", "wb") as f:  # the disk fills up but for 256 KiB
            f.write(b"\0" * room)
        rec.begin(Wanted("filler", [(p, "") for p in cell["scalars"][:60]]), "test")
        done = wait_done(store, "filler")
    finally:
        rec.stop()
    assert done["state"] == "failed" and done["cause"] == "disk_full" and "No space left" in done["reason"]
    assert digests(store.root / "before") == kept
    assert mcap_read.scan(store.get("before").parts()[0]).complete
    found = mcap_read.scan(store.get("filler").parts()[0])  # cut by the full disk: every flushed row reads
    assert found.rows > 0 and not found.complete
    seqs = [r for _, block in mcap_read.iter_rows(store.get("filler").parts()) for r in block.seq]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))

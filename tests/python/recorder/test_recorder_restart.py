"""test_recorder_restart.py -- a recording survives the agent stopping (SIGTERM), the agent being
killed (SIGKILL: its last part left without a footer) and irpd restarting (docs/recorder.md
"Restarts"): each time it goes on in a new part, the gap is recorded with the last seq before it
and the first after it, no row is written twice, and every row outside the gaps is there.

irpd runs the paper's Figure 1 set at 100 us: the rings hold 1.6 s, less than an agent's restart
takes, so the gaps are real; cntr2 adds 10 to knu.Robot.tick every period, so a row's tick tells
its seq."""

from __future__ import annotations

import os
import signal
import time

import pytest
from live_processes import FIG1, start_irpd
from recorder_helpers import IRPD, assert_in_time_order, irpd_ready, samples_of, start_agent, start_cell, stop

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")

U32 = 1 << 32


def written(api, parts: int) -> dict:
    """The recording once its part number `parts` holds rows (the agent takes seconds to start and
    complete a part left open; the API answers meanwhile)."""
    deadline = time.monotonic() + 60
    while True:
        got = api.get("survivor")
        if len(got["parts"]) >= parts and (got["parts"][parts - 1]["rows"] or 0) > 0:
            return got
        assert time.monotonic() < deadline, got
        time.sleep(0.2)


def test_a_recording_resumes_after_the_agent_and_irpd_restart_with_the_gaps_recorded(tmp_path):
    instance = f"rec-restart-{os.getpid()}"
    irpd, agent, api, sock = start_cell(tmp_path, FIG1, instance)
    port = int(api.url.split(":")[2].split("/")[0])
    try:
        r = api.start("survivor", ["knu.Robot.tick", "joint[0].x"])
        assert r.status_code == 201, r.text
        written(api, 1)
        time.sleep(1)
        stop(agent)  # SIGTERM: the part is closed, the recording stays "recording"
        assert api.data.joinpath("recordings/survivor/entry.json").read_text().count('"recording"') >= 1
        time.sleep(2.5)  # longer than the rings hold
        agent = start_agent(port, api.data, sock)
        assert written(api, 2)["state"] == "recording"
        time.sleep(1.5)  # a flush or more into the part
        os.kill(agent.pid, signal.SIGKILL)  # its part is left as the last flush made it
        agent.wait()
        agent = start_agent(port, api.data, sock)
        written(api, 3)
        stop(irpd)  # irpd restarts: new rings, seq from 1
        irpd = start_irpd(sock, FIG1, instance)
        irpd_ready(sock)
        written(api, 4)
        r = api.call("POST", "/recordings/survivor/stop")
        assert r.status_code == 200, r.text
        done = r.json()
    finally:
        stop(agent)
        stop(irpd)

    parts, gaps = done["parts"], done["gaps"]
    assert len(parts) == 4 and all(p["closed"] for p in parts), parts
    assert parts[1]["recovered"] and not parts[0]["recovered"]  # the part the kill cut short was completed
    assert [g["part"] for g in gaps] == [1, 2, 3]
    assert "agent was stopped" in gaps[0]["reason"] and "agent was stopped" in gaps[1]["reason"]
    assert "irpd restarted" in gaps[2]["reason"] and gaps[2]["missing"] is None
    assert parts[3]["irpd_pid"] != parts[2]["irpd_pid"] == parts[0]["irpd_pid"]

    files = [api.data / "recordings" / "survivor" / p["file"] for p in parts]
    rows_by_part = [samples_of([path]) for path in files]
    for path, p in zip(files, parts):  # gap, info and stop notes in time order, the recovered part too
        assert assert_in_time_order(path) > p["rows"]
    for p, rows in zip(parts, rows_by_part):
        seqs = [m["seq"] for m in rows]
        assert len(rows) == p["rows"] > 0 and seqs == list(range(seqs[0], seqs[0] + len(seqs)))  # no hole inside a part
        assert (p["first_seq"], p["last_seq"]) == (seqs[0], seqs[-1])
        offset = (int(rows[0]["knu_Robot_tick"]) - 10 * rows[0]["seq"]) % U32
        assert all((int(m["knu_Robot_tick"]) - 10 * m["seq"]) % U32 == offset for m in rows)  # each row its own period
    for k, gap in enumerate(gaps[:2]):  # one irpd run: the gap is exactly what lies between the parts
        before, after = rows_by_part[k][-1]["seq"], rows_by_part[k + 1][0]["seq"]
        assert (gap["last_seq"], gap["first_seq"]) == (before, after)
        assert after > before and gap["missing"] == after - before - 1
    assert gaps[0]["missing"] > 0  # 2.5 s away at 100 us: more than the rings hold
    assert gaps[2]["last_seq"] == rows_by_part[2][-1]["seq"] and gaps[2]["first_seq"] == rows_by_part[3][0]["seq"]
    assert done["rows"] == sum(len(r) for r in rows_by_part)

"""test_capture_cell.py -- the scope's demo on the plc-robot cell (config/sets/plc-robot: the PLC,
the robot and the I/O dispatcher every 10 ms, six simulated drives on Modbus TCP): a capture armed
on PLC_ROBOT.PLC_OUT.Error rising and one on the PLC's alarm main/8; the drive simulator is
stopped (SIGSTOP, by its pid: the plug pulled); both shots hold the second before the fault, the
first with the edge on its exact row, the alarm's within a row of it (docs/recorder.md)."""

from __future__ import annotations

import io
import json
import os
import signal
import sys
from pathlib import Path

import httpx
import pytest
from mcap.reader import make_reader

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import (
    API,
    BUILD,
    child_named,
    copy_cell,
    free_port,
    start_agent,
    start_irpd,
    stop,
    wait_until,
)

SET = BUILD / "sets" / "plc-robot"
ERROR, ERROR_ID, J0 = (
    "PLC_ROBOT.PLC_OUT.Error",
    "PLC_ROBOT.PLC_OUT.ErrorID",
    "PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[0]",
)
LIMIT_S = 60

pytestmark = pytest.mark.skipif(
    not (SET / "Robot.so").exists() or not (SET / "indurop-drivesim").exists(),
    reason=f"the plc-robot cell is not built ({SET})",
)


def test_a_capture_on_the_plcs_error_holds_the_second_before_the_drives_went_silent(tmp_path):
    config, _ = copy_cell(tmp_path / "cell")
    sock, data, port = tmp_path / "irpd.sock", tmp_path / "data", free_port()
    irpd = start_irpd(sock, config, f"capture-cell-{os.getpid()}")
    agent = start_agent(port, data, sock)
    sim = None
    try:
        url = f"http://127.0.0.1:{port}{API}"
        h = {"Authorization": f"Bearer {(data / 'admin-token').read_text().strip()}"}

        def value(path: str):
            r = httpx.get(f"{url}/variables/{path}", headers=h, timeout=30)
            return r.json()["value"] if r.status_code == 200 else None

        wait_until(lambda: value("PLC_ROBOT.IO_STATUS.cycles"), LIMIT_S, 0.1)
        assert httpx.put(f"{url}/variables/PLC_ROBOT.PLC_IN.Enable", json={"value": 1}, headers=h).status_code == 200
        wait_until(lambda: value("PLC_ROBOT.PLC_OUT.Powered") == 1, LIMIT_S, 0.1)
        edge = {
            "name": "error rising",
            "variables": [ERROR, ERROR_ID, J0],
            "trigger": {"kind": "condition", "conditions": [{"kind": "edge", "variable": ERROR, "threshold": 0.5}]},
            "pre": {"seconds": 1},
            "post": {"seconds": 0.2},
        }
        alarm = {**edge, "name": "alarm 8", "trigger": {"kind": "alarm", "key": "main/8"}}
        ids = []
        for request in (edge, alarm):
            r = httpx.post(f"{url}/captures", json=request, headers=h, timeout=30)
            assert r.status_code == 201, r.text
            ids.append(r.json()["id"])

        def full():
            """both captures' pre-trigger buffers full"""
            got = [httpx.get(f"{url}/captures/{i}", headers=h).json() for i in ids]
            return all(c["pre_filled"] == c["pre_rows"] == 100 for c in got)

        wait_until(full, LIMIT_S, 0.1)
        assert value(ERROR) == 0
        sim = child_named(irpd.pid, b"drivesim")
        os.kill(sim, signal.SIGSTOP)  # the plug pulled: the drives stop answering

        def shots():
            """both captures' shots saved"""
            got = [httpx.get(f"{url}/captures/{i}", headers=h).json() for i in ids]
            return got if all(c["shots"] for c in got) else None

        on_edge, on_alarm = (s["shots"][0] for s in wait_until(shots, LIMIT_S, 0.2))
        rows = httpx.get(f"{url}/captures/{ids[0]}/shots/1", headers=h).json()
        k = rows["seq"].index(on_edge["trigger_seq"])
        assert (on_edge["pre_rows"], on_edge["post_rows"], on_edge["drops"]) == (100, 20, 0)
        assert rows["columns"][0][k] == 1 and set(rows["columns"][0][:k]) == {0}  # a second without the error
        assert rows["columns"][1][k + 1] == 8  # ErrorID: the drives' communication
        assert on_alarm["cause"] == "alarm" and (on_alarm["pre_rows"], on_alarm["drops"]) == (100, 0)
        assert abs(on_alarm["trigger_seq"] - on_edge["trigger_seq"]) <= 1  # the alarm's row: the edge's, ± 1
        # the shot as the MCAP file an operator downloads for Foxglove: the rows of the second
        # before the fault, the edge's row named by the trigger note
        mcap = httpx.get(f"{url}/recordings/{ids[0]}.shot-1/download", headers=h, timeout=30)
        assert mcap.status_code == 200, mcap.text
        reader = make_reader(io.BytesIO(mcap.content))
        samples = [json.loads(m.data) for _, _, m in reader.iter_messages(topics=["/indurop/samples"])]
        assert [m["seq"] for m in samples] == rows["seq"]
        assert [m["PLC_ROBOT_PLC_OUT_Error"] for m in samples] == rows["columns"][0]
        notes = [json.loads(m.data) for _, _, m in reader.iter_messages(topics=["/indurop/notes"])]
        (trigger,) = [n for n in notes if n["kind"] == "trigger"]
        assert trigger["seq"] == on_edge["trigger_seq"] and f"{ERROR} rising 0.5" in trigger["text"]
        (schema,) = [s for s in reader.get_summary().schemas.values() if s.name == "indurop.Samples"]
        assert json.loads(schema.data)["properties"]["PLC_ROBOT_PLC_OUT_Error"]["x-indurop-path"] == ERROR
    finally:
        if sim is not None:
            os.kill(sim, signal.SIGCONT)
        stop(agent)
        stop(irpd)

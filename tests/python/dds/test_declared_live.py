"""test_declared_live.py -- a set whose dds.json declares its own message types (docs/dds.md): irpd
runs the plc-robot cell at 1 ms and the bridge publishes cell_msgs/CellStatus from its variables
and writes cell_msgs/CellCommand into its variables.  The peer is the test's C program on Debian's
libddsc, its types made by idlc from idl/cell_msgs/msg/Cell.idl: written apart from the .msg text
the bridge reads, it checks the type name, the field order and the values on the wire."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import (  # noqa: E402
    BUILD,
    ROOT,
    copy_cell,
    dispatching,
    output,
    start_bridge,
    start_irpd,
    stop,
    wait_dispatching,
    wait_until,
)

sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.dds.settings import BridgeSettings, cyclone_config  # noqa: E402
from indurop_agent.irpd.client import IrpdClient, IrpdRefused  # noqa: E402
from indurop_agent.irpd.variables import Segment  # noqa: E402

SET = BUILD / "sets" / "plc-robot"
P = "PLC_ROBOT"
JOINTS = [f"{P}.ROBOT_MODULE_STATE.dCmdJoint[{i}]" for i in range(6)]
HEADER = {"fields": {"stamp": {"stamp": True}, "frame_id": {"const": "cell"}}}
DDS_JSON = {
    "types": {
        "cell_msgs/msg/CellStatus": "std_msgs/Header header\nuint32 cycles\nint16 running\nfloat64[6] joints\n"
        "float64[<=3] first\nstring note",
        "cell_msgs/msg/CellCommand": "std_msgs/Header header\nfloat64 override\nint16 cycle_mode",
    },
    "publish": [
        {
            "topic": "cell/status",
            "type": "cell_msgs/msg/CellStatus",
            "rate_hz": 100,
            "fields": {
                "header": HEADER,
                "cycles": f"{P}.PLC_OUT.Cycles",
                "running": f"{P}.PLC_OUT.Running",
                "joints": JOINTS,
                "first": JOINTS[:2],
                "note": {"const": "declared"},
            },
        }
    ],
    "subscribe": [
        {
            "topic": "cell/command",
            "type": "cell_msgs/msg/CellCommand",
            "fields": {"header": HEADER, "override": f"{P}.PLC_IN.Override", "cycle_mode": f"{P}.PLC_IN.CycleMode"},
        }
    ],
}

pytestmark = pytest.mark.skipif(not (SET / "Robot.so").exists(), reason=f"the plc-robot cell is not built ({SET})")


@pytest.fixture(scope="module")
def cell(tmp_path_factory, cell_reader):
    tmp = tmp_path_factory.mktemp("dds-declared")
    domain = 160 + os.getpid() % 30  # test_bridge_live's bridge without irpd uses it too, never at once
    xml, _ = copy_cell(tmp / "plc-robot", "module-1ms.xml")
    (tmp / "plc-robot" / "dds.json").write_text(json.dumps(DDS_JSON, indent=1))
    sock = tmp / "irpd.sock"
    irpd = start_irpd(sock, xml, f"dds-declared-{os.getpid()}")
    control = IrpdClient(str(sock), timeout_s=30)
    st = wait_dispatching(control)
    bridge = start_bridge(sock, domain, "--name", "declared", log=tmp / "bridge.log")
    config = cyclone_config(BridgeSettings(domain_id=domain), pinned=True)
    c = type("Cell", (), {})()
    c.reader, c.bridge, c.status = cell_reader, bridge, lambda: dispatching(control)
    c.vars = Segment(st["shared_memory"]["variables"])
    c.env = {**os.environ, "CYCLONEDDS_URI": config}
    yield c
    stop(bridge)
    control.close()
    c.vars.close()
    stop(irpd)


def peer(c, *args: str, timeout_s: int = 60) -> list[dict]:
    r = subprocess.run([str(c.reader), *args], env=c.env, capture_output=True, text=True, timeout=timeout_s + 30)
    assert r.returncode == 0, f"{r.stderr}\nbridge: {output(c.bridge)}"
    return [json.loads(line) for line in r.stdout.splitlines()]


def test_a_declared_type_is_published_with_its_ros2_name_fields_and_values(cell):
    lines = peer(cell, "read", "cell_status", "rt/cell/status", "5", "60")
    match, samples = lines[0]["match"], lines[1:]
    assert match["type"] == "cell_msgs::msg::dds_::CellStatus_" and match["reliability"] == "reliable"
    joints = [cell.vars.read(j) for j in JOINTS]
    cycles = cell.vars.read(f"{P}.PLC_OUT.Cycles")
    for s in samples:
        assert s["frame_id"] == "cell" and s["note"] == "declared"
        assert s["joints"] == pytest.approx(joints, abs=0.05)  # the drives stand still (not enabled)
        assert s["first"] == s["joints"][:2]
        assert s["running"] == cell.vars.read(f"{P}.PLC_OUT.Running")
        assert abs(s["sec"] + s["nanosec"] / 1e9 - time.time()) < 60  # the sample's due time, on the wall clock
    assert samples[-1]["cycles"] == cycles  # no robot cycle runs: the drives are not enabled


def test_a_declared_subscription_writes_each_field_into_its_variable(cell):
    peer(cell, "write", "cell_command", "rt/cell/command", "0.375,1", "1")
    wait_until(lambda: cell.vars.read(f"{P}.PLC_IN.Override") == 0.375, 20, 0.05)
    wait_until(lambda: cell.vars.read(f"{P}.PLC_IN.CycleMode") == 1, 20, 0.05)
    peer(cell, "write", "cell_command", "rt/cell/command", "0.5,0", "1")
    wait_until(lambda: cell.vars.read(f"{P}.PLC_IN.CycleMode") == 0, 20, 0.05)
    assert cell.vars.read(f"{P}.PLC_IN.Override") == 0.5
    assert cell.status()["running"] and cell.bridge.poll() is None

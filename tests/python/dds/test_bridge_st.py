"""test_bridge_st.py -- a Structured Text set's variables on DDS (docs/dds.md "Topics, types, QoS"):
stc builds a PROGRAM into a set whose dds.json publishes one of its variables as std_msgs/Int32, a
real irpd runs it, and the test's separate peer (ros2_reader on Debian's libddsc, built here from
tools/dds/ros2_reader.c) sees the writer's USER_DATA name the variable with its IEC type beside
the C++ one, then the values; likewise a variable the set exports to the line's other controllers
(dds.json `export`): its writer on indurop/shared_variables names it with its IEC type, seen by the
test's own participant, and its samples come."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from contextlib import contextmanager

import pytest
from live_processes import BUILD, IRPD, ROOT, output, start_bridge, start_irpd, stop, wait_dispatching

sys.path.insert(0, str(ROOT / "tests" / "python" / "st"))
sys.path.insert(0, str(ROOT / "agent"))
from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication  # noqa: E402
from cyclonedds.core import Policy  # noqa: E402
from cyclonedds.domain import Domain, DomainParticipant  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from indurop_agent.dds.imports import READER_QOS, TOPIC  # noqa: E402
from indurop_agent.dds.indurop_types import SharedVariable  # noqa: E402
from indurop_agent.dds.settings import BridgeSettings, cyclone_config  # noqa: E402
from indurop_agent.irpd.client import IrpdClient  # noqa: E402
from st_live import stc_build  # noqa: E402

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD}, {BUILD})")

ST = """
PROGRAM Main
VAR count : DINT; END_VAR
  count := count + 1;
END_PROGRAM
"""
DDS_JSON = {"publish": [{"topic": "st/count", "type": "std_msgs/msg/Int32", "variable": "Main.count", "rate_hz": 20}]}
EXPORT_JSON = {"joint_states": {"enabled": False}, "export": [{"variable": "Main.count", "rate_hz": 20}]}


@contextmanager
def st_on_dds(tmp_path, dds_json: dict, domain: int, name: str):
    """ST built into a set with `dds_json`, run by irpd, its bridge on `domain` as controller `name`."""
    built = stc_build(tmp_path, {"main.st": ST})
    assert built.returncode == 0, built.stdout + built.stderr
    (tmp_path / "set" / "dds.json").write_text(json.dumps(dds_json))
    sock = tmp_path / "irpd.sock"
    irpd = start_irpd(sock, tmp_path / "set" / "module.xml", f"dds-{name}-{os.getpid()}")
    bridge = None
    try:
        control = IrpdClient(str(sock), timeout_s=30)
        wait_dispatching(control)
        control.close()
        bridge = start_bridge(sock, domain, "--name", name, log=tmp_path / "bridge.log")
        yield bridge
    finally:
        if bridge is not None:
            stop(bridge)
        stop(irpd)


def test_a_mapped_st_variable_is_described_with_its_iec_type_to_a_dds_reader(tmp_path, cell_reader):
    domain = 10 + os.getpid() % 10  # this file's range (the line tests use 20..99, the bridge's others 100 and up)
    with st_on_dds(tmp_path, DDS_JSON, domain, "st") as bridge:
        env = {**os.environ, "CYCLONEDDS_URI": cyclone_config(BridgeSettings(domain_id=domain), pinned=True)}
        r = subprocess.run(
            [str(cell_reader), "read", "int32", "rt/st/count", "3", "60"],
            env=env,
            capture_output=True,
            text=True,
            timeout=90,
        )
        assert r.returncode == 0, f"{r.stderr}\nbridge: {output(bridge)}"
        match, *samples = [json.loads(line) for line in r.stdout.splitlines()]
    assert match["match"]["type"] == "std_msgs::msg::dds_::Int32_"
    assert match["match"]["user_data"] == "indurop.variables=data: Main.count DINT (int32_t);"
    counts = [s["data"] for s in samples]
    assert len(counts) == 3 and counts == sorted(counts) and counts[0] > 0


def test_an_exported_st_variable_is_described_with_its_iec_type_to_the_importers(tmp_path):
    domain = 10 + (os.getpid() + 5) % 10  # this file's range, another domain than the test above
    with st_on_dds(tmp_path, EXPORT_JSON, domain, "st-a") as bridge:
        dds = Domain(domain, cyclone_config(BridgeSettings(domain_id=domain)))
        participant = DomainParticipant(domain)
        publications = BuiltinDataReader(participant, BuiltinTopicDcpsPublication)
        samples = DataReader(participant, Topic(participant, TOPIC, SharedVariable), READER_QOS)
        user_data, values, deadline = None, [], time.monotonic() + 60
        while (user_data is None or not values) and time.monotonic() < deadline:
            for p in publications.take(N=64):
                if getattr(p, "topic_name", None) == TOPIC:
                    given = p.qos[Policy.Userdata]
                    user_data = given.data.decode() if given is not None else ""
            values += [s for s in samples.take(N=16) if isinstance(s, SharedVariable)]
            time.sleep(0.05)
        del samples, publications, participant, dds
        said = output(bridge)
    assert user_data == "indurop.variables=Main.count DINT (int32_t);", said
    assert values and values[0].controller == "st-a" and values[0].path == "Main.count" and values[0].type == "int32"

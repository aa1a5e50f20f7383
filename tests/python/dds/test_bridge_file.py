"""test_bridge_file.py -- a set's dds.json (docs/dds.md): its shape, one mapping per topic, one
writer per variable, refused at upload with the file and line; the bridge's generated files are
current; the Cyclone DDS configuration made from the settings."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.dds import bridge_file  # noqa: E402
from indurop_agent.dds.bridge_file import BridgeFileError  # noqa: E402
from indurop_agent.dds.settings import BridgeSettings, cyclone_config, parse_args  # noqa: E402
from indurop_agent.sets.uploads import ModuleRef, UploadError, check_bridge_json  # noqa: E402

CELL_BRIDGE = ROOT / "config" / "sets" / "plc-robot" / "dds.json"


def refused(text: str) -> BridgeFileError:
    with pytest.raises(BridgeFileError) as e:
        bridge_file.parse(text)
    return e.value


def test_the_cells_bridge_file_is_accepted_as_shipped():
    b = bridge_file.parse(CELL_BRIDGE.read_bytes())
    assert b.joint_states and b.joint_states_hz == 1000
    assert [m.topic for m in b.publish] == ["cell/cycles", "cell/commanded_joints"]
    assert b.publish[1].is_array and len(b.publish[1].variables) == 6 and b.publish[1].qos == "sensor_data"
    assert b.written == {"PLC_ROBOT.PLC_IN.Override": b.subscribe[0]}


def test_an_empty_file_means_joint_states_and_diagnostics_at_their_defaults():
    b = bridge_file.parse("{}")
    assert (b.joint_states, b.joint_states_topic, b.joint_states_hz, b.diagnostics) == (True, "joint_states", 100, True)
    assert b.publish == () and b.subscribe == ()


def test_a_leading_slash_names_the_same_topic():
    b = bridge_file.parse('{"publish": [{"topic": "/a/b", "type": "std_msgs/msg/Bool", "variable": "x"}]}')
    assert b.publish[0].topic == "a/b"


@pytest.mark.parametrize(
    "text, line, words",
    [
        ('{"publish": [}', 1, "not valid JSON"),
        ('{\n "x": 1}', 1, "'x' was unexpected"),
        ('{\n "publish": [\n  {"topic": "9x", "type": "std_msgs/msg/Bool", "variable": "v"}]}', 3, "publish[0].topic"),
        ('{\n "publish": [\n  {"topic": "a", "type": "std_msgs/msg/String", "variable": "v"}]}', 3, "publish[0].type"),
        (
            '{"publish": [\n{"topic": "a", "type": "std_msgs/msg/Float64MultiArray", "variable": "v"}]}',
            2,
            "'variables' is a required property",
        ),
        ('{"subscribe": [\n{"topic": "a", "type": "std_msgs/msg/Bool", "variable": "v", "rate_hz": 5}]}', 2, "rate_hz"),
        ('{"joint_states": {\n"rate_hz": 0}}', 1, "joint_states.rate_hz"),
    ],
)
def test_a_malformed_file_is_refused_naming_the_line_and_the_field(text, line, words):
    e = refused(text)
    assert e.line == line, str(e)
    assert words in str(e)
    assert str(e).startswith(f"dds.json:{line}: ")


def test_a_topic_mapped_twice_or_both_ways_is_refused():
    e = refused(
        '{"publish": [{"topic": "a", "type": "std_msgs/msg/Bool", "variable": "v"}],\n'
        ' "subscribe": [{"topic": "a", "type": "std_msgs/msg/Bool", "variable": "w"}]}'
    )
    assert "subscribe: topic a is already mapped by publish (line 1)" in str(e) and e.line == 2
    e = refused('{"publish": [{"topic": "joint_states", "type": "std_msgs/msg/Bool", "variable": "v"}]}')
    assert "already mapped by joint_states" in str(e)


def test_a_variable_with_two_subscriptions_is_refused_naming_both():
    e = refused(
        '{"subscribe": [\n {"topic": "a", "type": "std_msgs/msg/Bool", "variable": "v.x"},\n'
        ' {"topic": "b", "type": "std_msgs/msg/Float64MultiArray", "variables": ["v.y", "v.x"]}]}'
    )
    assert "v.x would have two writers: the subscriptions to a (line 2) and b (line 3)" in str(e)
    assert e.line == 3


def test_a_variable_a_module_declares_it_writes_cannot_be_subscribed():
    b = bridge_file.parse('{"subscribe": [\n{"topic": "a", "type": "std_msgs/msg/Bool", "variable": "v.x"}]}')
    bridge_file.check_writers(b, {"plc": ["v.y"]})  # another variable: fine
    with pytest.raises(BridgeFileError) as e:
        bridge_file.check_writers(b, {"plc": ["v.y", "v.x"]})
    assert "v.x would have two writers: module plc (module.xml <writes>) and the subscription to a" in str(e.value)
    assert e.value.line == 2


def test_mapped_variables_must_be_scalars_of_the_layout():
    b = bridge_file.parse('{"publish": [{"topic": "a", "type": "std_msgs/msg/Bool", "variable": "v.s"}]}')
    layout = {
        "scalars": {"double": {}, "int16_t": {}},
        "leaves": [{"path": "v.s.x", "type": "double"}, {"path": "v.t", "type": "int16_t"}],
    }
    with pytest.raises(BridgeFileError) as e:
        bridge_file.check_variables(b, bridge_file.layout_scalars(layout))
    assert "no scalar variable v.s in the layout (it is a struct or an array: map v.s.x, ...)" in str(e.value)


def test_the_upload_refuses_a_second_writer_with_the_file_and_line(tmp_path):
    source = tmp_path / "dds.json"
    source.write_text('{"subscribe": [\n{"topic": "a", "type": "std_msgs/msg/Float64", "variable": "P.x"}]}')
    modules = [ModuleRef("plc", "./main.so", "main.so", "thread", 3, 5, ["P.x"])]
    with pytest.raises(UploadError) as e:
        check_bridge_json(source, modules, None)
    assert e.value.status_code == 400
    assert "P.x would have two writers: module plc" in str(e.value.detail)
    check_bridge_json(source, [ModuleRef("plc", "./main.so", "main.so", "thread", 3, 5, [])], None)


def test_the_generated_types_and_schema_are_current():
    r = subprocess.run(
        [sys.executable, str(ROOT / "protocol" / "dds" / "generate.py"), "--check"], capture_output=True, text=True
    )
    assert r.returncode == 0, r.stderr


def test_a_stale_generated_file_is_named_with_the_command(tmp_path, monkeypatch, capsys):
    import importlib.util

    spec = importlib.util.spec_from_file_location("dds_generate", ROOT / "protocol" / "dds" / "generate.py")
    gen = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "dds_generate", gen)  # its dataclasses look their module up
    spec.loader.exec_module(gen)
    for name in ("ros2_types.py", "indurop_types.py", "bridge_schema.py"):
        (tmp_path / name).write_text((ROOT / "agent" / "indurop_agent" / "dds" / name).read_text())
    monkeypatch.setattr(gen, "OUT", tmp_path)
    monkeypatch.setattr(sys, "argv", ["generate.py", "--check"])
    assert gen.main() == 0
    (tmp_path / "ros2_types.py").write_text("# edited\n")
    assert gen.main() == 1
    assert "ros2_types.py is stale: run python3 protocol/dds/generate.py" in capsys.readouterr().err


def test_an_idl_file_rosbags_cannot_read_is_refused_naming_the_file_and_line(tmp_path, monkeypatch, capsys):
    import importlib.util

    spec = importlib.util.spec_from_file_location("dds_generate", ROOT / "protocol" / "dds" / "generate.py")
    gen = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "dds_generate", gen)
    spec.loader.exec_module(gen)
    (tmp_path / "a" / "msg").mkdir(parents=True)
    (tmp_path / "a" / "msg" / "B.idl").write_text(
        '#include "x.idl"\nmodule a { module msg { module dds_ {\nstruct B_ {\n double x\n long y; };\n}; }; };\n'
    )
    monkeypatch.setattr(gen, "HERE", tmp_path)
    monkeypatch.setattr(sys, "argv", ["generate.py", "--check"])
    assert gen.main() == 2
    assert "generate.py: a/msg/B.idl: line 3 of its definition: rosbags cannot read" in capsys.readouterr().err


def test_the_generated_types_carry_ros2_s_dds_type_names():
    from indurop_agent.dds import ros2_types

    assert ros2_types.JointState.__idl_typename__ == "sensor_msgs::msg::dds_::JointState_"
    assert ros2_types.DiagnosticArray.__idl_typename__ == "diagnostic_msgs::msg::dds_::DiagnosticArray_"
    assert ros2_types.Time.__idl_typename__ == "builtin_interfaces::msg::dds_::Time_"
    msg = ros2_types.JointState(name=["a"], position=[1.5])
    assert ros2_types.JointState.deserialize(msg.serialize()) == msg


def test_the_cyclone_configuration_is_loopback_unicast_by_default_and_names_another_interface():
    lo = cyclone_config(BridgeSettings())
    assert '<NetworkInterface name="lo"/>' in lo and "<AllowMulticast>false</AllowMulticast>" in lo
    assert '<Peer address="127.0.0.1"/>' in lo
    eth = cyclone_config(BridgeSettings(interface="eth1", peers=("10.0.0.2",)))
    assert '<NetworkInterface name="eth1"/>' in eth and "AllowMulticast" not in eth and "10.0.0.2" in eth


def test_bad_settings_are_refused_naming_the_setting(tmp_path, capsys):
    for argv, words in (
        (["--domain-id", "300"], "domain_id 300"),
        (["--interface", "eth0; rm"], "interface"),
        (["--peer", "not-an-address"], "not-an-address"),
    ):
        with pytest.raises(SystemExit):
            parse_args(argv)
        assert words in capsys.readouterr().err
    config = tmp_path / "bridge.json"
    config.write_text(json.dumps({"domain_id": 7, "colour": "red"}))
    with pytest.raises(SystemExit):
        parse_args(["--config", str(config)])
    assert "unknown setting 'colour'" in capsys.readouterr().err
    config.write_text(json.dumps({"domain_id": 7, "namespace": "cell1"}))
    s = parse_args(["--config", str(config), "--name", "c1"])
    assert (s.domain_id, s.namespace, s.name) == (7, "cell1", "c1")

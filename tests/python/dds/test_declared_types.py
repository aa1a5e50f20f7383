"""test_declared_types.py -- message types a dds.json declares in .msg syntax (docs/dds.md): read by
rosbags, built as cyclonedds types under ROS 2's DDS names, their fields mapped to variables and
checked (every field, lengths, types, one writer), refused at upload naming the file, the mapping,
the field and the variable; and the bytes on the wire read back by rosbags' own CDR reader, for
the declared types and for the shipped ones against ROS 2 Jazzy's definitions rosbags carries."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest
from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.dds import bridge_file, declared, ros2_types  # noqa: E402
from indurop_agent.dds.bridge_file import BridgeFileError  # noqa: E402
from indurop_agent.sets.uploads import ModuleRef, UploadError, check_bridge_json  # noqa: E402

STATUS = "std_msgs/Header header\nuint32 cycles\nint16 running\nfloat64[6] joints\nfloat64[<=3] first\nstring note"
COMMAND = "std_msgs/Header header\nfloat64 override\nint16 cycle_mode"
J = [f"P.J[{i}]" for i in range(6)]
HEADER = {"fields": {"stamp": {"stamp": True}, "frame_id": {"const": "cell"}}}
LAYOUT = {
    "scalars": {
        "double": {"size": 8, "kind": "float"},
        "uint32_t": {"size": 4, "kind": "unsigned"},
        "short": {"size": 2, "kind": "signed"},
        "int32_t": {"size": 4, "kind": "signed"},
        "bool": {"size": 1, "kind": "bool"},
    },
    "leaves": [{"path": p, "type": "double"} for p in [*J, "P.OVR"]]
    + [
        {"path": "P.CYCLES", "type": "uint32_t"},
        {"path": "P.RUN", "type": "short"},
        {"path": "P.MODE", "type": "short"},
        {"path": "P.STEP", "type": "int32_t"},
        {"path": "P.FLAG", "type": "bool"},
    ],
}


def status_fields(**change) -> dict:
    fields = {
        "header": HEADER,
        "cycles": "P.CYCLES",
        "running": "P.RUN",
        "joints": J,
        "first": J[:2],
        "note": {"const": "declared"},
    }
    fields.update(change)
    return {k: v for k, v in fields.items() if v is not None}


def dds_json(status=None, command=None, types=None) -> str:
    return json.dumps(
        {
            "types": types or {"cell_msgs/msg/CellStatus": STATUS, "cell_msgs/msg/CellCommand": COMMAND},
            "publish": [
                {"topic": "cell/status", "type": "cell_msgs/msg/CellStatus", "fields": status or status_fields()}
            ],
            "subscribe": [
                {
                    "topic": "cell/command",
                    "type": "cell_msgs/msg/CellCommand",
                    "fields": command or {"header": HEADER, "override": "P.OVR", "cycle_mode": "P.MODE"},
                }
            ],
        },
        indent=1,
    )


def refused(text: str, layout: dict | None = None) -> str:
    with pytest.raises(BridgeFileError) as e:
        b = bridge_file.parse(text)
        if layout is not None:
            bridge_file.check_variables(b, bridge_file.layout_scalars(layout), kinds=bridge_file.layout_kinds(layout))
    assert str(e.value).startswith("dds.json:"), str(e.value)
    return str(e.value)


def test_a_declared_type_has_ros2_s_dds_name_and_its_fields_in_order():
    b = bridge_file.parse(dds_json())
    pub, sub = b.publish[0], b.subscribe[0]
    assert pub.cls.__idl_typename__ == "cell_msgs::msg::dds_::CellStatus_"
    assert sub.cls.__idl_typename__ == "cell_msgs::msg::dds_::CellCommand_"
    assert list(pub.cls.__annotations__) == ["header", "cycles", "running", "joints", "first", "note"]
    assert pub.variables == ("P.CYCLES", "P.RUN", *J, *J[:2])
    assert [leaf.field for leaf in pub.plan.leaves][:4] == ["cycles", "running", "joints[0]", "joints[1]"]
    assert b.written == {"P.OVR": sub, "P.MODE": sub}  # the header's stamp and constant are not written
    bridge_file.check_variables(b, bridge_file.layout_scalars(LAYOUT), kinds=bridge_file.layout_kinds(LAYOUT))


def test_a_message_is_built_from_the_variables_and_read_back_by_rosbags_from_its_cdr():
    b = bridge_file.parse(dds_json())
    plan = b.publish[0].plan
    values = [41.0, 1.0, *[0.5 * i for i in range(6)], 9.0, 8.0]
    message = plan.build(values, 1_700_000_000_123_456_789)
    store = get_typestore(Stores.ROS2_JAZZY)
    store.register(get_types_from_msg(STATUS, "cell_msgs/msg/CellStatus"))
    got = store.deserialize_cdr(message.serialize(), "cell_msgs/msg/CellStatus")
    assert (got.header.stamp.sec, got.header.stamp.nanosec, got.header.frame_id) == (1_700_000_000, 123_456_789, "cell")
    assert (got.cycles, got.running, list(got.joints), list(got.first), got.note) == (
        41,
        1,
        [0.5 * i for i in range(6)],
        [9.0, 8.0],
        "declared",
    )
    assert plan.read(message) == [41, 1, *[0.5 * i for i in range(6)], 9.0, 8.0]


def test_a_received_sequence_of_another_length_is_malformed():
    plan = bridge_file.parse(dds_json()).publish[0].plan
    message = plan.build([0.0] * 10, 0)
    message.first = [1.0, 2.0, 3.0]
    with pytest.raises(declared.Malformed):
        plan.read(message)


def test_traced_values_are_cast_to_their_field_in_its_range():
    assert declared.cast("int16", 1e9) == 32767 and declared.cast("uint8", -3.0) == 0
    assert declared.cast("bool", 2.0) is True and declared.cast("float32", 1) == 1.0
    assert (
        declared.fits("int16", -32768)
        and not declared.fits("int16", 40000)
        and not declared.fits("float64", float("nan"))
    )


@pytest.mark.parametrize(
    "text, words",
    [
        (
            dds_json(types={"cell_msgs/msg/CellStatus": "float64[x] speed", "cell_msgs/msg/CellCommand": COMMAND}),
            "types: cell_msgs/msg/CellStatus: line 1 of its definition: rosbags cannot read",
        ),
        (
            dds_json(types={"cell_msgs/msg/CellStatus": "flaot64 speed", "cell_msgs/msg/CellCommand": COMMAND}),
            "types: cell_msgs/msg/CellStatus: field speed: unknown type flaot64",
        ),
        (
            dds_json(types={"cell_msgs/msg/CellStatus": "geometry_msgs/Point p", "cell_msgs/msg/CellCommand": COMMAND}),
            "unknown type geometry_msgs/msg/Point",
        ),
        (
            dds_json(status_fields(cycles=None)),
            "publish cell/status (cell_msgs/msg/CellStatus): field cycles (uint32) is not mapped",
        ),
        (dds_json(status_fields(joints=J[:5])), "field joints (float64[6]) maps 5 variables; it has 6 elements"),
        (dds_json(status_fields(first=[*J[:4]])), "field first (float64[<=3]) maps 4 variables; it holds at most 3"),
        (dds_json(status_fields(note="P.X")), "field note (string) cannot hold a variable's value"),
        (dds_json(status_fields(speed="P.X")), "field speed: cell_msgs/msg/CellStatus has no such field"),
        (dds_json(status_fields(header="P.X")), "field header (std_msgs/msg/Header) is a message"),
        (
            dds_json(status_fields(header={"fields": {"stamp": "P.X", "frame_id": {"const": ""}}})),
            "field header.stamp (builtin_interfaces/msg/Time) is a message",
        ),
        (dds_json(status_fields(running={"const": 70000})), "field running (int16): 70000 is not a int16 value"),
        (
            dds_json(command={"header": HEADER, "override": "P.OVR", "cycle_mode": "P.OVR"}),
            "P.OVR would have two writers: fields override and cycle_mode",
        ),
        (
            dds_json(
                types={
                    "std_msgs/msg/Header": "uint8 x",
                    "cell_msgs/msg/CellStatus": STATUS,
                    "cell_msgs/msg/CellCommand": COMMAND,
                }
            ),
            "types: std_msgs/msg/Header is a type the bridge ships",
        ),
        (
            dds_json(types={"cell_msgs/msg/CellStatus": "CellStatus inner", "cell_msgs/msg/CellCommand": COMMAND}),
            "contains itself",
        ),
        (
            dds_json(types={"cell_msgs/msg/CellStatus": STATUS}),
            'subscribe[0].type: cell_msgs/msg/CellCommand is neither a std_msgs type the bridge maps',
        ),
    ],
)
def test_a_bad_declaration_or_mapping_is_refused_naming_the_type_or_mapping_and_field(text, words):
    assert words in refused(text)


@pytest.mark.parametrize(
    "status, command, words",
    [
        (
            status_fields(cycles="P.STEP"),
            None,
            "publish cell/status: field cycles (uint32) and variable P.STEP (int32_t) do not fit",
        ),
        (status_fields(running="P.OVR"), None, "field running (int16) and variable P.OVR (double) do not fit"),
        (
            None,
            {"header": HEADER, "override": "P.OVR", "cycle_mode": "P.CYCLES"},
            "subscribe cell/command: field cycle_mode (int16) and variable P.CYCLES (uint32_t) do not fit",
        ),
        (
            None,
            {"header": HEADER, "override": "P.FLAG", "cycle_mode": "P.MODE"},
            "field override (float64) and variable P.FLAG (bool) do not fit",
        ),
        (
            status_fields(cycles="P.NOPE"),
            None,
            "publish cell/status: field cycles: no scalar variable P.NOPE in the layout",
        ),
    ],
)
def test_a_variable_of_a_type_its_field_does_not_fit_is_refused(status, command, words):
    assert words in refused(dds_json(status, command), LAYOUT)


def test_the_upload_refuses_a_bad_declared_mapping_with_the_file_line_field_and_variable(tmp_path):
    source, layout = tmp_path / "dds.json", tmp_path / "layout.json"
    layout.write_text(json.dumps(LAYOUT))
    source.write_text(dds_json(status_fields(joints=[*J[:5], "P.FLAG"])))
    with pytest.raises(UploadError) as e:
        check_bridge_json(source, [], layout)
    assert e.value.status_code == 400
    assert "publish cell/status: field joints[5] (float64) and variable P.FLAG (bool) do not fit" in e.value.detail
    source.write_text(dds_json(status_fields(joints=[*J[:5], "P.MODE"])))
    check_bridge_json(source, [], layout)  # a short's values all go into a float64
    source.write_text(dds_json(command={"header": HEADER, "override": "P.OVR", "cycle_mode": "P.OVR2"}))
    with pytest.raises(UploadError) as e:
        check_bridge_json(source, [], layout)
    assert "subscribe cell/command: field cycle_mode: no scalar variable P.OVR2" in e.value.detail
    assert e.value.file == "dds.json" and isinstance(e.value.line, int)
    source.write_text(dds_json())
    modules = [ModuleRef("plc", "./main.so", "main.so", "thread", 3, 5, ["P.MODE"])]
    with pytest.raises(UploadError) as e:
        check_bridge_json(source, modules, layout)
    assert (
        "P.MODE would have two writers: module plc (module.xml <writes>) and the subscription to cell/command (field cycle_mode)"
        in e.value.detail
    )
    check_bridge_json(source, [], layout)


def test_the_shipped_types_are_ros2_jazzy_s_definitions_and_their_cdr_is_ros2_s():
    """protocol/ros2's IDL, read by rosbags, field for field against the definitions of ROS 2 Jazzy
    that rosbags carries; and a JointState from the generated class read by rosbags' Jazzy type."""
    jazzy = get_typestore(Stores.ROS2_JAZZY).fielddefs
    for path in sorted((ROOT / "protocol" / "ros2").rglob("*.idl")):
        text = re.sub(r"^#include.*$", "", path.read_text(), flags=re.M)
        for name, (_, fields) in get_types_from_idl(text).items():
            ros = re.sub(r"/dds_/(\w+)_$", r"/\1", name)
            ours = json.loads(json.dumps(fields).replace("/dds_/", "/").replace('_"', '"'))
            assert ours == json.loads(json.dumps(jazzy[ros][1])), ros
    store = get_typestore(Stores.ROS2_JAZZY)
    sent = ros2_types.JointState(
        header=ros2_types.Header(stamp=ros2_types.Time(sec=5, nanosec=7), frame_id="base"),
        name=["a", "b"],
        position=[1.5, -2.0],
    )
    got = store.deserialize_cdr(sent.serialize(), "sensor_msgs/msg/JointState")
    assert (got.header.stamp.sec, got.header.frame_id, got.name, list(got.position)) == (
        5,
        "base",
        ["a", "b"],
        [1.5, -2.0],
    )

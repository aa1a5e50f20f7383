"""test_opcua_parts.py -- the OPC UA server's parts without a live controller: the tree a layout makes
(namespaces, structs, arrays of structs as objects, arrays of scalars as array variables, the
built-in types), sampling intervals revised to multiples of the basic period, the spec's queue with
discardOldest and the Overflow bit, what a write must be, and settings refused naming what to fix."""

from __future__ import annotations

import asyncio
import json
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest
from asyncua import ua

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import BUILD, ROOT

sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.opcua.sampling import Sampler
from indurop_agent.opcua.settings import OpcuaSettings, check, parse_args
from indurop_agent.opcua.subscriptions import OVERFLOW, Subscription
from indurop_agent.opcua.values import Obj, Var, Variables, element_suffixes, index_range, narrowed, shaped, tree, typed
from indurop_agent.opcua.writes import _fits

CELL_LAYOUT = BUILD / "sets" / "plc-robot" / "layout.json"
needs_cell = pytest.mark.skipif(not CELL_LAYOUT.exists(), reason=f"the plc-robot cell is not built ({CELL_LAYOUT})")


@needs_cell
def test_the_cell_layout_makes_objects_for_structs_and_array_variables_for_arrays_of_scalars():
    layout = json.loads(CELL_LAYOUT.read_text())
    nodes = tree(layout)
    assert nodes["PLC_ROBOT"] == Obj("PLC_ROBOT", "", "PLC_ROBOT")
    assert nodes["PLC_ROBOT.PLC_OUT"] == Obj("PLC_ROBOT.PLC_OUT", "PLC_ROBOT", "PLC_OUT")
    cycles = nodes["PLC_ROBOT.PLC_OUT.Cycles"]
    assert isinstance(cycles, Var) and cycles.variant == ua.VariantType.UInt32 and cycles.dims == ()
    assert nodes["PLC_ROBOT.I0"].variant == ua.VariantType.Int16
    assert nodes["PLC_ROBOT.PLC_IN.Override"].variant == ua.VariantType.Double
    joints = nodes["PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint"]
    assert joints.dims == (6,) and joints.leaves == tuple(
        f"PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[{i}]" for i in range(6)
    )
    assert nodes["PLC_ROBOT.AXIS_IN"] == Obj("PLC_ROBOT.AXIS_IN", "PLC_ROBOT", "AXIS_IN")
    assert nodes["PLC_ROBOT.AXIS_IN[3]"] == Obj("PLC_ROBOT.AXIS_IN[3]", "PLC_ROBOT.AXIS_IN", "[3]")
    assert nodes["PLC_ROBOT.AXIS_IN[3].mode"].variant == ua.VariantType.SByte
    assert nodes["PLC_ROBOT.AXIS_IN[3].statusword"].variant == ua.VariantType.UInt16
    assert nodes["PLC_ROBOT.ROBOT_MODULE_STATE.nAXESGROUP"].variant == ua.VariantType.UInt16
    # every leaf of the layout is a variable or an element of one, exactly once
    covered = [leaf for n in nodes.values() if isinstance(n, Var) for leaf in n.leaves]
    assert sorted(covered) == sorted(leaf["path"] for leaf in layout["leaves"])
    # parents come before their children
    seen = {""}
    for path, n in nodes.items():
        assert n.parent in seen, path
        seen.add(path)


def test_multi_dimensional_arrays_and_nameless_namespaces():
    layout = {
        "scalars": {"double": {"kind": "float", "size": 8}, "bool": {"kind": "bool", "size": 1}},
        "types": {
            "P": {
                "fields": [{"name": "on", "type": "bool", "dims": []}, {"name": "m", "type": "double", "dims": [2, 3]}]
            }
        },
        "variables": [
            {"path": "tick", "namespace": "", "name": "tick", "type": "double", "dims": []},
            {"path": "A.B.p", "namespace": "A.B", "name": "p", "type": "P", "dims": [2]},
        ],
    }
    nodes = tree(layout)
    assert nodes["tick"].parent == "" and nodes["A"].parent == "" and nodes["A.B"].parent == "A"
    m = nodes["A.B.p[1].m"]
    assert m.dims == (2, 3) and m.leaves[:4] == (
        "A.B.p[1].m[0][0]",
        "A.B.p[1].m[0][1]",
        "A.B.p[1].m[0][2]",
        "A.B.p[1].m[1][0]",
    )
    assert element_suffixes((2, 2)) == ["[0][0]", "[0][1]", "[1][0]", "[1][1]"]
    assert shaped([1, 2, 3, 4, 5, 6], (2, 3)) == [[1, 2, 3], [4, 5, 6]]
    assert nodes["A.B.p[0].on"].variant == ua.VariantType.Boolean


def test_a_structured_text_variables_node_describes_its_iec_type_beside_the_cpp_one():
    """layout.json's iec_type (stc's variables, their fields) reaches the node's Description; a .glb
    variable keeps its C++ type alone, and a changed IEC type is a changed node (rebuilt)."""
    layout = {
        "scalars": {"int64_t": {"kind": "signed", "size": 8}, "bool": {"kind": "bool", "size": 1}},
        "types": {
            "TON": {
                "fields": [
                    {"name": "Q", "type": "bool", "dims": [], "iec_type": "BOOL"},
                    {"name": "ET", "type": "int64_t", "dims": [], "iec_type": "TIME"},
                ]
            }
        },
        "variables": [
            {"path": "Main.t", "namespace": "Main", "name": "t", "type": "TON", "dims": [], "iec_type": "TON"},
            {"path": "Main.n", "namespace": "Main", "name": "n", "type": "int64_t", "dims": [], "iec_type": "LINT"},
            {"path": "tick", "namespace": "", "name": "tick", "type": "int64_t", "dims": []},
        ],
    }
    nodes = tree(layout)
    assert nodes["Main.t.ET"].description == "TIME (int64_t) Main.t.ET"
    assert nodes["Main.n"].description == "LINT (int64_t) Main.n"
    assert nodes["tick"].description == "int64_t tick"
    layout["variables"][1]["iec_type"] = "LTIME"
    assert tree(layout)["Main.n"].signature != nodes["Main.n"].signature


def test_trace_doubles_become_the_variables_types():
    assert typed(ua.VariantType.UInt32, 7.0) == 7 and isinstance(typed(ua.VariantType.UInt32, 7.0), int)
    assert typed(ua.VariantType.Boolean, 1.0) is True
    assert typed(ua.VariantType.Int16, float("nan")) is None  # never sampled: nothing delivered
    assert typed(ua.VariantType.Float, 1) == 1.0


def test_sampling_intervals_are_revised_to_multiples_of_the_basic_period():
    s = Sampler(Variables(), irpd=None, owner="opcua", poll_ms=5)
    s.basic_ns = 1_000_000
    assert s.revise(10, 100, 10, 3_600_000) == 10
    assert s.revise(0, 100, 10, 3_600_000) == 10  # the fastest: the minimum
    assert s.revise(-1, 100, 10, 3_600_000) == 100  # the publishing interval
    assert s.revise(2, 100, 10, 3_600_000) == 10
    assert s.revise(1e9, 100, 10, 3_600_000) == 3_600_000
    s.basic_ns = 3_000_000
    assert s.revise(10, 100, 10, 3_600_000) == pytest.approx(12)
    s.basic_ns = 100_000
    assert s.revise(15.05, 100, 10, 3_600_000) == pytest.approx(15.1)


def notification(value: int) -> ua.MonitoredItemNotification:
    return ua.MonitoredItemNotification(ClientHandle=1, Value=ua.DataValue(ua.Variant(value, ua.VariantType.Int32)))


def queue_after(values: list[int], size: int, discard_oldest: bool) -> list[tuple[int, bool]]:
    """What a monitored item's queue holds after `values` arrived between two publishes: (value, overflow)."""
    sub = Subscription.__new__(Subscription)
    sub._triggered_datachanges = {}
    sub.monitored_item_srv = SimpleNamespace(_monitored_items={7: SimpleNamespace(discard_oldest=discard_oldest)})
    sub.data = SimpleNamespace(RevisedPublishingInterval=100.0)
    sub._task = object()  # publishing runs on its own schedule: enqueueing does not publish

    async def fill():
        for v in values:
            await sub.enqueue_datachange_event(7, notification(v), size)

    asyncio.run(fill())
    return [
        (n.Value.Value.Value, bool(n.Value.StatusCode.value & OVERFLOW == OVERFLOW))
        for n in sub._triggered_datachanges[7]
    ]


def test_a_full_queue_discards_the_oldest_and_marks_the_next_one():
    assert queue_after([1, 2, 3], 3, True) == [(1, False), (2, False), (3, False)]
    assert queue_after([1, 2, 3, 4], 3, True) == [(2, True), (3, False), (4, False)]


def test_without_discard_oldest_the_newest_is_replaced_and_marked():
    assert queue_after([1, 2, 3, 4, 5], 3, False) == [(1, False), (2, False), (5, True)]


def test_a_queue_of_one_keeps_the_newest_without_the_overflow_bit():
    assert queue_after([1, 2, 3], 1, True) == [(3, False)]
    assert queue_after([1, 2, 3], 0, True) == [(3, False)]


def test_a_publish_carries_at_most_max_notifications_the_rest_wait_oldest_first():
    sub = Subscription.__new__(Subscription)
    sub.max_notifications = 3
    sub._triggered_datachanges = {1: [notification(1), notification(2)], 2: [notification(3), notification(4)]}
    first, second = ua.PublishResult(), ua.PublishResult()
    sub._pop_triggered_datachanges(first)
    assert [n.Value.Value.Value for n in first.NotificationMessage.NotificationData[0].MonitoredItems] == [1, 2, 3]
    assert sub._triggered_datachanges == {2: [notification(4)]}
    sub._pop_triggered_datachanges(second)
    assert [n.Value.Value.Value for n in second.NotificationMessage.NotificationData[0].MonitoredItems] == [4]
    assert sub._triggered_datachanges == {}


def test_what_a_write_must_be():
    double = Var("x", "", "x", "double", ua.VariantType.Double, (), ("x",))
    short = Var("s", "", "s", "short", ua.VariantType.Int16, (), ("s",))
    flag = Var("b", "", "b", "bool", ua.VariantType.Boolean, (), ("b",))
    assert _fits(double, 1.5) and _fits(double, 2) and not _fits(double, float("nan")) and not _fits(double, True)
    assert _fits(short, 3) and not _fits(short, 3.0) and not _fits(short, False)
    assert _fits(flag, True) and not _fits(flag, 1)
    assert index_range("2", 6) == range(2, 3) and index_range("1:3", 6) == range(1, 4)
    assert index_range("6", 6) is None and index_range("3:1", 6) is None and index_range("x", 6) is None
    joints = Var("j", "", "j", "double", ua.VariantType.Double, (6,), tuple(f"j[{i}]" for i in range(6)))
    assert narrowed(joints, range(4, 5)).leaves == ("j[4]",) and narrowed(joints, range(4, 5)).dims == ()
    assert narrowed(joints, range(1, 3)).dims == (2,) and narrowed(joints, None) is joints


@pytest.mark.parametrize(
    "change, message",
    [
        ({"port": 0}, "port 0"),
        ({"security_policies": ("Basic128Rsa15",)}, "is not one of"),
        ({"security_policies": ()}, "at least one"),
        ({"anonymous_role": "root"}, "anonymous_role"),
        (
            {"user_certificates": ({"certificate": "/nonexistent.der", "name": "mes", "role": "operator"},)},
            "a DER or PEM file",
        ),
        ({"user_certificates": ({"certificate": "/etc/hostname", "name": "mes", "role": "god"},)}, "role 'god'"),
        ({"poll_ms": 50.0}, "poll_ms"),
        ({"max_sessions": 0}, "max_sessions 0"),
        ({"max_request_bytes": 10}, "max_request_bytes"),
    ],
)
def test_settings_that_do_not_hold_are_refused_naming_the_setting(change, message):
    with pytest.raises(ValueError, match=message):
        check(OpcuaSettings(**change))


def test_none_and_anonymous_are_off_unless_asked_for_and_then_warned_about(tmp_path, capsys):
    s = parse_args(["--data-dir", str(tmp_path)])
    assert "None" not in s.security_policies and not s.allow_anonymous and s.insecure == []
    config = tmp_path / "opcua.json"
    config.write_text(json.dumps({"security_policies": ["None", "Basic256Sha256"], "allow_anonymous": True}))
    s = parse_args(["--config", str(config)])
    assert len(s.insecure) == 2
    config.write_text(json.dumps({"max_sesions": 3}))
    with pytest.raises(SystemExit):
        parse_args(["--config", str(config)])
    assert "unknown setting 'max_sesions'" in capsys.readouterr().err

"""test_view_model.py -- the 3D view's model without any process: the URDF reader and its forward
kinematics against the arm's hand-worked poses (docs/robot.md §1) and against yourdfpy (what the
viser viewer draws with), robot.json's checks (one named case per malformed input), the map from
variable values to joint positions, viewer tickets, and meshcat's page as the proxy serves it."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "agent"))

from indurop_agent.access.auth import TokenStore  # noqa: E402
from indurop_agent.irpd.variables import number_problem  # noqa: E402
from indurop_agent.viewer.mapping import (
    JointMapping,
    MappingError,
    RobotConfig,
    check_against_urdf,
    check_variables,
    complete,
    parse_config,
)
from indurop_agent.viewer.meshcat_view import CONNECT, MeshcatViewer  # noqa: E402
from indurop_agent.viewer.ticket import TicketError, Tickets  # noqa: E402
from indurop_agent.viewer.urdf import UrdfError, parse  # noqa: E402

URDF = ROOT / "config" / "robots" / "indurop6.urdf"
CELL_ROBOT_JSON = ROOT / "config" / "sets" / "plc-robot" / "robot.json"


@pytest.fixture(scope="module")
def arm():
    return parse(URDF)


# ---- the URDF and forward kinematics -------------------------------------------------------------
def test_the_arm_has_six_revolute_joints_with_the_urdf_limits(arm):
    joints = arm.movable_joints()
    assert [j.name for j in joints] == [f"joint_{i}" for i in range(1, 7)]
    assert all(j.type == "revolute" for j in joints)
    assert (arm.joints["joint_2"].lower, arm.joints["joint_2"].upper) == (-1.745, 2.356)
    assert arm.joints["joint_tool0"].type == "fixed" and not arm.joints["joint_tool0"].movable
    assert arm.root == "base_link"
    assert len(arm.visuals) == 12 and {v.shape for v in arm.visuals} == {"box", "cylinder"}
    assert next(v for v in arm.visuals if v.link == "link_2").rgba == (0.95, 0.45, 0.08, 1.0)


def test_tool0_at_zero_joints_is_at_the_flange_with_z_along_x(arm):
    tool = arm.fk()["tool0"]
    np.testing.assert_allclose(tool[:3, 3], [0.63, 0, 0.885], atol=1e-12)
    np.testing.assert_allclose(tool[:3, 2], [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(arm.fk()["link_5"][:3, 3], [0.55, 0, 0.885], atol=1e-12)  # the wrist centre


def test_wrist_bent_down_points_the_tool_at_the_floor(arm):
    tool = arm.fk({"joint_5": math.pi / 2})["tool0"]
    np.testing.assert_allclose(tool[:3, 3], [0.55, 0, 0.805], atol=1e-12)
    np.testing.assert_allclose(tool[:3, 2], [0, 0, -1], atol=1e-12)


def test_the_base_joint_turns_the_arm_about_z(arm):
    tool = arm.fk({"joint_1": math.pi / 2})["tool0"]
    np.testing.assert_allclose(tool[:3, 3], [0, 0.63, 0.885], atol=1e-12)


def test_fk_matches_yourdfpy_for_random_joints(arm):
    yourdfpy = pytest.importorskip("yourdfpy")
    other = yourdfpy.URDF.load(str(URDF))
    rng = np.random.default_rng(7)
    for _ in range(50):
        q = {j.name: rng.uniform(j.lower, j.upper) for j in arm.movable_joints()}
        other.update_cfg(np.array([q[n] for n in other.actuated_joint_names]))
        mine = arm.fk(q)
        for link in arm.links:
            np.testing.assert_allclose(mine[link], other.get_transform(link, "base_link"), atol=1e-12)


def _urdf(body: str) -> bytes:
    return f'<?xml version="1.0"?>\n<robot name="t">{body}</robot>'.encode()


LINKS = '<link name="a"/><link name="b"/>'
BAD_URDFS = {
    "not xml": (b"<robot", "not a URDF"),
    "not a robot": (b"<model/>", "expected <robot>"),
    "a dtd": (b'<!DOCTYPE robot [<!ENTITY x "y">]><robot name="t"/>', "not a URDF"),
    "no link": (_urdf(""), "no <link>"),
    "unknown parent": (
        _urdf(LINKS + '<joint name="j" type="fixed"><parent link="z"/><child link="b"/></joint>'),
        "parent link 'z'",
    ),
    "revolute without limit": (
        _urdf(LINKS + '<joint name="j" type="revolute"><parent link="a"/><child link="b"/></joint>'),
        "needs <limit",
    ),
    "zero axis": (
        _urdf(
            LINKS + '<joint name="j" type="continuous"><parent link="a"/><child link="b"/><axis xyz="0 0 0"/></joint>'
        ),
        "axis is zero",
    ),
    "bad origin": (
        _urdf(LINKS + '<joint name="j" type="fixed"><parent link="a"/><child link="b"/><origin xyz="1 2"/></joint>'),
        "<origin xyz>",
    ),
    "two roots": (_urdf(LINKS), "one tree"),
    "unknown geometry": (
        _urdf('<link name="a"><visual><geometry><cone/></geometry></visual></link>'),
        "unknown geometry <cone>",
    ),
}


@pytest.mark.parametrize("case", list(BAD_URDFS))
def test_a_urdf_the_view_cannot_use_is_refused_with_what_is_wrong(case):
    text, words = BAD_URDFS[case]
    with pytest.raises(UrdfError, match="t.urdf") as e:
        parse(text, "t.urdf")
    assert words in str(e.value)


# ---- robot.json ---------------------------------------------------------------------------------
def test_the_cells_robot_json_maps_each_joint_to_the_measured_angle(arm):
    config = parse_config(CELL_ROBOT_JSON.read_bytes())
    assert config.urdf == "indurop6.urdf"
    assert [(j.joint, j.variable) for j in config.joints] == [
        (f"joint_{i + 1}", f"PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[{i}]") for i in range(6)
    ]
    check_against_urdf(config.joints, arm, "robot.json", "indurop6.urdf")
    assert config.dump() == CELL_ROBOT_JSON.read_bytes(), "robot.json is not in the form the agent writes"


def test_positions_are_value_times_scale_plus_offset_and_unmapped_joints_stay_at_zero(arm):
    joints = complete([JointMapping("joint_2", "A", 2.0, 0.5), JointMapping("joint_1", "B", -1.0, 0.0)], arm)
    assert [j.joint for j in joints] == [f"joint_{i}" for i in range(1, 7)]  # URDF order, all movable joints
    positions = RobotConfig("x.urdf", joints).positions({"A": 0.25, "B": 0.1})
    assert positions == {
        "joint_1": -0.1,
        "joint_2": 1.0,
        "joint_3": 0.0,
        "joint_4": 0.0,
        "joint_5": 0.0,
        "joint_6": 0.0,
    }
    assert RobotConfig("x.urdf", joints).positions({})["joint_2"] == 0.0  # no value yet: held at 0


def test_dump_and_parse_round_trip_in_one_form():
    config = RobotConfig("arm/r.urdf", [JointMapping("j1", "V.a[0]", 1.5, -0.25), JointMapping("j2", None)], "why")
    assert parse_config(config.dump()) == config
    assert config.dump() == RobotConfig("arm/r.urdf", list(config.joints), "why").dump()


GOOD = {"urdf": "r.urdf", "joints": [{"joint": "joint_1", "variable": "V.x", "scale": 1, "offset": 0}]}
BAD_MAPS = {
    "not json": (b"{", "not valid JSON"),
    "not an object": (b"[]", "must be an object"),
    "unknown key": ({**GOOD, "base": "x"}, "unknown keys base"),
    "no urdf": ({"joints": GOOD["joints"]}, '"urdf" must name'),
    "absolute urdf": ({**GOOD, "urdf": "/etc/r.urdf"}, "must be a path inside the set"),
    "urdf outside the set": ({**GOOD, "urdf": "../r.urdf"}, "must be a path inside the set"),
    "not a urdf": ({**GOOD, "urdf": "r.xml"}, "is not a .urdf file"),
    "no joints": ({**GOOD, "joints": []}, '"joints" must be a non-empty list'),
    "joint not an object": ({**GOOD, "joints": ["joint_1"]}, "joints[0] must be an object"),
    "joint without a name": ({**GOOD, "joints": [{"variable": "V.x"}]}, "joints[0].joint must be"),
    "joint twice": ({**GOOD, "joints": GOOD["joints"] * 2}, 'joints[1].joint "joint_1" is mapped twice'),
    "variable not a string": ({**GOOD, "joints": [{"joint": "joint_1", "variable": 3}]}, "joints[0].variable"),
    "scale not a number": (
        {**GOOD, "joints": [{"joint": "joint_1", "variable": "V.x", "scale": "2"}]},
        "joints[0].scale must be a finite number",
    ),
    "offset infinite": (
        {**GOOD, "joints": [{"joint": "joint_1", "variable": "V.x", "offset": float("inf")}]},
        "joints[0].offset must be a finite number",
    ),
    "unknown joint key": (
        {**GOOD, "joints": [{"joint": "joint_1", "variable": "V.x", "gain": 2}]},
        "unknown keys gain",
    ),
}


@pytest.mark.parametrize("case", list(BAD_MAPS))
def test_a_malformed_robot_json_is_refused_naming_the_entry(case):
    body, words = BAD_MAPS[case]
    with pytest.raises(MappingError) as e:
        parse_config(body if isinstance(body, bytes) else json.dumps(body))
    assert words in str(e.value) and "robot.json" in str(e.value)


@pytest.mark.parametrize(
    "joint, words",
    [("joint_9", '"joint_9" is not a joint of r.urdf'), ("joint_tool0", '"joint_tool0" is a fixed joint of r.urdf')],
)
def test_a_map_naming_a_joint_that_does_not_move_is_refused_with_the_movable_ones(arm, joint, words):
    with pytest.raises(MappingError) as e:
        check_against_urdf([JointMapping(joint, None)], arm, "robot.json", "r.urdf")
    assert words in str(e.value) and "joint_1, joint_2, joint_3, joint_4, joint_5, joint_6" in str(e.value)


LEAVES = {
    "C.s.x": {"path": "C.s.x", "type": "double", "size": 8},
    "C.a[0]": {"path": "C.a[0]", "type": "short", "size": 2},
    "C.name": {"path": "C.name", "type": "string", "size": 16},
}
SCALARS = {"double": {"kind": "float"}, "short": {"kind": "signed"}, "string": {"kind": "char"}}


@pytest.mark.parametrize("path", ["C.nope", "C.s", "C.name"])
def test_a_joints_variable_must_be_a_number_of_the_layout(path):
    """(variables.number_problem decides; tests/python/agent/test_number_problem.py)"""
    with pytest.raises(MappingError, match=r"joints\[0\]\.variable") as e:
        check_variables([JointMapping("j", path)], LEAVES, SCALARS, "the joint map")
    assert number_problem(path, LEAVES, SCALARS) in str(e.value)
    check_variables([JointMapping("j", "C.s.x"), JointMapping("k", "C.a[0]")], LEAVES, SCALARS, "the joint map")


# ---- tickets ------------------------------------------------------------------------------------
@pytest.fixture
def tickets(tmp_path):
    tokens = TokenStore(tmp_path)
    _, viewer = tokens.add("hmi", "viewer")
    return Tickets(tokens.by_id, ticket_s=600, session_s=3600), tokens, viewer


def test_a_ticket_opens_the_view_for_its_token_until_it_expires(tickets):
    t, _, viewer = tickets
    ticket = t.issue(viewer, now=1000.0)
    assert t.check(ticket, now=1599.0) == viewer
    with pytest.raises(TicketError, match="expired"):
        t.check(ticket, now=1600.0)
    session = t.issue(viewer, "session", now=1000.0)
    assert t.check(session, "session", now=4599.0) == viewer


@pytest.mark.parametrize(
    "change, words",
    [
        (lambda s: s[:-1] + ("A" if s[-1] != "A" else "B"), "signature does not match"),
        (lambda s: str(int(s.split(".")[0]) + 1000) + s[s.index(".") :], "signature does not match"),
        (lambda s: "nonsense", "not a viewer ticket"),
        (lambda s: "", "not a viewer ticket"),
    ],
)
def test_an_altered_ticket_is_refused(tickets, change, words):
    t, _, viewer = tickets
    with pytest.raises(TicketError, match=words):
        t.check(change(t.issue(viewer)))


def test_a_ticket_is_not_a_session_cookie_nor_the_other_way_round(tickets):
    t, _, viewer = tickets
    with pytest.raises(TicketError, match="signature"):
        t.check(t.issue(viewer, "url"), "session")
    with pytest.raises(TicketError, match="signature"):
        t.check(t.issue(viewer, "session"), "url")


def test_another_agents_tickets_and_a_revoked_tokens_are_refused(tickets):
    t, tokens, viewer = tickets
    other = Tickets(tokens.by_id)  # a restarted agent draws a new secret
    with pytest.raises(TicketError, match="signature"):
        other.check(t.issue(viewer))
    ticket = t.issue(viewer)
    tokens.revoke(viewer.id)
    with pytest.raises(TicketError, match="revoked"):
        t.check(ticket)


# ---- meshcat's page through the proxy -------------------------------------------------------------
def test_meshcats_page_is_told_to_connect_under_the_proxy_path():
    meshcat = pytest.importorskip("meshcat")
    page = (Path(meshcat.__file__).parent / "viewer" / "dist" / "index.html").read_bytes()
    assert CONNECT in page, "meshcat's page no longer calls viewer.connect(): the proxy cannot redirect it"
    served = MeshcatViewer().rewrite("", page)
    assert CONNECT not in served and b"location.href.split(/[?#]/)[0].replace(/^http/, 'ws')" in served
    assert MeshcatViewer().rewrite("main.min.js", b"viewer.connect();") == b"viewer.connect();"
    assert MeshcatViewer().http_path("main.min.js") == "/static/main.min.js"

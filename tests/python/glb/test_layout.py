# test_layout.py -- what layout.json says for the paper's figures and the stress file: offsets and
# sizes as g++ lays them out, cache-line placement, locks, leaves, the layout hash and type_ids.

from __future__ import annotations

import hashlib
import json

import pytest
from glb_helpers import compile_case, load_layout


@pytest.fixture
def fig3(tmp_path):
    return load_layout(compile_case("fig3", tmp_path))


@pytest.fixture
def fig11(tmp_path):
    return load_layout(compile_case("fig11", tmp_path))


def by_path(items):
    return {x["path"]: x for x in items}


def type_id(description) -> str:
    """docs/glbc.md: the first 16 hex digits of sha256 over the canonical JSON of the full type."""
    canonical = json.dumps(description, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    return hashlib.sha256(canonical.encode()).hexdigest()[:16]


def test_figure3_variables(fig3):
    v = by_path(fig3["variables"])
    assert v["knu.Robot.tick"] == {
        "path": "knu.Robot.tick",
        "namespace": "knu.Robot",
        "name": "tick",
        "type": "uint32_t",
        "type_id": type_id({"type": "uint32_t", "dims": [], "size": 4}),
        "offset": 0,
        "size": 4,
        "align": 4,
        "dims": [],
        "lock": 0,
        "source": "fig3-knuRobot.glb:3",
    }
    joints = v["knu.Robot.joints"]
    assert (joints["type"], joints["offset"], joints["size"], joints["dims"], joints["lock"]) == (
        "knu.Robot.joints_t",
        64,
        240,
        [10],
        1,
    )
    assert fig3["types"]["knu.Robot.joints_t"] == {
        "size": 24,
        "align": 8,
        "fields": [
            {"name": "x", "type": "double", "offset": 0, "size": 8, "dims": []},
            {"name": "y", "type": "double", "offset": 8, "size": 8, "dims": []},
            {"name": "z", "type": "double", "offset": 16, "size": 8, "dims": []},
        ],
    }
    assert (fig3["data_size"], fig3["lock_count"], fig3["namespaces"]) == (320, 2, ["knu.Robot"])


def test_figure3_leaf_joints_3_y(fig3):
    leaf = by_path(fig3["leaves"])["knu.Robot.joints[3].y"]
    assert leaf == {"path": "knu.Robot.joints[3].y", "type": "double", "offset": 64 + 3 * 24 + 8, "size": 8, "lock": 1}
    assert len(fig3["leaves"]) == 1 + 10 * 3


def test_figure11_robot_module_state_as_gxx_lays_it_out(fig11):
    t = fig11["types"]["PLC_ROBOT.ROBOT_MODULE_STATE_t"]
    offsets = {f["name"]: (f["offset"], f["size"]) for f in t["fields"]}
    assert offsets == {
        "nAXESGROUP": (0, 2),
        "MotionDone": (2, 2),
        "Busy": (4, 2),
        "eState": (6, 2),
        "bRuntimeService": (8, 2),
        "bJob_RobotMoving": (10, 2),
        # unsigned long is 8 bytes, aligned to 8: 4 bytes of padding after bJob_RobotMoving
        "dCurJoint": (16, 48),
        "dCmdJoint": (64, 48),
        "dWorldPos": (112, 48),
        "dUserPos": (160, 48),
        "dBasePos": (208, 48),
        "dJointSpeed": (256, 48),
        "dBaseSpeed": (304, 48),
        "dWorldSpeed": (352, 48),
        "nposeINFO": (400, 6),
    }
    assert (t["size"], t["align"]) == (408, 8)  # 406 rounded up to the alignment


def test_figure11_other_structs_and_scalars(fig11):
    service = {f["name"]: f["offset"] for f in fig11["types"]["PLC_ROBOT.ROBOT_MODULE_SERVICE_t"]["fields"]}
    assert service == {"eOpCode": 0, "t_pl": 4, "t_speed": 8, "p_Target": 16, "p_Mid": 18}
    assert fig11["types"]["PLC_ROBOT.ROBOT_MODULE_SERVICE_t"]["size"] == 24
    axis = fig11["types"]["PLC_ROBOT.AXIS1_IN_t"]
    assert [(f["name"], f["offset"]) for f in axis["fields"]] == [
        ("error", 0),
        ("status", 2),
        ("mode", 4),
        ("position", 8),
    ]
    assert (axis["size"], axis["align"]) == (12, 4)
    v = by_path(fig11["variables"])
    assert [(p, x["offset"], x["lock"]) for p, x in v.items()] == [
        ("PLC_ROBOT.I0", 0, 0),
        ("PLC_ROBOT.I1", 64, 1),
        ("PLC_ROBOT.O0", 128, 2),
        ("PLC_ROBOT.ROBOT_MODULE_STATE", 192, 3),
        ("PLC_ROBOT.ROBOT_MODULE_SERVICE", 640, 4),
        ("PLC_ROBOT.AXIS1_IN", 704, 5),
    ]
    assert v["PLC_ROBOT.I0"]["type"] == "short"
    assert fig11["defines"] == {"PLC_ROBOT.MAX_JOINTS": 6}
    assert (fig11["data_size"], fig11["lock_count"]) == (768, 6)
    leaf = by_path(fig11["leaves"])["PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[5]"]
    assert (leaf["offset"], leaf["type"], leaf["size"]) == (192 + 16 + 5 * 8, "unsigned long", 8)


def test_two_files_make_one_segment_with_namespaces_apart(tmp_path):
    doc = load_layout(compile_case("fig3_fig11", tmp_path))
    assert doc["namespaces"] == ["knu.Robot", "PLC_ROBOT"]
    assert doc["sources"] == ["fig3-knuRobot.glb", "fig11-plcRobot.glb"]
    paths = [(v["path"], v["offset"], v["lock"]) for v in doc["variables"]]
    assert paths[:3] == [("knu.Robot.tick", 0, 0), ("knu.Robot.joints", 64, 1), ("PLC_ROBOT.I0", 320, 2)]
    assert doc["lock_count"] == 8 and doc["data_size"] == 320 + 768


def test_stress_layout(tmp_path):
    doc = load_layout(compile_case("stress", tmp_path))
    t = doc["types"]
    assert t["test.stress.odd_t_nested_t_inner_t"] == {
        "size": 6,
        "align": 2,
        "fields": [
            {"name": "deep", "type": "int16_t", "offset": 0, "size": 2, "dims": []},
            {"name": "pad", "type": "char", "offset": 2, "size": 3, "dims": [3]},
        ],
    }
    nested = {f["name"]: (f["offset"], f["size"]) for f in t["test.stress.odd_t_nested_t"]["fields"]}
    assert nested == {"a": (0, 1), "b": (8, 16), "inner": (24, 12)}
    odd = {f["name"]: (f["offset"], f["size"], f["dims"]) for f in t["test.stress.odd_t"]["fields"]}
    assert odd == {"tag": (0, 1, []), "nested": (8, 40, []), "mat": (48, 18, [3, 3]), "flag": (66, 1, [])}
    assert t["test.stress.odd_t"]["size"] == 72
    assert t["test.stress.tail_padding_t"]["size"] == 16
    v = by_path(doc["variables"])
    assert v["test.stress.odd"]["dims"] == [2, 3] and v["test.stress.odd"]["size"] == 2 * 3 * 72
    assert v["test.stress.grid"]["dims"] == [3, 2, 5] and v["test.stress.grid"]["size"] == 30
    assert v["test.stress.after_comment"]["type"] == "double"
    spelled = {v["name"]: v["type"] for v in doc["variables"]}
    assert (
        spelled.items()
        >= {
            "c0": "char",
            "sc": "signed char",
            "uc": "unsigned char",
            "si16": "short",
            "ss": "short",
            "usi": "unsigned short",
            "sg": "int",
            "sgi": "int",
            "u": "unsigned int",
            "li": "long",
            "sl": "long",
            "lui": "unsigned long",
            "lli": "long long",
            "ull": "unsigned long long",
            "b": "bool",
            "B": "bool",
        }.items()
    )
    leaf = by_path(doc["leaves"])
    base = v["test.stress.odd"]["offset"]
    assert (
        leaf["test.stress.odd[1][2].nested.inner[1].pad[2]"]["offset"] == base + (1 * 3 + 2) * 72 + 8 + 24 + 6 + 2 + 2
    )
    assert leaf["test.stress.grid[2][1][4]"]["offset"] == v["test.stress.grid"]["offset"] + 2 * 10 + 1 * 5 + 4
    assert doc["defines"] == {"test.stress.ROWS": 3, "test.stress.COLS": 2, "test.stress.DIM": 3}


def test_every_variable_has_its_own_cache_lines(tmp_path):
    doc = load_layout(compile_case("stress", tmp_path))
    end = 0
    for i, v in enumerate(doc["variables"]):
        assert v["offset"] % 64 == 0 and v["offset"] >= end and v["lock"] == i
        end = v["offset"] + v["size"]
    assert doc["data_size"] % 64 == 0 and doc["data_size"] >= end > doc["data_size"] - 64


def test_hash_is_sha256_of_the_documented_canonical_form(fig3):
    canonical = json.dumps(
        {
            "types": fig3["types"],
            "variables": [{k: x for k, x in v.items() if k != "source"} for v in fig3["variables"]],
        },
        sort_keys=True,
        separators=(",", ":"),
        ensure_ascii=True,
    )
    assert fig3["hash"] == hashlib.sha256(canonical.encode()).hexdigest()


FIG3 = "namespace knu.Robot;\nuint32_t tick;\nstruct {\n    double x; double y; double z;\n} joints[10]\n"


def layout_of(glb, text, name="a.glb"):
    result = glb({name: text})
    assert result.returncode == 0, result.stderr
    return load_layout(glb.out)


def test_hash_ignores_file_names_comments_and_formatting(glb, fig3):
    doc = layout_of(
        glb,
        "// renamed\nnamespace knu.Robot\nuint32_t tick\nstruct { double x; double y; double z; } joints[10];",
        "other.glb",
    )
    assert doc["hash"] == fig3["hash"]


@pytest.mark.parametrize(
    "change",
    [
        ("uint32_t tick", "uint32_t tock"),  # a name
        ("uint32_t tick", "int32_t tick"),  # a type of the same size
        ("double z", "double w"),  # a field name
        ("joints[10]", "joints[11]"),  # a size
        ("knu.Robot", "knu.Robot2"),  # the namespace
    ],
)
def test_hash_changes_with_any_declaration(glb, fig3, change):
    assert layout_of(glb, FIG3.replace(*change))["hash"] != fig3["hash"]


def test_hash_changes_with_order(glb, fig3):
    swapped = "namespace knu.Robot;\nstruct {\n    double x; double y; double z;\n} joints[10]\nuint32_t tick;\n"
    assert layout_of(glb, swapped)["hash"] != fig3["hash"]


def test_same_input_twice_gives_identical_outputs(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    a, b = compile_case("fig3_fig11", tmp_path / "a"), compile_case("fig3_fig11", tmp_path / "b")
    for name in ("layout.json", "indurop/generated.h"):
        assert (a / name).read_bytes() == (b / name).read_bytes()


def test_layout_json_is_deterministic_utf8_json(tmp_path):
    out = compile_case("fig11", tmp_path)
    raw = (out / "layout.json").read_bytes()
    doc = json.loads(raw.decode("utf-8"))
    assert list(doc)[:4] == ["format", "version", "hash", "data_size"]
    assert (doc["format"], doc["version"]) == ("indurop-layout", 1)
    assert raw.endswith(b"\n") and b"\r" not in raw


def test_type_id_is_sha256_of_the_documented_canonical_form(fig3):
    xyz = [
        {"name": n, "type": "double", "offset": o, "size": 8, "dims": []} for n, o in (("x", 0), ("y", 8), ("z", 16))
    ]
    joints = by_path(fig3["variables"])["knu.Robot.joints"]
    assert joints["type_id"] == type_id({"type": {"fields": xyz}, "dims": [10], "size": 240})


def test_type_id_is_equal_exactly_when_the_bytes_mean_the_same(glb):
    doc = layout_of(
        glb,
        "namespace a;\nstruct { double x; int n[2]; } p;\nstruct { double x; int n[2]; } q;\n"
        "struct { double x; int m[2]; } r;\nstruct { double x; unsigned n[2]; } s;\n"
        "int t[2]; int u[3]; long v; long long w; int64_t y;\n"
        "struct { struct { char c; } in; } z1;\nstruct { struct { char d; } in; } z2;\n",
    )
    ids = {v["name"]: v["type_id"] for v in doc["variables"]}
    assert ids["p"] == ids["q"]  # the struct's generated name (p_t, q_t) does not enter it
    assert len({ids[n] for n in "prstuvwy"} | {ids["z1"], ids["z2"]}) == 10

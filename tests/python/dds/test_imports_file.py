"""test_imports_file.py -- dds.json's `export` and `imports` (docs/dds.md "Controllers sharing
variables"): their shape, one writer per variable (another import, a subscription, a module's
<writes>), the variables against the layout with types that fit, refused at upload with the file
and line; the generated SharedVariable type and its keys."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.dds import bridge_file, sharing  # noqa: E402
from indurop_agent.dds.bridge_file import BridgeFileError  # noqa: E402
from indurop_agent.sets.uploads import ModuleRef, UploadError, check_bridge_json  # noqa: E402

# A layout as glbc writes it, with only what the checks read: the scalars and the leaves.
SCALARS = {
    "uint32_t": {"size": 4, "kind": "unsigned"},
    "int16_t": {"size": 2, "kind": "signed"},
    "int32_t": {"size": 4, "kind": "signed"},
    "int64_t": {"size": 8, "kind": "signed"},
    "double": {"size": 8, "kind": "float"},
    "float": {"size": 4, "kind": "float"},
    "bool": {"size": 1, "kind": "bool"},
}
LEAVES = {
    "S.count": "uint32_t",
    "S.vec[0]": "float",
    "S.vec[1]": "float",
    "S.vec[2]": "float",
    "S.axis[0].pos": "double",
    "S.axis[1].pos": "double",
    "IN.count": "uint32_t",
    "IN.small": "int16_t",
    "IN.odd": "bool",
    "IN.vec[0]": "float",
    "IN.vec[1]": "float",
    "IN.vec[2]": "float",
    "IN.stale": "bool",
    "IN.stale2": "bool",
    "IN.flag32": "int32_t",
    "IN.age": "uint32_t",
    "IN.stamp": "int64_t",
    "IN.level": "double",
}
LAYOUT = {"scalars": SCALARS, "leaves": [{"path": p, "type": t} for p, t in LEAVES.items()]}
IMPORT = {"from": "cell-a", "path": "S.count", "variable": "IN.count", "stale": "IN.stale"}


def doc(*imports: dict, export: list | None = None, **more) -> str:
    """A dds.json with these imports, one a line (line 2, 3, ...)."""
    body = ",\n".join(json.dumps(i) for i in imports)
    extra = "".join(f',\n "{k}": {json.dumps(v)}' for k, v in more.items())
    return '{"imports": [\n' + body + "]" + (f',\n "export": {json.dumps(export)}' if export else "") + extra + "}"


def refused(text: str, layout: dict | None = None, writes: dict | None = None) -> BridgeFileError:
    with pytest.raises(BridgeFileError) as e:
        b = bridge_file.parse(text)
        bridge_file.check_writers(b, writes or {})
        bridge_file.check_layout(b, layout or LAYOUT)
    return e.value


def test_exports_and_imports_are_read_with_their_defaults():
    b = bridge_file.parse(doc(IMPORT, export=[{"variable": "S.count"}, {"variable": "S.vec", "rate_hz": 1000}]))
    assert [(x.variable, x.rate_hz) for x in b.export] == [("S.count", 100), ("S.vec", 1000)]
    (imp,) = b.imports
    assert (imp.source, imp.path, imp.variable, imp.stale, imp.age_us, imp.stamp_ns) == (
        "cell-a",
        "S.count",
        "IN.count",
        "IN.stale",
        None,
        None,
    )
    assert (imp.rate_hz, imp.timeout_ms, imp.fallback, imp.line) == (100, 250, 0, 2)
    assert imp.key == "cell-a:S.count" and imp.written == ("IN.count", "IN.stale")
    bridge_file.check_layout(b, LAYOUT)


@pytest.mark.parametrize(
    "entry, words",
    [
        ({"from": "cell-a", "path": "S.count", "variable": "IN.count"}, "'stale' is a required property"),
        ({**IMPORT, "from": "cell a"}, "imports[1].from"),
        ({**IMPORT, "fallback": "zero"}, "imports[1].fallback"),
        ({**IMPORT, "rate_hz": 5000}, "imports[1].rate_hz"),
        ({**IMPORT, "colour": "red"}, "'colour' was unexpected"),
    ],
)
def test_a_malformed_import_is_refused_naming_its_line_and_field(entry, words):
    e = refused(doc(IMPORT, entry))
    assert e.line == 3 and words in str(e), str(e)


def test_an_export_named_twice_is_refused():
    e = refused('{"export": [{"variable": "S.count"},\n{"variable": "S.count"}]}')
    assert "export: S.count is exported twice (also line 1)" in str(e) and e.line == 2


@pytest.mark.parametrize(
    "second, words",
    [
        (
            {**IMPORT, "path": "S.other"},
            "IN.count would have two writers: the import of cell-a:S.other and the import of cell-a:S.count (line 2)",
        ),
        ({**IMPORT, "variable": "IN.level", "stale": "IN.stale"}, "IN.stale would have two writers"),
        ({**IMPORT, "variable": "IN.vec[1]", "stale": "IN.stale2"}, "IN.vec[1] would have two writers"),
    ],
)
def test_a_variable_two_imports_write_is_refused_naming_both(second, words):
    first = {**IMPORT, "variable": "IN.vec"} if "vec" in second["variable"] else IMPORT
    e = refused(doc(first, second))
    assert words in str(e), str(e)
    assert e.line == 3


def test_an_import_and_a_subscription_on_one_variable_are_refused_naming_both():
    text = doc(IMPORT, subscribe=[{"topic": "t", "type": "std_msgs/msg/UInt32", "variable": "IN.count"}])
    e = refused(text)
    assert "IN.count would have two writers: the subscription to t" in str(e) and "the import of cell-a:S.count" in str(
        e
    )


def test_an_import_on_a_variable_a_module_writes_is_refused_naming_both():
    e = refused(doc({**IMPORT, "variable": "IN.vec[2]"}), writes={"plc": ["IN.vec"]})
    assert (
        "IN.vec[2] would have two writers: module plc (module.xml <writes>IN.vec</writes>) and the import of cell-a:S.count"
        in str(e)
    )
    assert e.line == 2
    e = refused(doc({**IMPORT, "stale": "IN.stale"}), writes={"plc": ["IN.stale"]})
    assert "IN.stale would have two writers: module plc" in str(e)


@pytest.mark.parametrize(
    "entry, words",
    [
        ({**IMPORT, "variable": "IN.missing"}, "no scalar variable or array of scalars IN.missing in the layout"),
        ({**IMPORT, "variable": "S.axis"}, "no scalar variable or array of scalars S.axis"),
        (
            {**IMPORT, "stale": "IN.level"},
            "the staleness flag IN.level is a float64; it must be a bool (or an integer)",
        ),
        ({**IMPORT, "stale": "IN.vec"}, "the staleness flag IN.vec is not a scalar variable"),
        ({**IMPORT, "stamp_ns": "IN.age"}, "the stamp IN.age is a uint32; it must be an int64_t or a uint64_t"),
        ({**IMPORT, "age_us": "IN.odd"}, "the age IN.odd is a bool; it must be an integer or a float"),
        ({**IMPORT, "variable": "IN.small", "fallback": 40000}, "the fallback 40000 is not a int16 (IN.small)"),
        ({**IMPORT, "variable": "IN.small", "fallback": 1.5}, "the fallback 1.5 is not a int16"),
        ({**IMPORT, "variable": "IN.odd", "fallback": 2}, "the fallback 2 is not a bool"),
        ({**IMPORT, "fallback": -1}, "the fallback -1 is not a uint32"),
        ({**IMPORT, "variable": "IN.vec", "fallback": [1, 2]}, "the fallback has 2 values; IN.vec has 3"),
        ({**IMPORT, "fallback": [1]}, "the fallback has 1 values; IN.count has one"),
    ],
)
def test_an_import_whose_variables_do_not_fit_the_layout_is_refused(entry, words):
    e = refused(doc(entry))
    assert words in str(e) and e.line == 2, str(e)
    assert str(e).startswith("dds.json:2: the import of cell-a:S.count: ")


def test_variables_that_fit_are_accepted():
    b = bridge_file.parse(
        doc(
            {**IMPORT, "age_us": "IN.age", "stamp_ns": "IN.stamp", "fallback": 7},
            {**IMPORT, "variable": "IN.vec", "stale": "IN.flag32", "fallback": [0.5, 1, 2]},
            {**IMPORT, "variable": "IN.odd", "stale": "IN.stale2", "fallback": True},
        )
    )
    bridge_file.check_layout(b, LAYOUT)


def test_an_export_must_be_a_scalar_or_an_array_of_scalars():
    e = refused('{"export": [{"variable": "S.axis"}]}')
    assert "export: no scalar variable or array of scalars S.axis in the layout" in str(e)
    bridge_file.check_layout(bridge_file.parse('{"export": [{"variable": "S.vec"}, {"variable": "S.count"}]}'), LAYOUT)


def test_shapes_overlaps_and_values():
    assert sharing.shape(LAYOUT, "S.vec") == sharing.Shape(("S.vec[0]", "S.vec[1]", "S.vec[2]"), "float32", True)
    assert sharing.shape(LAYOUT, "S.vec").name == "float32[3]"
    assert sharing.shape(LAYOUT, "IN.small").name == "int16"
    assert sharing.shape(LAYOUT, "S.axis") is None and sharing.shape(LAYOUT, "S") is None
    assert sharing.overlaps("a.b", "a.b") and sharing.overlaps("a.b", "a.b[2]") and sharing.overlaps("a.b.c", "a")
    assert not sharing.overlaps("a.b", "a.bc") and not sharing.overlaps("a.b[1]", "a.b[10]")
    assert [sharing.as_written("int16", v) for v in (3.0, 2.5, float("nan"))][:2] == [3, 2.5]
    assert sharing.as_written("bool", 1.0) is True and sharing.as_written("float64", 3.0) == 3.0
    assert sharing.fits("uint8", 255) and not sharing.fits("uint8", 256) and not sharing.fits("int8", True)
    assert not sharing.fits("float64", float("inf")) and sharing.fits("bool", 0)


def test_the_upload_refuses_an_import_with_the_file_line_and_both_writers(tmp_path):
    source, layout = tmp_path / "dds.json", tmp_path / "layout.json"
    layout.write_text(json.dumps(LAYOUT))
    source.write_text(doc({**IMPORT, "variable": "IN.missing"}))
    with pytest.raises(UploadError) as e:
        check_bridge_json(source, [], layout)
    assert e.value.status_code == 400 and "no scalar variable or array of scalars IN.missing" in str(e.value.detail)
    source.write_text(doc(IMPORT))
    modules = [ModuleRef("plc", "./main.so", "main.so", "thread", 3, 5, ["IN.count"])]
    with pytest.raises(UploadError) as e:
        check_bridge_json(source, modules, layout)
    assert "IN.count would have two writers: module plc" in str(e.value.detail)
    check_bridge_json(source, [ModuleRef("plc", "./main.so", "main.so", "thread", 3, 5, ["S.count"])], layout)


def test_the_shared_variable_type_is_keyed_by_controller_and_path():
    from indurop_agent.dds.indurop_types import SharedVariable

    assert SharedVariable.__idl_typename__ == "indurop::dds::SharedVariable"
    keys = {k for k, a in SharedVariable.__idl_field_annotations__.items() if a.get("key")}
    assert keys == {"controller", "path"}
    s = SharedVariable(controller="a", path="S.vec", seq=7, stamp_ns=1, every=1, type="float32[3]", values=[1, 2, 3])
    assert SharedVariable.deserialize(s.serialize()) == s

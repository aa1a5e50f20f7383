# test_convert.py -- glbc --previous on a variable whose type changed: converted where no value can be
# lost (widening scalars, structs field by field by name, arrays over the common index range, nested
# structs in arrays), with the copies irpd runs at the swap; otherwise moved, with the reason.  The
# scalar table is docs/glbc.md's "Converted variables".

from __future__ import annotations

import pytest
from test_previous import ok, run

CONVERTED = [
    ("int8_t", "int16_t"),
    ("int16_t", "int32_t"),
    ("int32_t", "int64_t"),
    ("uint8_t", "uint16_t"),
    ("uint16_t", "uint64_t"),
    ("uint8_t", "int16_t"),
    ("uint32_t", "int64_t"),
    ("int16_t", "float"),
    ("uint16_t", "float"),
    ("int32_t", "double"),
    ("uint32_t", "double"),
    ("float", "double"),
    ("short", "int16_t"),  # the same representation under another name
    ("char", "int16_t"),
]
NOT_CONVERTED = [
    ("int32_t", "int16_t", "int32_t to int16_t may lose values"),
    ("uint16_t", "int16_t", "uint16_t to int16_t may lose values"),
    ("int16_t", "uint32_t", "int16_t to uint32_t may lose values"),
    ("int32_t", "float", "int32_t to float may lose values"),
    ("int64_t", "double", "int64_t to double may lose values"),
    ("double", "float", "double to float may lose values"),
    ("float", "int64_t", "float to int64_t may lose values"),
    ("bool", "int8_t", "bool to int8_t may lose values"),
    ("uint8_t", "bool", "uint8_t to bool may lose values"),
]


def changed(tmp_path, before: str, after: str) -> dict:
    ok(tmp_path, before, "g1")
    return ok(tmp_path, after, "g2", "g1")["changes"]


@pytest.mark.parametrize("old, new", CONVERTED)
def test_a_widened_scalar_is_converted(tmp_path, old, new):
    changes = changed(tmp_path, f"{old} x;\n", f"{new} x;\n")
    assert changes["moved"] == []
    [c] = changes["converted"]
    assert (c["path"], c["dropped"], len(c["copies"])) == ("a.x", [], 1)
    assert (c["copies"][0]["from"], c["copies"][0]["to"]) == (c["from"], c["to"])


@pytest.mark.parametrize("old, new, why", NOT_CONVERTED)
def test_a_scalar_that_may_lose_values_is_moved_with_the_reason(tmp_path, old, new, why):
    changes = changed(tmp_path, f"{old} x;\n", f"{new} x;\n")
    assert changes["converted"] == []
    assert changes["moved"] == [
        {"path": "a.x", "from": 0, "to": 64, "from_type": old, "to_type": new, "reason": f"a.x: {why}"}
    ]


def test_a_struct_is_converted_field_by_field_by_name(tmp_path):
    changes = changed(
        tmp_path,
        "struct { int32_t count; int16_t mode; float gone; } fb;\n",
        "struct { double added; int16_t mode; int64_t count; } fb;\n",
    )
    [c] = changes["converted"]
    assert (c["from_type"], c["to_type"], c["dropped"]) == ("a.fb_t", "a.fb_t", ["a.fb.gone"])
    base_from, base_to = c["from"], c["to"]
    assert c["copies"] == [
        {"from": base_from + 4, "to": base_to + 8, "from_type": "s2", "to_type": "s2", "count": 1, "from_stride": 0, "to_stride": 0},
        {"from": base_from, "to": base_to + 16, "from_type": "s4", "to_type": "s8", "count": 1, "from_stride": 0, "to_stride": 0},
    ]  # fmt: skip


def test_an_array_is_converted_over_the_common_range(tmp_path):
    grown = changed(tmp_path, "int16_t a[3];\n", "int32_t a[5];\n")["converted"][0]
    assert (grown["from_type"], grown["to_type"], grown["dropped"]) == ("int16_t[3]", "int32_t[5]", [])
    assert grown["copies"] == [
        {"from": 0, "to": 64, "from_type": "s2", "to_type": "s4", "count": 3, "from_stride": 2, "to_stride": 4}
    ]
    (tmp_path / "b").mkdir()
    shrunk = changed(tmp_path / "b", "int32_t b[8][2];\n", "int32_t b[5][2];\n")["converted"][0]
    assert shrunk["dropped"] == ["a.b[5..7]"]
    assert len(shrunk["copies"]) == 5 and shrunk["copies"][1]["from"] - shrunk["copies"][0]["from"] == 8


def test_nested_structs_in_arrays_are_converted(tmp_path):
    changes = changed(
        tmp_path,
        "struct { struct { int16_t a; float b; } inner; uint8_t tag; } nest[2];\n",
        "struct { uint8_t tag; struct { int32_t a; double b; int8_t c; } inner; } nest[3];\n",
    )
    [c] = changes["converted"]
    assert c["dropped"] == []
    assert {(x["from_type"], x["to_type"], x["count"], x["from_stride"], x["to_stride"]) for x in c["copies"]} == {
        ("s2", "s4", 2, 12, 32),
        ("f4", "f8", 2, 12, 32),
        ("u1", "u1", 2, 12, 32),
    }


@pytest.mark.parametrize(
    "before, after, why",
    [
        ("int32_t x;", "struct { int32_t x; } x;", "a.x: int32_t becomes a struct"),
        ("struct { int32_t v; } x;", "int32_t x;", "a.x: a struct becomes int32_t"),
        ("int32_t x[4];", "int32_t x[2][2];", "a.x: 1 array dimensions become 2"),
        ("struct { int32_t v[2]; } x[3];", "struct { int16_t v[2]; } x[3];", "a.x[*].v[*]: int32_t to int16_t may lose values"),
    ],
)  # fmt: skip
def test_a_changed_shape_is_moved_with_the_reason(tmp_path, before, after, why):
    changes = changed(tmp_path, before + "\n", after + "\n")
    assert changes["converted"] == [] and [m["reason"] for m in changes["moved"]] == [why]


def test_glbc_says_which_variables_need_the_managed_restart_and_why(tmp_path):
    ok(tmp_path, "int32_t n;\nint16_t w;\n", "g1")
    result = run(tmp_path, "int16_t n;\nint32_t w;\n", "g2", "--previous", "g1/layout.json")
    assert result.returncode == 0, result.stderr
    assert result.stderr.splitlines()[1:] == [
        "glbc: not convertible without loss, only a managed restart of irpd runs this layout: "
        "a.n: int32_t to int16_t may lose values"
    ]
    assert result.stderr.splitlines()[0].endswith(": 0 added, 0 removed, 1 moved, 1 converted")

# test_retain.py -- the qualifiers `retain` and `persistent` on top-level declarations: recorded per
# variable in layout.json (and in its hash), the generated header otherwise the same, a clear error
# where they do not belong, and the variable's place kept by --previous when only the qualifier changes.

from __future__ import annotations

import json

import pytest
from test_bad_input import check, check_caret

NS = "namespace cell.Keep;\n"
QUALIFIED = NS + (
    "retain int32_t count;\n"
    "persistent struct {\n    double speed; int32_t parts[4];\n} recipe\n"
    "uint32_t plain;\n"
    "retain\n  uint64_t counts[3];\n"
)
PLAIN = QUALIFIED.replace("retain\n", "\n").replace("retain ", "").replace("persistent ", "")


def compiled(glb, text: str) -> tuple[dict, str]:
    result = glb({"keep.glb": text})
    assert result.returncode == 0, result.stderr
    return json.loads((glb.out / "layout.json").read_text()), (glb.out / "indurop" / "generated.h").read_text()


def test_each_variable_records_its_qualifier(glb):
    doc, _ = compiled(glb, QUALIFIED)
    qualifiers = {v["path"]: v.get("retain") for v in doc["variables"]}
    assert qualifiers == {
        "cell.Keep.count": "retain",
        "cell.Keep.recipe": "persistent",
        "cell.Keep.plain": None,  # no key at all: layouts without qualifiers are what they were
        "cell.Keep.counts": "retain",
    }
    assert "retain" not in next(v for v in doc["variables"] if v["name"] == "plain")


def test_the_header_differs_only_in_the_layout_hash(glb, tmp_path):
    doc, header = compiled(glb, QUALIFIED)
    (tmp_path / "out").rename(tmp_path / "qualified")
    plain_doc, plain_header = compiled(glb, PLAIN)
    assert doc["hash"] != plain_doc["hash"]  # a qualifier changed is another program (docs/retain.md)
    assert header.replace(doc["hash"], "H") == plain_header.replace(plain_doc["hash"], "H")
    offsets = [(v["offset"], v["lock"], v["type_id"]) for v in doc["variables"]]
    assert offsets == [(v["offset"], v["lock"], v["type_id"]) for v in plain_doc["variables"]]


def test_a_variable_may_still_be_called_retain(glb):
    doc, _ = compiled(glb, NS + "int retain;\npersistent int persistent;\nstruct { int retain; } s;\n")
    assert [(v["name"], v.get("retain")) for v in doc["variables"]] == [
        ("retain", None),
        ("persistent", "persistent"),
        ("s", None),
    ]


def test_previous_keeps_the_place_when_only_the_qualifier_changes(glb, tmp_path):
    compiled(glb, NS + "int32_t a;\nint32_t b;\n")
    (tmp_path / "out").rename(tmp_path / "g1")
    result = glb({"keep.glb": NS + "retain int32_t a;\npersistent int32_t b;\n"}, "--previous", "g1/layout.json")
    assert result.returncode == 0, result.stderr
    doc = json.loads((glb.out / "layout.json").read_text())
    assert doc["changes"]["added"] == [] and doc["changes"]["moved"] == []
    assert [(v["offset"], v.get("retain")) for v in doc["variables"]] == [(0, "retain"), (64, "persistent")]


@pytest.mark.parametrize(
    ("line", "col", "message"),
    [
        (
            "retain persistent int x;",
            8,
            "'persistent' after 'retain': a declaration takes one qualifier; "
            "'persistent' already includes what 'retain' keeps",
        ),
        (
            "struct { retain int x; } s;",
            10,
            "'retain' qualifies a top-level variable, not a field: write it before the variable's declaration "
            "(the whole variable is kept)",
        ),
        ("persistent;", 11, "expected a declaration (a type and a name), found ';'"),
    ],
    ids=["two qualifiers", "a qualified field", "no declaration"],
)
def test_a_qualifier_where_it_does_not_belong(glb, line, col, message):
    lines = check(glb({"a.glb": NS + line + "\n"}), f"a.glb:2:{col}: error: {message}", glb.out)
    check_caret(lines, line, col)

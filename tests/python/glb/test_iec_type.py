# test_iec_type.py -- declarations made through glbc's Python API (as stc makes them) carry their IEC
# type into layout.json: on the variable, on struct fields and on every leaf; .glb text has none,
# so a layout of .glb files is what it was (the golden files prove that).

from __future__ import annotations

import sys

from glb_helpers import ROOT

sys.path.insert(0, str(ROOT / "glb"))
from glbc_compiler.emit_layout import document  # noqa: E402
from glbc_compiler.errors import Loc, Source  # noqa: E402
from glbc_compiler.layout import build  # noqa: E402
from glbc_compiler.syntax import Decl, Dim, FileSyntax, NamespaceStmt, ScalarSpec, StructSpec  # noqa: E402


def test_the_iec_type_of_variables_fields_and_leaves():
    src = Source.from_text("main.st", "")
    at = Loc(src, 3, 5)
    timer = StructSpec(
        [
            Decl(ScalarSpec("bool", at), "IN", at, iec_type="BOOL"),
            Decl(ScalarSpec("int64_t", at), "PT", at, iec_type="TIME"),
        ],
        at,
    )
    items = [
        Decl(ScalarSpec("int64_t", at), "elapsed", at, iec_type="TIME"),
        Decl(ScalarSpec("char", at), "name", at, [Dim(at, 11)], iec_type="STRING[10]"),
        Decl(timer, "t1", at, iec_type="TON"),
        Decl(ScalarSpec("int32_t", at), "plain", at),
    ]
    doc = document(build([FileSyntax(src, NamespaceStmt("Main1", at), items)]))
    iec = {v["name"]: v.get("iec_type") for v in doc["variables"]}
    assert iec == {"elapsed": "TIME", "name": "STRING[10]", "t1": "TON", "plain": None}
    assert "iec_type" not in doc["variables"][3]  # no key where none was given
    fields = {f["name"]: f["iec_type"] for f in doc["types"]["Main1.t1_t"]["fields"]}
    assert fields == {"IN": "BOOL", "PT": "TIME"}
    leaves = {leaf["path"]: leaf.get("iec_type") for leaf in doc["leaves"]}
    assert leaves["Main1.t1.PT"] == "TIME" and leaves["Main1.elapsed"] == "TIME"
    assert leaves["Main1.name[10]"] == "STRING[10]" and leaves["Main1.plain"] is None
    assert doc["variables"][0]["source"] == "main.st:3"


def test_a_compilers_own_variable_is_marked_internal_on_the_variable_and_its_leaves():
    """stc's init flag (Decl.internal) is laid out like any variable (a place, a lock, kept by
    --previous) and marked `"internal": true`, so that the views of the variables leave it out."""
    src = Source.from_text("main.st", "")
    at = Loc(src, 3, 5)
    items = [
        Decl(ScalarSpec("int32_t", at), "count", at, [Dim(at, 2)], iec_type="DINT"),
        Decl(ScalarSpec("bool", at), "_stc_init", at, iec_type="BOOL", internal=True),
    ]
    doc = document(build([FileSyntax(src, NamespaceStmt("Main", at), items)]))
    assert [(v["path"], v.get("internal")) for v in doc["variables"]] == [
        ("Main.count", None),
        ("Main._stc_init", True),
    ]
    leaves = [(leaf["path"], leaf.get("internal")) for leaf in doc["leaves"]]
    assert leaves == [("Main.count[0]", None), ("Main.count[1]", None), ("Main._stc_init", True)]
    assert doc["variables"][1]["lock"] == 1 and doc["variables"][1]["offset"] > 0

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

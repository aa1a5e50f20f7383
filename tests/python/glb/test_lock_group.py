# test_lock_group.py -- declarations of one lock group (Decl.lock_group, as stc declares a PROGRAM
# instance's structs and arrays) share one lock in layout.json, keep it when the layout is laid out
# against the running one, and a variable that joins the group later takes the group's lock.

from __future__ import annotations

import json
import sys

from glb_helpers import ROOT

sys.path.insert(0, str(ROOT / "glb"))
from glbc_compiler.emit_layout import document, render  # noqa: E402
from glbc_compiler.errors import Loc, Source  # noqa: E402
from glbc_compiler.evolve import place, read_previous  # noqa: E402
from glbc_compiler.layout import build  # noqa: E402
from glbc_compiler.syntax import Decl, Dim, FileSyntax, NamespaceStmt, ScalarSpec  # noqa: E402


def declarations(names: list[str], group: str | None = "Main") -> list[FileSyntax]:
    src = Source.from_text("main.st", "")
    at = Loc(src, 1, 1)
    items = [Decl(ScalarSpec("int32_t", at), "own", at)]  # not in the group: a lock of its own
    items += [Decl(ScalarSpec("int16_t", at), n, at, [Dim(at, 4)], lock_group=group) for n in names]
    return [FileSyntax(src, NamespaceStmt("Main", at), items)]


def locks(doc: dict) -> dict[str, tuple[int, str | None]]:
    return {v["path"]: (v["lock"], v.get("lock_group")) for v in doc["variables"]}


def test_the_variables_of_a_group_share_one_lock_and_say_so():
    doc = document(build(declarations(["a", "b", "c"])))
    assert locks(doc) == {"Main.own": (0, None), "Main.a": (1, "Main"), "Main.b": (1, "Main"), "Main.c": (1, "Main")}
    assert doc["lock_count"] == 2
    assert {leaf["lock"] for leaf in doc["leaves"] if leaf["path"].startswith("Main.b")} == {1}
    assert "lock_group" not in doc["variables"][0]  # no key without a group: layouts without groups unchanged


def test_a_variable_that_joins_the_group_online_takes_its_lock_and_the_others_stay(tmp_path):
    before = build(declarations(["a", "b"]))
    running = tmp_path / "running.json"
    running.write_text(render(before))
    after = build(declarations(["a", "new", "b"]))
    place(after, read_previous(str(running)), 1 << 20)
    doc = document(after)
    was = {v["path"]: (v["offset"], v["lock"]) for v in json.loads(running.read_text())["variables"]}
    now = {v["path"]: (v["offset"], v["lock"]) for v in doc["variables"]}
    assert now["Main.a"] == was["Main.a"] and now["Main.b"] == was["Main.b"]  # values kept in place
    assert now["Main.new"][1] == was["Main.a"][1]  # the group's lock
    assert now["Main.new"][0] not in {o for o, _ in was.values()}
    assert doc["changes"]["added"] == ["Main.new"]
    assert doc["lineage"][0]["variables"][1]["lock_group"] == "Main"  # the lineage says it too
    assert doc["lock_count"] == 2


def test_a_group_laid_out_against_a_layout_without_groups_keeps_the_old_locks(tmp_path):
    """A running layout from before groups: its variables keep their own locks (modules built against
    it run on); the group's new variables share one new lock."""
    running = tmp_path / "running.json"
    running.write_text(render(build(declarations(["a", "b"], group=None))))
    after = build(declarations(["a", "b", "c", "d"]))
    place(after, read_previous(str(running)), 1 << 20)
    doc = locks(document(after))
    assert doc["Main.a"][0] != doc["Main.b"][0]
    assert doc["Main.c"][0] == doc["Main.d"][0] not in {doc["Main.a"][0], doc["Main.b"][0], doc["Main.own"][0]}


def packed(names: list[str]) -> list[FileSyntax]:
    src = Source.from_text("main.st", "")
    at = Loc(src, 1, 1)
    items = [Decl(ScalarSpec("int8_t", at), "alone", at)]  # not packed: lines of its own
    items += [Decl(ScalarSpec(t, at), n, at, packed=True) for n, t in names]
    items.append(Decl(ScalarSpec("int8_t", at), "after", at))
    return [FileSyntax(src, NamespaceStmt("Main", at), items)]


def offsets(doc: dict) -> dict[str, int]:
    return {v["name"]: v["offset"] for v in doc["variables"]}


def test_packed_variables_follow_each_other_at_their_alignment():
    doc = document(build(packed([("a", "int8_t"), ("b", "int32_t"), ("c", "int16_t"), ("d", "double")])))
    assert offsets(doc) == {"alone": 0, "a": 64, "b": 68, "c": 72, "d": 80, "after": 128}


def test_new_packed_variables_laid_out_against_the_running_layout_stay_packed_and_the_others_stay(tmp_path):
    running = tmp_path / "running.json"
    running.write_text(render(build(packed([("a", "int8_t"), ("b", "int32_t")]))))
    after = build(packed([("a", "int8_t"), ("n1", "int16_t"), ("n2", "double"), ("b", "int32_t"), ("n3", "int8_t")]))
    place(after, read_previous(str(running)), 1 << 20)
    now = offsets(document(after))
    assert (now["alone"], now["a"], now["b"], now["after"]) == (0, 64, 68, 128)  # kept where they were
    # one run on free lines, as build() packed it (n1 after a, n2 after n1: distances and alignment kept)
    assert now["n1"] >= 192 and now["n1"] % 2 == 0 and now["n2"] == now["n1"] + 6 and now["n2"] % 8 == 0
    assert now["n3"] // 64 > now["n2"] // 64  # after a kept one: a run of its own, on a line of its own

# test_conformance_online.py -- online change of an ST program in a real irpd: the changed program is
# built against the running layout (stc build --previous) and loaded with `load`: every variable keeps
# its value, an added variable starts at its initial value, a TON that is timing goes on timing.
# And a set's .glb variables keep the places its C++ modules were built against (--set-layout).

from __future__ import annotations

import json
import subprocess
import sys

from live_processes import ROOT, wait_until
from st_live import Running, stc_build

V1 = """
PROGRAM Counter
VAR n : DINT; t : TON; END_VAR
  n := n + 1;
  t(IN := TRUE, PT := T#1h);
END_PROGRAM
"""
V2 = V1.replace("VAR n : DINT;", "VAR n : DINT; added : INT := 42; hist : ARRAY[0..3] OF DINT := [1, 2, 3, 4];")
V2 = V2.replace("n := n + 1;", "n := n + 1000;\n  hist[0] := hist[0] + 1;")


def test_a_change_keeps_values_and_timers_and_starts_added_variables_at_their_initial_value(tmp_path):
    run = Running(tmp_path, {"counter.st": V1})
    try:
        wait_until(lambda: run.value("Counter.n") > 20)
        elapsed = run.value("Counter.t.ET")
        report = run.load({"counter.st": V2}, "set2")
        assert "Counter.added" in report["variables"]["added"], report
        n = run.value("Counter.n")
        assert n > 20  # kept
        wait_until(lambda: run.value("Counter.n") > n + 3000)  # the new logic counts by 1000
        assert n % 1000 != 0 and run.value("Counter.n") % 1000 == n % 1000
        assert run.value("Counter.added") == 42
        assert run.value("Counter.t.ET") > elapsed and run.value("Counter.t.Q") == 0  # still timing
        # an array added to the program's lock group (with the TON): the group's lock, its initial
        # values, and the new code writes it back
        assert "Counter.hist" in report["variables"]["added"], report
        run.segment.refresh()
        lock = {v["path"]: v["lock"] for v in run.segment.layout["variables"]}
        assert lock["Counter.hist"] == lock["Counter.t"]
        assert run.value("Counter.hist[3]") == 4
        wait_until(lambda: run.value("Counter.hist[0]") > 10)
    finally:
        run.close()


EXTRA = """
PROGRAM Extra
VAR x : INT := 7; END_VAR
  x := x + 1;
END_PROGRAM
"""


def test_an_added_program_starts_at_its_initial_values_and_the_report_names_its_variables_only(tmp_path):
    """A new PROGRAM instance brings stc's init flag (Extra._stc_init, "internal": true): laid out and
    zeroed with the others, so the instance writes its initial values once, but the report of the
    change (as the dry run's) names only the program's variables."""
    run = Running(tmp_path, {"counter.st": V1})
    try:
        wait_until(lambda: run.value("Counter.n") > 5)
        report = run.load({"counter.st": V1, "extra.st": EXTRA}, "set2")
        assert report["variables"]["added"] == ["Extra.x"], report
        wait_until(lambda: run.value("Extra.x") > 7)  # started at 7, not at 0
        running = {v["path"]: v.get("internal") for v in run.segment.layout["variables"]}
        assert running["Extra._stc_init"] is True and running["Counter._stc_init"] is True  # kept
    finally:
        run.close()


def test_the_sets_glb_variables_keep_their_places_and_its_layout_stays_valid(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    (src / "io.glb").write_text("namespace IO;\nint16_t start;\nint32_t speed;\n")
    glbc = [sys.executable, str(ROOT / "glb" / "glbc"), "io.glb", "-o", str(tmp_path / "glb")]
    subprocess.run(glbc, cwd=src, check=True)
    set_layout = json.loads((tmp_path / "glb" / "layout.json").read_text())
    program = (
        "PROGRAM P\nVAR go AT %IO.start : INT; n : DINT; END_VAR\n"
        "  n := n + 1;\n  IO.speed := DINT_TO_INT(go) * 2;\nEND_PROGRAM\n"
    )
    extra = ("--glb", "io.glb", "--set-layout", str(tmp_path / "glb" / "layout.json"), "--no-compile")
    r = stc_build(tmp_path, {"p.st": program}, *extra)
    assert r.returncode == 0, r.stdout
    doc = json.loads((tmp_path / "set" / "layout.json").read_text())
    before = {v["path"]: (v["offset"], v["lock"]) for v in set_layout["variables"]}
    after = {v["path"]: (v["offset"], v["lock"]) for v in doc["variables"]}
    assert all(after[p] == where for p, where in before.items())
    assert set_layout["hash"] in [e["hash"] for e in doc["lineage"]]
    assert "P.go" not in after  # an AT binding is the bound variable, not one of its own
    assert doc["variables"][-1]["path"].startswith("P.")  # the ST variables after the .glb ones


def test_a_set_layout_and_the_running_layout_together(tmp_path):
    """The set's .glb changed too: its layout was laid out against the running one (glbc --previous),
    its C++ modules built against it; stc keeps both: the ST variables where they run, the set's layout
    in the lineage.  A set layout not laid out against the running one is an error saying so."""
    src = tmp_path / "src"
    src.mkdir()

    def glbc(text: str, out: str, *extra: str) -> dict:
        (src / "io.glb").write_text(text)
        cmd = [sys.executable, str(ROOT / "glb" / "glbc"), "io.glb", "-o", str(tmp_path / out), *extra]
        subprocess.run(cmd, cwd=src, check=True, capture_output=True)
        return json.loads((tmp_path / out / "layout.json").read_text())

    glbc("namespace IO;\nint16_t start;\n", "glb0")
    program = {"p.st": "PROGRAM P\nVAR n : DINT; END_VAR\n  n := n + IO.start;\nEND_PROGRAM\n"}
    first = ("--glb", "io.glb", "--set-layout", str(tmp_path / "glb0" / "layout.json"), "--no-compile")
    assert stc_build(tmp_path, program, *first, out="v1").returncode == 0
    running = tmp_path / "v1" / "layout.json"
    set1 = glbc("namespace IO;\nint16_t start;\nint32_t added;\n", "glb1", "--previous", str(running))
    both = ("--glb", "io.glb", "--set-layout", str(tmp_path / "glb1" / "layout.json"), "--previous", str(running))
    r = stc_build(tmp_path, program, *both, "--no-compile", out="v2")
    assert r.returncode == 0, r.stdout
    doc = json.loads((tmp_path / "v2" / "layout.json").read_text())
    where = {v["path"]: (v["offset"], v["lock"]) for v in doc["variables"]}
    before = {v["path"]: (v["offset"], v["lock"]) for v in json.loads(running.read_text())["variables"]}
    assert where["P.n"] == before["P.n"] and where["IO.start"] == before["IO.start"]
    assert all(where[v["path"]] == (v["offset"], v["lock"]) for v in set1["variables"])
    assert set1["hash"] in [e["hash"] for e in doc["lineage"]]

    glbc("namespace IO;\nint32_t other;\nint16_t start;\n", "glb2")  # laid out afresh: not against the running
    bad = ("--glb", "io.glb", "--set-layout", str(tmp_path / "glb2" / "layout.json"), "--previous", str(running))
    r = stc_build(tmp_path, program, *bad, "--no-compile", out="v3")
    assert r.returncode == 1
    [e] = json.loads(r.stdout)
    assert e["code"] == "layout" and "was not laid out against the running one" in e["message"], e


def test_a_set_layout_whose_glb_variables_no_glb_declares_is_an_error_that_says_to_give_the_glb(tmp_path):
    """A set rebuilt from its .st files and layout.json without its .glb file: the layout's .glb
    variables (its C++ modules' own) are not laid out again from layout.json; with or without the
    running layout, the error names the variable and says to give the set's .glb files."""
    src = tmp_path / "src"
    src.mkdir()
    (src / "io.glb").write_text("namespace IO;\nint16_t start;\n")
    program = {"p.st": "PROGRAM P\nVAR n : DINT; END_VAR\n  n := n + IO.start;\nEND_PROGRAM\n"}
    built = stc_build(tmp_path, program, "--glb", "io.glb", "--no-compile", out="v1")
    assert built.returncode == 0, built.stdout
    layout = str(tmp_path / "v1" / "layout.json")
    for running in ((), ("--previous", layout)):
        r = stc_build(tmp_path, program, "--set-layout", layout, *running, "--no-compile", out="v2")
        assert r.returncode == 1, r.stdout
        [e] = json.loads(r.stdout)
        assert e["code"] == "layout" and "'IO.start' of the set's layout is declared by none" in e["message"], e
        assert "give the set's .glb files" in e["message"], e
    # with its .glb file, the same rebuild against the running layout keeps every place
    r = stc_build(tmp_path, program, "--glb", "io.glb", "--set-layout", layout, "--previous", layout, "--no-compile")
    assert r.returncode == 0, r.stdout


def test_a_variable_retyped_where_no_value_is_lost_keeps_its_value(tmp_path):
    """INT -> DINT: glbc plans the conversion (i29-st-evolve), irpd copies the value at the swap."""
    v1 = "PROGRAM Grow\nVAR n : INT; END_VAR\n  n := n + 1;\nEND_PROGRAM\n"
    run = Running(tmp_path, {"grow.st": v1})
    try:
        wait_until(lambda: run.value("Grow.n") > 20)
        report = run.load({"grow.st": v1.replace("n : INT;", "n : DINT;")}, "set2")
        assert [c["path"] for c in report["variables"]["converted"]] == ["Grow.n"], report
        assert run.value("Grow.n") > 20  # converted, not started again at 0
        run.segment.refresh()
        [entry] = [v for v in run.segment.layout["variables"] if v["path"] == "Grow.n"]
        assert entry["iec_type"] == "DINT"
    finally:
        run.close()

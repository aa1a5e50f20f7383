"""test_programs_api.py -- the Programs page's API against a real agent beside a real irpd running a
set written in Structured Text: the set's .st files and their POUs, a file's source, the check of
an edited file in its set (errors in place, symbols: variables with their IEC types and
shared-variable paths, FB types with their parameters, standard functions), an edit applied as a
new set derived from the running one (irpd's dry run, then activation online: the new logic runs),
the file's history, the diff of two versions and the rollback; a viewer reads and checks but
cannot apply; bad input is named."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import httpx
import pytest
from agent_helpers import FIG1, IRPD, LiveCell, free_port, st_configuration

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "plcopen"))
from export_helpers import independent_reader  # noqa: E402
from plcopen_live import shared  # noqa: E402

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")

MAIN = """\
PROGRAM Counter
VAR
  count : DINT;
  step : DINT := 1;
  inc : DINT;
  pulse : TON;
END_VAR
inc := {inc};
count := count + inc;
pulse(IN := NOT pulse.Q, PT := T#10ms);
END_PROGRAM
"""
TYPE_ERROR = MAIN.format(inc="step").replace("inc := step;", "inc := pulse.Q;")  # line 8
SYNTAX_ERROR = MAIN.format(inc="step").replace("inc := step;", "inc := step + ;")


class Cell(LiveCell):
    def __init__(self, tmp: Path):
        super().__init__(tmp, FIG1, instance=f"programs-{free_port()}")
        r = self.post("/tokens", json={"name": "hmi", "role": "viewer"})
        assert r.status_code == 201, r.text
        self.viewer = {"Authorization": f"Bearer {r.json()['token']}"}

    def as_viewer(self, method: str, path: str, **kw) -> httpx.Response:
        return httpx.request(method, f"{self.url}{path}", headers=self.viewer, timeout=120, **kw)

    def read(self, path: str):
        r = self.get(f"/variables/{path}")
        assert r.status_code == 200, r.text
        return r.json()["value"]


def running(tmp: Path, main: str) -> Cell:
    """A Cell running the set of `main` (PROGRAM Counter) and a configuration of one instance Main,
    uploaded and activated; its id is `base`."""
    c = Cell(tmp)
    files = {"main.st": main.encode(), "config.st": st_configuration("Counter").encode()}
    stored = c.upload([("files", (p, b)) for p, b in files.items()])
    r = c.post(f"/sets/{stored['id']}/activate", json={"mode": "auto"})
    assert r.status_code == 200, r.text
    c.base = stored["id"]
    return c


@pytest.fixture
def cell(tmp_path):
    c = running(tmp_path, MAIN.format(inc="step"))
    yield c
    c.close()


def steps_by(cell: Cell, step: int) -> None:
    """The running logic adds `step` a period (Main.inc), and the counter moves."""
    deadline = time.monotonic() + 10
    while cell.read("Main.inc") != step:
        assert time.monotonic() < deadline, f"Main.inc stays {cell.read('Main.inc')}, not {step}: the edit does not run"
        time.sleep(0.02)
    first = cell.read("Main.count")
    while cell.read("Main.count") == first:
        assert time.monotonic() < deadline, "Main.count does not move"
        time.sleep(0.02)


def test_a_viewer_lists_the_files_and_pous_reads_a_source_and_checks_an_edit(cell):
    for method, path, kw in [  # nobody signed in: every Programs route answers 401 (the role matrix's rule)
        ("GET", "/programs", {}),
        ("GET", "/programs/source", {"params": {"path": "main.st"}}),
        ("POST", "/programs/check", {"json": {"path": "main.st", "source": TYPE_ERROR}}),
        ("POST", "/programs/apply", {"json": {"path": "main.st", "source": TYPE_ERROR}}),
        ("GET", "/programs/history", {"params": {"path": "main.st"}}),
        ("GET", "/programs/diff", {"params": {"path": "main.st", "old": cell.base}}),
        ("GET", "/programs/export", {}),
    ]:
        assert httpx.request(method, f"{cell.url}{path}", timeout=30, **kw).status_code == 401, path
    listed = cell.as_viewer("GET", "/programs").json()
    assert listed["set_id"] == cell.base and listed["active"] is True
    files = {f["path"]: f for f in listed["files"]}
    assert files["main.st"]["pous"] == [{"name": "Counter", "kind": "PROGRAM", "line": 1, "language": None}]
    assert files["config.st"]["pous"] == [{"name": "Cell", "kind": "CONFIGURATION", "line": 1, "language": None}]
    source = cell.as_viewer("GET", "/programs/source", params={"path": "main.st"}).json()
    assert source["source"] == MAIN.format(inc="step") and source["set_id"] == cell.base

    # a type error: its place and the compiler's words, checked with the set's config.st
    r = cell.as_viewer("POST", "/programs/check", json={"path": "main.st", "source": TYPE_ERROR})
    assert r.status_code == 200, r.text
    checked = r.json()
    assert [(e["file"], e["line"], e["column"], e["code"]) for e in checked["errors"]] == [("main.st", 8, 8, "type")]
    assert "cannot assign BOOL to DINT" in checked["errors"][0]["message"]
    # the symbols: the variables with their IEC type and shared variable, the FBs' parameters
    counter = next(p for p in checked["symbols"]["pous"] if p["name"] == "Counter")
    variables = {v["name"]: (v["type"], v["paths"]) for v in counter["vars"]}
    assert variables["count"] == ("DINT", ["Main.count"]) and variables["pulse"] == ("TON", ["Main.pulse"]), variables
    ton = next(f for f in checked["symbols"]["fb_types"] if f["name"] == "TON")
    assert ton["library"] is True
    assert [(p["name"], p["kind"], p["type"]) for p in ton["params"]] == [
        ("IN", "VAR_INPUT", "BOOL"),
        ("PT", "VAR_INPUT", "TIME"),
        ("Q", "VAR_OUTPUT", "BOOL"),
        ("ET", "VAR_OUTPUT", "TIME"),
    ]
    limit = next(f for f in checked["symbols"]["functions"] if f["name"] == "LIMIT")
    assert [p["name"] for p in limit["params"]] == ["MN", "IN", "MX"]

    # a syntax error names what was expected, at its line; the clean source has no error
    syntax = cell.as_viewer("POST", "/programs/check", json={"path": "main.st", "source": SYNTAX_ERROR}).json()
    assert [(e["line"], e["code"]) for e in syntax["errors"]] == [(8, "syntax")], syntax["errors"]
    clean = cell.as_viewer(
        "POST", "/programs/check", json={"path": "main.st", "source": MAIN.format(inc="3 * step")}
    ).json()
    assert clean["errors"] == []

    # a viewer cannot apply an edit
    r = cell.as_viewer("POST", "/programs/apply", json={"path": "main.st", "source": MAIN.format(inc="2 * step")})
    assert r.status_code == 403, r.text


def test_an_edit_is_applied_online_has_a_history_a_diff_and_rolls_back(cell):
    steps_by(cell, 1)
    # a compile error refuses the edit with the compiler's errors; nothing is stored
    before = {s["id"] for s in cell.get("/sets").json()}
    r = cell.post("/programs/apply", json={"path": "main.st", "source": TYPE_ERROR})
    assert r.status_code == 400, r.text
    assert r.json()["problems"][0]["file"] == "main.st" and r.json()["problems"][0]["line"] == 8, r.json()
    assert {s["id"] for s in cell.get("/sets").json()} == before

    # Check: the new set and its dry run, nothing activated
    r = cell.post("/programs/apply", json={"path": "main.st", "source": MAIN.format(inc="2 * step")})
    assert r.status_code == 200, r.text
    new = r.json()["set"]
    assert new["derived_from"] == {"set_id": cell.base, "path": "main.st"}, new
    assert new["validation"]["valid"] is True and new["validation"]["online"] is True, new["validation"]
    assert new["validation"]["modules"]["replaced"] == ["Main"], new["validation"]["modules"]
    assert r.json()["report"] is None and cell.get("/programs").json()["set_id"] == cell.base

    # Apply: activated online; the new logic runs and the running version is the new text
    r = cell.post(f"/sets/{new['id']}/activate")
    assert r.status_code == 200, r.text
    steps_by(cell, 2)
    assert cell.get("/programs/source", params={"path": "main.st"}).json()["source"] == MAIN.format(inc="2 * step")

    history = cell.get("/programs/history", params={"path": "main.st"}).json()["versions"]
    assert [(v["set_id"], v["active"], v["derived_from"]) for v in history] == [
        (new["id"], True, cell.base),
        (cell.base, False, None),
    ]
    diff = cell.get("/programs/diff", params={"path": "main.st", "old": cell.base}).json()
    assert (diff["old"], diff["new"]) == (cell.base, new["id"])
    assert "-inc := step;\n+inc := 2 * step;\n" in diff["diff"], diff["diff"]
    assert diff["diff"].startswith(f"--- {cell.base}/main.st\n+++ {new['id']}/main.st\n")

    # rollback: the set before, its text again
    r = cell.post("/sets/rollback")
    assert r.status_code == 200, r.text
    steps_by(cell, 1)
    assert cell.get("/programs/source", params={"path": "main.st"}).json()["source"] == MAIN.format(inc="step")
    # Check and Apply in one request (activate: true): the edit runs again
    r = cell.post("/programs/apply", json={"path": "main.st", "source": MAIN.format(inc="2 * step"), "activate": True})
    assert r.status_code == 200, r.text
    assert r.json()["report"]["set_id"] == r.json()["set"]["id"], r.json()["report"]
    steps_by(cell, 2)
    audit = [a for a in cell.get("/audit").json() if a["action"] == "program_edit"]
    assert [(a["result"], a["path"], a["derived_from"]) for a in audit][-2:] == [
        ("ok", "main.st", cell.base),
        ("ok", "main.st", cell.base),
    ], audit


def test_a_viewer_downloads_the_running_programs_as_plcopen_xml(cell):
    """GET /programs/export: the active set's ST as one PLCopen XML 2.01 project, read by the PyPI
    package `plcopen` (an independent reader: xsdata classes of the TC6 schema)."""
    r = cell.as_viewer("GET", "/programs/export")
    assert r.status_code == 200, r.text
    assert r.headers["content-type"] == "application/xml"
    assert r.headers["content-disposition"] == f'attachment; filename="{cell.base}.xml"'
    project = independent_reader(r.content)
    assert project.content_header.name == f"set {cell.base}"
    (pou,) = project.types.pous.pou
    assert (pou.name, pou.pou_type.value) == ("Counter", "program")
    assert pou.body[0].st.w3_org_1999_xhtml_element.text == "inc := step;\ncount := count + inc;\n" + (
        "pulse(IN := NOT pulse.Q, PT := T#10ms);\n"
    )
    assert [v.name for v in pou.interface.local_vars[0].variable] == ["count", "step", "inc", "pulse"]
    (config,) = project.instances.configurations.configuration
    (resource,) = config.resource
    assert [(i.name, i.type_name) for t in resource.task for i in t.pou_instance] == [("Main", "Counter")]
    same = cell.as_viewer("GET", "/programs/export", params={"set": cell.base})
    assert same.status_code == 200 and independent_reader(same.content).types.pous.pou[0].name == "Counter"
    r = cell.as_viewer("GET", "/programs/export", params={"set": "0123456789abcdef"})
    assert r.status_code == 404 and "GET /api/v1/sets" in r.json()["detail"], r.text


def test_a_drawn_program_is_exported_with_its_drawing(cell):
    """A set uploaded as PLCopen XML (OpenPLC Editor's Blink, a ladder) is exported with its rungs
    as drawn: every element and position of the file's LD body."""
    blink = shared("openplc_blink")
    stored = cell.upload([("files", ("plc.xml", blink.read_bytes()))])
    r = cell.as_viewer("GET", "/programs/export", params={"set": stored["id"]})
    assert r.status_code == 200, r.text
    (pou,) = independent_reader(r.content).types.pous.pou
    ld = pou.body[0].ld
    original = independent_reader(blink.read_bytes()).types.pous.pou[0].body[0].ld
    assert (pou.name, len(ld.contact), len(ld.coil), len(ld.block)) == ("Blink", 1, 1, 2)
    assert ld == original


def test_bad_requests_are_named(cell):
    r = cell.post("/programs/check", json={"path": "nope.st", "source": ""})
    assert r.status_code == 404 and "no .st file 'nope.st'" in r.json()["detail"] and "main.st" in r.json()["detail"]
    r = cell.get("/programs", params={"set": "0123456789abcdef"})
    assert r.status_code == 404 and "GET /api/v1/sets" in r.json()["detail"], r.text
    r = cell.post("/programs/check", json={"path": "main.st"})
    assert r.status_code == 422, r.text
    bad = cell.post("/programs/check", json={"path": "main.st", "source": "PROGRAM P\n\x00\nEND_PROGRAM\n"}).json()
    assert bad["errors"] and bad["errors"][0]["line"] == 2, bad
    # nesting past the compiler's limit: its error, and the agent answers on
    deep = "PROGRAM Counter\nVAR x : DINT; END_VAR\nx := " + " + ".join(["1"] * 5000) + ";\nEND_PROGRAM\n"
    deep_errors = cell.post("/programs/check", json={"path": "main.st", "source": deep}).json()["errors"]
    assert [e["code"] for e in deep_errors] == ["too-deep"], deep_errors
    assert cell.get("/programs").status_code == 200
    r = cell.get("/programs/history", params={"path": "other.st"})
    assert r.status_code == 404 and "other.st" in r.json()["detail"]


def test_with_no_active_set_the_list_is_empty_and_a_check_says_what_to_do(tmp_path):
    """irpd runs a folder the store does not hold: the page lists nothing (no error to show), and a
    check names what is missing."""
    c = Cell(tmp_path)
    try:
        assert c.as_viewer("GET", "/programs").json() == {"set_id": None, "active": False, "files": []}
        r = c.as_viewer("POST", "/programs/check", json={"path": "main.st", "source": ""})
        assert r.status_code == 404 and "no set is active" in r.json()["detail"], r.text
    finally:
        c.close()

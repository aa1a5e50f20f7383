"""test_monitor_api.py -- live values for the ST editor's monitor and the Watch page, against a real
agent beside a real irpd running a set written in Structured Text: POST /variables/read reads many
leaves at once (an unknown path or a group is an error entry, not a failure; the bound is named);
POST /programs/monitor places each variable of the lines asked with its value, an FB instance as an
expandable group, and evaluates IF/ELSIF/WHILE/UNTIL conditions and CASE selectors with the compiler's folding on the values
read (a write moves them; a VAR_TEMP or a call is not evaluated, and the answer says why); the watch
lists are kept with the set, read by a viewer, saved by an operator only, and follow an edit; a REAL
that is NaN or infinite reads as null in both answers."""

from __future__ import annotations

import time

import httpx
import pytest
from agent_helpers import IRPD
from test_programs_api import Cell, running

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")

MAIN = """\
PROGRAM Counter
VAR
  count : DINT;
  limit : DINT := 1000000000;
  run : BOOL := TRUE;
  mode : INT := 2;
  pulse : TON;
  hits : DINT;
END_VAR
VAR_TEMP
  t : BOOL;
END_VAR
IF run AND count < limit THEN
  count := count + 1;
ELSIF NOT run THEN
  hits := hits + 1;
END_IF;
CASE mode * 10 OF
  10: hits := 0;
END_CASE;
t := count > 5;
IF t THEN
  hits := hits;
END_IF;
IF ABS(count) > 2 THEN
  hits := hits;
END_IF;
pulse(IN := NOT pulse.Q, PT := T#10ms);
WHILE hits < 0 DO
  hits := 0;
END_WHILE;
REPEAT
  hits := hits;
UNTIL TRUE OR run
END_REPEAT;
END_PROGRAM
"""


@pytest.fixture
def cell(tmp_path):
    c = running(tmp_path, MAIN)
    yield c
    c.close()


def write(cell: Cell, path: str, value) -> None:
    r = cell.call("PUT", f"/variables/{path}", json={"value": value})
    assert r.status_code == 200, r.text


def monitor(cell: Cell, **body) -> dict:
    r = cell.as_viewer("POST", "/programs/monitor", json={"path": "main.st", **body})
    assert r.status_code == 200, r.text
    return r.json()


def test_many_values_are_read_at_once_and_a_bad_path_is_named(cell):
    r = cell.as_viewer(
        "POST", "/variables/read", json={"paths": ["Main.run", "Main.count", "Main.cuont", "Main.pulse"]}
    )
    assert r.status_code == 200, r.text
    answer = r.json()
    assert [(v["path"], v["type"]) for v in answer["values"]] == [("Main.run", "bool"), ("Main.count", "int32_t")]
    assert answer["values"][0]["value"] is True and answer["values"][0]["forced"] is False
    errors = {e["path"]: e["message"] for e in answer["errors"]}
    assert "did you mean 'Main.count'" in errors["Main.cuont"]
    assert "is a group of" in errors["Main.pulse"] and "name its members" in errors["Main.pulse"]
    first = answer["values"][1]["value"]
    deadline = time.monotonic() + 10
    while (
        cell.as_viewer("POST", "/variables/read", json={"paths": ["Main.count"]}).json()["values"][0]["value"] == first
    ):
        assert time.monotonic() < deadline, "Main.count does not move: not live"
        time.sleep(0.02)
    too_many = cell.as_viewer("POST", "/variables/read", json={"paths": ["Main.run"] * 1001})
    assert too_many.status_code == 422 and "1000" in too_many.text, too_many.text


def test_the_monitor_places_values_and_evaluates_conditions_as_the_compiler_folds(cell):
    for path, body in (("/programs/monitor", {"path": "main.st"}), ("/variables/read", {"paths": []})):
        assert httpx.post(f"{cell.url}{path}", json=body, timeout=30).status_code == 401, path  # nobody signed in
    answer = monitor(cell, from_line=13, to_line=28, expand=["Main.pulse"])
    at = {(o["line"], o["column"]): o for o in answer["occurrences"]}
    assert at[(13, 4)]["path"] == "Main.run" and at[(13, 4)]["value"] is True and at[(13, 4)]["type"] == "BOOL"
    assert at[(13, 4)]["end_column"] == 7
    assert at[(13, 12)]["path"] == "Main.count" and isinstance(at[(13, 12)]["value"], int)
    assert at[(28, 1)] == {**at[(28, 1)], "path": "Main.pulse", "group": True}  # the FB instance: expandable
    assert "Main.pulse.Q" in [f["path"] for f in answer["fields"]["Main.pulse"]]
    assert all(13 <= o["line"] <= 28 for o in answer["occurrences"])
    conditions = {(x["line"], x["what"]): x for x in answer["conditions"]}
    assert conditions[(13, "IF")]["value"] is True and conditions[(13, "IF")]["end_column"] == 25
    assert conditions[(15, "ELSIF")]["value"] is False
    assert conditions[(18, "CASE")]["value"] == 20
    assert conditions[(22, "IF")]["value"] is None and "VAR_TEMP" in conditions[(22, "IF")]["reason"]
    assert conditions[(25, "IF")]["value"] is None and "calls ABS" in conditions[(25, "IF")]["reason"]
    loops = {(x["line"], x["what"]): x for x in monitor(cell, from_line=29, to_line=35)["conditions"]}
    assert loops[(29, "WHILE")]["value"] is False and loops[(29, "WHILE")]["end_column"] == 15
    assert loops[(34, "UNTIL")]["value"] is True and (
        loops[(34, "UNTIL")]["end_line"],
        loops[(34, "UNTIL")]["end_column"],
    ) == (34, 18)

    write(cell, "Main.run", False)
    write(cell, "Main.mode", 1)
    after = {(x["line"], x["what"]): x["value"] for x in monitor(cell, from_line=13, to_line=18)["conditions"]}
    assert after[(13, "IF")] is False and after[(15, "ELSIF")] is True and after[(18, "CASE")] == 10

    missing = cell.as_viewer("POST", "/programs/monitor", json={"path": "nothing.st"})
    assert missing.status_code == 404 and "main.st" in missing.text
    assert cell.as_viewer("POST", "/programs/monitor", json={"path": "main.st", "from_line": 0}).status_code == 422


def test_watch_lists_are_kept_with_the_set_saved_by_an_operator_and_follow_an_edit(cell):
    url = f"/sets/{cell.base}/watches/cell"
    assert cell.as_viewer("PUT", url, json={"paths": ["Main.count"]}).status_code == 403
    r = cell.call("PUT", url, json={"paths": ["Main.count", "Main.pulse.Q"]})
    assert r.status_code == 200, r.text
    assert r.json()["config"] == {"paths": ["Main.count", "Main.pulse.Q"]}
    listed = cell.as_viewer("GET", f"/sets/{cell.base}/watches").json()
    assert [w["name"] for w in listed["watches"]] == ["cell"]
    assert cell.as_viewer("GET", url).json()["config"]["paths"] == ["Main.count", "Main.pulse.Q"]
    assert cell.call("PUT", f"/sets/{cell.base}/watches/-x", json={"paths": []}).status_code == 400
    assert cell.call("PUT", url, json={"paths": "Main.count"}).status_code == 422
    assert any(e.get("action") == "watch_save" for e in _audit(cell))

    # an edit applied from the editor: the new set has the list too
    edited = MAIN.replace("count := count + 1;", "count := count + 2;")
    r = cell.post("/programs/apply", json={"path": "main.st", "source": edited, "activate": False})
    assert r.status_code == 200, r.text
    derived = r.json()["set"]["id"]
    assert cell.get(f"/sets/{derived}/watches/cell").json()["config"]["paths"] == ["Main.count", "Main.pulse.Q"]

    assert cell.call("DELETE", url).status_code == 204
    assert cell.as_viewer("GET", url).status_code == 404


def _audit(cell: Cell) -> list[dict]:
    r = cell.get("/audit")
    assert r.status_code == 200, r.text
    body = r.json()
    return body["entries"] if isinstance(body, dict) else body


NOT_FINITE = """\
PROGRAM Counter
VAR
  zero : REAL;
  nan : REAL;
  inf : LREAL;
END_VAR
nan := zero / zero;
inf := 1.0 / zero;
END_PROGRAM
"""


def test_a_float_that_is_not_finite_reads_as_null(tmp_path):
    """REAL division is IEEE's (docs/st.md): 0/0 is NaN and 1/0 an infinity, which JSON has no number
    for; both reads answer them as null, not a failure of the whole answer."""
    cell = running(tmp_path, NOT_FINITE)
    try:
        r = cell.as_viewer("POST", "/variables/read", json={"paths": ["Main.nan", "Main.inf", "Main.zero"]})
        assert r.status_code == 200, r.text
        assert [(v["path"], v["value"]) for v in r.json()["values"]] == [
            ("Main.nan", None),
            ("Main.inf", None),
            ("Main.zero", 0.0),
        ]
        values = {o["path"]: o["value"] for o in monitor(cell, from_line=7, to_line=8)["occurrences"]}
        assert values == {"Main.nan": None, "Main.inf": None, "Main.zero": 0.0}, values
    finally:
        cell.close()


GLOBALS = """\
VAR_GLOBAL
  level : INT := 7;
END_VAR
PROGRAM Counter
VAR_EXTERNAL
  level : INT;
END_VAR
VAR
  high : BOOL;
END_VAR
high := level > 5;
IF level > 5 THEN
  high := TRUE;
END_IF;
END_PROGRAM
"""


def test_a_var_external_shows_its_global_variable(tmp_path):
    """The editor's monitor places a VAR_EXTERNAL's value, read from its VAR_GLOBAL's shared variable,
    and evaluates the conditions that name it."""
    c = running(tmp_path, GLOBALS)
    try:
        answer = monitor(c, from_line=11, to_line=13)
        at = {(o["line"], o["column"]): o for o in answer["occurrences"]}
        level = at[(11, 9)]
        assert level["value"] == 7 and level["type"] == "INT" and not level["group"], level
        conditions = {(x["line"], x["what"]): x for x in answer["conditions"]}
        assert conditions[(12, "IF")]["value"] is True, conditions
        write(c, level["path"], 2)
        after = monitor(c, from_line=11, to_line=13)
        assert {(o["line"], o["column"]): o["value"] for o in after["occurrences"]}[(11, 9)] == 2
        assert {(x["line"], x["what"]): x["value"] for x in after["conditions"]}[(12, "IF")] is False
    finally:
        c.close()

"""test_diagram_api.py -- the live view's API (docs/programming.md "The live view") against a real
agent beside a real irpd: a set holding a real PLCopen XML project drawn in another tool (read in
place from ../shared/plcopen) is listed with each POU's body language; GET /programs/diagram answers
its LD POU as drawn in the file (rails, contacts normal and negated, coils, wires with the file's
polylines); POST /programs/diagram/monitor answers, from one read of the shared memory, the value
leaving each element as the translation computes it (an input written makes its rung conduct: the
contacts, the coil, the wires into it) and the variables the elements show; bad requests are named.
Every POU of every shared project is drawn (elements and wires as many as the file has)."""

from __future__ import annotations

import sys
import time

import httpx
import pytest
from agent_helpers import IRPD
from live_processes import ROOT
from lxml import etree
from test_programs_api import Cell

sys.path.insert(0, str(ROOT / "tests" / "python" / "plcopen"))
from plcopen_live import SHARED, WHERE, shared  # noqa: E402  (the shared projects, read in place)

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")
XOR = "tutorial_xor_xnor"


@pytest.fixture
def cell(tmp_path):
    c = Cell(tmp_path)
    files = [("files", ("plc.xml", shared(XOR).read_bytes()))]  # built by the agent (stc) as it is stored
    stored = c.upload(files)
    r = c.post(f"/sets/{stored['id']}/activate", json={"mode": "auto"})
    assert r.status_code == 200, r.text
    c.base = stored["id"]
    yield c
    c.close()


def xml_helpers():
    import plcopen_xml  # tests/python/plcopen: PLCopen XML written in a few lines

    return plcopen_xml


def diagram(cell: Cell, pou: str, path: str = "plc.xml") -> httpx.Response:
    return cell.as_viewer("GET", "/programs/diagram", params={"path": path, "pou": pou})


def test_a_viewer_lists_the_pous_and_gets_the_ladder_as_drawn_in_the_file(cell):
    listed = cell.as_viewer("GET", "/programs").json()
    files = {f["path"]: f for f in listed["files"]}
    assert files["plc.xml"]["plcopen"] is True
    assert [(p["name"], p["kind"], p["language"]) for p in files["plc.xml"]["pous"]] == [
        ("XOR_and_XNOR", "PROGRAM", "LD"),
        ("Config0", "CONFIGURATION", None),
    ]
    r = diagram(cell, "XOR_and_XNOR")
    assert r.status_code == 200, r.text
    d = r.json()
    assert (d["pou"], d["kind"], d["language"], d["set_id"]) == ("XOR_and_XNOR", "PROGRAM", "LD", cell.base)
    by_id = {e["id"]: e for e in d["elements"]}
    assert by_id[1]["kind"] == "leftPowerRail" and len(by_id[1]["outputs"]) == 5
    assert by_id[2]["kind"] == "rightPowerRail"
    assert (by_id[3]["kind"], by_id[3]["label"], by_id[3]["negated"]) == ("contact", "INPUT_0", False)
    assert (by_id[5]["kind"], by_id[5]["label"], by_id[5]["negated"]) == ("contact", "INPUT_0", True)
    assert (by_id[7]["kind"], by_id[7]["label"], by_id[7]["storage"]) == ("coil", "OUTPUT_0", "none")
    assert (by_id[3]["x"], by_id[3]["y"], by_id[3]["width"], by_id[3]["height"]) == (160, 100, 21, 20)
    assert by_id[3]["inputs"][0] | {"x": 160, "y": 110} == by_id[3]["inputs"][0]  # relPosition made absolute
    assert by_id[8]["kind"] == "comment" and "XOR" in by_id[8]["label"]
    into_coil = [w for w in d["wires"] if w["to_id"] == 7]  # the two parallel branches OR-ed into the coil
    assert sorted(w["from_id"] for w in into_coil) == [5, 6]
    assert [w["points"] for w in into_coil if w["from_id"] == 5][0] == [[530, 110], [420, 110], [420, 170], [361, 170]]
    assert d["width"] >= 720 and d["height"] >= 350


def monitor(cell: Cell) -> dict:
    r = cell.as_viewer("POST", "/programs/diagram/monitor", json={"path": "plc.xml", "pou": "XOR_and_XNOR"})
    assert r.status_code == 200, r.text
    answer = r.json()
    answer["flow"] = {(f["id"], f["pin"]): f["value"] for f in answer["flows"]}
    answer["value"] = {e["id"]: e for e in answer["elements"]}
    return answer


def test_the_monitor_answers_the_power_the_translation_computes_from_the_running_values(cell):
    """Rung 1 is INPUT_0 AND NOT INPUT_1 OR NOT INPUT_0 AND INPUT_1 -> OUTPUT_0: all FALSE, nothing
    after the rail conducts; INPUT_0 written TRUE, contact 3 and the negated contact 6 conduct, and so
    the coil 7, whose variable the running program sets in the same answer."""
    answer = monitor(cell)
    assert answer["instance"] == "instance0" and answer["set_id"] == cell.base
    assert answer["flow"][(1, None)] is True  # the left rail
    assert (answer["flow"][(3, None)], answer["flow"][(6, None)], answer["flow"][(7, None)]) == (False, False, False)
    assert answer["value"][3] | {"path": "instance0.INPUT_0", "value": False, "forced": False} == answer["value"][3]
    assert answer["value"][7]["path"] == "instance0.OUTPUT_0" and answer["value"][7]["value"] is False
    r = cell.call("PUT", "/variables/instance0.INPUT_0", json={"value": True})
    assert r.status_code == 200, r.text
    deadline = time.monotonic() + 10
    while not (answer := monitor(cell))["value"][7]["value"]:
        assert time.monotonic() < deadline, "OUTPUT_0 does not follow INPUT_0: the program does not run"
        time.sleep(0.05)
    flow = answer["flow"]
    assert (flow[(3, None)], flow[(6, None)], flow[(7, None)]) == (True, True, True)
    assert (flow[(4, None)], flow[(5, None)]) == (False, False)  # the other branch: INPUT_1, NOT INPUT_0
    # rung 2, XNOR of INPUT_2 = INPUT_3 = FALSE: the branch of the negated contacts 10, 12 conducts
    assert (flow[(11, None)], flow[(12, None)], flow[(13, None)]) == (False, True, True)
    assert answer["value"][3]["value"] is True


def test_an_sfc_function_blocks_steps_are_shown_active_with_their_time(tmp_path):
    """beremiz_first_steps (read in place): its SFC counter is a function block; the view shows its
    first instance in the running program, plc_task_instance.CounterSFC0: with Reset FALSE the step
    Count is active and its time grows; Reset written TRUE, the chart goes through Start to
    ResetCounter.  The LD counter's block and variables show that instance's values."""
    c = Cell(tmp_path)
    try:
        stored = c.upload([("files", ("plc.xml", shared("beremiz_first_steps").read_bytes()))])
        assert c.post(f"/sets/{stored['id']}/activate", json={"mode": "auto"}).status_code == 200

        def steps() -> dict:
            r = c.as_viewer("POST", "/programs/diagram/monitor", json={"path": "plc.xml", "pou": "CounterSFC"})
            assert r.status_code == 200, r.text
            assert r.json()["instance"] == "plc_task_instance.CounterSFC0"
            return {e["path"].rsplit(".", 1)[1]: e for e in r.json()["elements"]}

        first = steps()
        assert (first["Start"]["active"], first["ResetCounter"]["active"], first["Count"]["active"]) == (
            False,
            False,
            True,
        )
        deadline = time.monotonic() + 10
        while steps()["Count"]["time_ms"] <= first["Count"]["time_ms"]:
            assert time.monotonic() < deadline, "the active step's time does not grow"
            time.sleep(0.1)
        assert c.call("PUT", "/variables/plc_task_instance.Reset", json={"value": True}).status_code == 200
        while not steps()["ResetCounter"]["active"]:
            assert time.monotonic() < deadline, "Reset TRUE does not take the chart to ResetCounter"
            time.sleep(0.1)
        r = c.as_viewer("POST", "/programs/diagram/monitor", json={"path": "plc.xml", "pou": "CounterLD"})
        ld = r.json()
        assert ld["instance"] == "plc_task_instance.CounterLD0"
        shown = {e["path"]: e["value"] for e in ld["elements"]}
        assert shown["plc_task_instance.CounterLD0.Reset"] is True
    finally:
        c.close()


def test_a_drawn_function_blocks_values_are_its_instances_and_its_globals(tmp_path):
    """A program (LD) calls a function block drawn in FBD: Total := ADD(Total, Step) with Step a
    VAR_EXTERNAL of a configuration global, Limit a CONSTANT one compared by GT.  The FB's view shows
    its instance instance0.Acc: the ADD and GT blocks folded as their operators, the global's value
    through the VAR_EXTERNAL, the constant folded."""
    x = xml_helpers()
    fb = x.pou(
        "Accumulate",
        "functionBlock",
        x.section("outputVars", x.var("Total", "DINT"), x.var("Over", "BOOL"))
        + x.section("externalVars", x.var("Step", "DINT"))
        + x.section("externalVars", x.var("Limit", "DINT"), constant="true"),
        "FBD",
        x.in_var(1, "Total", 0, 0)
        + x.in_var(2, "Step", 0, 40)
        + x.block(3, "ADD", {"IN1": 1, "IN2": 2}, ["OUT"], 100, 0)
        + x.out_var(4, "Total", (3, "OUT"), 200, 0)
        + x.in_var(5, "Limit", 100, 100)
        + x.block(6, "GT", {"IN1": (3, "OUT"), "IN2": 5}, ["OUT"], 200, 100)
        + x.out_var(7, "Over", (6, "OUT"), 300, 100),
    )
    main = x.pou(
        "Main",
        "program",
        x.section("localVars", x.var("Acc", "<derived name=\"Accumulate\"/>")),
        "FBD",
        x.block(1, "Accumulate", {}, ["Total"], 0, 0, instance="Acc"),
    )
    conf = (
        '<configuration name="Config0"><resource name="Res0"><task name="task0" priority="1" interval="T#10ms">'
        '<pouInstance name="instance0" typeName="Main"/></task></resource>'
        f"{x.section('globalVars', x.var('Step', 'DINT', '3'))}"
        f"{x.section('globalVars', x.var('Limit', 'DINT', '1000000000'), constant='true')}</configuration>"
    )
    c = Cell(tmp_path)
    try:
        stored = c.upload([("files", ("plc.xml", x.project(fb, main, instances=conf)))])
        assert c.post(f"/sets/{stored['id']}/activate", json={"mode": "auto"}).status_code == 200
        r = c.as_viewer("POST", "/programs/diagram/monitor", json={"path": "plc.xml", "pou": "Accumulate"})
        assert r.status_code == 200, r.text
        answer = r.json()
        assert answer["instance"] == "instance0.Acc"
        flow = {(f["id"], f["pin"]): f for f in answer["flows"]}
        assert flow[(2, None)]["value"] == 3 and flow[(2, None)]["reason"] is None  # the global, via VAR_EXTERNAL
        assert flow[(5, None)]["value"] == 1000000000 and flow[(5, None)]["constant"] is True
        total = flow[(1, None)]["value"]
        assert isinstance(total, int) and flow[(3, "OUT")]["value"] == total + 3  # ADD folded as +
        assert flow[(6, "OUT")]["value"] is False  # GT folded as >
        shown = {e["id"]: e for e in answer["elements"]}
        assert shown[4]["path"] == "instance0.Acc.Total"
    finally:
        c.close()


def test_a_changed_ladder_has_a_history_and_a_diff(cell):
    """The tutorial uploaded again with a comment changed: GET /programs/history lists both sets'
    plc.xml, GET /programs/diff shows the changed line."""
    changed = shared(XOR).read_bytes().replace(b"LOGIC Gate | XOR |", b"LOGIC Gate | exclusive OR |")
    second = cell.upload([("files", ("plc.xml", changed))])
    r = cell.as_viewer("GET", "/programs/history", params={"path": "plc.xml"})
    assert r.status_code == 200, r.text
    assert {v["set_id"] for v in r.json()["versions"]} == {cell.base, second["id"]}
    r = cell.as_viewer("GET", "/programs/diff", params={"path": "plc.xml", "old": cell.base, "new": second["id"]})
    assert r.status_code == 200, r.text
    assert "-                <xhtml:p><![CDATA[LOGIC Gate | XOR |]]></xhtml:p>" in r.json()["diff"]
    assert "+                <xhtml:p><![CDATA[LOGIC Gate | exclusive OR |]]></xhtml:p>" in r.json()["diff"]


def test_bad_requests_are_named(cell):
    assert httpx.get(f"{cell.url}/programs/diagram", params={"path": "plc.xml", "pou": "x"}).status_code == 401
    body = {"path": "plc.xml", "pou": "XOR_and_XNOR"}
    assert httpx.post(f"{cell.url}/programs/diagram/monitor", json=body).status_code == 401
    r = diagram(cell, "Nope")
    assert r.status_code == 404 and "no POU 'Nope'" in r.text and "XOR_and_XNOR" in r.text, r.text
    r = diagram(cell, "XOR_and_XNOR", path="main.xml")
    assert r.status_code == 404 and "no PLCopen XML file 'main.xml'" in r.text and "plc.xml" in r.text, r.text
    r = cell.as_viewer("POST", "/programs/diagram/monitor", json={"path": "plc.xml", "pou": "Nope"})
    assert r.status_code == 404 and "no POU 'Nope'" in r.text, r.text
    r = cell.as_viewer("POST", "/programs/diagram/monitor", json={"path": "plc.xml", "pou": "XOR_and_XNOR", "x": 1})
    assert r.status_code == 422 and "x" in r.text, r.text
    r = cell.as_viewer("GET", "/programs/diagram", params={"path": "plc.xml", "pou": "XOR_and_XNOR", "set": "f" * 16})
    assert r.status_code == 404 and "no set" in r.text, r.text


def test_all_shared_projects_are_drawn_element_by_element():
    """Every POU of the nine projects: as many elements as the body has localIds, as many wires as
    connections, each wire's points as written (LD, FBD, SFC, and ST/IL bodies as text)."""
    from indurop_agent.sets import plc_diagram

    stc = ROOT / "st" / "stc"
    projects = sorted(p.name for p in SHARED.iterdir() if (p / "plc.xml").is_file()) if SHARED.is_dir() else []
    if not projects:
        pytest.skip(f"the shared PLCopen projects are not at {SHARED} ({WHERE})")
    kinds: set[str] = set()
    for name in projects:
        found = plc_diagram.project(stc, SHARED / name / "plc.xml", "plc.xml")
        root = etree.parse(str(SHARED / name / "plc.xml")).getroot()
        for pou in plc_diagram.outline(found):
            if pou["kind"] == "CONFIGURATION":
                continue
            d = plc_diagram.diagram(found, pou["name"])
            if pou["language"] not in plc_diagram.GRAPHICAL:
                assert d["elements"] == [] and d["text"], (name, pou["name"])
                continue
            body = next(b for p in root.iter("{*}pou") if p.get("name") == pou["name"] for b in p.find("{*}body"))
            ids = [el for el in body if isinstance(el.tag, str) and el.get("localId") is not None]
            assert len(d["elements"]) == len(ids), (name, pou["name"])
            connections = [c for el in ids for c in el.iter("{*}connection")]
            assert len(d["wires"]) == len(connections), (name, pou["name"])
            kinds |= {e["kind"] for e in d["elements"]}
    assert {"contact", "coil", "block", "step", "transition", "actionBlock", "jumpStep", "connector"} <= kinds

"""test_online_layout.py -- online change of the shared-variable layout through the agent, against a
real irpd: GET /layout gives the running layout.json; an uploaded set whose layout adds a variable is
checked online with its variable changes, activated by a hot swap that keeps the counter module, and
the new variable is listed and read at once; a set laid out afresh is valid but needs a restart, and
activating it online is refused with the reason; an <executor> added and taken away again is swapped
in and out online while the counter module on main misses no period.  The dry run (upload
validation, POST /sets/{id}/check, `irpctl check`) refuses a new module built against a layout the
set's was not laid out from, with activation's error, and names the modules a load keeps, starts,
stops and replaces; every route the docs name for the running layout.json answers it.  Retyped
variables are converted at the swap: the dry run, irpctl and the swap report name them, and the one
that cannot be converted, and the values read through the agent are kept.  The
fixtures are built by tests/cpp/online/."""

from __future__ import annotations

import json
import re
import time
from pathlib import Path

import httpx
import pytest
from agent_helpers import BUILD, IRPD, ROOT, LiveCell, free_port

ONLINE = BUILD / "tests" / "cpp" / "online"
pytestmark = pytest.mark.skipif(
    not (ONLINE / "modules" / "oc_adder_v2.so").exists(), reason=f"the online-change fixtures are not built ({ONLINE})"
)


def module(name: str, file: str, extra: str = "") -> str:
    return (
        f"  <module><name>{name}</name><filename>{file}</filename><moduletype>thread</moduletype>"
        f"<operationtype>periodic</operationtype><period>1000000</period><priority>1</priority>{extra}</module>\n"
    )


def set_files(layout: str, *modules: tuple[str, ...], root: str = "") -> list[tuple[str, tuple[str, bytes]]]:
    """A set: module.xml (`root` at its top), its modules (name, fixture file[, tags inside the
    <module>]) and the layout of tests/cpp/online/oc_<layout>."""
    xml = "<root>\n  <layout>layout.json</layout>\n" + root + "".join(module(*m) for m in modules) + "</root>\n"
    files = [
        ("files", ("module.xml", xml.encode())),
        ("files", ("layout.json", (ONLINE / f"oc_{layout}" / "layout.json").read_bytes())),
    ]
    files += [("files", (f, (ONLINE / "modules" / f).read_bytes())) for f in dict.fromkeys(m[1] for m in modules)]
    return files


class Cell(LiveCell):
    """irpd on the v1 layout with the counter module (or on `layout` with module `first`: name,
    fixture file), and an agent."""

    def __init__(self, tmp: Path, layout: str = "v1", first: tuple[str, str] = ("counter", "oc_counter_v1.so")):
        folder = tmp / "start"
        folder.mkdir()
        (folder / "module.xml").write_text(
            "<root>\n  <layout>"
            + str(ONLINE / f"oc_{layout}" / "layout.json")
            + "</layout>\n"
            + module(first[0], str(ONLINE / "modules" / first[1]))
            + "</root>\n"
        )
        super().__init__(tmp, folder / "module.xml", instance=f"online-{free_port()}")


@pytest.fixture
def cell(tmp_path):
    c = Cell(tmp_path)
    yield c
    c.close()


def test_a_variable_added_online_is_planned_activated_and_read_at_once(cell):
    running = cell.call("GET", "/layout")
    assert running.status_code == 200, running.text
    assert json.loads(running.text)["hash"] == json.loads((ONLINE / "oc_v1" / "layout.json").read_text())["hash"]

    stored = cell.upload(set_files("v2", ("counter", "oc_counter_v2.so"), ("adder", "oc_adder_v2.so")))
    validation = stored["validation"]
    assert validation["valid"] is True and validation["online"] is True, validation
    assert validation["restart"] is None
    assert validation["variables"]["added"] == ["oc.added"] and validation["variables"]["removed"] == []
    planned = cell.call("POST", f"/sets/{stored['id']}/check")
    assert planned.status_code == 200, planned.text
    viewer = cell.call("POST", "/tokens", json={"name": "v", "role": "viewer"}).json()["token"]
    r = httpx.post(f"{cell.url}/sets/{stored['id']}/check", headers={"Authorization": f"Bearer {viewer}"})
    assert r.status_code == 403 and "needs the operator role" in r.json()["detail"]
    assert cell.call("POST", "/sets/0123456789abcdef/check").status_code == 404
    assert planned.json()["validation"]["variables"]["added"] == ["oc.added"]

    r = cell.call("POST", f"/sets/{stored['id']}/activate")
    assert r.status_code == 200, r.text
    report = r.json()
    assert report["kept"] == ["counter"] and report["started"] == ["adder"], report
    assert report["variables"]["added"] == ["oc.added"] and isinstance(report["missed_periods"], int)

    assert "oc.added" in [v["path"] for v in cell.call("GET", "/variables").json()["variables"]]
    deadline = time.monotonic() + 5
    while cell.call("GET", "/variables/oc.added").json()["value"] == 0:
        assert time.monotonic() < deadline, (
            "oc.added stayed 0: the adder does not run, or the agent reads the old layout"
        )
        time.sleep(0.05)
    assert json.loads(cell.call("GET", "/layout").text)["hash"] == report["variables"]["layout"]


def test_a_layout_laid_out_afresh_is_valid_but_needs_a_restart(cell):
    stored = cell.upload(set_files("reordered", ("counter", "oc_counter_reordered.so")))
    validation = stored["validation"]
    assert validation["valid"] is True and validation["online"] is False, validation
    assert "keeps its type but moves" in validation["restart"]["reason"]
    r = cell.call("POST", f"/sets/{stored['id']}/activate")
    assert r.status_code == 409, r.text
    assert "keeps its type but moves" in r.json()["detail"]
    assert cell.call("GET", "/status").json()["generation"] == 1
    # The managed restart runs it: the same irpd process, the new layout, the downtime measured.
    pid = cell.call("GET", "/status").json()["pid"]
    r = cell.call("POST", f"/sets/{stored['id']}/activate", json={"mode": "auto"})
    assert r.status_code == 200, r.text
    report = r.json()
    assert report["mode"] == "restart" and report["downtime_ns"] > 0, report
    status = cell.call("GET", "/status").json()
    assert status["pid"] == pid and status["set_id"] == stored["id"], status
    reordered = json.loads((ONLINE / "oc_reordered" / "layout.json").read_text())["hash"]
    assert json.loads(cell.call("GET", "/layout").text)["hash"] == reordered


def test_an_executor_added_and_taken_away_online_keeps_the_counter_counting(cell):
    side = cell.upload(
        set_files(
            "v2",
            ("counter", "oc_counter_v2.so"),
            ("adder", "oc_adder_v2.so", "<executor>side</executor>"),
            root="  <executor><name>side</name><rtpriority>30</rtpriority></executor>\n",
        )
    )
    assert side["validation"]["online"] is True and side["validation"]["restart"] is None, side["validation"]
    r = cell.call("POST", f"/sets/{side['id']}/activate")
    assert r.status_code == 200, r.text
    report = r.json()
    assert report["mode"] == "online" and report["kept"] == ["counter"] and report["started"] == ["adder"], report
    assert isinstance(report["missed_periods"], int), report  # a timing figure: reported, not asserted
    jitter = cell.call("GET", "/jitter").json()
    assert [e["name"] for e in jitter["executors"]] == ["dispatcher", "dispatcher@side"], jitter["executors"]
    adder = next(m for m in jitter["modules"] if m["name"] == "adder")
    assert adder["executor"] == "side"

    # The same modules without the executor: adder moves to main, the side thread goes.
    back = cell.upload(set_files("v2", ("counter", "oc_counter_v2.so"), ("adder", "oc_adder_v2.so")))
    r = cell.call("POST", f"/sets/{back['id']}/activate")
    assert r.status_code == 200, r.text
    report = r.json()
    assert report["kept"] == ["counter", "adder"] and isinstance(report["missed_periods"], int), report
    time.sleep(0.3)
    jitter = cell.call("GET", "/jitter").json()
    assert [e["name"] for e in jitter["executors"]] == ["dispatcher"], jitter["executors"]
    assert next(m for m in jitter["modules"] if m["name"] == "adder")["executor"] == "main"
    # The counter on main ran (or was skipped by policy) in every period of the dispatcher, late
    # or not (lateness is a timing figure, not asserted); a slot may be in flight between the two.
    counter = next(m for m in jitter["modules"] if m["name"] == "counter")
    main = jitter["executors"][0]
    assert abs((counter["runs"] + counter["skipped"]) - (main["runs"] + main["skipped"])) <= 1, (counter, main)


def test_a_module_built_against_a_layout_the_sets_was_not_laid_out_from_is_refused_by_the_dry_run(cell, capsys):
    """v3's layout.json was laid out against v2 and v1 (glbc --previous); the new adder was built
    against v3.glb compiled without --previous: upload validation, the dry run and irpctl refuse it
    with the error activation gives, naming the module and what to do, rather than saying online."""
    stored = cell.upload(set_files("v3", ("counter", "oc_counter_v1.so"), ("adder", "oc_adder_v3_afresh.so")))
    for validation in (stored["validation"], cell.call("POST", f"/sets/{stored['id']}/check").json()["validation"]):
        assert validation["valid"] is False and validation["online"] is False, validation
        assert validation["restart"] is None and validation["modules"] is None, validation
        [error] = validation["errors"]
        assert "module 'adder'" in error and "rebuild it against the set's .glb files" in error, error
        [problem] = validation["problems"]
        assert problem["module"] == "adder" and problem["file"] == "oc_adder_v3_afresh.so", problem
    code, out = cell.irpctl(capsys, "check", stored["id"])
    assert code == 1 and "NOT valid" in out and error in out, out

    r = cell.call("POST", f"/sets/{stored['id']}/activate", json={"mode": "auto"})
    assert r.status_code == 409, r.text
    assert error in r.json()["detail"], "activation refuses it with the dry run's error"
    assert cell.call("GET", "/status").json()["generation"] == 1


def test_the_dry_run_names_the_modules_kept_started_stopped_and_replaced(cell, capsys):
    first = cell.upload(set_files("v2", ("counter", "oc_counter_v2.so"), ("adder", "oc_adder_v2.so")))
    assert cell.call("POST", f"/sets/{first['id']}/activate").status_code == 200
    # counter the same; adder another code under its name (replaced); fresh new.
    stored = cell.upload(
        set_files("v2", ("counter", "oc_counter_v2.so"), ("adder", "oc_counter_v2.so"), ("fresh", "oc_adder_v2.so"))
    )
    planned = cell.call("POST", f"/sets/{stored['id']}/check").json()["validation"]
    fates = {"kept": ["counter"], "started": ["adder", "fresh"], "stopped": ["adder"], "replaced": ["adder"]}
    assert planned["modules"] == fates, planned
    assert stored["validation"]["modules"] == fates
    code, out = cell.irpctl(capsys, "check", stored["id"])
    assert code == 0, out
    assert "modules: kept counter; started adder, fresh; stopped adder; replaced adder" in out, out

    code, out = cell.irpctl(capsys, "activate", stored["id"])
    assert code == 0, out
    assert [line.split(None, 1)[1] for line in out.splitlines() if line.startswith("replaced")] == ["adder"], out
    report = cell.call("GET", "/sets/active").json()
    assert report["id"] == stored["id"]
    assert cell.call("POST", f"/sets/{stored['id']}/check").json()["validation"]["modules"] == {
        "kept": ["counter", "adder", "fresh"],
        "started": [],
        "stopped": [],
        "replaced": [],
    }, "once it runs, a dry run of the same set keeps every module"


def test_every_route_the_docs_name_for_the_running_layout_answers_it(cell):
    """docs name where to fetch the running layout.json (for glbc --previous): each answers it."""
    docs = ROOT / "docs"
    named = {
        m.group(1)
        for page in docs.glob("*.md")
        for m in re.finditer(r"`GET /api/v1(/[^` ]*layout[^` ]*)`", page.read_text())
    }
    assert "/layout" in named, named
    expected = json.loads((ONLINE / "oc_v1" / "layout.json").read_text())["hash"]
    for route in sorted(named):
        r = cell.call("GET", route)
        assert r.status_code == 200 and json.loads(r.text)["hash"] == expected, (route, r.status_code, r.text[:200])


def test_retyped_variables_are_converted_and_named_by_the_dry_run_irpctl_and_the_report(tmp_path, capsys):
    cell = Cell(tmp_path, "cv1", ("cv", "oc_cv_v1.so"))
    try:
        deadline = time.monotonic() + 5
        while cell.call("GET", "/variables/cv.wide").json()["value"] != -1234:
            assert time.monotonic() < deadline, "the cv module does not run"
            time.sleep(0.05)
        stored = cell.upload(set_files("cv2", ("cv", "oc_cv_v2.so")))
        validation = stored["validation"]
        assert validation["valid"] is True and validation["online"] is True, validation
        converted = {c["path"]: (c["from_type"], c["to_type"]) for c in validation["variables"]["converted"]}
        assert converted["cv.wide"] == ("int16_t", "int32_t") and len(converted) == 6, validation
        assert validation["variables"]["moved"] == [], validation
        code, out = cell.irpctl(capsys, "check", stored["id"])
        assert code == 0, out
        assert "cv.wide (int16_t -> int32_t)" in out and "online: yes" in out, out

        code, out = cell.irpctl(capsys, "activate", stored["id"])
        assert code == 0, out
        assert "converted cv.fb (cv.fb_t -> cv.fb_t)" in out, out
        report = cell.call("GET", "/sets/active").json()
        assert report["id"] == stored["id"], report
        values = {p: cell.call("GET", f"/variables/{p}").json()["value"] for p in ("cv.wide", "cv.f", "cv.arr[2]")}
        assert values == {"cv.wide": -1234, "cv.f": 1.5, "cv.arr[2]": 30}
        assert cell.call("GET", "/variables/cv.arr[4]").json()["value"] == 0
        assert cell.call("GET", "/variables/cv.narrow").json()["value"] == 70000
    finally:
        cell.close()

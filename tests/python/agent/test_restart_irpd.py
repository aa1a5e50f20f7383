"""test_restart_irpd.py -- activation modes against a REAL irpd and a real agent on loopback
(docs/set-store.md): a set irpd cannot take online (Figure 1 with a fourth process module, on an irpd
started with room for three) is refused
in mode online, naming why and what mode restart would do; mode restart (and auto) restarts irpd
onto it -- the same pid -- and records it like any activation; a restart whose set does not start
brings irpd back on its old set and changes nothing in the store."""

from __future__ import annotations

import json

import pytest
from agent_helpers import BUILD, IRPD
from test_sets_irpd import FIG1_DIR, Cell

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")

# One process module more than the three of Figure 1 (cntr4.exe once more, under another name).
FOURTH = (
    b"  <module><name>cntr5</name><filename>./cntr4.exe</filename><moduletype>process</moduletype>"
    b"<operationtype>periodic</operationtype><period>1000000</period><priority>5</priority></module>\n</root>"
)
INIT_THROWS = BUILD / "tests" / "cpp" / "modules" / "init_throws.so"  # a real module whose initialize() throws


def fig1_files(fourth: bool = False, broken_module: bool = False) -> list[tuple[str, tuple[str, bytes]]]:
    """The built Figure 1 set as `files` parts; with a fourth process module (on an irpd with
    three control slots a change only a restart can take), and with cntr1's file replaced by a module whose initialize() throws (irpd's check passes
    it -- the file is there -- but the set cannot start)."""
    out = []
    for p in sorted(FIG1_DIR.rglob("*")):
        if p.is_file():
            content = p.read_bytes()
            if p.name == "module.xml" and fourth:
                content = content.replace(b"</root>", FOURTH, 1)
            if broken_module and p.name == "cntr1.so":
                content = INIT_THROWS.read_bytes()
            out.append(("files", (str(p.relative_to(FIG1_DIR)), content)))
    return out


@pytest.fixture
def cell(tmp_path):
    c = Cell(tmp_path, "--process-slots", "3")
    yield c
    c.close()


def upload(cell, **variant) -> dict:
    r = cell.post("/sets", files=fig1_files(**variant))
    assert r.status_code == 201, r.text
    return r.json()


def test_online_refuses_a_set_that_needs_a_restart_and_says_why(cell):
    base = upload(cell)
    cell.activate(base["id"])
    side = upload(cell, fourth=True)
    assert side["validation"]["valid"] is True, side["validation"]
    r = cell.post(f"/sets/{side['id']}/activate")  # no body: mode online
    assert r.status_code == 409, r.text
    detail = r.json()["detail"]
    assert "process modules" in detail and "mode restart" in detail and "expected downtime" in detail, detail
    r = cell.post(f"/sets/{side['id']}/activate", json={"mode": "online"})
    assert r.status_code == 409, r.text
    assert cell.get("/status").json()["set_id"] == base["id"]
    assert cell.get("/sets/active").json()["id"] == base["id"]


def test_mode_restart_restarts_irpd_onto_the_set_with_the_same_pid(cell):
    base = upload(cell)
    cell.activate(base["id"])
    pid = cell.get("/status").json()["pid"]
    assert pid == cell.irpd.pid
    side = upload(cell, fourth=True)
    r = cell.post(f"/sets/{side['id']}/activate", json={"mode": "restart"})
    assert r.status_code == 200, r.text
    report = r.json()
    assert report["mode"] == "restart" and report["set_id"] == side["id"], report
    assert report["downtime_ns"] > 0 and report["missed_periods"] is None, report
    print(
        f"agent restart: downtime {report['downtime_ns'] / 1e6:.1f} ms, "
        f"expected {report['expected_downtime_ns'] / 1e6:.1f} ms"
    )
    status = cell.get("/status").json()
    assert status["set_id"] == side["id"] and status["pid"] == pid and cell.irpd.poll() is None
    assert status["last_restart"]["downtime_ns"] == report["downtime_ns"]
    history = [json.loads(line) for line in (cell.data / "history.jsonl").read_text().splitlines()]
    assert [(h["action"], h["set_id"]) for h in history] == [("activate", base["id"]), ("restart", side["id"])]
    assert history[-1]["mode"] == "restart" and history[-1]["downtime_ns"] == report["downtime_ns"]
    active = cell.get("/sets/active").json()
    assert active["id"] == side["id"] and active["action"] == "restart" and active["rollback_to"] == base["id"]
    audit = [e for e in cell.get("/audit").json() if e["action"] == "activate"][-1]  # the route's action
    assert audit["result"] == "ok" and audit["mode"] == "restart" and audit["downtime_ns"] == report["downtime_ns"]
    kinds = [e["kind"] for e in cell.get("/events").json()["events"]]
    assert "restart" in kinds  # irpd's
    # The watcher left it alone: still the new set, no restore.
    assert not [e for e in cell.get("/audit").json() if e["action"] == "restore"]
    # Back with auto: the restart made room for four processes, so the old set goes online.
    r = cell.post("/sets/rollback", json={"mode": "auto"})
    assert r.status_code == 200 and r.json()["mode"] == "online" and r.json()["set_id"] == base["id"], r.text
    assert cell.get("/status").json()["pid"] == pid


def test_a_restart_whose_set_does_not_start_comes_back_and_changes_nothing(cell):
    base = upload(cell)
    cell.activate(base["id"])
    broken = upload(cell, broken_module=True)
    before = (cell.data / "active.json").read_text(), (cell.data / "history.jsonl").read_text()
    r = cell.post(f"/sets/{broken['id']}/activate", json={"mode": "restart"})
    assert r.status_code == 409, r.text
    detail = r.json()["detail"]
    assert f"irpd could not start set {broken['id']}" in detail and f"came back on set {base['id']}" in detail, detail
    status = cell.get("/status").json()
    assert status["set_id"] == base["id"] and status["last_restart"]["fell_back"] is True
    assert ((cell.data / "active.json").read_text(), (cell.data / "history.jsonl").read_text()) == before


def test_an_unknown_mode_is_refused(cell):
    base = upload(cell)
    r = cell.post(f"/sets/{base['id']}/activate", json={"mode": "sometimes"})
    assert r.status_code == 422, r.text

"""test_sets_irpd.py -- sets, hot reload, module changes, variable writes, events and restore
against a REAL irpd speaking control protocol VERSION 2 (notes: contract-v2), with a real agent,
both on loopback.

THESE TESTS NEED irpd v2 (commands check, load, set_period, set_priority, enable, disable, events,
write; `status` with set_id).  Against irpd v1 they FAIL on purpose -- the first one,
test_irpd_speaks_control_protocol_v2, says so plainly -- instead of being skipped: they are the
end-to-end check of the agent's set work and must run once irpd v2 is in.

The sets are the paper's Figure 1 set as built in build/sets/paper-fig1 (every module kind), and
variants of it that differ in module.xml only.
"""

from __future__ import annotations

import json
import socket
import time
from pathlib import Path

import httpx
import pytest
from agent_helpers import BUILD, FIG1, IRPD, LiveCell, free_port, start_agent, start_irpd, stop

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")

FIG1_DIR = FIG1.parent


def fig1_files(cntr1_period: str = "500000") -> list[tuple[str, tuple[str, bytes]]]:
    """The built Figure 1 set as `files` parts; cntr1's period changed to make a variant."""
    out = []
    for p in sorted(FIG1_DIR.rglob("*")):
        if p.is_file():
            content = p.read_bytes()
            if p.name == "module.xml":
                content = content.replace(b"<period>500000</period>", f"<period>{cntr1_period}</period>".encode(), 1)
            out.append(("files", (str(p.relative_to(FIG1_DIR)), content)))
    return out


class Cell(LiveCell):
    """irpd (Figure 1) and an agent that polls it every 0.2 s, with the admin token."""

    def __init__(self, tmp: Path, *irpd_args: str):
        super().__init__(tmp, FIG1, *irpd_args)

    def upload_fig1(self, cntr1_period: str = "500000") -> dict:
        return self.upload(fig1_files(cntr1_period))

    def activate(self, set_id: str) -> dict:
        r = self.post(f"/sets/{set_id}/activate")
        assert r.status_code == 200, r.text
        return r.json()

    def module(self, name: str) -> dict:
        r = self.get(f"/modules/{name}")
        assert r.status_code == 200, r.text
        return r.json()

    def wait_for_set(self, set_id: str, seconds: float = 15) -> dict:
        deadline = time.monotonic() + seconds
        while True:
            status = self.get("/status").json() if self.get("/health").json()["irpd"] == "ok" else {}
            if status.get("set_id") == set_id:
                return status
            assert time.monotonic() < deadline, f"irpd still runs set {status.get('set_id')}, not {set_id}"
            time.sleep(0.1)


@pytest.fixture
def cell(tmp_path):
    c = Cell(tmp_path)
    yield c
    c.close()


def test_irpd_speaks_control_protocol_v2(cell):
    with socket.socket(socket.AF_UNIX) as s:
        s.connect(str(cell.sock))
        hello = json.loads(s.makefile().readline())
    assert hello["version"] == 2, f"irpd speaks control protocol {hello['version']}: these tests need irpd v2"


def test_an_upload_is_checked_by_irpd(cell):
    s = cell.upload_fig1()
    assert s["validation"]["valid"] is True, s["validation"]
    assert s["validation"]["errors"] == []
    running = cell.get("/schedule").json()
    assert s["validation"]["schedule"]["slots"] == running["slots"]  # the same set as the running one


def test_a_set_irpd_finds_wrong_is_stored_with_irpds_errors(cell):
    s = cell.upload_fig1(cntr1_period="10000")  # a basic period of 10 us: under irpd's 50 us minimum
    assert s["validation"]["valid"] is False
    assert s["validation"]["errors"] and any("module.xml" in e for e in s["validation"]["errors"])
    assert cell.get(f"/sets/{s['id']}").json()["validation"] == s["validation"]


def test_irpds_errors_of_a_stored_set_say_the_file_line_column_module_and_field(cell):
    s = cell.upload_fig1(cntr1_period="abc")  # irpd's parser: "<set>/module.xml:13: module 'cntr1': <period>: ..."
    line = FIG1.read_text().splitlines().index("    <period>500000</period>") + 1
    where = {"file": "module.xml", "line": line, "column": 5, "module": "cntr1", "field": "period"}
    validation = s["validation"]
    assert validation["valid"] is False
    problem = validation["problems"][0]
    assert problem["message"] == validation["errors"][0]
    assert {k: problem[k] for k in where} == where, validation
    assert cell.get(f"/sets/{s['id']}").json()["validation"]["problems"] == validation["problems"]
    r = cell.post(f"/sets/{s['id']}/activate")
    assert r.status_code == 409, r.text
    assert {k: r.json()[k] for k in where} == where, r.json()
    assert f"module.xml:{line}: module 'cntr1': <period>" in r.json()["detail"]


def test_a_schedule_error_names_module_xml_without_a_line(cell):
    s = cell.upload_fig1(cntr1_period="10000")
    problem = s["validation"]["problems"][0]
    assert problem["file"] == "module.xml" and problem["line"] is None and "minimum basic period" in problem["message"]


def test_activation_hot_swaps_irpd_to_the_set_and_records_it(cell):
    s = cell.upload_fig1()
    report = cell.activate(s["id"])
    assert report["set_id"] == s["id"] and report["generation"] >= 1
    assert report["set"] == str(cell.data / "sets" / s["id"] / "files" / "module.xml")
    assert {"kept", "started", "stopped", "missed_periods", "swap_cycle"} <= set(report)
    status = cell.get("/status").json()
    assert status["set_id"] == s["id"] and status["running"] is True
    active = cell.get("/sets/active").json()
    assert active["id"] == s["id"] and active["action"] == "activate" and active["rollback_to"] is None
    assert json.loads((cell.data / "active.json").read_text())["set_id"] == s["id"]
    assert (cell.data / "active").resolve() == (cell.data / "sets" / s["id"] / "files").resolve()
    history = [json.loads(line) for line in (cell.data / "history.jsonl").read_text().splitlines()]
    assert [(h["action"], h["set_id"]) for h in history] == [("activate", s["id"])]
    assert [m["name"] for m in cell.get("/modules").json()] == [
        "cntr1",
        "cntr2",
        "cntr3",
        "cntr4",
        "event1",
        "visionEvt",
        "nonReaTime",
    ]


def test_a_refused_activation_changes_nothing(cell):
    good = cell.upload_fig1()
    cell.activate(good["id"])
    bad = cell.upload_fig1(cntr1_period="10000")
    before = (cell.data / "active.json").read_text(), (cell.data / "history.jsonl").read_text()
    r = cell.post(f"/sets/{bad['id']}/activate")
    assert r.status_code == 409 and "module.xml" in r.json()["detail"], r.text
    assert cell.get("/status").json()["set_id"] == good["id"]
    assert ((cell.data / "active.json").read_text(), (cell.data / "history.jsonl").read_text()) == before
    assert cell.get("/sets/active").json()["id"] == good["id"]


def test_rollback_goes_back_to_the_set_active_before(cell):
    a, b = cell.upload_fig1(), cell.upload_fig1(cntr1_period="1000000")
    cell.activate(a["id"])
    cell.activate(b["id"])
    assert cell.module("cntr1")["period_ns"] == 1000000
    r = cell.post("/sets/rollback")
    assert r.status_code == 200 and r.json()["set_id"] == a["id"], r.text
    assert cell.get("/status").json()["set_id"] == a["id"]
    assert cell.module("cntr1")["period_ns"] == 500000
    r = cell.post("/sets/rollback")
    assert r.status_code == 409 and "nothing to roll back to" in r.json()["detail"]


def test_a_restarted_irpd_gets_the_active_set_back(cell):
    a, b = cell.upload_fig1(), cell.upload_fig1(cntr1_period="1000000")
    cell.activate(a["id"])
    cell.activate(b["id"])
    stop(cell.irpd)
    cell.irpd = start_irpd(cell.sock)  # the Figure 1 set, no set_id
    cell.wait_for_set(b["id"])
    assert cell.module("cntr1")["period_ns"] == 1000000
    kinds = [e["kind"] for e in cell.get("/events").json()["events"] if e["source"] == "agent"]
    assert kinds.count("irpd_connected") == 2 and "restore" in kinds  # (irpd_lost only if a poll fell in the gap)
    restore = [e for e in cell.get("/audit").json() if e["action"] == "restore"][-1]
    assert restore["result"] == "ok" and restore["target"] == b["id"]
    assert cell.get("/sets/active").json()["rollback_to"] == a["id"]  # a restore is not a new step


def test_a_restarted_agent_restores_and_irpd_can_start_from_the_active_link(cell):
    s = cell.upload_fig1(cntr1_period="1000000")
    cell.activate(s["id"])
    stop(cell.agent)
    stop(cell.irpd)
    cell.irpd = start_irpd(cell.sock, config=cell.data / "active" / "module.xml")
    cell.agent = start_agent(cell.port, cell.data, cell.sock, "--config", str(cell.config))
    status = cell.wait_for_set(s["id"])
    assert status["running"] is True
    assert cell.module("cntr1")["period_ns"] == 1000000


def test_patch_changes_a_running_module(cell):
    r = httpx.patch(f"{cell.url}/modules/cntr1", json={"period_ns": 1000000}, headers=cell.h, timeout=40)
    assert r.status_code == 200, r.text
    assert len(r.json()["reports"]) == 1 and r.json()["generation"] >= 1
    assert cell.module("cntr1")["period_ns"] == 1000000
    r = httpx.patch(f"{cell.url}/modules/cntr1", json={"priority": 7, "enabled": False}, headers=cell.h, timeout=40)
    assert r.status_code == 200, r.text
    assert len(r.json()["reports"]) == 2 and r.json()["generation"] == r.json()["reports"][-1]["generation"]
    assert cell.module("cntr1")["priority"] == 7
    r = httpx.patch(f"{cell.url}/modules/nothing", json={"priority": 1}, headers=cell.h, timeout=40)
    assert r.status_code == 404
    r = httpx.patch(f"{cell.url}/modules/cntr2", json={"period_ns": 10000}, headers=cell.h, timeout=40)
    assert r.status_code == 409 and "nothing was changed" in r.json()["detail"], r.text
    assert cell.module("cntr2")["period_ns"] == 100000


def test_a_variable_write_goes_through_irpd(cell):
    r = httpx.put(f"{cell.url}/variables/joint[5].z", json={"value": 42.5}, headers=cell.h, timeout=10)
    assert r.status_code == 200 and r.json() == {"path": "joint[5].z", "value": 42.5}, r.text
    assert cell.get("/variables/joint[5].z").json()["value"] == 42.5
    r = httpx.put(f"{cell.url}/variables/joint[99].q", json={"value": 1}, headers=cell.h, timeout=10)
    assert r.status_code == 409, r.text
    line = [e for e in cell.get("/audit").json() if e["action"] == "write_variable"][0]
    assert (line["target"], line["value"], line["result"]) == ("joint[5].z", 42.5, "ok")


def test_events_merge_irpds_and_the_agents_by_time(cell):
    s = cell.upload_fig1()
    cell.activate(s["id"])
    page = cell.get("/events").json()
    assert page["irpd"] == "ok"
    sources = {e["source"] for e in page["events"]}
    assert sources == {"irpd", "agent"}
    assert any(e["source"] == "irpd" and e["kind"] == "swap" for e in page["events"])
    assert any(e["source"] == "agent" and e["kind"] == "activate" for e in page["events"])
    times = [e["time_ns"] for e in page["events"]]
    assert times == sorted(times)
    later = cell.get(f"/events?since={page['next']}&agent_since={page['agent_next']}").json()
    assert all(e["seq"] >= page["next"] for e in later["events"] if e["source"] == "irpd")


COUNTERS = BUILD / "tests" / "cpp" / "modules"


def counter_set(swap_version: int) -> list:
    """A set of two counter modules (tests/cpp/modules/counter.cpp): `keep` at the basic period,
    `swap` in the given version; uploading it again with the other version changes only swap."""
    xml = (
        b"<root>\n"
        b"  <module><name>keep</name><filename>keep.so</filename><moduletype>thread</moduletype>"
        b"<operationtype>periodic</operationtype><period>1000000</period><priority>1</priority></module>\n"
        b"  <module><name>swap</name><filename>swap.so</filename><moduletype>thread</moduletype>"
        b"<operationtype>periodic</operationtype><period>2000000</period><priority>2</priority></module>\n"
        b"</root>\n"
    )
    return [
        ("files", ("module.xml", xml)),
        ("files", ("keep.so", (COUNTERS / "counter_v1.so").read_bytes())),
        ("files", ("swap.so", (COUNTERS / f"counter_v{swap_version}.so").read_bytes())),
    ]


def test_upload_validate_activate_keeps_a_counter_counting_through_hot_reloads(cell):
    sets = []
    for version in (1, 2):
        r = cell.post("/sets", files=counter_set(version))
        assert r.status_code == 201, r.text
        assert r.json()["validation"]["valid"] is True, r.json()["validation"]
        sets.append(r.json()["id"])
    first = cell.activate(sets[0])  # from Figure 1 to the counters: everything new
    assert first["started"] == ["keep", "swap"]
    for i in range(4):
        report = cell.activate(sets[(i + 1) % 2])
        assert report["kept"] == ["keep"] and report["started"] == ["swap"], report
        assert report["set_id"] == sets[(i + 1) % 2]
        # keep's record goes on: one run per 1 ms period since it started, nothing lost to swaps
        jitter = cell.get("/jitter").json()
        keep = next(m for m in jitter["modules"] if m["name"] == "keep")
        assert keep["runs"] > 0
        assert keep["state"] == "running"
    status = cell.get("/status").json()
    assert status["generation"] == 6
    # keep and the dispatcher in one snapshot: keep is due in every slot, so its runs + skipped are
    # exactly the slots since it started (the dispatcher's runs + skipped count every slot since
    # irpd started; the first activation's swap_cycle is where keep came in): none lost to the
    # four swaps after it.  One slot may end between the two records' reads.
    jitter = cell.get("/jitter").json()
    keep = next(m for m in jitter["modules"] if m["name"] == "keep")
    dispatcher = jitter["executors"][0]
    slots_since = dispatcher["runs"] + dispatcher["skipped"] - first["swap_cycle"]
    assert abs(keep["runs"] + keep["skipped"] - slots_since) <= 1, (keep, dispatcher, first["swap_cycle"])
    events = cell.get("/events", params={"limit": 100}).json()["events"]
    assert sum(e["kind"] == "swap" for e in events) == 5


def test_killing_the_agent_does_not_stop_irpd(cell):
    before = cell.get("/status").json()
    cell.agent.kill()  # SIGKILL, by pid
    cell.agent.wait()
    time.sleep(1.0)
    with socket.socket(socket.AF_UNIX) as s:
        s.connect(str(cell.sock))
        f = s.makefile("rw")
        f.readline()
        f.write(json.dumps({"cmd": "status"}) + "\n")
        f.flush()
        after = json.loads(f.readline())["result"]
    assert cell.irpd.poll() is None
    assert after["running"] is True and after["pid"] == before["pid"]
    # Still dispatching: about 10000 basic periods of 100 µs went by in that second.
    assert after["cycles"] - before["cycles"] > 5000

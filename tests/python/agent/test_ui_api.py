"""test_ui_api.py -- the routes the web UI needs, against a real irpd and a real agent on loopback:
histograms (GET /jitter/histograms), batch module changes and their dry run
(POST /modules/changes), the host's load (GET /host), and the minimum basic period in /status."""

from __future__ import annotations

import math
import os
import time
from pathlib import Path

import httpx
import pytest
from agent_helpers import BUILD, IRPD, free_port, start_agent, start_irpd, stop

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")

COUNTERS = BUILD / "tests" / "cpp" / "modules"


class Live:
    """irpd (the Figure 1 set, or `config`) and an agent in front of it, with a token per role."""

    def __init__(self, tmp: Path, config: Path | None = None):
        self.sock, self.data = tmp / "irpd.sock", tmp / "data"
        self.irpd = start_irpd(self.sock, **({"config": config} if config else {}))
        self.port = free_port()
        self.agent = start_agent(self.port, self.data, self.sock)
        self.url = f"http://127.0.0.1:{self.port}/api/v1"
        self.tokens = {"admin": (self.data / "admin-token").read_text().strip()}
        for role in ("viewer", "operator"):
            r = httpx.post(f"{self.url}/tokens", json={"name": f"t-{role}", "role": role}, headers=self.h("admin"))
            assert r.status_code == 201, r.text
            self.tokens[role] = r.json()["token"]

    def h(self, role: str = "operator") -> dict:
        return {"Authorization": f"Bearer {self.tokens[role]}"}

    def get(self, path: str, role: str = "viewer", **kw) -> httpx.Response:
        return httpx.get(f"{self.url}{path}", headers=self.h(role), timeout=40, **kw)

    def ok(self, path: str, **kw) -> dict | list:
        r = self.get(path, **kw)
        assert r.status_code == 200, r.text
        return r.json()

    def change(self, changes: list[dict], dry_run: bool, role: str = "operator") -> httpx.Response:
        return httpx.post(
            f"{self.url}/modules/changes",
            json={"changes": changes, "dry_run": dry_run},
            headers=self.h(role),
            timeout=40,
        )

    def module(self, name: str) -> dict:
        return self.ok(f"/modules/{name}")

    def close(self) -> None:
        stop(self.agent)
        stop(self.irpd)


@pytest.fixture
def live(tmp_path):
    cell = Live(tmp_path)
    yield cell
    cell.close()


@pytest.fixture
def budget_cell(tmp_path):
    """Two counter modules whose <budget>s make the main executor 90 % busy: keep (600 us every
    1 ms) and swap (600 us every 2 ms)."""

    def module(name: str, period: int, priority: int) -> str:
        return (
            f"  <module><name>{name}</name><filename>{COUNTERS / 'counter_v1.so'}</filename>"
            f"<moduletype>thread</moduletype><operationtype>periodic</operationtype><period>{period}</period>"
            f"<priority>{priority}</priority><budget>600000</budget></module>\n"
        )

    config = tmp_path / "module.xml"
    config.write_text("<root>\n" + module("keep", 1_000_000, 1) + module("swap", 2_000_000, 2) + "</root>\n")
    cell = Live(tmp_path, config)
    yield cell
    cell.close()


def quantile(h: dict, q: float) -> float:
    """As irpd computes its percentiles (stats/summary.cpp): the middle of the bucket holding rank
    ceil(q * count), clamped to [min, max]."""
    rank = min(max(math.ceil(q * h["count"]), 1), h["count"])
    seen = 0
    for b in h["buckets"]:
        seen += b["count"]
        if seen >= rank:
            return min(max(b["low_ns"] + (b["width_ns"] - 1) / 2, h["min"]), h["max"])
    return h["max"]


# ---- histograms -------------------------------------------------------------------------------
def test_histograms_cover_every_record_and_their_buckets_add_up_to_the_counts(live):
    time.sleep(0.2)
    h = live.ok("/jitter/histograms")
    assert h["cycles"] > 0 and h["time_ns"] > 0
    stats = live.ok("/jitter")
    assert [r["name"] for r in h["records"]] == [r["name"] for r in stats["executors"] + stats["modules"]]
    assert {r["kind"] for r in h["records"]} == {"dispatcher", "module"}
    for r in h["records"]:
        for key in ("jitter_ns", "latency_ns", "exec_ns"):
            hist = r[key]
            assert sum(b["count"] for b in hist["buckets"]) == hist["count"], (r["name"], key)
            assert all(b["count"] > 0 and b["width_ns"] >= 1 for b in hist["buckets"])
            ends = [(b["low_ns"], b["low_ns"] + b["width_ns"]) for b in hist["buckets"]]
            assert all(a[1] <= b[0] for a, b in zip(ends, ends[1:])), f"{r['name']} {key}: ascending, disjoint"
            if hist["count"]:
                assert ends[0][0] <= hist["min"] <= hist["max"]
            if key != "jitter_ns":
                assert all(b["low_ns"] >= 0 for b in hist["buckets"])
    cntr2 = next(r for r in h["records"] if r["name"] == "cntr2")
    assert cntr2["runs"] > 0 and cntr2["exec_ns"]["count"] > 0 and cntr2["executor"] == "main"


def test_percentiles_from_the_buckets_agree_with_jitter(live):
    # A disabled module's figures stand still, so both answers read the same histogram.
    r = httpx.patch(f"{live.url}/modules/cntr2", json={"enabled": False}, headers=live.h(), timeout=40)
    assert r.status_code == 200, r.text
    h = live.ok("/jitter/histograms", params={"name": "cntr2"})
    assert [r["name"] for r in h["records"]] == ["cntr2"]
    hist = h["records"][0]
    figures = next(m for m in live.ok("/jitter")["modules"] if m["name"] == "cntr2")
    assert hist["runs"] == figures["runs"] > 0
    for key in ("latency_ns", "exec_ns"):
        assert hist[key]["count"] == figures[key]["count"]
        for q, name in ((0.5, "p50"), (0.99, "p99"), (0.999, "p999")):
            assert quantile(hist[key], q) == figures[key][name], (key, name)
    # The signed jitter clamps each half to its own bounds: the same up to one bucket.
    jitter = hist["jitter_ns"]
    p99 = quantile(jitter, 0.99)
    width = next(b["width_ns"] for b in jitter["buckets"] if b["low_ns"] <= p99 < b["low_ns"] + b["width_ns"])
    assert abs(p99 - figures["jitter_ns"]["p99"]) <= width
    assert (jitter["min"], jitter["max"]) == (figures["jitter_ns"]["min"], figures["jitter_ns"]["max"])


def test_histograms_of_an_unknown_record_are_a_404_naming_it(live):
    r = live.get("/jitter/histograms", params={"name": "nope"})
    assert r.status_code == 404 and "'nope'" in r.json()["detail"] and "cntr1" in r.json()["detail"], r.text
    assert live.get("/jitter/histograms", params={"name": ""}).status_code == 422


def test_status_gives_the_minimum_basic_period(live):
    assert live.ok("/status")["min_basic_period_ns"] == 50_000


# ---- batch changes ----------------------------------------------------------------------------
CHANGES = [{"name": "cntr1", "period_ns": 1_000_000}, {"name": "cntr2", "priority": 7}]


def test_a_dry_run_shows_the_new_table_and_changes_nothing(live):
    status, schedule = live.ok("/status"), live.ok("/schedule")
    runs = live.module("cntr3")["runs"]
    r = live.change(CHANGES, dry_run=True)
    assert r.status_code == 200, r.text
    report = r.json()
    assert report["dry_run"] is True and report["report"] is None
    assert report["before"]["slots"] == schedule["slots"]
    after = report["after"]
    assert after["macro_period_ns"] == 1_000_000 and len(after["slots"]) == 10
    assert after["slots"][0]["modules"] == ["cntr3", "cntr1", "cntr4", "cntr2"]  # cntr2 now last (priority 7)
    assert {m["name"]: m["period_ns"] for m in after["modules"]}["cntr1"] == 1_000_000
    assert 0 <= report["utilization"] < 1 and set(report["executors"]) == {"main"}
    assert any("macro period" in w for w in report["warnings"]), report["warnings"]
    # Nothing changed: same generation and table, the counters go on at their periods.
    assert live.ok("/status")["generation"] == status["generation"]
    assert live.ok("/schedule") == schedule
    assert live.module("cntr1")["period_ns"] == 500_000 and live.module("cntr2")["priority"] == 2
    assert live.module("cntr3")["runs"] > runs
    audit = httpx.get(f"{live.url}/audit", headers=live.h("admin")).json()
    assert not any(e["action"] == "change_modules" for e in audit)


def test_a_batch_change_is_one_swap_of_every_module_it_names(live):
    generation = live.ok("/status")["generation"]
    before = live.ok("/schedule")
    r = live.change(CHANGES, dry_run=False)
    assert r.status_code == 200, r.text
    report = r.json()
    assert report["dry_run"] is False
    assert report["report"]["generation"] == generation + 1
    assert report["report"]["kept"] == ["cntr1", "cntr2", "cntr3", "cntr4", "event1", "visionEvt", "nonReaTime"]
    assert report["before"]["slots"] == before["slots"]
    assert live.ok("/status")["generation"] == generation + 1
    assert live.ok("/schedule")["slots"] == report["after"]["slots"]
    assert live.module("cntr1")["period_ns"] == 1_000_000 and live.module("cntr2")["priority"] == 7
    line = [
        e for e in httpx.get(f"{live.url}/audit", headers=live.h("admin")).json() if e["action"] == "change_modules"
    ][-1]
    assert (line["result"], line["target"], line["generation"]) == ("ok", "cntr1, cntr2", generation + 1)
    events = live.ok("/events")["events"]
    assert any(e["source"] == "agent" and e["kind"] == "change_modules" for e in events)
    assert sum(e["source"] == "irpd" and e["kind"] == "swap" for e in events) == 1


@pytest.mark.parametrize("dry_run", [True, False])
def test_refused_changes_say_what_to_fix_and_change_nothing(live, dry_run):
    generation = live.ok("/status")["generation"]
    r = live.change([{"name": "cntr2", "period_ns": 10_000}], dry_run)
    assert r.status_code == 409 and "below the minimum basic period of 50000 ns" in r.json()["detail"], r.text
    r = live.change([{"name": "cntr1", "priority": 1}, {"name": "nope", "priority": 1}], dry_run)
    assert r.status_code == 404 and "no module 'nope'" in r.json()["detail"], r.text
    r = live.change([{"name": "event1", "period_ns": 1_000_000}], dry_run)
    assert r.status_code == 409 and "only periodic modules have a period" in r.json()["detail"], r.text
    r = live.change([{"name": "cntr1", "priority": 1}, {"name": "cntr1", "period_ns": 1_000_000}], dry_run)
    assert r.status_code == 409 and "changed twice" in r.json()["detail"], r.text  # irpd's refusal
    r = live.change([{"name": "cntr1"}], dry_run)  # the spec's entry gives at least one value
    assert r.status_code == 422 and "at least one of period_ns, priority or enabled" in r.text, r.text
    for body in (
        {"changes": []},
        {"changes": [{"name": "cntr1", "period_ns": "1ms"}]},
        {"changes": [{"name": "cntr1", "period_ns": 0}]},
        {"changes": [{"name": "cntr1", "period": 5}]},
        {"changes": [{"name": "cntr1", "enabled": "no"}]},
        {"changes": "cntr1"},
    ):
        r = httpx.post(f"{live.url}/modules/changes", json=body, headers=live.h(), timeout=40)
        assert r.status_code == 422, (body, r.text)
    assert live.change(CHANGES, dry_run, role="viewer").status_code == 403
    assert live.ok("/status")["generation"] == generation
    assert live.module("cntr2")["period_ns"] == 100_000


def test_a_change_over_100_percent_is_refused_and_80_percent_warned(budget_cell):
    cell = budget_cell
    r = cell.change([{"name": "swap", "priority": 1}], dry_run=True)
    assert r.status_code == 200, r.text
    warnings = r.json()["warnings"]
    assert r.json()["utilization"] == pytest.approx(0.9, abs=0.01)
    assert any("above 80 %" in w for w in warnings) and any("both have priority 1" in w for w in warnings), warnings
    generation = cell.ok("/status")["generation"]
    for dry_run in (True, False):
        r = cell.change([{"name": "swap", "period_ns": 1_000_000}], dry_run)
        assert r.status_code == 409 and "would be 120 % busy" in r.json()["detail"], r.text
    assert cell.ok("/status")["generation"] == generation
    assert cell.module("swap")["period_ns"] == 2_000_000


# ---- the host ---------------------------------------------------------------------------------
def test_host_load_is_in_range_and_names_irpds_process(live):
    first = live.ok("/host")
    status = live.ok("/status")
    assert len(first["cpus"]) == len(
        [
            line
            for line in Path("/proc/stat").read_text().splitlines()
            if line.startswith("cpu") and not line.startswith("cpu ")
        ]
    )
    assert all(0.0 <= c["busy"] <= 1.0 for c in first["cpus"])
    assert len(first["load_avg"]) == 3 and all(v >= 0 for v in first["load_avg"])
    assert first["interval_s"] > 0
    irpd = first["irpd"]
    assert irpd["pid"] == status["pid"] == live.irpd.pid
    assert irpd["threads"] >= 3  # main, control socket, dispatcher (and more)
    assert irpd["rss_bytes"] > 1 << 20
    assert 0 <= irpd["cpu"] <= os.cpu_count()
    assert first["agent"]["pid"] == live.agent.pid and first["agent"]["threads"] >= 1
    assert first["agent"]["rss_bytes"] > 1 << 20
    assert first["agent_uptime_s"] > 0
    time.sleep(0.3)
    second = live.ok("/host")
    assert second["interval_s"] >= 0.3  # since the first request's sample
    assert second["irpd"]["pid"] == irpd["pid"]
    assert second["agent_uptime_s"] > first["agent_uptime_s"]


def test_host_answers_without_irpd(live):
    stop(live.irpd)
    host = live.ok("/host")
    assert host["irpd"] is None and host["agent"]["pid"] == live.agent.pid

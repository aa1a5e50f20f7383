"""test_line_live.py -- three controllers on loopback (irpd on the signals set + agent + DDS bridge
each, on a DDS domain of their own): every agent's GET /line lists all three with their fields; a
killed bridge turns lost within its lease and comes back when started again; a killed irpd turns
its controller to fault (irpd unreachable) and back; a cleanly stopped bridge leaves the line and
its agent says the bridge is off; irpctl line prints the same (docs/dds.md "The line").  States are
polled with generous limits: what is asserted is the state reached, never how fast."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from line_processes import LineNode  # noqa: E402
from live_processes import BUILD, wait_until  # noqa: E402

SIGNALS = BUILD / "sets" / "signals" / "module.xml"
NAMES = ("line-a", "line-b", "line-c")
LIMIT_S = 45  # for a state to be reached; the lease is 3 s, the machine may be loaded

pytestmark = pytest.mark.skipif(not SIGNALS.exists(), reason=f"the signals set is not built ({SIGNALS})")


@pytest.fixture(scope="module")
def nodes(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("line")
    domain = 50 + os.getpid() % 25  # the line tests use 20..99 (docs/dds.md)
    made = {name: LineNode(tmp, name, domain, SIGNALS) for name in NAMES}
    try:
        for n in made.values():
            n.start_irpd()
            n.start_agent()
            n.start_bridge()
        for n in made.values():
            n.wait_agent()
        yield made
    finally:
        for n in made.values():
            n.close()


def states(node: LineNode) -> dict[str, str]:
    return {name: c["state"] for name, c in node.controllers().items()}


def wait_for(node: LineNode, want: dict[str, str | None], others: list[LineNode]) -> dict:
    """Until node's GET /line shows each name of `want` in its state (None: not listed)."""

    def reached():
        got = states(node)
        return got if all(got.get(k) == v for k, v in want.items()) else None

    reached.__doc__ = f"{node.name} to see {want}"
    try:
        return wait_until(reached, LIMIT_S, 0.25)
    except AssertionError:
        raise AssertionError(
            f"{node.name} sees {states(node)}, not {want}\n" + "\n".join(n.logs() for n in others)
        ) from None


def test_every_agent_lists_every_controller_with_its_fields(nodes):
    everyone = list(nodes.values())
    for node in everyone:
        wait_for(node, {name: "ok" for name in NAMES}, everyone)
    a = nodes["line-a"]
    view = a.line()
    assert view["bridge"] == "ok" and view["this"] == "line-a" and view["interface"] == "lo"
    listed = {c["name"]: c for c in view["controllers"]}
    assert [c["name"] for c in view["controllers"]] == list(NAMES)
    for name, c in listed.items():
        assert c["this"] == (name == "line-a")
        assert c["agent_url"] == f"{nodes[name].url}/"
        assert c["set_name"] == "signals/module.xml" and c["health"] == "running" and c["alive"]
        assert c["basic_period_ns"] == 1_000_000 and c["uptime_ns"] > 0 and c["version"]
        assert c["lease_s"] == 3 and c["period_s"] == 1 and c["alarms_active"] == 0
        assert len(c["layout_hash"]) >= 16, c
    # the jitter comes from the dispatcher's histograms once a second has passed
    wait_until(lambda: all(c["jitter_p99_ns"] for c in a.line()["controllers"]), LIMIT_S, 0.5)


def test_irpctl_line_prints_the_table_and_the_json(nodes):
    b = nodes["line-b"]
    r = b.irpctl("line")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[0].startswith("domain ") and "as line-b (*) sees it" in lines[0]
    assert lines[1].split()[:3] == ["NAME", "STATE", "HEALTH"]
    rows = {line.split()[0]: line for line in lines[2:5]}
    assert set(rows) == set(NAMES)
    assert "line-b *" in r.stdout and all(" ok " in row and nodes[n].url in row for n, row in rows.items())
    r = b.irpctl("line", "--json")
    assert r.returncode == 0, r.stderr
    assert [c["name"] for c in json.loads(r.stdout)["controllers"]] == list(NAMES)


def test_a_killed_bridge_turns_lost_within_its_lease_and_comes_back(nodes):
    a, b, c = (nodes[n] for n in NAMES)
    everyone = [a, b, c]
    b.kill("bridge")
    for node in (a, c):
        wait_for(node, {"line-b": "lost", "line-a": "ok", "line-c": "ok"}, everyone)
    lost = a.controllers()["line-b"]
    assert not lost["alive"] and lost["lost_since"] >= lost["last_seen"] and "lease" in lost["lost_reason"]
    assert lost["reasons"] == [lost["lost_reason"]]
    # b's own agent: the view its bridge left behind grows old: it says the bridge stopped
    wait_until(lambda: b.line()["bridge"] == "stale", LIMIT_S, 0.5)
    assert "not running" in b.line()["message"] and b.line()["controllers"] == []
    b.start_bridge()
    for node in everyone:
        wait_for(node, {"line-b": "ok"}, everyone)
    assert a.controllers()["line-b"]["lost_since"] is None


def test_a_killed_irpd_turns_its_controller_to_fault_and_back(nodes):
    a, b, c = (nodes[n] for n in NAMES)
    c.kill("irpd")
    wait_for(a, {"line-c": "fault"}, [a, b, c])
    seen = a.controllers()["line-c"]
    assert seen["health"] == "irpd_unreachable" and seen["alive"] and "irpd" in seen["reasons"][0]
    c.start_irpd()
    wait_for(a, {"line-c": "ok"}, [a, b, c])
    assert a.controllers()["line-c"]["uptime_ns"] < 600e9


def test_a_bridge_stopped_cleanly_leaves_the_line(nodes):
    a, b, c = (nodes[n] for n in NAMES)
    wait_for(a, {"line-b": "ok"}, [a, b, c])
    b.stop("bridge")
    wait_for(a, {"line-b": None, "line-c": "ok"}, [a, b, c])
    wait_for(c, {"line-b": None}, [a, b, c])
    view = b.line()  # its view is removed with it: off, not stale
    assert view["bridge"] == "off" and "not running" in view["message"]
    r = b.irpctl("line")
    assert r.returncode == 0 and r.stdout.startswith("no line: the DDS bridge is not running")
    b.start_bridge()  # for whatever runs after
    wait_for(a, {"line-b": "ok"}, [a, b, c])

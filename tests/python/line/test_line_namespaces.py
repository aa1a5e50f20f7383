"""test_line_namespaces.py -- issue 17's three-namespace test: three controllers (irpd on the PLC +
robot cell, agent and DDS bridge each) in three network namespaces joined by veth pairs to a Linux
bridge in a fourth (tests/python/netns.py), on addresses that exist only inside them, the bridges
discovering each other by multicast.  A DDS reader in A's namespace sees each controller's JointState
at the configured rate with robot.json's joint names; every agent's GET /line (asked over its own
namespace address) lists the three; A killed (irpd, agent and bridge) turns lost on B and C, and
comes back when started again; samples written from B's namespace to topics A does not map change
nothing in A's segment, while one to the topic it maps does.  B imports A's I/O cycle count into a
variable its cell.glb gained (laid out against the cell's layout, so the cell's modules still run on
it): it follows A's; A killed turns it stale with its fallback and raises B's dds/import alarm, and
A back clears both.  Limits on waits are generous; what is asserted is the state reached, never how
fast."""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import netns  # noqa: E402
from line_processes import LineNode  # noqa: E402
from live_processes import BUILD, ROOT, copy_cell, wait_until  # noqa: E402

sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.irpd.client import IrpdClient  # noqa: E402
from indurop_agent.irpd.variables import Segment  # noqa: E402

CELL = BUILD / "sets" / "plc-robot"
PROBE = Path(__file__).with_name("netns_probe.py")
NAMES = ("a", "b", "c")  # the controllers' names, and their topics' namespaces (rt/a/joint_states)
JOINTS = [f"joint_{i}" for i in range(1, 7)]
JOINT_RATE_HZ = 50  # dds.json's, under the cell's 100 Hz basic rate: every second basic period
LIMIT_S = 60
# B's import of A's I/O cycle count (docs/dds.md "Controllers sharing variables"), into variables
# B's cell.glb gains at its end.
EXPORTED = "PLC_ROBOT.IO_STATUS.cycles"
FROM_A = "PLC_ROBOT.FROM_A"
GROWN_GLB = """
struct {
  uint32_t cycles;      // A's PLC_ROBOT.IO_STATUS.cycles, imported
  bool stale;           // 1 while A is gone (cycles then holds the fallback)
  uint32_t age_us;
  int64_t stamp_ns;
} FROM_A;
"""
FALLBACK = 7  # never one of A's counts while B follows: A has counted past it long before
IMPORT = {
    "from": "a",
    "path": EXPORTED,
    "variable": f"{FROM_A}.cycles",
    "stale": f"{FROM_A}.stale",
    "age_us": f"{FROM_A}.age_us",
    "stamp_ns": f"{FROM_A}.stamp_ns",
    "rate_hz": 50,
    "fallback": FALLBACK,
}
ALARM = f"dds/import:{FROM_A}.cycles"


def grow_layout(folder: Path) -> None:
    """B's cell.glb gains FROM_A, laid out by glbc against the cell's layout (its modules kept)."""
    glb = folder / "cell.glb"
    glb.write_text((ROOT / "config" / "sets" / "plc-robot" / "cell.glb").read_text() + GROWN_GLB)
    r = subprocess.run(
        [
            sys.executable,
            str(ROOT / "glb" / "glbc"),
            "--previous",
            str(folder / "layout.json"),
            "-o",
            str(folder),
            str(glb),
        ],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr


why_not = netns.unavailable()
pytestmark = [
    pytest.mark.skipif(why_not is not None, reason=f"no network namespaces here: {why_not}"),
    pytest.mark.skipif(not (CELL / "Robot.so").exists(), reason=f"the plc-robot cell is not built ({CELL})"),
]


@pytest.fixture(scope="module")
def line(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("line-netns")
    domain = 75 + os.getpid() % 25  # the line tests use 20..99 (docs/dds.md)
    with netns.Switch(len(NAMES)) as net:
        nodes = {}
        try:
            for name, ns in zip(NAMES, net.spaces):
                config, _ = copy_cell(tmp / f"cell-{name}")
                dds = json.loads((config.parent / "dds.json").read_text())
                dds["joint_states"]["rate_hz"] = JOINT_RATE_HZ
                if name == "a":
                    dds["export"] = [{"variable": EXPORTED, "rate_hz": 50}]
                if name == "b":
                    grow_layout(config.parent)
                    dds["imports"] = [IMPORT]
                (config.parent / "dds.json").write_text(json.dumps(dds))
                nodes[name] = LineNode(tmp, name, domain, config, ns, ["--namespace", name])
            for n in nodes.values():
                n.start_irpd()
                n.start_agent()
                n.start_bridge()
            for n in nodes.values():
                n.wait_agent()
            yield nodes
        finally:
            for n in nodes.values():
                n.close()


def probe(node: LineNode, *args: str, timeout: float = 120) -> dict:
    r = node.ns.run(sys.executable, str(PROBE), *args, timeout=timeout)
    assert r.returncode == 0, f"{r.stderr}\n{node.logs()}"
    return json.loads(r.stdout)


def wait_for(node: LineNode, want: dict[str, str], everyone) -> None:
    def reached():
        got = {k: c["state"] for k, c in node.controllers().items()}
        return all(got.get(k) == v for k, v in want.items())

    reached.__doc__ = f"{node.name}'s line to show {want}"
    try:
        wait_until(reached, LIMIT_S, 0.5)
    except AssertionError:
        raise AssertionError(
            f"{node.name} shows {node.line()}\n" + "\n".join(n.logs() for n in everyone.values())
        ) from None


def segment_of(node: LineNode) -> Segment:
    """The node's shared-variable segment, mapped read-only (irpd's status names it)."""
    control = IrpdClient(str(node.sock))
    try:
        return Segment(control.request("status")["shared_memory"]["variables"])
    finally:
        control.close()


def import_alarm(node: LineNode) -> dict:
    return next((a for a in node.get("/alarms")["alarms"] if a["key"] == ALARM), {})


def wait_following(a: LineNode, b: LineNode, everyone) -> None:
    """B's import fresh, holding a count A had (never ahead of A's, at most 100 of A's cycles behind)."""
    sa, sb = segment_of(a), segment_of(b)

    def follows():
        if sb.read(f"{FROM_A}.stale"):
            return False
        theirs = sb.read(f"{FROM_A}.cycles")
        ours = sa.read(EXPORTED)
        return theirs != FALLBACK and 0 <= ours - theirs <= 100

    try:
        wait_until(follows, LIMIT_S, 0.2)
        assert not import_alarm(b).get("active"), import_alarm(b)
    except AssertionError:
        raise AssertionError(
            f"B holds {sb.values(sb.select(FROM_A))}, A counts {sa.read(EXPORTED)}\n"
            + "\n".join(n.logs() for n in everyone.values())
        ) from None
    finally:
        sa.close()
        sb.close()


def test_b_s_import_follows_a_s_variable(line):
    wait_following(line["a"], line["b"], line)
    sb = segment_of(line["b"])
    try:
        assert 0 < sb.read(f"{FROM_A}.age_us") < 10_000_000  # written with each value: seconds at most
    finally:
        sb.close()


def test_joint_states_of_every_controller_come_at_the_configured_rate_with_their_names(line):
    a = line["a"]
    got = probe(a, "joint-states", str(a.domain), a.ns.interface, "60", *(f"rt/{n}/joint_states" for n in NAMES))
    for name in NAMES:
        topic = got[f"rt/{name}/joint_states"]
        assert len(topic["stamps"]) == 60, (name, topic, line[name].logs())
        assert topic["type"] == "sensor_msgs::msg::dds_::JointState_"
        assert all(names == JOINTS for names in topic["names"])
        steps = [b - a for a, b in zip(topic["stamps"], topic["stamps"][1:])]
        # stamped with the samples' due times: every second 10 ms period, whatever the delivery
        assert statistics.median(steps) == 1_000_000_000 // JOINT_RATE_HZ, (name, steps)


def test_every_agent_lists_the_three_over_its_namespace_address(line):
    for node in line.values():
        wait_for(node, {n: "ok" for n in NAMES}, line)
        view = node.line()
        assert view["this"] == node.name and view["interface"] == node.ns.interface
        listed = {c["name"]: c for c in view["controllers"]}
        for name in NAMES:
            assert listed[name]["agent_url"] == f"http://{line[name].ns.address}:8080/"
            assert listed[name]["set_name"] == "cell-" + name + "/module.xml"
            assert listed[name]["this"] == (name == node.name)
    r = line["c"].irpctl("line")
    assert r.returncode == 0 and all(f"http://{line[n].ns.address}:8080/" in r.stdout for n in NAMES), r


def test_a_write_to_an_unmapped_topic_changes_nothing_in_a_s_segment(line):
    a, b = line["a"], line["b"]
    segment = segment_of(a)
    inputs = segment.select("PLC_ROBOT.PLC_IN")
    before = segment.values(inputs)
    for topic in ("rt/a/cell/not_mapped", "rt/a/override", "rt/cell/override", "rt/b/cell/override_x"):
        probe(b, "write", str(a.domain), b.ns.interface, topic, "0.37", "20")
    time.sleep(2)
    assert segment.values(inputs) == before
    # the same from B to the topic A maps does arrive: the writes above did reach A's network
    assert probe(b, "write", str(a.domain), b.ns.interface, "rt/a/cell/override", "0.25", "5", "--matched")["matched"]
    wait_until(lambda: segment.read("PLC_ROBOT.PLC_IN.Override") == 0.25, LIMIT_S, 0.2)
    segment.close()


def test_a_killed_turns_lost_on_b_and_c_and_comes_back_when_restarted(line):
    a, b, c = (line[n] for n in NAMES)
    for n in (b, c):
        wait_for(n, {"a": "ok"}, line)
    wait_following(a, b, line)
    for which in ("bridge", "agent", "irpd"):
        a.kill(which)
    for n in (b, c):
        wait_for(n, {"a": "lost", "c": "ok"}, line)
    lost = b.controllers()["a"]
    assert not lost["alive"] and "lease" in lost["lost_reason"] and lost["last_seen"] <= lost["lost_since"]
    # B's import: stale, the fallback in place, the alarm active
    sb = segment_of(b)
    try:
        wait_until(lambda: sb.read(f"{FROM_A}.stale") and sb.read(f"{FROM_A}.cycles") == FALLBACK, LIMIT_S, 0.2)
        alarm = wait_until(lambda: import_alarm(b).get("active") and import_alarm(b), LIMIT_S, 0.5)
        assert alarm["severity"] == "high", alarm
    finally:
        sb.close()
    a.start()
    for n in (a, b, c):
        wait_for(n, {"a": "ok", "b": "ok", "c": "ok"}, line)
    wait_following(a, b, line)
    wait_until(lambda: not import_alarm(b).get("active"), LIMIT_S, 0.5)

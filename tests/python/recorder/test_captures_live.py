"""test_captures_live.py -- triggered captures in a real agent in front of a real irpd running the
signals set (a square wave SIG.wave[4], rising once a second at 1 ms rows): a rising-edge capture
lands on the exact row (its seq, the pre and post counts, and every value equal to the ring's,
read here with agent/indurop_agent/irpd/trace.py); a repeated one takes its shots one period of the
wave apart; an alarm raised by a module (the C++ tests' alarming.so beside the generator) makes a
shot of the rows before the alarm's time; bad input is refused naming what to fix; irpctl capture
arms, lists, gets and disarms (docs/recorder.md "Triggered captures")."""

from __future__ import annotations

import io
import json
import os
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import httpx
import pytest
from mcap.reader import make_reader
from recorder_helpers import assert_in_time_order

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from indurop_agent.irpd.trace import TraceRing
from live_processes import (
    ALARMING,
    API,
    ROOT,
    SIGNALS,
    free_port,
    signals_with_an_alarm,
    start_agent,
    start_irpd,
    stop,
    wait_until,
)

SQUARE, SINE, SAMPLE = "SIG.wave[4]", "SIG.wave[0]", "SIG.sample"
WAVE_ROWS = 1000  # the square wave's period in rows (1 Hz at 1 ms)
LIMIT_S = 30  # for a state to be reached on a loaded machine; never a figure asserted

pytestmark = pytest.mark.skipif(
    not (SIGNALS / "module.xml").exists(), reason=f"the signals set is not built ({SIGNALS})"
)


class Cell:
    def __init__(self, tmp: Path, config: Path):
        self.tmp, self.sock, self.data = tmp, tmp / "irpd.sock", tmp / "data"
        self.irpd = start_irpd(self.sock, config, f"captures-{os.getpid()}-{tmp.name}")
        self.port = free_port()
        agent_config = tmp / "agent.json"
        agent_config.write_text(json.dumps({"irpd_poll_s": 0.2}))
        self.agent = start_agent(self.port, self.data, self.sock, "--config", str(agent_config))
        self.url = f"http://127.0.0.1:{self.port}{API}"
        admin = (self.data / "admin-token").read_text().strip()
        self.tokens = {"admin": admin}
        for role in ("operator", "viewer"):
            r = httpx.post(f"{self.url}/tokens", json={"name": role, "role": role}, headers=self.h())
            self.tokens[role] = r.json()["token"]

    def h(self, role: str = "admin") -> dict:
        return {"Authorization": f"Bearer {self.tokens[role]}"}

    def call(self, method: str, path: str, role: str = "operator", **kw) -> httpx.Response:
        return httpx.request(method, f"{self.url}{path}", headers=self.h(role), timeout=30, **kw)

    def capture(self, capture_id: str) -> dict:
        return self.call("GET", f"/captures/{capture_id}", "viewer").json()

    def stop(self) -> None:
        stop(self.agent)
        stop(self.irpd)


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("captures")
    c = Cell(tmp, signals_with_an_alarm(tmp / "set"))
    yield c
    c.stop()


class RingCopy(threading.Thread):
    """Every row of the trace rings from now on, read here as the agent reads them: seq -> (t_ns,
    {path: value})."""

    def __init__(self, name: str):
        super().__init__(daemon=True)
        self.ring = TraceRing(name)
        self.rows: dict[int, tuple[int, dict[str, float]]] = {}
        self.lost = 0
        self.done = threading.Event()

    def run(self) -> None:
        since = self.ring.head()
        while not self.done.wait(0.02):
            read = self.ring.read_since(since)
            since, self.lost = read.next, self.lost + read.lost
            for part in read.parts:
                for k in range(part.count):
                    values = {p: part.columns[c][k] for c, p in enumerate(part.config.paths)}
                    self.rows[part.first_seq + k] = (part.t_ns[k], values)

    def stop(self) -> None:
        self.done.set()
        self.join(5)
        self.ring.close()


def edge_request(pre=200, post=100, repeat=1, **more) -> dict:
    return {
        "name": "square rising",
        "variables": [SQUARE, SINE, SAMPLE],
        "trigger": {
            "kind": "condition",
            "conditions": [{"kind": "edge", "variable": SQUARE, "direction": "rising", "threshold": 0}],
        },
        "pre": {"rows": pre},
        "post": {"rows": post},
        "repeat": repeat,
        **more,
    }


def wait_shots(cell: Cell, capture_id: str, n: int) -> dict:
    def shots_in():
        """the capture's shots to be saved"""
        c = cell.capture(capture_id)
        return c if len(c["shots"]) >= n else None

    return wait_until(shots_in, LIMIT_S, 0.1)


def test_a_rising_edge_lands_on_the_exact_row_with_the_rings_values(cell, tmp_path):
    status = cell.call("GET", "/status", "viewer").json()
    copy = RingCopy(status["shared_memory"]["trace"])
    copy.start()
    try:
        r = cell.call("POST", "/captures", json=edge_request())
        assert r.status_code == 201, r.text
        armed = r.json()
        assert armed["state"] in ("armed", "triggered") and armed["pre_rows"] == 200 and armed["post_rows"] == 100
        assert [c["path"] for c in armed["channels"]] == [SQUARE, SINE, SAMPLE]
        done = wait_shots(cell, armed["id"], 1)
        assert done["state"] == "done" and done["shots_taken"] == 1
        rows = cell.call("GET", f"/captures/{armed['id']}/shots/1", "viewer").json()
    finally:
        copy.stop()
    s = rows["summary"]
    trigger = s["trigger_seq"]
    assert (s["pre_rows"], s["post_rows"], s["drops"], s["rows"]) == (200, 100, 0, 301)
    assert rows["seq"] == list(range(trigger - 200, trigger + 101))
    square = rows["columns"][0]
    assert square[200] >= 0 > square[199]  # the trigger row is the first at or above the threshold
    assert copy.lost == 0
    for k, seq in enumerate(rows["seq"]):  # every row is the ring's
        t_ns, values = copy.rows[seq]
        assert rows["t_ns"][k] == t_ns
        assert [c[k] for c in rows["columns"]] == [values[SQUARE], values[SINE], values[SAMPLE]]
    # and the edge is the wave's: the first row of its second half-period, SIG.sample counting rows
    assert all(b - a == 1 for a, b in zip(rows["columns"][2], rows["columns"][2][1:]))
    assert sum(1 for v in square if v > 0) == 101
    # the shot is a file of the recordings: listed, and an MCAP file any reader opens with its trigger
    name = f"{armed['id']}.shot-1"
    listed = cell.call("GET", f"/recordings/{name}", "viewer").json()
    assert listed["kind"] == "capture" and listed["rows"] == 301 and listed["drops"] == 0
    assert listed["shot"] == {"capture": armed["id"], "shot": 1, "trigger_seq": trigger, "cause": s["cause"]}
    assert [v["path"] for v in listed["variables"]] == [SQUARE, SINE, SAMPLE]
    mcap = cell.call("GET", f"/recordings/{name}/download", "viewer")
    assert mcap.status_code == 200, mcap.text
    reader = make_reader(io.BytesIO(mcap.content))
    notes = [json.loads(m.data) for _, _, m in reader.iter_messages(topics=["/indurop/notes"])]
    assert [n["seq"] for n in notes if n["kind"] == "trigger"] == [trigger]
    samples = [json.loads(m.data) for _, _, m in reader.iter_messages(topics=["/indurop/samples"])]
    assert [m["seq"] for m in samples] == rows["seq"]
    (tmp_path / "shot.mcap").write_bytes(mcap.content)
    assert assert_in_time_order(tmp_path / "shot.mcap") == 301 + len(notes)  # the trigger note at its row


def test_a_repeated_capture_takes_a_shot_at_each_edge(cell):
    armed = cell.call("POST", "/captures", json=edge_request(pre=100, post=50, repeat=2)).json()
    done = wait_shots(cell, armed["id"], 2)
    first, second = done["shots"]
    assert done["state"] == "done" and done["shots_taken"] == 2
    assert second["trigger_seq"] - first["trigger_seq"] == WAVE_ROWS
    assert [(x["pre_rows"], x["post_rows"], x["drops"]) for x in done["shots"]] == [(100, 50, 0), (100, 50, 0)]
    newest = cell.call("GET", f"/captures/{armed['id']}/shots/0", "viewer", params={"channel": SAMPLE}).json()
    assert newest["summary"]["shot"] == 2 and [c["path"] for c in newest["channels"]] == [SAMPLE]
    assert len(newest["columns"]) == 1 and len(newest["seq"]) == 151


def test_an_alarm_makes_a_shot_of_the_rows_before_its_time(cell):
    (cell.tmp / "set" / "jam").unlink(missing_ok=True)
    request = {
        "name": "jam",
        "variables": [SINE, SAMPLE],
        "trigger": {"kind": "alarm", "key": "conveyor/5"},
        "pre": {"seconds": 0.5},
        "post": {"rows": 20},
    }
    armed = cell.call("POST", "/captures", json=request).json()
    assert armed["pre_rows"] == 500
    wait_until(lambda: cell.capture(armed["id"])["pre_filled"] == 500, LIMIT_S, 0.1)
    (cell.tmp / "set" / "jam").touch()
    try:
        done = wait_shots(cell, armed["id"], 1)
    finally:
        (cell.tmp / "set" / "jam").unlink()
    rows = cell.call("GET", f"/captures/{armed['id']}/shots/1", "viewer").json()
    raised = next(
        t
        for t in cell.call("GET", "/alarms/history", "viewer", params={"key": "conveyor/5"}).json()["transitions"]
        if t["event"] == "raise"
    )
    s = rows["summary"]
    assert s["cause"] == "alarm" and s["trigger_time_ns"] == raised["time_ns"]
    assert (s["pre_rows"], s["post_rows"], s["drops"]) == (500, 20, 0) and done["state"] == "done"
    # the rows' due times (CLOCK_MONOTONIC) against the alarm's (CLOCK_REALTIME), within a row
    alarm_mono = raised["time_ns"] - (time.time_ns() - time.monotonic_ns())
    k = rows["seq"].index(s["trigger_seq"])
    assert rows["t_ns"][k] <= alarm_mono + 1_000_000 and rows["t_ns"][k + 1] > alarm_mono - 1_000_000
    assert all(t < alarm_mono for t in rows["t_ns"][: k - 1])


def refused(cell: Cell, request: dict, status: int, *words: str) -> None:
    r = cell.call("POST", "/captures", json=request)
    assert r.status_code == status, r.text
    text = json.dumps(r.json()["detail"])
    for w in words:
        assert w in text, text


def test_bad_input_is_refused_naming_what_to_fix(cell):
    before = cell.call("GET", "/captures", "viewer").json()["captures"]
    limits = cell.call("GET", "/captures/limits", "viewer").json()
    assert (limits["max_pre_rows"], limits["ring_rows"], limits["max_conditions"], limits["max_channels"]) == (
        16384,
        16384,
        4,
        64,
    )
    refused(cell, edge_request(variables=["SIG.wavee[4]"]), 422, "SIG.wavee[4]", "did you mean")
    group = edge_request()
    group["trigger"]["conditions"][0]["variable"] = "SIG.wave"
    refused(cell, group, 422, "the trigger: 'SIG.wave' is a struct or an array, not a scalar", "'SIG.wave[0]'")
    refused(cell, edge_request(pre=16385), 422, "16385 rows", "at most 16384 rows", "shorten pre")
    longest = cell.call("POST", "/captures", json=edge_request(pre=16384))  # as long as the rings: taken
    assert longest.status_code == 201 and longest.json()["pre_rows"] == 16384, longest.text
    assert cell.call("DELETE", f"/captures/{longest.json()['id']}").status_code == 204
    five = edge_request()
    five["trigger"]["conditions"] *= 5
    refused(cell, five, 422, "conditions", "at most 4")
    many = edge_request(variables=[f"SIG.x{i}" for i in range(64)])
    refused(cell, many, 422, "65 channels", "first 'SIG.wave[4]' over", "at most 64")
    refused(cell, edge_request(variables=[f"SIG.x{i}" for i in range(65)]), 422, "variables", "at most 64")
    every = [f"SIG.wave[{i}]" for i in range(16)] + [SAMPLE]  # 17 channels: 152 bytes a row
    refused(cell, edge_request(variables=every, post=500_000), 422, "MiB", "fewer rows or fewer channels")
    refused(cell, {**edge_request(), "pre": {"rows": 1, "seconds": 1}}, 422, "one of the two")
    r = cell.call("POST", "/captures", "viewer", json=edge_request())
    assert r.status_code == 403 and "operator" in r.text
    assert cell.call("POST", "/captures/nosuch/disarm").status_code == 404
    assert cell.call("GET", "/captures", "viewer").json()["captures"] == before  # nothing armed by them


def test_irpctl_arms_lists_gets_and_disarms(cell, tmp_path):
    env = {**os.environ, "INDUROP_URL": f"http://127.0.0.1:{cell.port}", "INDUROP_TOKEN": cell.tokens["operator"]}

    def irpctl(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [sys.executable, "-m", "indurop_agent.cli", *args],
            cwd=ROOT / "agent",
            env=env,
            capture_output=True,
            text=True,
        )

    arm = irpctl(
        "--json", "capture", "arm", SQUARE, SAMPLE, "--when", f"{SQUARE} falling 0", "--pre", "50", "--post", "20ms"
    )
    assert arm.returncode == 0, arm.stderr
    capture_id = json.loads(arm.stdout)["id"]
    wait_shots(cell, capture_id, 1)
    listed = irpctl("capture", "list")
    assert listed.returncode == 0 and capture_id in listed.stdout and "done" in listed.stdout
    csv_file = tmp_path / "shot.csv"
    got = irpctl("capture", "get", capture_id, "--csv", str(csv_file))
    assert got.returncode == 0, got.stderr
    lines = csv_file.read_text().splitlines()
    assert lines[0] == f"seq,t_ns,{SQUARE},{SAMPLE}" and len(lines) == 1 + 50 + 1 + 20
    assert "falling" in got.stdout or "trigger" in got.stdout
    manual = irpctl(
        "--json", "capture", "arm", SAMPLE, "--on", "manual", "--pre", "10", "--post", "5", "--name", "by hand"
    )
    assert manual.returncode == 0, manual.stderr
    manual_id = json.loads(manual.stdout)["id"]
    assert irpctl("capture", "trigger", manual_id).returncode == 0
    wait_shots(cell, manual_id, 1)
    rearmed = irpctl("capture", "arm", "--again", manual_id)  # done: armed again as it was asked for
    assert rearmed.returncode == 0 and "armed" in rearmed.stdout, rearmed.stderr
    disarmed = irpctl("capture", "disarm", manual_id)
    assert disarmed.returncode == 0 and "idle" in disarmed.stdout
    assert irpctl("capture", "disarm", manual_id).returncode == 1  # not armed
    bad = irpctl("capture", "arm", SQUARE, "--when", f"{SQUARE} sideways 0", "--pre", "1", "--post", "1")
    assert bad.returncode == 2 and "sideways" in bad.stderr
    assert irpctl("capture", "delete", capture_id).returncode == 0
    assert irpctl("capture", "get", capture_id).returncode == 1


def test_a_hot_swap_makes_a_shot_at_the_row_of_its_event(cell):
    request = {
        "name": "swap",
        "variables": [SAMPLE],
        "trigger": {"kind": "swap"},
        "pre": {"rows": 300},
        "post": {"rows": 50},
    }
    armed = cell.call("POST", "/captures", json=request).json()
    wait_until(lambda: cell.capture(armed["id"])["pre_filled"] == 300, LIMIT_S, 0.1)
    swapped = cell.call("PATCH", "/modules/conveyor", json={"priority": 3})
    assert swapped.status_code == 200, swapped.text
    done = wait_shots(cell, armed["id"], 1)
    s = done["shots"][0]
    events = cell.call("GET", "/events", "viewer", params={"limit": 5000}).json()["events"]
    swap = [e for e in events if e["source"] == "irpd" and e["kind"] == "swap"][-1]
    assert (s["cause"], s["trigger_time_ns"]) == ("swap", swap["time_ns"])
    assert (s["pre_rows"], s["post_rows"], s["drops"]) == (300, 50, 0)


def test_an_armed_capture_goes_on_after_the_agent_and_irpd_restart(tmp_path):
    c = Cell(tmp_path, SIGNALS / "module.xml")
    try:
        request = {
            "name": "night",
            "variables": [SAMPLE],
            "trigger": {"kind": "fault"},
            "pre": {"rows": 100},
            "post": {"rows": 10},
            "repeat": 0,
        }
        armed = c.call("POST", "/captures", json=request).json()
        stop(c.agent)
        c.agent = start_agent(c.port, c.data, c.sock, "--config", str(tmp_path / "agent.json"))

        def filled():
            """the capture armed again by the restarted agent, its pre-trigger buffer full"""
            x = c.capture(armed["id"])
            return x if x["state"] == "armed" and x["pre_filled"] == 100 else None

        assert wait_until(filled, LIMIT_S, 0.1)["armed_at"] != armed["armed_at"]
        stop(c.irpd)  # irpd restarts: its rings begin again at seq 1
        c.irpd = start_irpd(c.sock, SIGNALS / "module.xml", f"captures-{os.getpid()}-{tmp_path.name}")

        def rearmed():
            """the capture armed again in the new rings, its pre-trigger buffer full"""
            x = filled()
            return x if x and "irpd restarted" in (x["message"] or "") else None

        wait_until(rearmed, LIMIT_S, 0.1)
        status = c.call("GET", "/status", "viewer").json()
        forced = c.call("POST", f"/captures/{armed['id']}/trigger")
        assert forced.status_code == 200, forced.text
        done = wait_shots(c, armed["id"], 1)
        s = done["shots"][0]
        assert s["cause"] == "manual" and s["pre_rows"] == 100 and s["post_rows"] == 10 and s["drops"] == 0
        assert s["trigger_seq"] <= status["cycles"] + 2000  # a row of the new rings
        assert done["state"] == "armed"  # repeat 0: armed again after the shot
        assert c.call("POST", f"/captures/{armed['id']}/trigger", "viewer").status_code == 403
    finally:
        c.stop()


def test_the_roles_of_a_captures_routes(cell):
    armed = cell.call("POST", "/captures", json={**edge_request(), "trigger": {"kind": "manual"}}).json()
    path = f"/captures/{armed['id']}"
    for method, suffix in (("POST", "/arm"), ("POST", "/disarm"), ("POST", "/trigger"), ("DELETE", "")):
        r = cell.call(method, path + suffix, "viewer")
        assert r.status_code == 403 and "needs the operator role" in r.json()["detail"], (method, suffix)
        assert httpx.request(method, f"{cell.url}{path}{suffix}").status_code == 401
    assert cell.call("GET", path, "viewer").status_code == 200
    assert cell.call("POST", path + "/trigger").status_code == 200
    wait_shots(cell, armed["id"], 1)
    assert cell.call("GET", path + "/shots/1", "viewer").status_code == 200
    assert cell.call("GET", path + "/shots/2", "viewer").status_code == 404
    assert cell.call("DELETE", path).status_code == 204
    assert cell.call("GET", path, "viewer").status_code == 404
    audit = [json.loads(line) for line in (cell.data / "audit.jsonl").read_text().splitlines()]
    mine = [a for a in audit if a.get("target") == armed["id"]]
    assert [a["action"] for a in mine if a["result"] == "ok"] == ["capture_arm", "capture_trigger", "capture_delete"]

"""test_imports_live.py -- two controllers on one host sharing variables over DDS (docs/dds.md
"Controllers sharing variables"): A (irpd + bridge) exports the share set's variables, B (irpd +
bridge + agent) imports them.  Loopback only, one domain of the test's own, unique irpd instances.

B's imports follow A's values (each value one A had, its stamp A's due time of that value or an
earlier one, within a bounded number of A's cycles); the age is small and grows while A is stopped;
A's bridge and, separately, A's irpd killed: B's flags turn stale, the fallbacks are written and
the agent's alarm is active; A back: the flags clear, the values follow, the alarms clear.  Bad
input: an import of a controller nobody runs stays stale, a type mismatch is counted and never
written, a flood from a foreign writer is bounded and counted, and a dds.json with a bad import is
refused at upload."""

from __future__ import annotations

import bisect
import json
import os
import shutil
import signal
import sys
import threading
import time
from pathlib import Path

import httpx
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import (  # noqa: E402
    API,
    BUILD,
    ROOT,
    free_port,
    output,
    start_agent,
    start_bridge,
    start_irpd,
    stop,
    wait_until,
)

sys.path.insert(0, str(ROOT / "agent"))
from cyclonedds.core import Policy, Qos  # noqa: E402
from cyclonedds.domain import Domain, DomainParticipant  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from cyclonedds.util import duration  # noqa: E402
from indurop_agent.dds import ros2_types  # noqa: E402
from indurop_agent.dds.imports import TOPIC  # noqa: E402
from indurop_agent.dds.indurop_types import SharedVariable  # noqa: E402
from indurop_agent.dds.settings import BridgeSettings, cyclone_config  # noqa: E402
from indurop_agent.irpd.client import IrpdClient, IrpdRefused, IrpdUnavailable  # noqa: E402
from indurop_agent.irpd.trace import TraceRing  # noqa: E402
from indurop_agent.irpd.variables import Segment  # noqa: E402

SET = BUILD / "tests" / "sets" / "dds-share"
PID = os.getpid()
DOMAIN = 60 + PID % 40  # this file's range; the bridge's other tests use 100 and up
A, B = f"line-a-{PID}", f"line-b-{PID}"
V = "SHARE.IN."
EXPORTS = ["SHARE.count", "SHARE.level", "SHARE.small", "SHARE.odd", "SHARE.vec"]
FALLBACK = {"count": 0, "level": -1, "small": -999, "odd": False, "vec": [-1, -1, -1, -1]}
ALARM = f"dds/import:{V}count"
SETTLE = 10  # trace rows left out after a trace configuration is put in force
LAG_CYCLES = 1000  # how far B's value may be behind A's (in A's cycles): a bound, not a figure

pytestmark = pytest.mark.skipif(not (SET / "share.so").exists(), reason=f"the share set is not built ({SET})")


def a_file() -> dict:
    return {
        "joint_states": {"enabled": False},
        "diagnostics": {"rate_hz": 5},
        "export": [{"variable": v, "rate_hz": 1000} for v in EXPORTS],
    }


def b_file() -> dict:
    imports = [
        {
            "from": A,
            "path": "SHARE.count",
            "variable": V + "count",
            "stale": V + "count_stale",
            "age_us": V + "count_age_us",
            "stamp_ns": V + "count_stamp_ns",
            "rate_hz": 1000,
            "fallback": 0,
        }
    ]
    for name in ("level", "small", "odd", "vec"):
        imports.append(
            {
                "from": A,
                "path": f"SHARE.{name}",
                "variable": V + name,
                "stale": f"{V}{name}_stale",
                "rate_hz": 200,
                "fallback": FALLBACK[name],
            }
        )
    imports.append(
        {"from": A, "path": "SHARE.count", "variable": V + "wrong", "stale": V + "wrong_stale", "fallback": -5}
    )
    imports.append(
        {
            "from": f"nobody-{PID}",
            "path": "SHARE.level",
            "variable": V + "unknown",
            "stale": V + "unknown_stale",
            "rate_hz": 50,
            "fallback": 42,
        }
    )
    return {"joint_states": {"enabled": False}, "diagnostics": {"rate_hz": 5}, "imports": imports}


class Controller:
    """irpd on a copy of the share set with its dds.json, the bridge named `name`, and an agent."""

    def __init__(self, tmp: Path, name: str, bridge_file: dict, agent: bool):
        self.tmp, self.name = tmp, name
        self.folder = tmp / "set"
        shutil.copytree(SET, self.folder)
        (self.folder / "dds.json").write_text(json.dumps(bridge_file, indent=1))
        self.sock, self.instance = tmp / "irpd.sock", f"dds-share-{PID}-{name}"
        self.start_irpd()
        self.control = IrpdClient(str(self.sock), timeout_s=30)
        self.vars = Segment(wait_until(self.status, 60)["shared_memory"]["variables"])
        self.agent = None
        if agent:
            self.port = free_port()
            self.agent = start_agent(self.port, tmp / "agent-data", self.sock, "--config", str(self.agent_config()))
            self.h = {"Authorization": f"Bearer {(tmp / 'agent-data' / 'admin-token').read_text().strip()}"}
        self.start_bridge()

    def agent_config(self) -> Path:
        config = self.tmp / "agent.json"
        config.write_text(json.dumps({"irpd_poll_s": 0.2}))
        return config

    def start_irpd(self) -> None:
        self.irpd = start_irpd(self.sock, self.folder / "module.xml", self.instance, log=self.tmp / "irpd.log")

    def start_bridge(self) -> None:
        self.bridge = start_bridge(
            self.sock, DOMAIN, "--name", self.name, log=self.tmp / f"bridge-{time.monotonic_ns()}.log"
        )

    def status(self):
        """irpd's status once it runs a set"""
        try:
            s = self.control.request("status")
            return s if s.get("running") else None
        except (IrpdRefused, IrpdUnavailable):
            return None

    def read(self, path: str):
        if self.vars.replaced():
            self.vars.close()
            self.vars = Segment(wait_until(self.status, 60)["shared_memory"]["variables"])
        return self.vars.read(path)

    def alarms(self) -> dict:
        r = httpx.get(f"http://127.0.0.1:{self.port}{API}/alarms", headers=self.h, timeout=10)
        r.raise_for_status()
        return {a["key"]: a for a in r.json()["alarms"]}

    def kill_irpd(self) -> None:
        self.irpd.send_signal(signal.SIGKILL)
        self.irpd.wait()
        for shm in Path("/dev/shm").glob(f"indurop.{self.instance}.*"):
            shm.unlink(missing_ok=True)

    def close(self) -> None:
        for p in (self.bridge, self.agent):
            if p is not None:
                stop(p)
        self.control.close()
        self.vars.close()
        stop(self.irpd)
        for shm in Path("/dev/shm").glob(f"indurop.{self.instance}.*"):
            shm.unlink(missing_ok=True)


class Peer:
    """The test's own DDS participant on the domain (loopback): reads the bridges' diagnostics and
    writes as a foreign controller would."""

    def __init__(self):
        config = cyclone_config(BridgeSettings(domain_id=DOMAIN))
        self.domain = Domain(DOMAIN, config)
        self.participant = DomainParticipant(DOMAIN)
        topic = Topic(self.participant, "rt/diagnostics", ros2_types.DiagnosticArray)
        self.diagnostics = DataReader(self.participant, topic, Qos(Policy.History.KeepLast(10)))
        self.shared = Topic(self.participant, TOPIC, SharedVariable)

    def status(self, name: str, timeout_s: float = 30) -> dict:
        """The newest DiagnosticStatus called `name`, as {message, level, values}."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            for sample in reversed(self.diagnostics.take(N=50)):
                for s in getattr(sample, "status", []):
                    if s.name == name:
                        return {"message": s.message, "level": s.level, **{kv.key: kv.value for kv in s.values}}
            time.sleep(0.05)
        raise AssertionError(f"no diagnostics status {name!r} within {timeout_s} s")

    def counts(self, variable: str) -> dict:
        s = self.status(f"{B}: import {variable}")
        return {k: int(v) for k, v in s.items() if isinstance(v, str) and v.isdigit()}

    def writer(self) -> DataWriter:
        return DataWriter(self.participant, self.shared, Qos(Policy.Reliability.Reliable(duration(milliseconds=100))))


@pytest.fixture(scope="module")
def line(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("dds-share")
    (tmp / "a").mkdir()
    (tmp / "b").mkdir()
    a = b = None
    try:
        a = Controller(tmp / "a", A, a_file(), agent=False)
        b = Controller(tmp / "b", B, b_file(), agent=True)
        peer = Peer()
        yield a, b, peer
    finally:
        for c in (b, a):
            if c is not None:
                c.close()


def fresh(b: Controller, name: str = "count") -> bool:
    """B's import follows A"""
    value, fallback = (b.read(V + "vec[0]"), -1) if name == "vec" else (b.read(V + name), FALLBACK[name])
    return b.read(f"{V}{name}_stale") is False and value != fallback


def stale_with_fallbacks(b: Controller) -> bool:
    """every import of A stale, with its fallback"""
    return (
        all(b.read(f"{V}{n}_stale") is True for n in FALLBACK)
        and [b.read(f"{V}vec[{i}]") for i in range(4)] == [-1] * 4
        and (b.read(V + "count"), b.read(V + "level"), b.read(V + "small"), b.read(V + "odd")) == (0, -1, -999, False)
    )


def rows(c: Controller, channels: list[str], seconds: float) -> list[dict]:
    """Every trace row of `channels` on `c` for `seconds`: [{"t": due time, path: value}], but the
    first SETTLE rows of the configuration (its first row once showed 0.0 for a channel that never
    held it: not this test's subject)."""
    answer = c.control.request("trace", channels=channels, owner="test")
    ring = TraceRing(answer["shm"])
    cursor, out = ring.head(), []
    try:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            time.sleep(0.2)
            read = ring.read_since(cursor)
            cursor = read.next
            for part in read.parts:
                cols = {p: part.columns[i] for i, p in enumerate(part.config.paths)}
                if all(ch in cols for ch in channels):
                    for k in range(part.count):
                        out.append({"t": part.t_ns[k], **{ch: cols[ch][k] for ch in channels}})
    finally:
        ring.close()
        c.control.request("trace", channels=[], owner="test")
    return out[SETTLE:]


def test_b_follows_a_value_by_value(line):
    a, b, _ = line
    wait_until(lambda: fresh(b) and fresh(b, "level") and fresh(b, "vec"), 60)
    got: dict = {}
    t = threading.Thread(target=lambda: got.setdefault("a", rows(a, ["SHARE.count"], 3.0)))
    t.start()
    b_rows = rows(b, [V + n for n in ("count", "count_stamp_ns", "count_stale", "level", "vec[3]")], 2.5)
    t.join()
    a_rows = got["a"]
    due = {int(r["SHARE.count"]): r["t"] for r in a_rows}  # A's count -> its due time
    counts = sorted(due)
    assert len(b_rows) > 100 and len(counts) > 100
    seen = [r for r in b_rows if r[V + "count_stale"] == 0 and counts[0] <= r[V + "count"] <= counts[-1]]
    assert len(seen) > len(b_rows) // 2, "B's import was stale most of the time"
    exact = 0
    times = sorted(due.values())  # A's due times, and its count at each
    count_at = {t: c for c, t in due.items()}
    for r in seen:
        count, stamp = int(r[V + "count"]), r[V + "count_stamp_ns"]
        assert count in due, f"B holds {count}, a value A never had"
        if not times[0] - 500_000 < stamp < times[-1] + 500_000:
            continue  # a stamp from before A's rows were read (it lags its value by a write)
        # The stamp is A's due time of this value or of one before it (B writes the value, then
        # its stamp): never of a later one.
        i = bisect.bisect_left(times, stamp)
        nearest = min(times[max(0, i - 1) : i + 1], key=lambda t: abs(t - stamp))
        assert abs(nearest - stamp) < 500_000, "B's stamp is no due time of A"
        assert count_at[nearest] <= count
        exact += count_at[nearest] == count
        j = bisect.bisect_right(times, r["t"])  # A's rows due by B's row
        a_now = count_at[times[j - 1]] if j else counts[0]
        assert a_now - count <= LAG_CYCLES, f"B is {a_now - count} of A's cycles behind"
    assert exact > 0
    for r in b_rows:  # the other imports hold values A had
        if counts[0] <= r[V + "level"] * 2 <= counts[-1]:
            assert int(r[V + "level"] * 2) in due
        assert r[V + "vec[3]"] == -1 or r[V + "vec[3]"] - 3 in {c % 1000 for c in due}


def test_the_age_is_small_and_grows_while_a_is_stopped(line):
    a, b, _ = line
    wait_until(lambda: fresh(b), 60)
    assert b.read(V + "count_age_us") < LAG_CYCLES * 1000  # µs: a bound, not a figure
    a.irpd.send_signal(signal.SIGSTOP)
    try:
        wait_until(lambda: b.read(V + "count_stale") is True, 30)
        first = b.read(V + "count_age_us")
        wait_until(lambda: b.read(V + "count_age_us") > first, 30)
        assert b.read(V + "count") == 0
    finally:
        a.irpd.send_signal(signal.SIGCONT)
    wait_until(lambda: fresh(b), 60)


@pytest.mark.parametrize("what", ["bridge", "irpd"])
def test_a_killed_turns_b_stale_with_its_fallbacks_and_an_alarm_and_back(line, what):
    a, b, _ = line
    wait_until(lambda: fresh(b) and fresh(b, "vec"), 60)
    wait_until(lambda: ALARM not in b.alarms() or not b.alarms()[ALARM]["active"], 60)
    if what == "bridge":
        a.bridge.send_signal(signal.SIGKILL)
        a.bridge.wait()
    else:
        a.kill_irpd()
    wait_until(lambda: stale_with_fallbacks(b), 30)
    alarm = wait_until(lambda: b.alarms().get(ALARM, {}).get("active") and b.alarms()[ALARM], 30)
    assert alarm["severity"] == "high" and f"{A}:SHARE.count" in alarm["detail"], alarm
    assert b.bridge.poll() is None and b.irpd.poll() is None
    if what == "bridge":
        a.start_bridge()
    else:
        a.start_irpd()
        a.vars.close()
        a.vars = Segment(wait_until(a.status, 60)["shared_memory"]["variables"])
    wait_until(lambda: fresh(b) and fresh(b, "level") and fresh(b, "vec"), 60)
    first = b.read(V + "count")
    wait_until(lambda: b.read(V + "count") != first, 30)  # follows again
    wait_until(lambda: not b.alarms().get(ALARM, {}).get("active"), 30)


def test_b_s_own_bridge_killed_its_stamp_ages_and_the_alarm_says_so(line):
    """The flag stays as the dead bridge left it; the stamp is what tells."""
    _, b, _ = line
    wait_until(lambda: fresh(b), 60)
    wait_until(lambda: not b.alarms().get(ALARM, {}).get("active"), 60)
    b.bridge.send_signal(signal.SIGKILL)
    b.bridge.wait()
    flag = b.read(V + "count_stale")
    alarm = wait_until(lambda: b.alarms().get(ALARM, {}).get("active") and b.alarms()[ALARM], 30)
    if flag is False:  # as the bridge left it, following A: only the stamp's age tells
        assert "count_stamp_ns is" in alarm["detail"] and "the DDS bridge does not write it" in alarm["detail"], alarm
    b.start_bridge()
    wait_until(lambda: fresh(b), 60)
    wait_until(lambda: not b.alarms().get(ALARM, {}).get("active"), 30)


def test_an_unknown_source_stays_stale_and_a_mismatch_is_counted_never_written(line):
    a, b, peer = line
    wait_until(lambda: fresh(b), 60)
    assert b.read(V + "unknown_stale") is True and b.read(V + "unknown") == 42
    assert b.read(V + "wrong_stale") is True and b.read(V + "wrong") == -5

    def mismatch_said():
        """B's diagnostics name the mismatch of the import 'wrong' (the status taken may be one
        published before B's first sample of it: 'no sample yet')"""
        status = peer.status(f"{B}: import {V}wrong")
        return status if "exports SHARE.count as uint32" in status["message"] else None

    wrong = wait_until(mismatch_said, 30)
    assert wrong["level"] == 1, wrong
    assert int(wrong["mismatched"]) > 0 and int(wrong["written"]) == 0
    unknown = peer.status(f"{B}: import {V}unknown")
    assert unknown["message"] == "no sample yet" and int(unknown["received"]) == 0
    assert b.bridge.poll() is None and a.bridge.poll() is None
    alarms = b.alarms()
    assert alarms[f"dds/import:{V}unknown"]["active"] and alarms[f"dds/import:{V}wrong"]["active"]


def test_a_flood_from_a_foreign_writer_is_bounded_and_counted(line):
    a, b, peer = line
    wait_until(lambda: fresh(b), 60)
    before, ignored = peer.counts(V + "unknown"), int(peer.status(f"{B}: dds bridge")["imports_ignored"])
    writer = peer.writer()
    n, start = 5000, time.monotonic()
    for i in range(1, n + 1):
        writer.write(
            SharedVariable(
                controller=f"nobody-{PID}",
                path="SHARE.level",
                seq=i,
                stamp_ns=time.time_ns(),
                every=1,
                type="float64",
                values=[i * 0.5],
            )
        )
        writer.write(
            SharedVariable(
                controller=f"intruder-{PID}",
                path=f"x{i % 100}",
                seq=i,
                stamp_ns=time.time_ns(),
                every=1,
                type="bool",
                values=[1.0],
            )
        )
    time.sleep(0.5)
    elapsed = time.monotonic() - start + 1.0  # and the diagnostics' period
    after = peer.counts(V + "unknown")
    written = after["written"] - before["written"]
    received = after["received"] - before["received"]
    assert 0 < written <= 50 * elapsed + 2, (written, elapsed)  # rate_hz 50
    assert received >= written and received + after["superseded"] - before["superseded"] <= n
    assert int(peer.status(f"{B}: dds bridge")["imports_ignored"]) > ignored
    del writer  # the foreign writer goes: the import is stale again, with its fallback
    wait_until(lambda: b.read(V + "unknown_stale") is True and b.read(V + "unknown") == 42, 30)
    assert fresh(b) or wait_until(lambda: fresh(b), 30)
    assert b.bridge.poll() is None and b.irpd.poll() is None and b.status()["running"]


def test_a_bad_import_is_refused_at_upload_naming_what_to_fix(line):
    _, b, _ = line
    files = {p.name: p.read_bytes() for p in (SET / "module.xml", SET / "share.so", SET / "layout.json")}

    def upload(imports: list[dict]) -> httpx.Response:
        body = {**files, "dds.json": json.dumps({"imports": imports}, indent=1).encode()}
        return httpx.post(
            f"http://127.0.0.1:{b.port}{API}/sets",
            files=[("files", (name, content)) for name, content in body.items()],
            headers=b.h,
            timeout=60,
        )

    base = {"from": A, "path": "SHARE.count", "variable": V + "count", "stale": V + "count_stale"}
    for imports, words in (
        (
            [{**base, "variable": V + "nothing"}],
            "no scalar variable or array of scalars SHARE.IN.nothing in the layout",
        ),
        ([{**base, "stale": V + "level"}], "the staleness flag SHARE.IN.level is a float64; it must be a bool"),
        (
            [{**base, "variable": "SHARE.count"}],
            "SHARE.count would have two writers: module share (module.xml <writes>SHARE.count</writes>) and the import of",
        ),
    ):
        r = upload(imports)
        assert r.status_code == 400, r.text
        assert words in r.json()["detail"] and r.json()["file"] == "dds.json", r.text
    assert upload([base]).status_code in (200, 201)

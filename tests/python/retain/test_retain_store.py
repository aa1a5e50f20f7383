"""test_retain_store.py -- RETAIN and PERSISTENT shared variables kept by a real irpd across its
restarts (docs/retain.md): the two copies in the state folder, a SIGKILL while a copy is written, a
copy torn or corrupted (and the alarm as the agent shows it), both corrupted, a copy that cannot be
written, a changed program (a start and a managed restart), and the bound on the writes' rate.

The set: keep.glb (a RETAIN counter, a PERSISTENT total, a plain variable, a RETAIN array) and
the fixture module retained.so, which adds 1 to the counter every 10 ms period and writes the value it finds in its initialize() to a journal: what irpd restored."""

from __future__ import annotations

import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest
from indurop_agent.alarms.segment import AlarmSegment
from indurop_agent.irpd.client import IrpdClient
from indurop_agent.irpd.variables import Segment
from live_processes import (
    API,
    BUILD,
    ROOT,
    free_port,
    module_entry,
    remove_shm,
    start_agent,
    start_irpd,
    stop,
    wait_dispatching,
    wait_until,
)

RETAINED = BUILD / "tests" / "cpp" / "modules" / "retained.so"
pytestmark = pytest.mark.skipif(not RETAINED.exists(), reason=f"the fixture module is not built ({RETAINED})")

GLB = """namespace keep;
retain uint64_t count;
persistent uint64_t total;
uint64_t plain;
retain uint64_t history[8];
"""
SEQUENCE_AT = 16  # the header's sequence number (rtcore/src/retain/retain_file.cpp)


class Cell:
    """One irpd instance on a set of its own, its state folder, and the journal of retained.so."""

    def __init__(self, folder: Path):
        self.folder = folder
        self.state = folder / "state"
        self.journal = folder / "journal"
        self.instance = f"retain-{os.getpid()}-{random.randrange(1 << 30)}"
        self.sets = {}
        self.process = None
        self.client = None
        self.make_set("a", GLB)
        self.make_set("b", GLB + "uint32_t added;\n")  # a changed program

    def make_set(self, name: str, glb: str) -> None:
        folder = self.folder / name
        folder.mkdir(parents=True)
        (folder / "keep.glb").write_text(glb)
        subprocess.run([sys.executable, str(ROOT / "glb" / "glbc"), "keep.glb", "-o", "."], cwd=folder, check=True)
        shutil.copy(RETAINED, folder / "retained.so")
        props = (
            f'<property><value name="count">keep.count</value><value name="journal">{self.journal}</value></property>'
        )
        module = module_entry("count", "./retained.so", 10_000_000, 1, props)
        (folder / "module.xml").write_text(f"<root>\n{module}</root>\n")
        self.sets[name] = folder / "module.xml"

    def start(self, name: str = "a", interval_ms: int = 50) -> dict:
        self.process = start_irpd(
            self.folder / "irpd.sock",
            self.sets[name],
            self.instance,
            "--no-rt",
            "--state-dir",
            str(self.state),
            "--retain-interval",
            str(interval_ms),
            log=self.folder / "irpd.log",
        )
        self.client = IrpdClient(str(self.folder / "irpd.sock"), timeout_s=30)
        return wait_dispatching(self.client)

    def stop(self) -> None:
        self.client.close()
        stop(self.process)

    def kill(self) -> None:
        self.client.close()
        self.process.send_signal(signal.SIGKILL)
        self.process.wait()
        remove_shm(self.instance)

    def status(self) -> dict:
        return self.client.request("status")["retain"]

    def events(self, kind: str) -> list[str]:
        return [e["message"] for e in self.client.request("events", since=0)["events"] if e["kind"] == kind]

    def value(self, path: str):
        return Segment(f"/indurop.{self.instance}.vars").read(path)

    def write(self, path: str, value) -> None:
        self.client.request("write", path=path, value=value)

    def restored_counts(self) -> list[int]:
        """The counter's value at each start's initialize(), oldest first."""
        return [int(line.split("=")[1]) for line in self.journal.read_text().split("\n") if line]

    def copies(self) -> list[Path]:
        return [self.state / f"{self.instance}.retain.{x}" for x in "ab"]

    def saves(self, n: int) -> None:
        """Waits for n more copies written."""
        first = self.status()["sequence"]
        wait_until(lambda: self.status()["sequence"] >= first + n)

    def irpd_alarms(self) -> tuple[list[int], list]:
        """irpd's active alarm ids (the `alarms` command) and its records in the alarm segment."""
        active = self.client.request("alarms")["sources"][0]["active"]
        ring = AlarmSegment(f"/indurop.{self.instance}.alarms")
        records = [ring.record(s) for s in range(1, ring.head() + 1)]
        return active, [r for r in records if not isinstance(r, int) and r.source == 0]


@pytest.fixture
def cell(tmp_path):
    c = Cell(tmp_path)
    yield c
    if c.process:
        c.client.close()
        stop(c.process)


def test_values_survive_a_restart_and_the_plain_ones_do_not(cell):
    cell.start()
    cell.write("keep.total", 7)
    cell.write("keep.plain", 5)
    wait_until(lambda: cell.value("keep.count") > 20)
    cell.saves(2)
    cell.stop()
    cell.start()
    first, second = cell.restored_counts()
    assert first == 0 and second > 20  # restored before the module's initialize()
    assert (cell.value("keep.total"), cell.value("keep.plain")) == (7, 0)
    (restored,) = cell.events("retain")
    assert "restored 3 of 3 retained variables" in restored and "the same program" in restored
    status = cell.status()
    assert status["variables"] == 3 and status["last_error"] is None
    assert status["file"] in [str(c) for c in cell.copies()]


def test_writes_are_bounded_by_the_interval(cell):
    cell.start(interval_ms=200)
    cell.saves(1)
    began, sequence, time_began = time.monotonic(), cell.status()["sequence"], cell.status()["last_save_ns"]
    time.sleep(2)
    window = time.monotonic() - began
    written = cell.status()["sequence"] - sequence
    # the counter changes every 10 ms; at most one write per 200 ms, and one at the window's edges
    assert 1 <= written <= window / 0.2 + 2, written
    assert cell.status()["last_save_ns"] > time_began


def test_nothing_is_written_while_nothing_changes(cell):
    xml = cell.sets["a"]
    xml.write_text(xml.read_text().replace("keep.count", "keep.plain"))  # the module counts a plain variable
    cell.start(interval_ms=50)
    cell.saves(1)  # the first copy of this program; then no retained value changes
    sequence = cell.status()["sequence"]
    time.sleep(1)
    assert cell.status()["sequence"] == sequence


def test_a_sigkill_while_a_copy_is_written_keeps_the_values(cell, monkeypatch):
    """Every other kill lands while a copy is being written: irpd pauses 300 ms between a copy
    written to <copy>.tmp and its rename (INDUROP_RETAIN_TEST_PAUSE_MS, a test's hook) and is killed
    while <copy>.tmp is there; the others land at a random time."""
    monkeypatch.setenv("INDUROP_RETAIN_TEST_PAUSE_MS", "300")
    cell.start(interval_ms=10)
    cell.write("keep.total", 7)
    cell.saves(2)  # a whole copy holds it (the first may have been captured before the write)
    for attempt in range(6):
        if attempt % 2 == 0:
            wait_until(lambda: any(Path(f"{c}.tmp").exists() for c in cell.copies()))
        else:
            time.sleep(random.uniform(0, 0.5))
        cell.kill()
        if attempt % 2 == 0:
            assert any(Path(f"{c}.tmp").exists() for c in cell.copies())  # killed between write and rename
        cell.start(interval_ms=10)
        assert cell.events("retain_corrupt") == []
        restored = cell.restored_counts()
        assert restored[-1] >= max(restored[:-1]) and cell.value("keep.total") == 7  # never older, never lost
    assert restored[-1] > 0


def corrupt(file: Path, how: str) -> None:
    data = bytearray(file.read_bytes())
    if how == "flip":
        for i in range(len(data) - 8, len(data)):
            data[i] ^= 0xFF
        file.write_bytes(bytes(data))
    else:
        file.write_bytes(bytes(data[: len(data) // 2]))


def newest(cell) -> tuple[Path, Path]:
    a, b = cell.copies()
    seq = {c: int.from_bytes(c.read_bytes()[SEQUENCE_AT : SEQUENCE_AT + 8], "little") for c in (a, b)}
    return (a, b) if seq[a] > seq[b] else (b, a)


def corrupt_the_newest(cell, how: str) -> tuple[Path, Path]:
    """Runs the cell until both copies hold total = 7, stops it, spoils the newest copy and starts
    it again with no write soon (the alarm stays active while the test looks); (bad, good)."""
    cell.start()
    cell.write("keep.total", 7)
    cell.saves(3)
    cell.stop()
    bad, good = newest(cell)
    corrupt(bad, how)
    cell.start(interval_ms=60_000)
    return bad, good


@pytest.mark.parametrize("how", ["flip", "truncate"])
def test_a_corrupt_copy_falls_back_to_the_other_and_raises_an_alarm(cell, how):
    bad, good = corrupt_the_newest(cell, how)
    (why,) = cell.events("retain_corrupt")
    assert why.startswith(str(bad)) and str(good) in why
    assert ("corrupt" if how == "flip" else "torn") in why
    (restored,) = cell.events("retain")
    assert f"from {good}" in restored
    assert cell.value("keep.total") == 7 and cell.restored_counts()[-1] > 0
    active, records = cell.irpd_alarms()
    assert active == [1]
    assert [(r.id, r.raised) for r in records] == [(1, True)] and bad.name in records[0].text
    declared = cell.client.request("alarms")["sources"][0]["declared"]
    assert [d["id"] for d in declared] == [1, 2]
    cell.stop()  # the stop writes the bad copy anew
    cell.start(interval_ms=60_000)
    assert cell.events("retain_corrupt") == []


def test_both_copies_corrupt_start_at_initial_values(cell):
    cell.start()
    cell.write("keep.total", 7)
    cell.saves(3)
    cell.stop()
    for copy in cell.copies():
        corrupt(copy, "flip")
    cell.start(interval_ms=60_000)  # irpd starts all the same
    assert len(cell.events("retain_corrupt")) == 2
    assert all("no good copy" in e for e in cell.events("retain_corrupt"))
    assert cell.restored_counts()[-1] == 0 and cell.value("keep.total") == 0
    assert cell.irpd_alarms()[0] == [1]


def test_persistent_survives_a_changed_program_and_retain_does_not(cell):
    cell.start("a")
    cell.write("keep.total", 7)
    wait_until(lambda: cell.value("keep.count") > 20)
    cell.stop()
    cell.start("b")  # another layout: the download of a changed program
    assert cell.restored_counts()[-1] == 0  # RETAIN: its initial value
    assert cell.value("keep.total") == 7  # PERSISTENT: kept
    (restored,) = cell.events("retain")
    assert "restored 1 of 3" in restored and "saved by another program" in restored
    cell.write("keep.total", 8)
    wait_until(lambda: cell.value("keep.count") > 20)

    # A managed restart back into set a: a changed program again.
    cell.client.request("restart", config=str(cell.sets["a"]))
    wait_until(lambda: cell.process.poll() is None and _running(cell, cell.sets["a"]), 60)
    assert cell.restored_counts()[-1] == 0
    assert cell.value("keep.total") == 8


def _running(cell, config: Path) -> bool:
    """irpd answers with `config` running."""
    try:
        return cell.client.request("status")["set"] == str(config)
    except Exception:
        return False


def test_a_copy_that_cannot_be_written_is_an_error_and_an_alarm_until_a_write_succeeds(cell):
    cell.state.mkdir()
    for copy in cell.copies():
        Path(f"{copy}.tmp").mkdir()  # where the copy is written first: a folder, even root cannot write it
    cell.start()
    failed = wait_until(lambda: cell.status()["last_error"])
    assert "cannot create" in failed and ".retain.a.tmp" in failed
    (event,) = cell.events("retain_write_failed")  # once, not at every pass
    assert event == failed
    assert cell.irpd_alarms()[0] == [2]
    for copy in cell.copies():
        Path(f"{copy}.tmp").rmdir()
    wait_until(lambda: cell.status()["last_error"] is None)
    assert cell.irpd_alarms()[0] == []
    assert [(r.id, r.raised) for r in cell.irpd_alarms()[1]] == [(2, True), (2, False)]


def test_the_agent_shows_the_alarm_with_its_declared_text_and_the_store_in_its_status(cell):
    bad, good = corrupt_the_newest(cell, "flip")
    port, data = free_port(), cell.folder / "agent"
    agent = start_agent(port, data, cell.folder / "irpd.sock", log=cell.folder / "agent.log")
    try:
        token = (data / "admin-token").read_text().strip()

        def irpd_alarm():
            """the agent lists irpd/1"""
            r = httpx.get(f"http://127.0.0.1:{port}{API}/alarms", headers={"Authorization": f"Bearer {token}"})
            return next((a for a in r.json()["alarms"] if a["key"] == "irpd/1"), None)

        alarm = wait_until(irpd_alarm, 60, 0.2)
        assert alarm["text"].startswith("A copy of the retain store was torn or corrupt")
        assert alarm["severity"] == "high" and bad.name in alarm["detail"]
        status = httpx.get(f"http://127.0.0.1:{port}{API}/status", headers={"Authorization": f"Bearer {token}"})
        assert status.json()["retain"] | {"last_save_ns": None} == {
            "file": str(good),
            "last_save_ns": None,
            "sequence": int.from_bytes(good.read_bytes()[SEQUENCE_AT : SEQUENCE_AT + 8], "little"),
            "variables": 3,
            "last_error": None,
        }
    finally:
        stop(agent)

"""The agent's memory snapshots (memtrace.py): PYTHONTRACEMALLOC + SIGUSR2 write them, the comparison
names the call site that grew, and without the tracer SIGUSR2 is left alone."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import live_processes
from indurop_agent.system import memtrace

ROOT = Path(__file__).resolve().parents[3]


def wait_for(paths, count: int, seconds: float = 30.0) -> list[Path]:
    deadline = time.monotonic() + seconds
    while len(found := sorted(paths())) < count:
        assert time.monotonic() < deadline, f"{len(found)} snapshots of {count}"
        time.sleep(0.1)
    return found


def test_sigusr2_writes_snapshots_of_a_traced_agent(tmp_path, monkeypatch):
    monkeypatch.setenv("PYTHONTRACEMALLOC", "5")
    data = tmp_path / "data"
    # Tracing every allocation with 5 frames slows the agent's imports several times over: on a
    # loaded machine its start takes longer than the usual minute.
    agent = live_processes.start_agent(
        live_processes.free_port(), data, tmp_path / "no-irpd.sock", timeout_s=4 * live_processes.START_TIMEOUT_S
    )
    try:
        for n in (1, 2):
            agent.send_signal(signal.SIGUSR2)
            snaps = wait_for(lambda: (data / "memtrace").glob("*.snap"), n)
        assert [p.name for p in snaps] == [f"{agent.pid}-1.snap", f"{agent.pid}-2.snap"]
        assert (data / "memtrace").stat().st_mode & 0o777 == 0o700
        assert agent.poll() is None  # the signal did not end it
        assert f"kill -USR2 {agent.pid}" in live_processes.output(agent)
        g = memtrace.growth(*snaps)
        assert g["traced_kib"]["old"] > 1000 and g["traced_kib"]["new"] > 1000  # a whole FastAPI app
        assert all(d["where"] and ":" in d["where"][-1] for d in g["top"])
    finally:
        live_processes.stop(agent)


def test_the_comparison_names_the_call_site_that_grew(tmp_path):
    hoard: list[bytes] = []

    def grow() -> None:
        hoard.extend(bytes(1000) for _ in range(2000))  # about 2 MB from this line

    tracemalloc.start(5)
    try:
        tracemalloc.take_snapshot().dump(str(tmp_path / "old.snap"))
        grow()
        tracemalloc.take_snapshot().dump(str(tmp_path / "new.snap"))
    finally:
        tracemalloc.stop()
    g = memtrace.growth(tmp_path / "old.snap", tmp_path / "new.snap")
    first = g["top"][0]
    assert first["size_diff_kib"] > 1900 and first["count_diff"] >= 2000
    assert any(w.endswith(f"test_memtrace.py:{grow.__code__.co_firstlineno + 1}") for w in first["where"])

    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "indurop_agent.system.memtrace",
            str(tmp_path / "old.snap"),
            str(tmp_path / "new.snap"),
            "--top",
            "3",
        ],
        cwd=ROOT / "agent",
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr
    assert "traced by Python:" in out.stdout and "test_memtrace.py" in out.stdout


def test_a_missing_snapshot_is_named(tmp_path):
    out = subprocess.run(
        [sys.executable, "-m", "indurop_agent.system.memtrace", str(tmp_path / "a.snap"), str(tmp_path / "b.snap")],
        cwd=ROOT / "agent",
        capture_output=True,
        text=True,
    )
    assert out.returncode == 2 and f"{tmp_path / 'a.snap'}: no such snapshot" in out.stderr


def test_without_the_tracer_nothing_is_installed(tmp_path):
    assert not tracemalloc.is_tracing()
    before = signal.getsignal(signal.SIGUSR2)
    assert memtrace.install(tmp_path) is None
    assert signal.getsignal(signal.SIGUSR2) is before and not (tmp_path / "memtrace").exists()

"""test_live_processes.py -- the tests' own helpers leave /dev/shm clean: an irpd a test killed
(SIGKILL: it cannot remove its segments) leaves none once stopped (live_processes.stop, and the
teardown of conftest.py), and an irpd started again on the same instance keeps its own; the ports
they hand out are free, outside the kernel's ephemeral range and apart per pytest-xdist worker."""

from __future__ import annotations

import os
import signal
import socket
from pathlib import Path

import live_processes
import pytest
from live_processes import FIG1, IRPD, free_port, start_irpd, stop, wait_until

needs_irpd = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")


def test_free_ports_are_free_outside_the_ephemeral_range_and_apart_per_worker(monkeypatch):
    low_ephemeral = int(Path("/proc/sys/net/ipv4/ip_local_port_range").read_text().split()[0])
    seen: dict[str, set[int]] = {}
    for worker in ("gw0", "gw1"):
        monkeypatch.setenv("PYTEST_XDIST_WORKER", worker)
        monkeypatch.setattr(live_processes, "_next_port", [])
        seen[worker] = {free_port() for _ in range(50)}
        assert len(seen[worker]) == 50, "a port was handed out twice"
        assert max(seen[worker]) < low_ephemeral
    assert not seen["gw0"] & seen["gw1"]
    with socket.socket() as held:  # a port something holds is skipped
        first = free_port()
        held.bind(("127.0.0.1", first))  # free a moment ago: held now, by this test
        live_processes._next_port[0] -= 1  # the next call starts at it again
        assert free_port() != first


def segments(instance: str) -> list[str]:
    return sorted(p.name for p in Path("/dev/shm").glob(f"indurop.{instance}.*"))


def killed(p) -> None:
    os.kill(p.pid, signal.SIGKILL)
    p.wait()


@needs_irpd
def test_an_irpd_killed_with_sigkill_leaves_no_segment_once_stopped(tmp_path):
    instance = f"live-processes-{os.getpid()}-killed"
    p = start_irpd(tmp_path / "irpd.sock", FIG1, instance)
    left = wait_until(lambda: segments(instance))
    killed(p)
    assert segments(instance) == left  # irpd could not remove them
    stop(p)
    assert segments(instance) == []


@needs_irpd
def test_an_irpd_started_again_on_the_instance_keeps_its_segments(tmp_path):
    instance = f"live-processes-{os.getpid()}-again"
    first = start_irpd(tmp_path / "first.sock", FIG1, instance)
    wait_until(lambda: segments(instance))
    killed(first)
    second = start_irpd(tmp_path / "second.sock", FIG1, instance)  # replaces the dead one's segments
    wait_until(lambda: segments(instance))
    stop(first)  # ended before the second started: what is there is the second's
    assert segments(instance) and second.poll() is None
    stop(second)
    assert segments(instance) == []

"""test_live_processes.py -- the tests' own helpers leave /dev/shm clean: an irpd a test killed
(SIGKILL: it cannot remove its segments) leaves none once stopped (live_processes.stop, and the
teardown of conftest.py), and an irpd started again on the same instance keeps its own."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest
from live_processes import FIG1, IRPD, start_irpd, stop, wait_until

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")


def segments(instance: str) -> list[str]:
    return sorted(p.name for p in Path("/dev/shm").glob(f"indurop.{instance}.*"))


def killed(p) -> None:
    os.kill(p.pid, signal.SIGKILL)
    p.wait()


def test_an_irpd_killed_with_sigkill_leaves_no_segment_once_stopped(tmp_path):
    instance = f"live-processes-{os.getpid()}-killed"
    p = start_irpd(tmp_path / "irpd.sock", FIG1, instance)
    left = wait_until(lambda: segments(instance))
    killed(p)
    assert segments(instance) == left  # irpd could not remove them
    stop(p)
    assert segments(instance) == []


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

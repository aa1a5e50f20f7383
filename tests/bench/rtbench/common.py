"""common.py -- what every part of the benchmark uses: where the repository is, the targets, the
CPUs, logging, running a program with a deadline, the power-management request, figure formatting.
"""

from __future__ import annotations

import os
import shlex
import struct
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]  # tests/bench/rtbench/common.py -> the repository

# Targets of the issue (item 8).
P99_RATIO_TARGET = 1.3
PROC_P99_RATIO_TARGET = 1.1  # a process module's wake-up p99 against a thread module's, same run (issue 28)
OVERHEAD_TARGET_NS = 50.0  # dispatch per empty thread module (issue 28)
LONG_RUN_TARGET_S = 60

# CPUs this script may use; children get them all back (the script itself keeps off the measured CPU).
ALLOWED_CPUS = sorted(os.sched_getaffinity(0))


def restore_affinity() -> None:
    os.sched_setaffinity(0, ALLOWED_CPUS)


class BenchError(Exception):
    """Something failed to run (as opposed to a target that was missed)."""


def mono_ns() -> int:
    return time.clock_gettime_ns(time.CLOCK_MONOTONIC)


def log(msg: str) -> None:
    print(f"[bench] {msg}", file=sys.stderr, flush=True)


def quote(cmd: list[str]) -> str:
    return " ".join(shlex.quote(str(c)) for c in cmd)


def rel(path: Path) -> str:
    """A path as shown in the report: relative to the repository when inside it."""
    try:
        return str(Path(path).resolve().relative_to(REPO))
    except ValueError:
        return str(path)


def two_process_cmd(binary: Path, a, seconds: int, *extra: str) -> list[str]:
    """The command of signal_wakeup or release_variants at the run's period, CPU and priority."""
    return [
        str(binary),
        "--period-ns",
        str(a.period_ns),
        "--duration",
        str(seconds),
        "--cpu",
        str(a.cpu),
        "--rt-priority",
        str(a.rt_priority),
        *extra,
    ]


def run_checked(cmd: list[str], what: str, timeout: float) -> subprocess.CompletedProcess:
    log(f"{what}: {quote(cmd)}")
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, preexec_fn=restore_affinity)
    except subprocess.TimeoutExpired as e:
        raise BenchError(f"{what} did not finish within {timeout:.0f} s") from e
    if p.returncode != 0:
        raise BenchError(f"{what} exited with status {p.returncode}:\n{p.stdout[-2000:]}{p.stderr[-2000:]}")
    return p


class PmQos:
    """Holds /dev/cpu_dma_latency at 0 us while open, as cyclictest does for itself, so that every
    program of the benchmark runs under the same power-management request."""

    def __init__(self, enabled: bool):
        self.enabled, self.fd = enabled, None

    def __enter__(self):
        if self.enabled:
            try:
                self.fd = os.open("/dev/cpu_dma_latency", os.O_WRONLY)
                os.write(self.fd, struct.pack("i", 0))
            except OSError as e:
                log(f"cannot hold /dev/cpu_dma_latency at 0 ({e}); running without")
                self.fd = None
        return self

    def __exit__(self, *exc):
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None

    @property
    def held(self) -> bool:
        return self.fd is not None


def us(ns) -> str:
    return "—" if ns is None else f"{ns / 1000:.2f}"


def ratio(x, y) -> float | None:
    return None if x is None or y in (None, 0) else x / y


def fmt_ratio(r) -> str:
    return "—" if r is None else f"{r:.2f}×"


def verdict(ok: bool) -> str:
    return "PASS" if ok else "FAIL"

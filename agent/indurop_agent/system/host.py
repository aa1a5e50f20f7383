"""host.py -- the host's load for GET /host, read from /proc: busy fraction per CPU (/proc/stat),
load averages (/proc/loadavg), and a process's CPU time, resident memory and threads
(/proc/<pid>/stat).  CPU figures are differences between two samples; Sampler keeps the last one."""

from __future__ import annotations

import os
import threading
import time
from dataclasses import dataclass, field

TICKS_PER_S = os.sysconf("SC_CLK_TCK")
PAGE_BYTES = os.sysconf("SC_PAGE_SIZE")
FIRST_INTERVAL_S = 0.1  # the first request samples twice, this far apart
MIN_INTERVAL_S = 0.05  # a previous sample younger than this is too close to difference against


@dataclass
class CpuTimes:
    busy: int  # jiffies not idle
    total: int


@dataclass
class ProcessTimes:
    pid: int
    cpu_ticks: int  # utime + stime
    rss_bytes: int
    threads: int


@dataclass
class Sample:
    time: float  # time.monotonic()
    cpus: dict[int, CpuTimes] = field(default_factory=dict)
    processes: dict[int, ProcessTimes] = field(default_factory=dict)


def read_cpus(path: str = "/proc/stat") -> dict[int, CpuTimes]:
    """Per CPU: jiffies not idle and all jiffies (guest time is already inside user time)."""
    cpus = {}
    with open(path) as f:
        for line in f:
            if not line.startswith("cpu") or line.startswith("cpu "):
                continue
            name, *values = line.split()
            ticks = [int(v) for v in values[:8]]  # user nice system idle iowait irq softirq steal
            idle = ticks[3] + (ticks[4] if len(ticks) > 4 else 0)
            total = sum(ticks)
            cpus[int(name[3:])] = CpuTimes(total - idle, total)
    return cpus


def read_process(pid: int) -> ProcessTimes | None:
    """utime + stime, RSS and thread count of `pid`; None when it is gone or cannot be read."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            text = f.read()
    except OSError:
        return None
    # The command name (field 2) may hold spaces and parentheses: the fields after it follow the last ')'.
    fields = text[text.rfind(")") + 2 :].split()
    try:
        # fields[0] is field 3 (state): utime 14, stime 15, num_threads 20, rss 24 (pages).
        return ProcessTimes(pid, int(fields[11]) + int(fields[12]), int(fields[21]) * PAGE_BYTES, int(fields[17]))
    except (IndexError, ValueError):
        return None


def load_averages(path: str = "/proc/loadavg") -> list[float]:
    with open(path) as f:
        return [float(v) for v in f.read().split()[:3]]


def take(pids: list[int]) -> Sample:
    sample = Sample(time.monotonic(), read_cpus())
    for pid in pids:
        p = read_process(pid)
        if p is not None:
            sample.processes[pid] = p
    return sample


def process_load(pid: int, before: Sample, after: Sample) -> dict | None:
    a, b = before.processes.get(pid), after.processes.get(pid)
    if a is None or b is None:
        return None
    interval = max(after.time - before.time, 1e-9)
    cpu = max(0, b.cpu_ticks - a.cpu_ticks) / TICKS_PER_S / interval
    return {"pid": pid, "cpu": round(cpu, 4), "rss_bytes": b.rss_bytes, "threads": b.threads}


class Sampler:
    """Answers the host's load over the interval since the previous request (or over 100 ms for
    the first one, or when the previous sample is too recent or lacks a process asked for now)."""

    def __init__(self, sleep=time.sleep):
        self.sleep = sleep
        self.started = time.monotonic()
        self._previous: Sample | None = None
        self._lock = threading.Lock()

    def load(self, irpd_pid: int | None) -> dict:
        pids = [os.getpid()] + ([irpd_pid] if irpd_pid else [])
        with self._lock:
            before = self._previous
            fresh = (
                before is None
                or time.monotonic() - before.time < MIN_INTERVAL_S
                or any(pid not in before.processes and read_process(pid) is not None for pid in pids)
            )
            if fresh:
                before = take(pids)
                self.sleep(FIRST_INTERVAL_S)
            after = take(pids)
            self._previous = after
        interval = after.time - before.time
        cpus = []
        for cpu, b in sorted(after.cpus.items()):
            a = before.cpus.get(cpu)
            total = b.total - a.total if a else 0
            busy = (b.busy - a.busy) / total if a and total > 0 else 0.0
            cpus.append({"cpu": cpu, "busy": round(min(max(busy, 0.0), 1.0), 4)})
        return {
            "cpus": cpus,
            "load_avg": load_averages(),
            "interval_s": round(interval, 4),
            "irpd": process_load(irpd_pid, before, after) if irpd_pid else None,
            "agent": process_load(os.getpid(), before, after),
            "agent_uptime_s": round(time.monotonic() - self.started, 3),
        }

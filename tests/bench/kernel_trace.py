"""kernel_trace.py -- what the kernel did between a Modbus request and its late answer, for
tests/bench/io_load.py --kernel-trace: the scheduler's own events from ftrace (tracefs), on the
CLOCK_MONOTONIC clock.

Recorded: the drive simulator's context switches (sched_switch; the switch into it names the task
that ran before it, and that task's state) and its wake-ups (sched_waking: who woke it, from which
CPU).  For one late answer this tells apart

- the wake-up came late: the request reached the simulator's socket late (the loopback softirq ran
  late, e.g. deferred to a ksoftirqd thread that waited for a CPU);
- the simulator was woken in time but ran late: something else held its CPU (named, with its
  priority) or nothing ran at all (the hypervisor took the virtual CPU: steal);
- it ran in time and answered late: its own work.
"""

from __future__ import annotations

import bisect
import re
import subprocess
from dataclasses import dataclass
from pathlib import Path

TRACEFS = next(
    (p for p in (Path("/sys/kernel/tracing"), Path("/sys/kernel/debug/tracing")) if (p / "trace").exists()), None
)

# "  <comm>-<pid>  [001] d..2.  1234.567890123: sched_switch: prev_comm=... ==> next_comm=..."
_LINE = re.compile(
    r"^\s*(?P<task>.+?)-(?P<pid>\d+)\s+\[(?P<cpu>\d+)\]\s+\S+\s+(?P<ts>\d+\.\d+): (?P<event>\w+): (?P<rest>.*)$"
)
_SWITCH = re.compile(
    r"prev_comm=(?P<prev>.*?) prev_pid=(?P<prev_pid>-?\d+) prev_prio=(?P<prev_prio>-?\d+) prev_state=(?P<state>\S+)"
    r" ==> next_comm=(?P<next>.*?) next_pid=(?P<next_pid>-?\d+) next_prio=(?P<next_prio>-?\d+)"
)


class KernelTrace:
    """ftrace's sched events streamed to a file while it runs (start/stop); root only."""

    def __init__(self, out: Path, pid: int, buffer_kb: int = 16384):
        if TRACEFS is None:
            raise RuntimeError("tracefs is not mounted (mount -t tracefs nodev /sys/kernel/tracing)")
        self.out, self.pid, self.buffer_kb = out, pid, buffer_kb
        self._reader = None

    def _w(self, name: str, value: str) -> None:
        (TRACEFS / name).write_text(value)

    def _r(self, name: str) -> str:
        return (TRACEFS / name).read_text()

    def start(self) -> None:
        # what stop() puts back: the clock in brackets ("[local] global ..."), the buffer's real
        # size ("7 (expanded: 1408)" before its first use)
        self._clock = re.search(r"\[(\w+)\]", self._r("trace_clock")).group(1)
        size = self._r("buffer_size_kb")
        self._buffer_kb = (re.search(r"expanded: (\d+)", size) or re.match(r"(\d+)", size)).group(1)
        self._w("tracing_on", "0")
        self._w("trace", "")
        self._w("trace_clock", "mono")
        self._w("buffer_size_kb", str(self.buffer_kb))
        self._w("events/enable", "0")
        # the simulator's wake-ups, and its own switches: the one into it names what ran before it
        self._w("events/sched/sched_waking/filter", f"pid == {self.pid}")
        self._w("events/sched/sched_switch/filter", f"prev_pid == {self.pid} || next_pid == {self.pid}")
        self._w("events/sched/sched_waking/enable", "1")
        self._w("events/sched/sched_switch/enable", "1")
        self._reader = subprocess.Popen(["cat", str(TRACEFS / "trace_pipe")], stdout=open(self.out, "w"))
        self._w("tracing_on", "1")

    def stop(self) -> None:
        """Tracing off and tracefs as it was; safe to call twice."""
        self._w("tracing_on", "0")
        self._w("events/sched/sched_waking/enable", "0")
        self._w("events/sched/sched_switch/enable", "0")
        self._w("events/sched/sched_waking/filter", "0")
        self._w("events/sched/sched_switch/filter", "0")
        self._w("trace_clock", self._clock)
        if self._reader:
            self._reader.terminate()
            self._reader.wait(timeout=10)
            self._reader = None
        self._w("buffer_size_kb", self._buffer_kb)
        stats = [(cpu / "stats").read_text() for cpu in (TRACEFS / "per_cpu").iterdir()]
        self.overruns = sum(int(re.search(r"overrun: (\d+)", text).group(1)) for text in stats)


@dataclass
class Switch:
    t: int  # ns, CLOCK_MONOTONIC
    cpu: int
    prev: str
    prev_prio: int
    state: str
    next: str
    next_pid: int
    next_prio: int


def read(
    path: Path, pid: int, windows: list[tuple[int, int]]
) -> tuple[list[tuple[int, int, str, int]], dict[int, list[Switch]]]:
    """The simulator's wake-ups (time, waker's CPU, waker, waker's pid) and switches inside the
    `windows` (CLOCK_MONOTONIC ns, sorted by start): a long run's trace is far bigger than what the
    late answers need."""
    starts = [w[0] for w in windows]
    wakeups: list[tuple[int, int, str, int]] = []
    switches: dict[int, list[Switch]] = {}
    with open(path, errors="replace") as f:
        for line in f:
            m = _LINE.match(line)
            if not m:
                continue
            t = int(m["ts"].replace(".", "")) * (10 ** (9 - len(m["ts"].split(".")[1])))
            i = bisect.bisect_right(starts, t) - 1
            if i < 0 or t > windows[i][1]:
                continue
            cpu = int(m["cpu"])
            if m["event"] == "sched_waking":
                wakeups.append((t, cpu, m["task"].strip(), int(m["pid"])))
            elif m["event"] == "sched_switch":
                s = _SWITCH.match(m["rest"])
                if s:
                    switches.setdefault(cpu, []).append(
                        Switch(
                            t,
                            cpu,
                            s["prev"],
                            int(s["prev_prio"]),
                            s["state"],
                            s["next"],
                            int(s["next_pid"]),
                            int(s["next_prio"]),
                        )
                    )
    return wakeups, switches


def explain(
    late: list[dict], wakeups, switches: dict[int, list[Switch]], pid: int, realtime_offset_ns: int
) -> list[dict]:
    """For each late transaction (request/answer in CLOCK_REALTIME ns, from the capture): the
    simulator's first wake-up after the request (by whom, from which CPU) and its first run, and
    the timeline of the scheduler's events from the request to the answer (times in ms after the
    request): who ran on each CPU meanwhile."""
    wake_times = [w[0] for w in wakeups]
    every = sorted((s for ss in switches.values() for s in ss), key=lambda s: s.t)
    times = [s.t for s in every]
    out = []
    for r in late:
        req = r["request"] - realtime_offset_ns
        end = (r["answer"] - realtime_offset_ns) if r["answer"] else req + 20_000_000
        ms = lambda t, req=req: round((t - req) / 1e6, 3)  # noqa: E731
        entry: dict = {"answer_ms": ms(end) if r["answer"] else None}
        i = bisect.bisect_left(wake_times, req)
        if i < len(wakeups) and wakeups[i][0] <= end:
            t, cpu, waker, _ = wakeups[i]
            entry["first_wakeup"] = {"ms": ms(t), "by": waker, "cpu": cpu}
        runs = [s for s in every[bisect.bisect_left(times, req) : bisect.bisect_right(times, end)] if s.next_pid == pid]
        if runs:
            entry["first_run"] = {"ms": ms(runs[0].t), "cpu": runs[0].cpu, "after": f"{runs[0].prev} ({runs[0].state})"}
        timeline = [
            f"{ms(s.t):7.3f} CPU{s.cpu}: {s.prev}/{s.prev_prio} ({s.state}) -> {s.next}/{s.next_prio}"
            for s in every[bisect.bisect_left(times, req - 500_000) : bisect.bisect_right(times, end + 200_000)]
        ]
        timeline += [
            f"{ms(t):7.3f} CPU{cpu}: wakes the simulator ({waker})"
            for t, cpu, waker, _ in wakeups[
                bisect.bisect_left(wake_times, req - 500_000) : bisect.bisect_right(wake_times, end)
            ]
        ]
        entry["timeline"] = sorted(timeline, key=lambda line: float(line.split()[0]))[:80]
        out.append(entry)
    return out

"""dispatch_profile.py -- what the dispatch of an empty module is made of: irpd on the 100-module set
under `perf record` (cpu-clock samples of its main executor thread), each sample put in one part
by the source line it was in (addr2line, through inlined functions), and the report's table of the
parts in ns per module.
"""

from __future__ import annotations

import shutil
import subprocess
from collections import Counter
from pathlib import Path

from .common import OVERHEAD_TARGET_NS, BenchError, log, quote
from .irpd_runs import run_irpd

# (part, what it is), in the table's order; classify() names them
PARTS = (
    (
        "statistics",
        "the run's sample into the sample ring (jitter, latency, execution time; the histograms are filled from "
        "it by irpd's stats thread, on another CPU) and the counters",
    ),
    ("clock", "the clock read after each module (`clock_gettime`, vDSO)"),
    ("loop", "the loop itself: the order, the checks (halted, disabled, skip, kind, budget), Eq. (1)'s run"),
    ("call", "the call of the module's `run()` (empty) through its pointer, its try/catch, the crash marker"),
    ("per slot", "per slot, spread over the modules: the cycle, the trace sampling, the slot's own figures"),
    ("other", "anything else in the slot (libc, the module's library)"),
)
THREAD = "irp@main"


def classify(dso: str, sym: str, frames: list[str]) -> str | None:
    """The part of one sample: frames are its source files, innermost first (irpd's own code)."""
    if "kernel" in dso or sym.startswith(("clock_nanosleep", "__GI___pthread", "irp::osal::MonotonicClock::sleep")):
        return None  # the sleep and the wake-up: outside the slot's work
    if "vdso" in dso or sym.startswith("clock_gettime") or sym == "irp::osal::MonotonicClock::now":
        return "clock"
    if sym.startswith(("irp::trace::", "irp::runtime::setCycle", "__tls_get_addr")):
        return "per slot"
    if sym.startswith(("onRun", "irp::dispatch::Executor::runThread", "irp::dispatch::Executor::serveCalls")):
        return "call"
    if not frames:
        return "other"
    inner = frames[0]
    if inner.endswith(("histogram.hpp", "stats_block.hpp", "sample_ring.hpp")):
        return "statistics"
    if inner.endswith(("running_marker.hpp", "watchdog.hpp")):
        return "call"
    if inner.endswith("executor.cpp") or inner.endswith("executor.hpp"):
        return "loop"
    return "other"


def run_profile(a, irpd: Path, many: Path, work: Path, commands: list[str], tag: str = "profile") -> dict | None:
    """None when perf is not installed (the report says so).  tag names the run and its perf data."""
    if not shutil.which("perf") or not shutil.which("addr2line"):
        log("perf or addr2line not found: no profile of the dispatch")
        return None
    data = work / ("dispatch.perf.data" if tag == "profile" else f"dispatch-{tag}.perf.data")
    prefix = ["perf", "record", "-q", "-e", "cpu-clock", "-F", "20000", "-o", str(data), "--"]
    doc = run_irpd(a, irpd, many, a.overhead_duration, None, tag, work, commands, prefix=prefix)
    cmd = ["perf", "script", "-i", str(data), "--comm", THREAD, "-F", "ip,sym,symoff,dso"]
    commands.append(quote(cmd))
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise BenchError(f"perf script failed: {p.stderr[-1000:]}")
    # irpd is position-independent: a sample's address in the file is its symbol's + the offset
    symbols: dict[str, int] = {}
    for line in subprocess.run(
        ["nm", "-C", "--defined-only", str(irpd)], capture_output=True, text=True
    ).stdout.splitlines():
        addr, _, name = line.split(" ", 2)
        symbols.setdefault(name.split("(")[0], int(addr, 16))
    samples = []  # (address in irpd's file or 0, symbol, dso)
    for line in p.stdout.splitlines():
        parts = line.split()
        if len(parts) < 2:
            continue
        dso, symoff = parts[-1].strip("()"), " ".join(parts[1:-1])
        sym, _, off = symoff.rpartition("+0x")
        addr = symbols.get(sym, -1) + int(off, 16) if dso.endswith("/irpd") and sym in symbols else 0
        samples.append((addr, sym or symoff, dso))
    ours = sorted({ip for ip, _, _ in samples if ip})
    frames: dict[int, list[str]] = {}
    if ours:
        # -a: each address, then its frames, the innermost inlined one first
        cmd = ["addr2line", "-a", "-i", "-e", str(irpd), *(hex(ip) for ip in ours)]
        current: list[str] = []
        for line in subprocess.run(cmd, capture_output=True, text=True).stdout.splitlines():
            if line.startswith("0x"):
                current = frames.setdefault(int(line, 16), [])
            else:
                current.append(line.split(":")[0])
    counts: Counter[str] = Counter()
    for ip, sym, dso in samples:
        part = classify(dso, sym, frames.get(ip, []))
        if part:
            counts[part] += 1
    total = sum(counts.values())
    if not total:
        return None
    n = len(doc["modules"])
    slot_mean = doc["dispatcher"]["exec_ns"]["mean"]
    return {
        "samples": total,
        "modules": n,
        "slot_mean_ns": slot_mean,
        "per_module_ns": slot_mean / n,
        "parts": {
            name: {"share": counts[name] / total, "ns": counts[name] / total * slot_mean / n} for name, _ in PARTS
        },
        "data": data,
    }


def render_profile(a, prof: dict | None) -> str:
    L: list[str] = ["### What it is made of (perf)", ""]
    if not prof:
        L += ["perf was not available: no profile of the dispatch.", ""]
        return "\n".join(L)
    L.append(
        f"The {prof['modules']}-module set again, {a.overhead_duration} s under `perf record -e cpu-clock -F 20000` "
        f"(this VM has no hardware counters): {prof['samples']} samples of `{THREAD}` inside the slots' work, "
        "each put in one part by the source line it was in (`addr2line -i`: a histogram update inlined into the "
        "loop counts as statistics). ns per module = the part's share × this run's slot work mean "
        f"({prof['slot_mean_ns']:.0f} ns) / {prof['modules']} = {prof['per_module_ns']:.1f} ns (target "
        f"≤ {OVERHEAD_TARGET_NS:.0f})."
    )
    L += ["", "| part | what | share | ns per module |", "| --- | --- | ---: | ---: |"]
    for name, what in PARTS:
        part = prof["parts"][name]
        L.append(f"| {name} | {what} | {100 * part['share']:.1f} % | {part['ns']:.1f} |")
    L.append("")
    parts = prof["parts"]
    L.append(
        f"The statistics are {parts['statistics']['ns']:.1f} ns of it. Until issue 28 they were most of it "
        "(54.6 ns of 89.0 ns per module in the full run of 2026-12-07 05:13 UTC, load 1.66), and not by their instructions: "
        "each module's record in the stats block is 34 KiB of shared memory (counters and three log-linear "
        "histograms of 1 056 buckets, read live by the agent and the UI), a run wrote about seven of its cache "
        "lines on four pages (a bucket and the head of each histogram, the counters), and in the millisecond "
        "between two slots other work on the CPU evicted them. Now the RT thread stores one 32-byte sample per "
        "run (jitter, latency, execution time) into its executor's sample ring, contiguous and written in "
        "order, and irpd's stats thread folds the samples into the same histograms and run counts every "
        "millisecond on another CPU (docs/scheduler.md): every figure the UI shows keeps its meaning, and "
        "reaches the stats block up to a millisecond later. What is left here is that store and the counters "
        "the faults act on (missed, overruns: a compare each, written only when they count). "
        f"The clock read between two modules ({parts['clock']['ns']:.1f} ns) is the only one per module (the end "
        "of one module is the start of the next). Also cut in issue 28: the division of Eq. (1)'s run "
        "number (the task keeps its run's due time), and the call through the PLT and the TLS lookup that set "
        "the module's alarm source (one store into the thread's word). Tried and not kept: prefetching the next "
        "modules' lines (no difference within this machine's noise); reading the end of each module from the "
        "TSC (`lfence; rdtsc`, scaled by the TSC's rate against CLOCK_MONOTONIC since the first slot and "
        "anchored at each wake-up's clock_gettime) instead of `clock_gettime`: 33.6 ns against 31.5 ns per "
        "module mean, 29.8 against 31.7 p50, in 2 alternating rounds of 15 s (2026-12-07 06:40 UTC, load 0.1): "
        "on this VM the ordered TSC read costs about what the vDSO's read does, and it would bring a second "
        "time base to keep right. Considered and not measured: huge pages "
        "for the stats segment (a file of /dev/shm gets them only from the mount's `huge=` option, which "
        "irpd does not control, and they would have removed the TLB misses, not the cache misses) and a "
        "record reordered so that the heads of the three histograms share a line (the buckets would still be "
        "three lines on three pages per run)."
    )
    L.append("")
    return "\n".join(L)

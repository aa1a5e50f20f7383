#!/usr/bin/env python3
"""run_bench.py -- irpd's wake-up latency against cyclictest's, on the same CPU, in one command.

    .venv/bin/python tests/bench/run_bench.py [--duration S] [--period-ns N] [--cpu N] [--rt-priority P]
                                     [--out docs/benchmark.md] [--build-dir DIR] [--no-build]
                                     [--proc-duration S] [--proc-rounds R] [--sporadic-duration S]

Runs, one after the other, pinned to the same CPU at the same SCHED_FIFO priority and period:

  1. cyclictest (Debian rt-tests): one thread, absolute clock_nanosleep, nanosecond histogram;
  2. irpd, a set of ONE empty thread module at the period, overrun policy "skip": one latency
     sample per real wake-up, as cyclictest counts them -> the like-for-like comparison.
     1 and 2 alternate in --rounds rounds; their histograms (cyclictest's histfile, irpd's
     log-linear histogram read from its shared-memory stats block) are merged exactly;
  3. irpd, the same set with the default policy "catch-up": the no-drift run.  Its run count is
     checked against the grid (duration / period), and an observer on another CPU reads irpd's
     cycle counter from shared memory during the run and times the completion of the last slot;
  4. relative_sleep: the same loop written with a RELATIVE sleep, for contrast (periods lost, drift);
  5. irpd, a set of 100 empty thread modules (one .so listed 100 times) at a longer period: the
     dispatch overhead per module = dispatcher slot work (exec_ns) mean / 100;
  6. shared_vars: shared-variable access costs against plain memory;
  7. the process-module wake-up, in rotating rounds of four programs at the same period: irpd with
     one empty thread module (its start latency), irpd with one periodic process module
     (processes/wake_process.cpp measures its own wake-up: waitPeriod() return - the slot's due
     time), and signal_wakeup.cpp, the paper's signal-based design (a dispatcher process sigqueue()s
     a worker process waiting in sigwaitinfo), with and without a time bound on its wait for "done";
  8. the sporadic reaction time: a periodic thread module raises an event in shared variables
     (shared/sporadic.glb), a sporadic thread module (modules/reactor.cpp), then a sporadic process
     module (processes/reactor_proc.cpp) record when they start working minus the raise time.
  The programs of 7 and 8 print histograms of irpd's shape as text (common/bench_hist.hpp).

Prints the distributions, the ratios irpd/cyclictest (p50, p99, p99.9, max) and each target's
verdict, and writes them with the machine's description to --out (docs/benchmark.md).  Targets are
reported, not asserted: the exit status is 0 when everything ran, 1 when something failed to run.
Python 3.11 standard library only.  Run as root (SCHED_FIFO, mlockall, /dev/cpu_dma_latency).
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
import mmap
import os
import platform
import shlex
import shutil
import struct
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]

# Targets of the issue (item 8).
P99_RATIO_TARGET = 1.3
PROC_P99_RATIO_TARGET = 2.0  # a process module's wake-up p99 against a thread module's, same run
OVERHEAD_TARGET_NS = 200.0
LONG_RUN_TARGET_S = 60

# What the script runs (tests/bench/CMakeLists.txt: the `bench` target builds the same).
BUILD_TARGETS = [
    "irpd",
    "empty",
    "relative_sleep",
    "shared_vars",
    "wake_process",
    "signal_wakeup",
    "raiser",
    "reactor",
    "reactor_proc",
]

CT_HIST_NS = 1_000_000  # cyclictest caps its histogram at 1,000,000 entries: 1 ms in ns mode

# Layout of the stats segment (docs/shared-memory.md): its offsets come from irpd itself
# (`irpd --print-shm-layout`): see load_stats_layout().
STATS = {}


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


# --------------------------------------------------------------------------------------------
# the machine


def read_text(path: str) -> str:
    try:
        return Path(path).read_text().strip()
    except OSError:
        return ""


def command_output(cmd: list[str]) -> str:
    try:
        return subprocess.run(cmd, capture_output=True, text=True, timeout=20).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""


def machine() -> dict:
    uname = platform.uname()
    model = ""
    for line in read_text("/proc/cpuinfo").splitlines():
        if line.startswith("model name"):
            model = line.split(":", 1)[1].strip()
            break
    flags = read_text("/proc/cpuinfo")
    preempt_rt = "PREEMPT_RT" in uname.version or read_text("/sys/kernel/realtime") == "1"
    vm = command_output(["systemd-detect-virt", "--vm"]) or (
        "hypervisor flag set" if " hypervisor" in flags else "none"
    )
    container = command_output(["systemd-detect-virt", "--container"]) or "none"
    virt = f"VM: {vm}; container: {container}"
    ct_version = ""
    if shutil.which("cyclictest"):
        ct_version = command_output(["dpkg-query", "-W", "-f=${Version}", "rt-tests"])
        ct_version = f"rt-tests {ct_version}" if ct_version else "unknown version"
    git = command_output(["git", "-C", str(REPO), "describe", "--always", "--dirty", "--abbrev=12"])
    return {
        "hostname": uname.node,
        "kernel_release": uname.release,
        "kernel_version": uname.version,
        "preempt_rt": preempt_rt,
        "cpu_model": model or uname.machine,
        "nproc": os.cpu_count(),
        "virtualization": virt,
        "clocksource": read_text("/sys/devices/system/clocksource/clocksource0/current_clocksource"),
        "cpuidle_driver": read_text("/sys/devices/system/cpu/cpuidle/current_driver"),
        "rt_runtime_us": read_text("/proc/sys/kernel/sched_rt_runtime_us"),
        "cmdline_isolcpus": " ".join(
            w for w in read_text("/proc/cmdline").split() if w.startswith(("isolcpus", "nohz_full"))
        ),
        "cyclictest": ct_version,
        "git": git,
        "loadavg_start": read_text("/proc/loadavg"),
    }


# --------------------------------------------------------------------------------------------
# build and sets


def build(build_dir: Path, commands: list[str]) -> None:
    if not (build_dir / "CMakeCache.txt").exists():
        cmd = ["cmake", "-S", str(REPO), "-B", str(build_dir), "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release"]
        commands.append(quote(cmd))
        log("configuring " + str(build_dir))
        if subprocess.run(cmd, stdout=subprocess.DEVNULL).returncode != 0:
            raise BenchError("cmake configure failed: " + quote(cmd))
    cmd = ["cmake", "--build", str(build_dir), "--target", *BUILD_TARGETS]
    commands.append(quote(cmd))
    log("building " + ", ".join(BUILD_TARGETS))
    if subprocess.run(cmd, stdout=subprocess.DEVNULL).returncode != 0:
        raise BenchError("build failed: " + quote(cmd))


def module_xml(count: int, period_ns: int) -> str:
    """`count` entries of the same ./empty.so, named m001.., priorities 1..count."""
    lines = [
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>",
        f"<!-- generated by tests/bench/run_bench.py: {count} empty thread module(s), period {period_ns} ns -->",
        "<root>",
    ]
    for i in range(1, count + 1):
        lines.append(
            f"  <module><filename>./empty.so</filename><moduletype>thread</moduletype>"
            f"<operationtype>periodic</operationtype><period>{period_ns}</period>"
            f"<priority>{i}</priority><name>m{i:03d}</name></module>"
        )
    lines.append("</root>")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------------
# figures


def summary_from_counts(counts: dict[int, int], overflow: int, limit: int) -> dict:
    """Nearest-rank percentiles (rank = ceil(q * n), as irpd's summary) of an exact histogram.
    A percentile whose rank lies among the overflows is the limit, marked as a lower bound."""
    n = sum(counts.values()) + overflow
    out = {"count": n, "overflows": overflow, "lower_bound": []}
    if n == 0:
        return out
    keys = sorted(counts)
    out["min"] = keys[0] if keys else limit
    out["mean_in_range"] = sum(k * c for k, c in counts.items()) / max(1, n - overflow)
    for name, q in (("p50", 0.50), ("p99", 0.99), ("p999", 0.999)):
        rank = min(max(math.ceil(q * n), 1), n)
        seen, value = 0, None
        for k in keys:
            seen += counts[k]
            if seen >= rank:
                value = k
                break
        if value is None:
            value = limit
            out["lower_bound"].append(name)
        out[name] = value
    return out


def parse_cyclictest_hist(text: str) -> dict:
    """The raw figures of one cyclictest run: exact counts per ns, overflows, min, max, mean."""
    counts: dict[int, int] = {}
    meta: dict[str, str] = {}
    for line in text.splitlines():
        if line.startswith("#"):
            if ":" in line:
                key, _, value = line[1:].partition(":")
                meta[key.strip()] = value.strip()
            continue
        parts = line.split()
        if len(parts) >= 2 and parts[0].isdigit():
            c = int(parts[1])
            if c:
                counts[int(parts[0])] = c
    if "Max Latencies" not in meta:
        raise BenchError("cyclictest's histogram has no '# Max Latencies' line")
    overflows = int(meta.get("Histogram Overflows", "0").split()[0] or 0)
    n = sum(counts.values()) + overflows
    return {
        "counts": counts,
        "overflows": overflows,
        "count": n,
        "min": int(meta["Min Latencies"].split()[0]),
        "max": int(meta["Max Latencies"].split()[0]),
        "sum": int(meta["Avg Latencies"].split()[0]) * n,
    }  # cyclictest's own average (all samples)


def merge_cyclictest(raws: list[dict]) -> dict:
    counts: dict[int, int] = {}
    for r in raws:
        for v, c in r["counts"].items():
            counts[v] = counts.get(v, 0) + c
    return {
        "counts": counts,
        "overflows": sum(r["overflows"] for r in raws),
        "count": sum(r["count"] for r in raws),
        "min": min(r["min"] for r in raws),
        "max": max(r["max"] for r in raws),
        "sum": sum(r["sum"] for r in raws),
    }


def summarize_cyclictest(raw: dict, period_ns: int) -> dict:
    counts = raw["counts"]
    s = summary_from_counts(counts, raw["overflows"], CT_HIST_NS)
    s.update(min=raw["min"], max=raw["max"], mean=raw["sum"] / raw["count"] if raw["count"] else 0)
    # wake-ups a whole period or more late (the stalls): exact below 1 ms, plus every overflow
    s["late_ge_period"] = raw["overflows"] + sum(c for v, c in counts.items() if v >= period_ns)
    return s


# irpd's log-linear histogram (rtcore/src/stats/histogram.hpp), read back from its stats block
K_SUB_BITS, K_SUB, K_MAX_EXP = 5, 32, 36
K_BUCKETS = K_SUB + (K_MAX_EXP - K_SUB_BITS + 1) * K_SUB


def load_stats_layout(irpd: Path) -> None:
    """Takes the stats block's offsets and histogram shape from the irpd binary under test."""
    global K_SUB_BITS, K_SUB, K_MAX_EXP, K_BUCKETS
    stats = json.loads(
        subprocess.run([str(irpd), "--print-shm-layout"], check=True, capture_output=True, text=True).stdout
    )["segments"]["stats"]
    structs = stats["structs"]
    STATS.clear()
    STATS.update(
        magic=stats["magic"],
        version=stats["version"],
        record_size=structs["timing_record"]["size"],
        header=structs[stats["header"]]["fields"],
        record=structs["timing_record"]["fields"],
        histogram=structs["histogram"]["fields"],
    )
    constants = {k: c["value"] for k, c in stats["constants"].items()}
    K_SUB_BITS, K_MAX_EXP, K_BUCKETS = (
        constants["sub_bucket_bits"],
        constants["max_exponent"],
        constants["bucket_count"],
    )
    K_SUB = 1 << K_SUB_BITS


def header_offset(name: str) -> int:
    return STATS["header"][name]["offset"]


def bucket_low(i: int) -> int:
    if i < K_SUB:
        return i
    k, sub = divmod(i - K_SUB, K_SUB)
    e = k + K_SUB_BITS
    return (1 << e) | (sub << (e - K_SUB_BITS))


def bucket_width(i: int) -> int:
    return 1 if i < K_SUB else 1 << ((i - K_SUB) // K_SUB)


def summarize_irpd_hist(h: dict) -> dict:
    """irpd's own figures (stats/summary.cpp): nearest rank, the middle of the bucket, clamped."""
    total = sum(h["buckets"])
    out = {"count": total}
    if not total:
        return out
    out.update(min=h["min"], max=h["max"], mean=h["sum"] / total)
    for name, q in (("p50", 0.50), ("p99", 0.99), ("p999", 0.999)):
        rank = min(max(math.ceil(q * total), 1), total)
        seen = 0
        for i, c in enumerate(h["buckets"]):
            seen += c
            if seen >= rank:
                mid = bucket_low(i) + (bucket_width(i) - 1) / 2
                out[name] = min(max(mid, min(h["min"], h["max"])), h["max"])
                break
    return out


def merge_irpd_hists(hs: list[dict]) -> dict:
    return {
        "buckets": [sum(col) for col in zip(*(h["buckets"] for h in hs))],
        "sum": sum(h["sum"] for h in hs),
        "min": min(h["min"] for h in hs),
        "max": max(h["max"] for h in hs),
    }


def linear_slope(points: list[tuple[float, float]]) -> float:
    if len(points) < 2:
        return 0.0
    mx = sum(p[0] for p in points) / len(points)
    my = sum(p[1] for p in points) / len(points)
    sxx = sum((p[0] - mx) ** 2 for p in points)
    return sum((p[0] - mx) * (p[1] - my) for p in points) / sxx if sxx else 0.0


# --------------------------------------------------------------------------------------------
# runs


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


def run_checked(cmd: list[str], what: str, timeout: float) -> subprocess.CompletedProcess:
    log(f"{what}: {quote(cmd)}")
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, preexec_fn=restore_affinity)
    except subprocess.TimeoutExpired as e:
        raise BenchError(f"{what} did not finish within {timeout:.0f} s") from e
    if p.returncode != 0:
        raise BenchError(f"{what} exited with status {p.returncode}:\n{p.stdout[-2000:]}{p.stderr[-2000:]}")
    return p


def run_cyclictest(a, seconds: int, tag: str, work: Path, commands: list[str]) -> dict:
    hist = work / f"cyclictest-{tag}-hist.txt"
    cmd = [
        "cyclictest",
        "-m",
        "-p",
        str(a.rt_priority),
        "-i",
        str(a.period_ns // 1000),
        "-a",
        str(a.cpu),
        "-t",
        "1",
        "-D",
        str(seconds),
        "-q",
        "-N",
        "-h",
        str(CT_HIST_NS),
        f"--histfile={hist}",
    ]
    if not a.pm_qos:
        cmd.append("--default-system")
    commands.append(quote(cmd))
    run_checked(cmd, f"cyclictest ({tag}, {seconds} s)", seconds + 60)
    raw = parse_cyclictest_hist(hist.read_text())
    hist.unlink()  # 14 MB of mostly zeros; the parsed counts are kept
    return raw


class ShmObserver:
    """Reads irpd's cycle counter from its stats segment while it runs (from another CPU)."""

    def __init__(self, instance: str):
        self.path = Path("/dev/shm") / f"indurop.{instance}.stats"
        self.mm = None

    def attach(self, proc: subprocess.Popen, timeout_s: float = 30) -> bool:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline and proc.poll() is None:
            try:
                with open(self.path, "rb") as f:
                    if os.fstat(f.fileno()).st_size >= 128:
                        self.mm = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
                        if (
                            struct.unpack_from("<Q", self.mm, 0)[0] == STATS["magic"]
                            and struct.unpack_from("<I", self.mm, header_offset("version"))[0] == STATS["version"]
                        ):
                            return True
                        self.mm.close()
                        self.mm = None
            except OSError:
                pass
            time.sleep(0.002)
        return False

    def started(self) -> tuple[int, int]:
        return (
            struct.unpack_from("<q", self.mm, header_offset("started_ns"))[0],
            struct.unpack_from("<I", self.mm, header_offset("running"))[0],
        )

    def basic(self) -> int:
        return struct.unpack_from("<q", self.mm, header_offset("basic_ns"))[0]

    def cycles(self) -> int:
        return struct.unpack_from("<Q", self.mm, header_offset("cycles"))[0]

    def latency_hist(self, record: int = 0) -> dict:
        """The latency histogram of a record (0 = the main dispatcher).  The mapping outlives irpd's
        unlinking of the segment, so this reads the final figures after irpd has exited."""
        return self.record_hist(record, "latency")

    def record_hist(self, record: int, field: str) -> dict:
        """One histogram ("latency" or "exec") of a record: dispatchers first, then the modules."""
        header_size = struct.unpack_from("<I", self.mm, header_offset("header_size"))[0]
        record_size = struct.unpack_from("<I", self.mm, header_offset("record_size"))[0]
        if record_size != STATS["record_size"]:
            raise BenchError(f"irpd's stats records are {record_size} bytes, its layout says {STATS['record_size']}")
        base = header_size + record * record_size + STATS["record"][field]["offset"]
        h = STATS["histogram"]
        count, total, lo, hi = (
            struct.unpack_from("<Q", self.mm, base + h[f]["offset"])[0] for f in ("count", "sum", "min", "max")
        )
        buckets = list(struct.unpack_from(f"<{K_BUCKETS}Q", self.mm, base + h["buckets"]["offset"]))
        return {"count": count, "sum": total, "min": lo, "max": hi, "buckets": buckets}


def run_irpd(
    a,
    irpd: Path,
    xml: Path,
    duration: int,
    policy: str | None,
    tag: str,
    work: Path,
    commands: list[str],
    observe: bool = False,
    histogram: bool = False,
    hists: tuple[tuple[str, str], ...] = (),
) -> dict:
    """Runs irpd on a set; returns its --stats-json, plus "_stdout" (module output arrives there as
    "[name] ..." lines), and with histogram=True the main dispatcher's latency histogram read from
    shared memory ("_latency_hist"); hists = ((record name, "latency" | "exec"), ...) reads those
    histograms too, into "_hists"["name.field"] (a record name: "dispatcher" or a module's name)."""
    out = work / f"irpd-{tag}.json"
    instance = f"bench-{os.getpid()}-{tag}"
    cmd = [
        str(irpd),
        "--config",
        str(xml),
        "--duration",
        str(duration),
        "--stats-json",
        str(out),
        "--cpu",
        str(a.cpu),
        "--rt-priority",
        str(a.rt_priority),
        "--instance",
        instance,
    ]
    if policy:
        cmd += ["--overrun-policy", policy]
    if a.period_ns < 50_000:
        cmd += ["--min-basic-period", str(a.period_ns)]
    commands.append(quote(cmd))
    log(f"irpd ({tag}, {duration} s): {quote(cmd)}")
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=restore_affinity)
    observation = None
    reader = None
    try:
        if observe:
            observation = observe_grid(proc, instance, duration)
        elif histogram or hists:
            reader = ShmObserver(instance)
            if not reader.attach(proc):
                reader = None
        stdout, stderr = proc.communicate(timeout=duration + 120)
    except subprocess.TimeoutExpired as e:
        proc.kill()
        proc.communicate()
        raise BenchError(f"irpd ({tag}) did not stop within {duration + 120} s") from e
    if proc.returncode != 0:
        raise BenchError(f"irpd ({tag}) exited with status {proc.returncode}:\n{stdout[-2000:]}{stderr[-2000:]}")
    try:
        doc = json.loads(out.read_text())
    except (OSError, ValueError) as e:
        raise BenchError(f"irpd ({tag}) wrote no readable {out}: {e}") from e
    if not doc.get("realtime"):
        log(f"WARNING: irpd ({tag}) did not run SCHED_FIFO (not root?); its figures are not real-time")
    doc["_stderr"] = stderr.strip()
    doc["_stdout"] = stdout
    doc["_observation"] = observation
    if hists:
        if reader is None:
            raise BenchError(f"irpd ({tag}): could not map its stats block to read its histograms")
        doc["_hists"] = {}
        for name, field in hists:
            if name == "dispatcher":
                index, summary = 0, doc["dispatcher"]
            else:
                names = [m["name"] for m in doc["modules"]]
                if name not in names:
                    raise BenchError(f"irpd ({tag}): no module '{name}' in its stats ({names})")
                index = len(doc["executors"]) + names.index(name)
                summary = doc["modules"][names.index(name)]
            h = reader.record_hist(index, field)
            mine, its = summarize_irpd_hist(h), summary[f"{field}_ns"]
            if mine["count"] != its["count"] or (
                its["count"] and any(abs(mine[k] - its[k]) > 1 for k in ("p50", "p99", "p999", "max"))
            ):
                raise BenchError(
                    f"irpd ({tag}): the {name} {field} histogram read from shared memory ({mine}) does "
                    f"not match --stats-json ({its}); has the stats layout changed?"
                )
            doc["_hists"][f"{name}.{field}"] = h
    if histogram:
        if reader is None:
            raise BenchError(f"irpd ({tag}): could not map its stats block to read the latency histogram")
        h = reader.latency_hist(0)
        mine, its = summarize_irpd_hist(h), doc["dispatcher"]["latency_ns"]
        if mine["count"] != its["count"] or any(abs(mine[k] - its[k]) > 1 for k in ("p50", "p99", "p999", "max")):
            raise BenchError(
                f"irpd ({tag}): the histogram read from shared memory ({mine}) does not match "
                f"--stats-json ({its}); has the stats layout changed?"
            )
        doc["_latency_hist"] = h
    return doc


def observe_grid(proc: subprocess.Popen, instance: str, duration: int) -> dict | None:
    """Watches irpd's cycle counter from this process (on another CPU) against the monotonic clock.

    Every 0.5 s: lag = slots due by now (floor((now - T0) / basic) + 1) - slots completed; 0 or 1
    while the loop keeps to the grid (1 while a due slot is being woken), growing if it drifted.
    Then, spinning at SCHED_FIFO 1 from 5 ms before the last slot is due, it brackets the moment
    the last slot of the grid completed: between the last read that did not see it and the first
    that did."""
    obs = ShmObserver(instance)
    if not obs.attach(proc):
        log("WARNING: could not attach to irpd's stats segment; no grid observation")
        return None
    t0 = 0
    while proc.poll() is None:
        t0, running = obs.started()
        if t0 and running:
            break
        time.sleep(0.001)
    if not t0:
        return None
    basic = obs.basic()
    total = duration * 1_000_000_000 // basic
    last_due = t0 + (total - 1) * basic
    spin_from = last_due - 5_000_000

    def read() -> tuple[int, int, int]:
        ta = mono_ns()
        c = obs.cycles()
        return ta, c, mono_ns()

    samples: list[tuple[int, int]] = []
    while proc.poll() is None and mono_ns() < spin_from:
        ta, c, tb = read()
        if ta >= t0 and tb - ta < 20_000:  # a read interrupted by the scheduler says nothing
            samples.append((ta, c))
        time.sleep(max(0.0, min(0.5, (spin_from - mono_ns()) / 1e9)))
    end_lo = end_hi = None
    fifo = False
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
        fifo = True
    except OSError:
        pass
    try:
        before = mono_ns()
        while proc.poll() is None or obs.cycles() >= total:
            ta, c, tb = read()
            if c >= total:
                end_lo, end_hi = before, tb
                break
            before = ta
            if ta > last_due + 2_000_000_000:
                break
    finally:
        if fifo:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    lags = [((t - t0) // basic + 1) - c for t, c in samples]
    slope = linear_slope([((t - t0) / 1e9, float(lag)) for (t, _), lag in zip(samples, lags)])
    sorted_lags = sorted(lags)
    return {
        "t0_ns": t0,
        "basic_ns": basic,
        "grid_slots": total,
        "samples": len(samples),
        "lag_min": sorted_lags[0] if lags else None,
        "lag_median": sorted_lags[len(lags) // 2] if lags else None,
        "lag_max": sorted_lags[-1] if lags else None,
        "lag_slope_per_s": slope,
        "observer_fifo": fifo,
        # the last slot completed between end_lo and end_hi (CLOCK_MONOTONIC), relative to its due time
        "end_after_last_due_ns": [end_lo - last_due, end_hi - last_due] if end_hi else None,
        # periods of the grid elapsed when the last slot was seen done: ceil((end_hi - T0) / basic)
        "grid_periods_elapsed": math.ceil((end_hi - t0) / basic) if end_hi else None,
    }


def run_relative(a, binary: Path, work: Path, commands: list[str]) -> dict:
    cmd = [
        str(binary),
        "--period-ns",
        str(a.period_ns),
        "--duration",
        str(a.duration),
        "--cpu",
        str(a.cpu),
        "--rt-priority",
        str(a.rt_priority),
        "--work-ns",
        str(a.work_ns),
    ]
    commands.append(quote(cmd))
    p = run_checked(cmd, "relative_sleep", a.duration + 60)
    try:
        return json.loads(p.stdout)
    except ValueError as e:
        raise BenchError(f"relative_sleep printed no JSON: {p.stdout[:500]}") from e


# --------------------------------------------------------------------------------------------
# report


def run_shared_vars(a, bench: Path, commands: list[str]) -> dict:
    """Shared-variable access costs, uncontended, pinned to the benchmark CPU (tests/bench/shared_vars.cpp)."""
    cmd = ["taskset", "-c", str(a.cpu), str(bench / "shared_vars"), str(bench / "shared" / "layout.json")]
    commands.append(quote(cmd))
    log(f"shared variables: {quote(cmd)}")
    p = run_checked(cmd, "shared_vars", 120)
    try:
        return json.loads(p.stdout)
    except json.JSONDecodeError as e:
        raise BenchError(f"shared_vars printed no JSON: {p.stdout[:500]}") from e


def render_shared(r: dict) -> str:
    target = r["scalar_read_ns"] <= 20 and r["scalar_write_ns"] <= 20
    rows = [
        ("scalar (uint64_t) read", "plain_scalar_read_ns", "scalar_read_ns"),
        ("scalar write", "plain_scalar_write_ns", "scalar_write_ns"),
        ("48-byte struct read (whole, consistent)", "plain_struct48_read_ns", "struct48_read_ns"),
        ("48-byte struct write (whole, locked)", "plain_struct48_write_ns", "struct48_write_ns"),
    ]
    out = [
        "## Shared variables: access cost, uncontended",
        "",
        "ns per access, best of 7 rounds of 2 000 000 (`tests/bench/shared_vars.cpp`, variables of "
        "`tests/bench/shared/bench.glb`, pinned to the benchmark CPU). Target: a scalar ≤ 20 ns: "
        f"{verdict(target)} ({r['scalar_read_ns']:.2f} ns read, {r['scalar_write_ns']:.2f} ns write).",
        "",
        "| access | plain memory | shared variable |",
        "| --- | ---: | ---: |",
    ]
    out += [f"| {name} | {r[p]:.2f} | {r[v]:.2f} |" for name, p, v in rows]
    out += [
        f"| one member of the struct, written (locked, keeps whole-struct readers consistent) | — | "
        f"{r['member_write_ns']:.2f} |",
        f"| `scalar += 1` (atomic read-modify-write, locked) | — | {r['scalar_add_ns']:.2f} |",
        "",
        "A scalar is one atomic load or store; a struct read is a seqlock copy (no lock); every locked "
        "write is a priority-inheritance mutex taken and released without a syscall when uncontended "
        "(docs/shared-variables.md).",
        "",
    ]
    return "\n".join(out)


def us(ns) -> str:
    return "—" if ns is None else f"{ns / 1000:.2f}"


def ratio(x, y) -> float | None:
    return None if x is None or y in (None, 0) else x / y


def fmt_ratio(r) -> str:
    return "—" if r is None else f"{r:.2f}×"


def end_text(obs: dict) -> str:
    e = obs.get("end_after_last_due_ns") if obs else None
    return "— (not observed)" if not e else f"{e[0] / 1000:.1f}–{e[1] / 1000:.1f} µs"


def verdict(ok: bool) -> str:
    return "PASS" if ok else "FAIL"


def analyse(a, ct: dict, skip: dict, catch: dict, over: dict, relative: dict) -> dict:
    lat = skip["dispatcher"]["latency_ns"]
    res = {"ratios": {}}
    for key in ("p50", "p99", "p999", "max"):
        res["ratios"][key] = ratio(lat[key], ct[key])
    res["ratios"]["max_catchup"] = ratio(catch["dispatcher"]["latency_ns"]["max"], ct["max"])
    # target 1: p99 ratio
    p99 = res["ratios"]["p99"]
    res["t1"] = p99 is not None and p99 <= P99_RATIO_TARGET and "p99" not in ct["lower_bound"]
    # target 2: runs == grid periods, no drift
    d = catch["dispatcher"]
    expected = a.long_duration * 1_000_000_000 // a.period_ns
    module_runs = [m["runs"] for m in catch["modules"]]
    obs = catch.get("_observation") or {}
    res["expected_runs"] = expected
    res["module_runs"] = module_runs
    grid_ok = obs.get("grid_periods_elapsed") == expected if obs else False
    res["t2_parts"] = {
        "dispatcher runs == duration/period": d["runs"] == expected,
        "module runs == duration/period": all(r == expected for r in module_runs),
        "no slot skipped": d["skipped"] == 0,
        "last slot completed inside its period (observed)": grid_ok,
        "cycle-counter lag on the grid (median 0 or 1)": bool(obs) and obs.get("lag_median") in (0, 1),
    }
    res["t2"] = all(res["t2_parts"].values())
    res["t2_full_length"] = a.long_duration >= LONG_RUN_TARGET_S
    # target 3: dispatch overhead
    n = len(over["modules"])
    ex = over["dispatcher"]["exec_ns"]
    res["overhead_mean"] = ex["mean"] / n
    res["overhead_p50"] = ex["p50"] / n
    res["overhead_marginal"] = (ex["mean"] - catch["dispatcher"]["exec_ns"]["mean"]) / max(1, n - 1)
    means = [m["exec_ns"]["mean"] for m in over["modules"]]
    p50s = [m["exec_ns"]["p50"] for m in over["modules"]]
    res["module_exec_mean"] = {"min": min(means), "mean": sum(means) / n, "max": max(means)}
    res["module_exec_p50"] = {"min": min(p50s), "mean": sum(p50s) / n, "max": max(p50s)}
    res["t3"] = res["overhead_mean"] <= OVERHEAD_TARGET_NS
    return res


def render(
    a,
    info: dict,
    ct: dict,
    skip: dict,
    catch: dict,
    over: dict,
    relative: dict,
    res: dict,
    commands: list[str],
    sets: dict,
    pm_qos_held: bool,
    started: str,
    took_s: float,
) -> str:
    ls, lc = skip["dispatcher"]["latency_ns"], catch["dispatcher"]["latency_ns"]
    per_us = a.period_ns / 1000
    L: list[str] = []
    w = L.append
    w("# Benchmark: irpd against cyclictest")
    w("")
    w(
        f"Latest result of `.venv/bin/python tests/bench/run_bench.py{(' ' + ' '.join(a.shown_args)) if a.shown_args else ''}`, "
        f"run {started} (took {took_s / 60:.1f} min). This file is written by that command; "
        "do not edit the figures by hand, run it again."
    )
    w("")
    w(
        f"Period {a.period_ns} ns ({per_us:g} µs), SCHED_FIFO priority {a.rt_priority}, everything pinned to "
        f"CPU {a.cpu}, run one after the other. cyclictest and irpd (skip): {a.duration} s each, in {a.rounds} "
        f"alternating rounds of {a.duration // a.rounds} s whose samples are merged; then irpd (catch-up) "
        f"{a.long_duration} s, the relative-sleep loop {a.duration} s, the {a.modules}-module set "
        f"{a.overhead_duration} s."
    )
    w("")
    w("## Targets")
    w("")
    w("| target | measured | verdict |")
    w("| --- | --- | --- |")
    p99r = res["ratios"]["p99"]
    w(
        f"| irpd p99 ≤ {P99_RATIO_TARGET}× cyclictest p99 at {per_us:g} µs, same run | "
        f"{us(ls['p99'])} µs / {us(ct['p99'])} µs = {fmt_ratio(p99r)} | {verdict(res['t1'])} |"
    )
    parts = res["t2_parts"]
    obs = catch.get("_observation") or {}
    t2_text = (
        f"{catch['dispatcher']['runs']} runs, grid {res['expected_runs']} periods, "
        f"{catch['dispatcher']['skipped']} skipped; last slot done {end_text(obs)} after its due time, "
        f"i.e. within period {obs.get('grid_periods_elapsed')} of the grid; cycle-counter lag median "
        f"{obs.get('lag_median')}, slope {obs.get('lag_slope_per_s', float('nan')):+.4f} period/s"
    )
    note = "" if res["t2_full_length"] else f" (only {a.long_duration} s; the target asks {LONG_RUN_TARGET_S} s)"
    w(
        f"| run count exactly elapsed/period over {LONG_RUN_TARGET_S} s (no drift) | {t2_text} | "
        f"{verdict(res['t2'])}{note} |"
    )
    w(
        f"| dispatch overhead ≤ {OVERHEAD_TARGET_NS:.0f} ns per empty thread module ({len(over['modules'])}-module set) | "
        f"slot work mean {over['dispatcher']['exec_ns']['mean']:.0f} ns / {len(over['modules'])} = "
        f"{res['overhead_mean']:.1f} ns (p50: {res['overhead_p50']:.1f} ns) | {verdict(res['t3'])} |"
    )
    w("")
    w(
        "The no-drift verdict, part by part: "
        + "; ".join(f"{k}: {'yes' if v else 'NO'}" for k, v in parts.items())
        + "."
    )
    w("")
    w("## Wake-up latency: irpd against cyclictest")
    w("")
    w("Wake-up latency = actual wake-up − planned absolute time, in µs (lower is better).")
    w("")
    w(f"| figure | cyclictest | irpd (skip) | irpd/cyclictest | irpd (catch-up, {a.long_duration} s) |")
    w("| --- | ---: | ---: | ---: | ---: |")
    w(f"| samples | {ct['count']} | {ls['count']} | | {lc['count']} |")
    w(f"| min | {us(ct['min'])} | {us(ls['min'])} | {fmt_ratio(ratio(ls['min'], ct['min']))} | {us(lc['min'])} |")
    w(f"| mean | {us(ct['mean'])} | {us(ls['mean'])} | {fmt_ratio(ratio(ls['mean'], ct['mean']))} | {us(lc['mean'])} |")
    for key, name in (("p50", "p50"), ("p99", "p99"), ("p999", "p99.9"), ("max", "max")):
        lb = "≥ " if key in ct["lower_bound"] else ""
        w(f"| **{name}** | {lb}{us(ct[key])} | {us(ls[key])} | **{fmt_ratio(res['ratios'][key])}** | {us(lc[key])} |")
    stall_share = ct["late_ge_period"] / ct["count"] if ct["count"] else 0.0
    w(
        f"| wake-ups ≥ 1 period late (stalls) | {ct['late_ge_period']} ({100 * stall_share:.2f} %) | "
        f"{skip['dispatcher']['missed']} | | {catch['dispatcher']['missed']} |"
    )
    w(
        f"| periods not served | {a.duration * 1_000_000_000 // a.period_ns - ct['count']} | "
        f"{skip['dispatcher']['skipped']} skipped | | {catch['dispatcher']['skipped']} skipped |"
    )
    w("")
    w("Round by round (p50 / p99 / p99.9 / max in µs; the ratio is irpd's p99 over cyclictest's):")
    w("")
    w("| round | first | cyclictest | irpd (skip) | p99 ratio |")
    w("| --- | --- | ---: | ---: | ---: |")
    for r in ct["rounds"]:
        c, i = r["cyclictest"], r["irpd"]
        w(
            f"| {r['round']} | {'cyclictest' if r['first'] == 'ct' else 'irpd'} | "
            f"{us(c['p50'])} / {us(c['p99'])} / {us(c['p999'])} / {us(c['max'])} | "
            f"{us(i['p50'])} / {us(i['p99'])} / {us(i['p999'])} / {us(i['max'])} | "
            f"{fmt_ratio(ratio(i['p99'], c['p99']))} |"
        )
    w("")
    w(
        "- cyclictest: exact nanosecond histogram (`-N -h 1000000`, i.e. 0–1 ms in 1 ns bins; above 1 ms only the "
        f"count and the max are known: {ct['overflows']} sample(s) here). irpd: its log-linear histogram, "
        "each percentile the middle of a bucket at most 3.1 % wide."
    )
    w(
        "- irpd runs with `--overrun-policy skip` for this comparison because cyclictest behaves that way: each "
        "wake-up is one sample, its lateness against the period it slept for, and after a stall both resume with "
        "the period due now. irpd's default policy, catch-up (last column), runs the missed slots back to back "
        "after a stall; those slots did not sleep, so they are not wake-up samples: irpd counts them apart, as "
        "`caught_up` (" + str(catch['dispatcher'].get('caught_up', 0)) + " in the catch-up run), and the wake-up "
        "figures of both irpd columns measure the same thing as cyclictest's."
    )
    w("")
    w("## Relative sleep, for contrast")
    w("")
    rs = relative
    w(
        f"The same loop with `clock_nanosleep(CLOCK_MONOTONIC, 0, {{period}})` (relative) after {rs['work_ns']} ns of "
        f"work each iteration (`tests/bench/relative_sleep.cpp`), same CPU, priority, period and duration:"
    )
    w("")
    w(f"| | relative sleep ({a.duration} s) | irpd (catch-up, {a.long_duration} s) |")
    w("| --- | ---: | ---: |")
    w(
        f"| iterations done / periods elapsed | {rs['iterations']} / {rs['expected_iterations']} | "
        f"{catch['dispatcher']['runs']} / {res['expected_runs']} |"
    )
    lost_pct = 100.0 * rs["periods_lost"] / rs["expected_iterations"] if rs["expected_iterations"] else 0
    w(
        f"| periods lost | {rs['periods_lost']} ({lost_pct:.1f} %) | "
        f"{res['expected_runs'] - catch['dispatcher']['runs']} |"
    )
    w(
        f"| drift (last wake-up − its grid time) | {rs['drift_ns'] / 1e6:.1f} ms over {rs['elapsed_ns'] / 1e9:.0f} s = "
        f"{rs['drift_ns_per_s'] / 1e3:.0f} µs/s | last slot done {end_text(obs)} after its due time; none |"
    )
    ap, ov = rs["actual_period_ns"], rs["overshoot_ns"]
    w(
        f"| actual period p50 / p99 / max (µs) | {us(ap['p50'])} / {us(ap['p99'])} / {us(ap['max'])} | "
        f"{per_us:g} on the grid |"
    )
    w(
        f"| per-iteration overshoot p50 / p99 / max (µs) | {us(ov['p50'])} / {us(ov['p99'])} / {us(ov['max'])} | "
        "— (does not accumulate) |"
    )
    w("")
    w(
        f"irpd's own `elapsed_ns` in `--stats-json` for the catch-up run is {catch['elapsed_ns']} ns "
        f"(= {catch['elapsed_ns'] / a.period_ns:.4f} periods for {catch['dispatcher']['runs']} runs): from slot 0's "
        "due time to the end of the last slot's work, as the RT thread itself records it."
    )
    w("")
    w(
        "Every iteration of the relative loop is longer than the period by its wake-up latency, its work and the "
        "re-arming of the timer; nothing ever pays that back, so it loses periods and drifts without bound. irpd "
        "sleeps until T0 + n × period (absolute), so a late wake-up delays one slot and never the next."
    )
    w("")
    w(f"## Dispatch overhead ({len(over['modules'])} empty thread modules at {over['basic_period_ns'] / 1000:g} µs)")
    w("")
    ex = over["dispatcher"]["exec_ns"]
    me, mp = res["module_exec_mean"], res["module_exec_p50"]
    w("| figure | ns |")
    w("| --- | ---: |")
    w(
        f"| slot work (dispatcher `exec_ns`) mean / p50 / p99 / max | {ex['mean']:.0f} / {ex['p50']:.0f} / "
        f"{ex['p99']:.0f} / {ex['max']:.0f} |"
    )
    w(f"| **per module: slot work mean / {len(over['modules'])}** | **{res['overhead_mean']:.1f}** |")
    w(f"| per module: slot work p50 / {len(over['modules'])} | {res['overhead_p50']:.1f} |")
    one_ex = catch["dispatcher"]["exec_ns"]
    w(
        f"| for comparison: slot work of the 1-module set (catch-up run), mean / p50 | {one_ex['mean']:.0f} / "
        f"{one_ex['p50']:.0f} |"
    )
    w(
        f"| marginal cost of a module: (slot work mean, {len(over['modules'])} modules − 1 module) / "
        f"{len(over['modules']) - 1} | {res['overhead_marginal']:.1f} |"
    )
    w(
        f"| per-module `exec_ns` mean, min / average / max over the modules | {me['min']:.0f} / {me['mean']:.0f} / "
        f"{me['max']:.0f} |"
    )
    w(
        f"| per-module `exec_ns` p50, min / average / max over the modules | {mp['min']:.0f} / {mp['mean']:.0f} / "
        f"{mp['max']:.0f} |"
    )
    w(
        f"| slots: runs / missed / overruns / skipped | {over['dispatcher']['runs']} / {over['dispatcher']['missed']} / "
        f"{over['dispatcher']['overruns']} / {over['dispatcher']['skipped']} |"
    )
    w("")
    w(
        "The slot work is measured by irpd from its wake-up to the end of the last module of the slot, so it "
        "includes everything the dispatcher does per module: the Eq. (1) jitter, latency and execution-time "
        "histogram updates, a clock read, the call to `run()` (empty here) and the counters. A module's own "
        "`exec_ns` is measured from the end of the previous module, so it too includes that bookkeeping, not "
        "only `run()`. The mean includes any stall of the machine during a slot; the p50 does not."
    )
    w("")
    w("## Machine")
    w("")
    w("| | |")
    w("| --- | --- |")
    rows = [
        ("date", started),
        ("kernel (`uname -r`)", info["kernel_release"]),
        ("kernel build (`uname -v`)", info["kernel_version"]),
        ("PREEMPT_RT", "yes" if info["preempt_rt"] else "no (`uname -v` does not say PREEMPT_RT)"),
        ("CPU model", info["cpu_model"]),
        ("CPUs (`nproc`)", str(info["nproc"])),
        ("virtualization", info["virtualization"]),
        ("clocksource", info["clocksource"]),
        ("cpuidle driver", info["cpuidle_driver"] or "none"),
        ("sched_rt_runtime_us", info["rt_runtime_us"]),
        ("isolcpus / nohz_full", info["cmdline_isolcpus"] or "none"),
        ("load average at start", info["loadavg_start"]),
        ("cyclictest", info["cyclictest"]),
        ("source (`git describe --dirty`)", info["git"]),
        (
            "/dev/cpu_dma_latency",
            "held at 0 µs during every run (cyclictest does this itself; the script does it "
            "for irpd and the relative loop)"
            if pm_qos_held
            else "not held (`--no-pm-qos`; cyclictest ran with `--default-system`)",
        ),
    ]
    for k, v in rows:
        w(f"| {k} | {str(v).replace('|', '/')} |")
    w("")
    w("## Exact commands")
    w("")
    w("```sh")
    for c in commands:
        w(c.replace(str(REPO) + "/", ""))
    w("```")
    w("")
    w(
        f"`{rel(sets['one'])}` (the 1-module set) is `{sets['one_desc']}`; `{rel(sets['many'])}` lists the same "
        f"`./empty.so` {len(over['modules'])} times as m001…m{len(over['modules']):03d} (priorities 1…"
        f"{len(over['modules'])}) at {over['basic_period_ns']} ns. `empty.so` is `tests/bench/modules/empty.cpp`: "
        "`INDUROP_MODULE(run = &::onRun)` with an empty `onRun()`."
    )
    w("")
    w("## How to read this")
    w("")
    w(
        "- **What is measured.** Both programs sleep with `clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME)` until "
        "the next point of a fixed grid and read the clock on waking; the wake-up latency is that reading minus the "
        "grid point. cyclictest is the reference for what the kernel and the machine can do; irpd's figure is the "
        "same measurement taken inside its RT loop (`rtcore/src/dispatch/executor.cpp`, dispatcher record "
        "`latency_ns`), with a set of one empty thread module, so the ratio irpd/cyclictest shows what the "
        "dispatcher adds to the wake-up itself. A ratio of 1.00× means no difference; the target is p99 ≤ "
        f"{P99_RATIO_TARGET}×."
    )
    w(
        "- **The runs are sequential, not simultaneous** (they would compete for the CPU otherwise). On a "
        "shared or virtual machine the background changes from one minute to the next, so cyclictest and irpd "
        "alternate in short rounds and their samples are merged: both see the same mix of quiet and busy moments. "
        "The round-by-round table shows how far apart a single pair of short runs can be on this machine. ms "
        "spikes in the max most likely come from the host (a vCPU not scheduled) or from the load on the other "
        "CPU, not from the program that happens to be running; compare the p50 and p99 first and treat p99.9 and "
        "max as the machine's."
    )
    w(
        "- **No drift.** irpd's catch-up run must execute exactly duration/period slots, none skipped. An observer "
        "on another CPU reads irpd's cycle counter from its shared-memory stats block every 0.5 s, compares it "
        "with the slots due by the monotonic clock (lag: 0 or 1 when on the grid), fits a slope to the lag, and "
        "times when the last slot of the grid is seen completed: it must be inside that slot's period "
        "(ceil((end − T0)/period) = slots run). A drift of even 1 µs per period would make the lag grow by "
        f"{1e6 / per_us / per_us:g} periods per second, and the last slot would be seconds late, as the relative "
        "loop's is."
    )
    w(
        "- **Dispatch overhead** is the dispatcher's work per slot divided by the number of modules, with empty "
        "`run()` functions: the cost of dispatching, not of any module."
    )
    w(
        "- **Not a PREEMPT_RT machine?** Then both programs see the same non-RT kernel latencies; the ratio is "
        "still meaningful, the absolute figures are not those of a production controller."
    )
    w("")
    return "\n".join(L)


# --------------------------------------------------------------------------------------------
# process modules: wake-up latency against a thread module's and a signal-based wake-up;
# sporadic modules: reaction time from "condition true" to the start of their work


def parse_bench_output(text: str, what: str) -> tuple[dict, dict]:
    """The histograms and counters a benchmark program printed (tests/bench/common/bench_hist.hpp):
    '@hist', '@buckets', '@info', '@end' lines, anywhere in a line (irpd prefixes "[name] ")."""
    hists: dict[str, dict] = {}
    info: dict[str, dict] = {}
    ended: set[str] = set()
    for line in text.splitlines():
        at = line.find("@")
        if at < 0:
            continue
        words = line[at:].split()
        if len(words) < 2 or words[0] not in ("@hist", "@buckets", "@info", "@end"):
            continue
        kind, label, rest = words[0], words[1], words[2:]
        if kind == "@hist":
            f = dict(w.split("=", 1) for w in rest)
            shape = (int(f["sub_bucket_bits"]), int(f["max_exponent"]), int(f["bucket_count"]))
            if shape != (K_SUB_BITS, K_MAX_EXP, K_BUCKETS):
                raise BenchError(
                    f"{what}: histogram '{label}' has shape {shape}, irpd's is "
                    f"{(K_SUB_BITS, K_MAX_EXP, K_BUCKETS)}: update tests/bench/common/bench_hist.hpp"
                )
            hists[label] = {
                "buckets": [0] * K_BUCKETS,
                "sum": int(f["sum"]),
                "min": int(f["min"]),
                "max": int(f["max"]),
                "count": int(f["count"]),
            }
        elif kind == "@buckets":
            for w in rest:
                i, c = w.split(":")
                hists[label]["buckets"][int(i)] += int(c)
        elif kind == "@info":
            info[label] = {
                k: (int(v) if v.lstrip("-").isdigit() else v) for k, v in (w.split("=", 1) for w in rest if "=" in w)
            }
        else:
            ended.add(label)
    for label, h in hists.items():
        if label not in ended or sum(h["buckets"]) != h["count"]:
            raise BenchError(
                f"{what}: histogram '{label}' arrived incomplete ({sum(h['buckets'])} of {h['count']} "
                "samples; was its output cut or rate-limited?)"
            )
    return hists, info


def bench_hist(hists: dict, label: str, what: str) -> dict:
    if label not in hists:
        raise BenchError(f"{what} printed no histogram '{label}'")
    return hists[label]


def process_set_xml(period_ns: int) -> str:
    return (
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
        f"<!-- generated by tests/bench/run_bench.py: one periodic process module, period {period_ns} ns -->\n"
        "<root>\n"
        "  <module><filename>./wake_process.exe</filename><moduletype>process</moduletype>"
        f"<operationtype>periodic</operationtype><period>{period_ns}</period><priority>1</priority>"
        "<name>p001</name></module>\n"
        "</root>\n"
    )


def sporadic_set_xml(period_ns: int, every: int, process: bool) -> str:
    reactor = (
        "<filename>./reactor_proc.exe</filename><moduletype>process</moduletype>"
        if process
        else "<filename>./reactor.so</filename><moduletype>thread</moduletype>"
    )
    name = "reactor_proc" if process else "reactor"
    return (
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
        f"<!-- generated by tests/bench/run_bench.py: sporadic {'process' if process else 'thread'} reaction -->\n"
        "<root>\n"
        "  <module><filename>./raiser.so</filename><moduletype>thread</moduletype>"
        f"<operationtype>periodic</operationtype><period>{period_ns}</period><priority>1</priority>"
        f"<name>raiser</name><property><value name=\"every\">{every}</value></property></module>\n"
        f"  <module>{reactor}<operationtype>sporadic</operationtype><deadline>{period_ns}</deadline>"
        f"<priority>1</priority><name>{name}</name></module>\n"
        "</root>\n"
    )


PROGRAMS = ("thread", "process", "signal", "signal_unbounded")
PROGRAM_TITLES = {
    "thread": "thread module (irpd)",
    "process": "process module (irpd)",
    "signal": "signal-based",
    "signal_unbounded": "signal-based, unbounded wait",
}


def run_wakeup_comparison(a, irpd: Path, bench: Path, one: Path, work: Path, commands: list[str]) -> dict:
    """Thread module, process module and the signal-based worker (its dispatcher waiting for "done"
    with a time bound as irpd does, then without), same period, CPU and priority, in alternating
    rounds whose order rotates; the histograms of the rounds are merged exactly."""
    proc_xml = bench / f"bench-proc-1x{a.period_ns}ns.xml"
    proc_xml.write_text(process_set_xml(a.period_ns))
    seconds = a.proc_duration // a.proc_rounds
    acc = {p: {} for p in PROGRAMS}  # program -> figure -> list of per-round histograms or counters
    rounds = []

    def add(program: str, key: str, value) -> None:
        acc[program].setdefault(key, []).append(value)

    for r in range(1, a.proc_rounds + 1):
        k = (r - 1) % len(PROGRAMS)
        order = PROGRAMS[k:] + PROGRAMS[:k]
        this = {"round": r, "order": order}
        for program in order:
            if program == "thread":
                d = run_irpd(
                    a,
                    irpd,
                    one,
                    seconds,
                    "skip",
                    f"wake-thread-r{r}",
                    work,
                    commands,
                    hists=(("dispatcher", "latency"), ("m001", "latency")),
                )
                add("thread", "wake", d["_hists"]["m001.latency"])
                add("thread", "dispatcher", d["_hists"]["dispatcher.latency"])
                for c in ("runs", "missed", "skipped"):
                    add("thread", "module_" + c, d["modules"][0][c])
                add("thread", "realtime", d["realtime"])
            elif program == "process":
                d = run_irpd(
                    a,
                    irpd,
                    proc_xml,
                    seconds,
                    "skip",
                    f"wake-process-r{r}",
                    work,
                    commands,
                    hists=(("dispatcher", "latency"), ("p001", "latency"), ("p001", "exec")),
                )
                hs, info = parse_bench_output(d["_stdout"], f"wake_process.exe (round {r})")
                add("process", "wake", bench_hist(hs, "process_wake", "wake_process.exe"))
                add("process", "dispatcher", d["_hists"]["dispatcher.latency"])
                add("process", "release", d["_hists"]["p001.latency"])
                add("process", "exec", d["_hists"]["p001.exec"])
                m = d["modules"][0]
                for c in ("runs", "overruns", "missed", "skipped"):
                    add("process", "module_" + c, m[c])
                pi = info.get("process_wake", {})
                add("process", "gaps", pi.get("gaps", 0))
                add("process", "mlockall", pi.get("mlockall", 0))
                add("process", "realtime", d["realtime"])
            else:
                cmd = [
                    str(bench / "signal_wakeup"),
                    "--period-ns",
                    str(a.period_ns),
                    "--duration",
                    str(seconds),
                    "--cpu",
                    str(a.cpu),
                    "--rt-priority",
                    str(a.rt_priority),
                ]
                if program == "signal_unbounded":
                    cmd.append("--unbounded")
                commands.append(quote(cmd))
                p = run_checked(cmd, f"signal_wakeup (round {r}, {seconds} s)", seconds + 60)
                hs, info = parse_bench_output(p.stdout, f"signal_wakeup (round {r})")
                add(program, "wake", bench_hist(hs, "signal_wake", "signal_wakeup"))
                add(program, "dispatcher", bench_hist(hs, "signal_dispatcher", "signal_wakeup"))
                add(program, "exec", bench_hist(hs, "signal_exec", "signal_wakeup"))
                di = info.get("signal_dispatcher", {})
                for c in ("releases", "missed", "skipped", "overruns", "not_ready", "grid"):
                    add(program, c, di.get(c, 0))
                add(program, "realtime", bool(di.get("realtime")) and bool(info.get("signal_wake", {}).get("realtime")))
            this[program] = summarize_irpd_hist(acc[program]["wake"][-1])
        rounds.append(this)

    out = {"seconds_per_round": seconds, "rounds": rounds, "process_xml": proc_xml}
    for program, figures in acc.items():
        out[program] = {}
        for key, values in figures.items():
            if isinstance(values[0], dict):
                out[program][key] = summarize_irpd_hist(merge_irpd_hists(values))
            elif isinstance(values[0], bool):
                out[program][key] = all(values)
            else:
                out[program][key] = sum(values)
    t99, p99 = out["thread"]["wake"].get("p99"), out["process"]["wake"].get("p99")
    out["ratio_p99"] = ratio(p99, t99)
    out["target"] = out["ratio_p99"] is not None and out["ratio_p99"] <= PROC_P99_RATIO_TARGET
    return out


def run_sporadic(a, irpd: Path, bench: Path, work: Path, commands: list[str]) -> dict:
    """A periodic thread module raises an event every `every`-th basic period; a sporadic thread
    module, then (in a second run) a sporadic process module reacts to it."""
    folder = bench / "sporadic"
    out = {"every": a.sporadic_every, "seconds": a.sporadic_duration}
    for kind, label, name in (
        ("thread", "sporadic_thread", "reactor"),
        ("process", "sporadic_process", "reactor_proc"),
    ):
        xml = folder / f"bench-sporadic-{kind}-{a.period_ns}ns.xml"
        xml.write_text(sporadic_set_xml(a.period_ns, a.sporadic_every, kind == "process"))
        d = run_irpd(a, irpd, xml, a.sporadic_duration, None, f"sporadic-{kind}", work, commands)
        what = "reactor.so" if kind == "thread" else "reactor_proc.exe"
        hs, info = parse_bench_output(d["_stdout"], what)
        names = [m["name"] for m in d["modules"]]
        out[kind] = {
            "xml": xml,
            "reaction": summarize_irpd_hist(bench_hist(hs, label, what)),
            "info": info.get(label, {}),
            "irpd": d["modules"][names.index(name)],
            "raiser": d["modules"][names.index("raiser")],
            "dispatcher": d["dispatcher"],
            "realtime": d["realtime"],
            "policy": d.get("overrun_policy"),
        }
    ti = out["thread"]["info"]
    out["target"] = (
        ti.get("same_period", 0) > 0
        and ti.get("next_period", 1) == 0
        and ti.get("later", 1) == 0
        and ti.get("lost", 1) == 0
    )
    return out


def render_wakeup(a, w: dict) -> str:
    t, p, s, u = (w[k] for k in PROGRAMS)
    tw, pw = t["wake"], p["wake"]
    per_us = a.period_ns / 1000
    L: list[str] = []
    add = L.append

    def q(h: dict) -> str:
        return " / ".join(us(h.get(k)) for k in ("p50", "p99", "p999", "max")) if h.get("count") else "—"

    add("## Process module wake-up: against a thread module and a signal-based wake-up")
    add("")
    add(
        f"Period {a.period_ns} ns ({per_us:g} µs), CPU {a.cpu}, the dispatcher at SCHED_FIFO {a.rt_priority}, the "
        f"processes at {a.rt_priority - 1}; {len(PROGRAMS)} programs, {w['seconds_per_round']} s each per round, in "
        f"{a.proc_rounds} rounds whose order rotates; the samples of the rounds are merged. irpd runs with "
        "`--overrun-policy skip`, as in the cyclictest comparison, so that every sample is a real wake-up."
    )
    add("")
    add(
        f"Target: process p99 ≤ {PROC_P99_RATIO_TARGET:g}× thread p99: {us(pw.get('p99'))} µs / "
        f"{us(tw.get('p99'))} µs = {fmt_ratio(w['ratio_p99'])}: **{verdict(w['target'])}**."
    )
    per_round = [ratio(r["process"].get("p99"), r["thread"].get("p99")) for r in w["rounds"]]
    per_round = [x for x in per_round if x is not None]
    if per_round:
        add("")
        add(
            f"Round by round the same ratio goes from {min(per_round):.2f}× to {max(per_round):.2f}× (last table): "
            "a merged p99 leans on the program's noisiest round, and the noisiest rounds of the thread and of the "
            "process need not be the same ones. The p50s are the steadier comparison: the process's p50 is its "
            f"dispatcher's plus {us(pw.get('p50', 0) - p['dispatcher'].get('p50', 0))} µs of hand-over (second "
            "table)."
        )
    add("")
    add(
        "Wake-up latency = when the module's code starts running − the basic period's due time, in µs (the "
        "ratios are against the thread module):"
    )
    add("")
    add(
        "| figure | " + " | ".join(PROGRAM_TITLES[k] for k in PROGRAMS) + " | process/thread | signal/thread | "
        "signal, unbounded/thread |"
    )
    add("| --- |" + " ---: |" * (len(PROGRAMS) + 3))
    add("| samples | " + " | ".join(str(w[k]["wake"].get("count", 0)) for k in PROGRAMS) + " | | | |")
    for key, name in (
        ("min", "min"),
        ("mean", "mean"),
        ("p50", "**p50**"),
        ("p99", "**p99**"),
        ("p999", "p99.9"),
        ("max", "max"),
    ):
        vals = [w[k]["wake"].get(key) for k in PROGRAMS]
        add(
            f"| {name} | "
            + " | ".join(us(v) for v in vals)
            + " | "
            + " | ".join(fmt_ratio(ratio(v, vals[0])) for v in vals[1:])
            + " |"
        )
    add("")
    add("The same runs, what each dispatcher saw (µs; p50 / p99 / p99.9 / max):")
    add("")
    add("| | " + " | ".join(PROGRAM_TITLES[k] for k in PROGRAMS) + " |")
    add("| --- |" + " ---: |" * len(PROGRAMS))
    add(
        "| dispatcher's own wake-up latency (woke − due) | "
        + " | ".join(q(w[k]["dispatcher"]) for k in PROGRAMS)
        + " |"
    )
    add(
        f"| irpd's record for the module, `latency_ns` | {q(tw)} (start − due) | {q(p['release'])} (release − due) "
        "| — | — |"
    )
    add(
        f"| release → done (irpd: the process's `exec_ns`; signal: `sigqueue` → \"done\" received) | — | "
        f"{q(p['exec'])} | {q(s['exec'])} | {q(u['exec'])} |"
    )
    add(
        "| hand-over: p50 of the module's wake-up − p50 of its dispatcher's | "
        + " | ".join(us(w[k]["wake"].get("p50", 0) - w[k]["dispatcher"].get("p50", 0)) for k in PROGRAMS)
        + " |"
    )
    add(
        f"| wake-up samples | {t['module_runs']} runs | {p['module_runs']} runs; the process counted "
        f"{pw.get('count', 0)} | {s['releases']} releases | {u['releases']} releases |"
    )
    add(
        f"| slots skipped (a whole period late) / releases missed (not ready) / not done within the period | "
        f"{t['module_skipped']} / — / — | {p['module_skipped']} / {p['module_missed']} / {p['module_overruns']} | "
        f"{s['skipped']} / {s['not_ready']} / {s['overruns']} | {u['skipped']} / {u['not_ready']} / {u['overruns']} |"
    )
    add("")
    add(
        "Round by round (the module's wake-up p50 / p99 / max in µs; the ratio is the process's p99 over the thread's):"
    )
    add("")
    add("| round | first | " + " | ".join(PROGRAM_TITLES[k] for k in PROGRAMS) + " | p99 process/thread |")
    add("| --- | --- |" + " ---: |" * (len(PROGRAMS) + 1))
    for r in w["rounds"]:
        cells = [" / ".join(us(r[k].get(x)) for x in ("p50", "p99", "max")) for k in PROGRAMS]
        add(
            f"| {r['round']} | {r['order'][0]} | " + " | ".join(cells) + " | "
            f"{fmt_ratio(ratio(r['process'].get('p99'), r['thread'].get('p99')))} |"
        )
    add("")
    add(
        f"- **thread module**: `{rel(a.one_set)}`, one empty thread module (`empty.so`); its wake-up is its record's "
        "`latency_ns` in `--stats-json` (its `run()` start − the slot's due time), the histogram read from irpd's "
        "stats block. It starts right after the dispatcher's own wake-up, so the two are nearly equal. With the "
        "skip policy a slot woken a whole period late or more is dropped and the module runs in the slot due now, "
        "its latency counted against that slot: its max stays below one period, and the stalls show as skipped "
        "slots (last table row)."
    )
    add(
        f"- **process module**: `{rel(w['process_xml'])}`, one periodic process module, "
        "`tests/bench/processes/wake_process.cpp`: `mlockall`, `irp::initPeriodExe()`, then "
        "`while (irp::waitPeriod() == 0)` recording (return of `waitPeriod()`) − `irp::cycle().planned_ns` (the "
        "due time of the slot that released it) into a histogram of irpd's shape, printed when `waitPeriod()` "
        "returns −1 and read from irpd's stdout (`[p001] @hist …`). irpd releases it through the control segment "
        "(release_seq + 1, FUTEX_WAKE) and waits for its done word (FUTEX_WAIT with a timeout: the end of the "
        "basic period); the process, one priority below and on the same CPU, gets the CPU when the dispatcher "
        "blocks. Its wake-up therefore includes the dispatcher's own wake-up, the release, the start of the "
        "bounded wait and a switch to another address space."
    )
    add(
        "- **signal-based**: `tests/bench/signal_wakeup.cpp`, the paper's original design (Figures 6 and 8: the "
        "event handler \"sends signal to each process\", `waitPeriod()` \"waits signal\"): a dispatcher process "
        f"at SCHED_FIFO {a.rt_priority} sleeps on the same absolute grid, sends `sigqueue(worker, SIGRTMIN, due)` "
        f"and waits in `sigtimedwait`, bounded by the end of the period as irpd's wait is, for the worker's "
        f"\"done\" (SIGRTMIN+1); the worker, SCHED_FIFO {a.rt_priority - 1} on the same CPU, blocks in "
        "`sigwaitinfo` and records (its return) − the due time the signal carries. Same histogram, same skip rule, "
        "same \"not released while not done\" rule as irpd."
    )
    add(
        "- **signal-based, unbounded wait**: the same program with `--unbounded`: its dispatcher waits for \"done\" "
        "in `sigwaitinfo`, without a time bound, so no timer is armed between the release and the switch to the "
        "worker. The difference between the two signal columns (hand-over "
        f"{us(s['wake'].get('p50', 0) - s['dispatcher'].get('p50', 0))} µs against "
        f"{us(u['wake'].get('p50', 0) - u['dispatcher'].get('p50', 0))} µs at p50; release → done "
        f"{us(s['exec'].get('p50'))} µs against {us(u['exec'].get('p50'))} µs) is what arming and cancelling that "
        "timer costs on this machine; irpd's release of a process pays it too (its wait for done is a FUTEX_WAIT "
        "with a timeout, `rtcore/src/hosts/control_segment.cpp`, called from `Executor::runProcess`)."
    )
    add(
        f"- **Period.** {per_us:g} µs is sustainable for a process module here: {p['module_overruns']} of "
        f"{p['module_runs']} releases were not done within their basic period "
        f"({100 * p['module_overruns'] / max(1, p['module_runs']):.3f} %), {p['module_missed']} releases were not "
        f"made because the process was not ready, and the whole release → done takes "
        f"{us(p['exec'].get('p50'))} µs at p50, {us(p['exec'].get('p99'))} µs at p99."
    )
    if not all(w[k]["realtime"] for k in PROGRAMS):
        add("- **WARNING**: some run did not get SCHED_FIFO (not root?); these figures are not real-time.")
    if not p.get("mlockall"):
        add("- **WARNING**: the process module could not mlockall (page faults may add latency).")
    add("")
    return "\n".join(L)


def render_sporadic(a, sp: dict) -> str:
    per_us = a.period_ns / 1000
    L: list[str] = []
    add = L.append
    add("## Sporadic reaction time")
    add("")
    add(
        f"A periodic thread module (`tests/bench/modules/raiser.cpp`, period {per_us:g} µs) raises an event every "
        f"{sp['every']}th basic period: it reads CLOCK_MONOTONIC, stores that time and the basic period's count in "
        "shared variables (`tests/bench/shared/sporadic.glb`), then bumps `sporadic::seq`; from that store on, the "
        "sporadic module's condition (\"seq moved\") is true. Reaction time = when the sporadic module's work "
        "starts − that raise time. One irpd run per variant, "
        f"{sp['seconds']} s each, default overrun policy ({sp['thread']['policy']}), same CPU and priority."
    )
    add("")
    th, pr = sp["thread"], sp["process"]
    add(
        f"Expected (by design, docs/process-modules.md): a sporadic thread reacts in the basic period that raised "
        f"the event, as the event handler runs right after the periodic modules: "
        f"{th['info'].get('same_period', 0)} of {th['reaction'].get('count', 0)} reactions in that basic period: "
        f"**{verdict(sp['target'])}**."
    )
    add("")
    add("| reaction time, µs | sporadic thread (`run()` start) | sporadic process (`waitPeriod()` return) |")
    add("| --- | ---: | ---: |")
    tr, prr = th["reaction"], pr["reaction"]
    add(f"| events handled | {tr.get('count', 0)} | {prr.get('count', 0)} |")
    for key, name in (
        ("min", "min"),
        ("mean", "mean"),
        ("p50", "**p50**"),
        ("p99", "**p99**"),
        ("p999", "p99.9"),
        ("max", "**max**"),
    ):
        add(f"| {name} | {us(tr.get(key))} | {us(prr.get(key))} |")
    ti, pi = th["info"], pr["info"]
    add(
        f"| handled in the basic period that raised it / the next / later | {ti.get('same_period')} / "
        f"{ti.get('next_period')} / {ti.get('later')} | {pi.get('same_period')} / {pi.get('next_period')} / "
        f"{pi.get('later')} |"
    )
    add(f"| events lost (raised again before being handled) | {ti.get('lost')} | {pi.get('lost')} |")
    it, ip = th["irpd"], pr["irpd"]
    add(
        f"| irpd's record `latency_ns` p50 / p99 / max | {us(it['latency_ns'].get('p50'))} / "
        f"{us(it['latency_ns'].get('p99'))} / {us(it['latency_ns'].get('max'))} (condition checked → `run()`) | "
        f"{us(ip['latency_ns'].get('p50'))} / {us(ip['latency_ns'].get('p99'))} / {us(ip['latency_ns'].get('max'))} "
        "(release − due, every basic period) |"
    )
    add(
        f"| irpd's record `exec_ns` p50 / p99 / max | {us(it['exec_ns'].get('p50'))} / {us(it['exec_ns'].get('p99'))} / "
        f"{us(it['exec_ns'].get('max'))} (`run()`) | {us(ip['exec_ns'].get('p50'))} / {us(ip['exec_ns'].get('p99'))} / "
        f"{us(ip['exec_ns'].get('max'))} (release → done) |"
    )
    add(
        f"| irpd's record: runs / deadline misses (deadline {per_us:g} µs) | {it['runs']} / {it['missed']} | "
        f"{ip['runs']} releases completed / {ip['missed']} |"
    )
    add("")
    add(
        f"- The sporadic **thread** (`tests/bench/modules/reactor.cpp`, `{rel(th['xml'])}`) runs on the dispatcher "
        "thread: after the raiser's `run()` returns, irpd finishes the raiser's bookkeeping, the event handler calls "
        "`condition()` and then `run()`, whose first act is to read the clock. `irp::cycle().count` in `run()` "
        "against the raiser's count gives the basic period of the reaction."
    )
    add(
        f"- The sporadic **process** (`tests/bench/processes/reactor_proc.cpp`, `{rel(pr['xml'])}`, Figure 8's "
        "shape) is released by the event handler every basic period and not awaited: it runs when the dispatcher "
        "goes back to sleep (after arming the timer of its next wake-up: see the unbounded-wait column above for "
        "what arming a timer costs on this machine), checks the event itself after `waitPeriod()` returns, and "
        "records that return − the raise time. It is released in the basic period that raised the event when it finished its previous "
        "release; otherwise (the machine stalled it) in a later one."
    )
    add("")
    return "\n".join(L)


def add_targets_and_runs(a, report: str, wake: dict, sporadic: dict) -> str:
    """Adds this run's process and sporadic targets to the report's target table, and says in its
    opening paragraph what ran after the 100-module set."""
    lines = report.split("\n")
    for i, line in enumerate(lines):
        if line.startswith("| dispatch overhead ≤"):
            pw, tw = wake["process"]["wake"], wake["thread"]["wake"]
            ti = sporadic["thread"]["info"]
            lines[i + 1 : i + 1] = [
                f"| process module wake-up p99 ≤ {PROC_P99_RATIO_TARGET:g}× thread module's, same run, "
                f"{a.period_ns / 1000:g} µs | {us(pw.get('p99'))} µs / {us(tw.get('p99'))} µs = "
                f"{fmt_ratio(wake['ratio_p99'])} (signal-based wake-up: {us(wake['signal']['wake'].get('p99'))} µs) | "
                f"{verdict(wake['target'])} |",
                f"| sporadic thread reacts in the basic period its condition turned true (by design) | "
                f"{ti.get('same_period', 0)} of {sporadic['thread']['reaction'].get('count', 0)}; reaction p99 "
                f"{us(sporadic['thread']['reaction'].get('p99'))} µs (process: "
                f"{us(sporadic['process']['reaction'].get('p99'))} µs) | {verdict(sporadic['target'])} |",
            ]
            break
    for i, line in enumerate(lines):
        if line.startswith(f"Period {a.period_ns} ns (") and line.endswith(" s."):
            lines[i] = (
                line + f" Then the shared-variable costs; the thread module, the process module and the "
                f"signal-based wake-up (with a bounded and an unbounded wait), {a.proc_duration} s each in "
                f"{a.proc_rounds} rotating rounds; the sporadic thread and the sporadic process, "
                f"{a.sporadic_duration} s each."
            )
            break
    for i, line in enumerate(lines):
        if line.startswith(f"`{rel(a.one_set)}` (the 1-module set) is "):
            proc = process_set_xml(a.period_ns).splitlines()[3].strip()
            spt = sporadic_set_xml(a.period_ns, a.sporadic_every, False).splitlines()[3:5]
            spp = sporadic_set_xml(a.period_ns, a.sporadic_every, True).splitlines()[4].strip()
            lines[i + 1 : i + 1] = [
                "",
                f"`{rel(wake['process_xml'])}` (the process set) is `{proc}`. The sporadic sets, in "
                f"`{rel(sporadic['thread']['xml'].parent)}/` beside their `layout.json`, are "
                f"`{spt[0].strip()}` followed by `{spt[1].strip()}` (thread) or `{spp}` (process).",
            ]
            break
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument(
        "--duration",
        type=int,
        default=60,
        help="seconds of cyclictest, of irpd (skip), each split in --rounds, and of the "
        "relative-sleep loop (default 60)",
    )
    ap.add_argument(
        "--rounds",
        type=int,
        default=6,
        help="cyclictest and irpd (skip) alternate in this many rounds of duration/rounds seconds; "
        "their samples are merged (default 6)",
    )
    ap.add_argument(
        "--long-duration",
        type=int,
        default=None,
        help=f"seconds of the irpd catch-up (no-drift) run (default {LONG_RUN_TARGET_S}; shorten for quick tries)",
    )
    ap.add_argument("--overhead-duration", type=int, default=20, help="seconds of the 100-module run (default 20)")
    ap.add_argument("--period-ns", type=int, default=100_000, help="basic period (default 100000, a whole µs)")
    ap.add_argument(
        "--overhead-period-ns", type=int, default=1_000_000, help="period of the 100-module set (default 1000000)"
    )
    ap.add_argument("--modules", type=int, default=100, help="modules in the overhead set (default 100)")
    ap.add_argument(
        "--proc-duration",
        type=int,
        default=20,
        help="seconds of each program of the thread/process/signal wake-up comparison, split in "
        "--proc-rounds (default 20)",
    )
    ap.add_argument(
        "--proc-rounds",
        type=int,
        default=4,
        help="rounds of that comparison; the order of its four programs rotates (default 4)",
    )
    ap.add_argument(
        "--sporadic-duration",
        type=int,
        default=8,
        help="seconds of each sporadic-reaction run, thread and process (default 8)",
    )
    ap.add_argument(
        "--sporadic-every",
        type=int,
        default=4,
        help="the sporadic event is raised every this many basic periods (default 4)",
    )
    ap.add_argument("--cpu", type=int, default=None, help="CPU of every run (default: the last one allowed)")
    ap.add_argument("--rt-priority", type=int, default=80, help="SCHED_FIFO priority (default 80)")
    ap.add_argument("--work-ns", type=int, default=1000, help="relative loop's work per iteration (default 1000)")
    ap.add_argument(
        "--build-dir",
        type=Path,
        default=REPO / "build-bench",
        help="CMake build directory (default build-bench; configured Release if new)",
    )
    ap.add_argument("--no-build", action="store_true", help="do not (re)build, use --build-dir as it is")
    ap.add_argument(
        "--out",
        default=str(REPO / "docs" / "benchmark.md"),
        help="Markdown report to write (default docs/benchmark.md; '-' for none)",
    )
    ap.add_argument("--json", type=Path, default=None, help="also write every raw figure to this JSON file")
    ap.add_argument(
        "--no-pm-qos",
        dest="pm_qos",
        action="store_false",
        help="do not hold /dev/cpu_dma_latency at 0 (and run cyclictest with --default-system)",
    )
    a = ap.parse_args(argv)
    a.shown_args = argv
    if a.long_duration is None:
        a.long_duration = LONG_RUN_TARGET_S
    allowed = ALLOWED_CPUS
    if a.cpu is None:
        a.cpu = allowed[-1]
    if a.cpu not in allowed:
        ap.error(f"--cpu {a.cpu}: not among the CPUs allowed here ({allowed})")
    if a.period_ns % 1000 or a.period_ns < 10_000:
        ap.error("--period-ns must be a whole number of microseconds (cyclictest's -i), at least 10000")
    for name in (
        "duration",
        "long_duration",
        "overhead_duration",
        "modules",
        "rounds",
        "proc_duration",
        "proc_rounds",
        "sporadic_duration",
        "sporadic_every",
    ):
        if getattr(a, name) < 1:
            ap.error(f"--{name.replace('_', '-')} must be at least 1")
    if a.duration % a.rounds:
        ap.error(f"--duration {a.duration} must be a multiple of --rounds {a.rounds} (cyclictest takes whole seconds)")
    if a.proc_duration % a.proc_rounds:
        ap.error(f"--proc-duration {a.proc_duration} must be a multiple of --proc-rounds {a.proc_rounds}")
    if not 2 <= a.rt_priority <= 99:
        ap.error("--rt-priority must be 2..99 (process modules run one below it)")

    if not shutil.which("cyclictest"):
        print(
            "run_bench: cyclictest not found. It is in Debian's rt-tests package: apt-get install rt-tests",
            file=sys.stderr,
        )
        return 1
    if os.geteuid() != 0:
        log("WARNING: not root: SCHED_FIFO, mlockall and /dev/cpu_dma_latency will probably be refused")

    started_wall = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    t_start = time.monotonic()
    commands: list[str] = []
    try:
        if not a.no_build:
            build(a.build_dir, commands)
        irpd = a.build_dir / "bin" / "irpd"
        load_stats_layout(irpd)
        bench = a.build_dir / "bench"
        for f in (
            irpd,
            bench / "empty.so",
            bench / "relative_sleep",
            bench / "shared_vars",
            bench / "wake_process.exe",
            bench / "signal_wakeup",
            bench / "sporadic" / "raiser.so",
            bench / "sporadic" / "reactor.so",
            bench / "sporadic" / "reactor_proc.exe",
            bench / "sporadic" / "layout.json",
        ):
            if not f.exists():
                raise BenchError(f"{f} is missing: build first (or drop --no-build)")
        # this script and its observer stay off the measured CPU
        others = [c for c in allowed if c != a.cpu]
        if others:
            os.sched_setaffinity(0, others)
        info = machine()

        # the sets sit next to empty.so: "./empty.so" resolves against the XML's folder
        one = bench / f"bench-1x{a.period_ns}ns.xml"
        many = bench / f"bench-{a.modules}x{a.overhead_period_ns}ns.xml"
        one.write_text(module_xml(1, a.period_ns))
        a.one_set = one
        many.write_text(module_xml(a.modules, a.overhead_period_ns))
        sets = {"one": one, "many": many, "one_desc": module_xml(1, a.period_ns).splitlines()[3].strip()}
        work = bench / "results"
        work.mkdir(exist_ok=True)
        for stale in list(work.glob("irpd-*.json")) + list(work.glob("cyclictest-*hist.txt")):
            stale.unlink()

        with PmQos(a.pm_qos) as qos:
            # cyclictest and irpd (skip) in alternating rounds, so both sample the same background
            seconds = a.duration // a.rounds
            ct_raws, skip_docs, rounds = [], [], []
            for r in range(1, a.rounds + 1):
                order = ("ct", "irpd") if r % 2 else ("irpd", "ct")
                for who in order:
                    if who == "ct":
                        ct_raws.append(run_cyclictest(a, seconds, f"r{r}", work, commands))
                    else:
                        skip_docs.append(
                            run_irpd(a, irpd, one, seconds, "skip", f"skip-r{r}", work, commands, histogram=True)
                        )
                c1 = summarize_cyclictest(ct_raws[-1], a.period_ns)
                rounds.append(
                    {
                        "round": r,
                        "first": order[0],
                        "cyclictest": {k: c1[k] for k in ("p50", "p99", "p999", "max")},
                        "irpd": {
                            k: skip_docs[-1]["dispatcher"]["latency_ns"][k] for k in ("p50", "p99", "p999", "max")
                        },
                        "irpd_skipped": skip_docs[-1]["dispatcher"]["skipped"],
                    }
                )
            ct = summarize_cyclictest(merge_cyclictest(ct_raws), a.period_ns)
            ct["rounds"] = rounds
            skip = {
                "dispatcher": {
                    "latency_ns": summarize_irpd_hist(merge_irpd_hists([d["_latency_hist"] for d in skip_docs])),
                    "runs": sum(d["dispatcher"]["runs"] for d in skip_docs),
                    "skipped": sum(d["dispatcher"]["skipped"] for d in skip_docs),
                    "missed": sum(d["dispatcher"]["missed"] for d in skip_docs),
                    "realtime": all(d["realtime"] for d in skip_docs),
                }
            }
            catch = run_irpd(a, irpd, one, a.long_duration, None, "catchup", work, commands, observe=True)
            relative = run_relative(a, bench / "relative_sleep", work, commands)
            over = run_irpd(a, irpd, many, a.overhead_duration, None, "overhead", work, commands)
            shared = run_shared_vars(a, bench, commands)
            wake = run_wakeup_comparison(a, irpd, bench, one, work, commands)
            sporadic = run_sporadic(a, irpd, bench, work, commands)
            pm_qos_held = qos.held
        res = analyse(a, ct, skip, catch, over, relative)
    except BenchError as e:
        print(f"run_bench: {e}", file=sys.stderr)
        return 1

    took = time.monotonic() - t_start
    info["loadavg_end"] = read_text("/proc/loadavg")
    report = render(a, info, ct, skip, catch, over, relative, res, commands, sets, pm_qos_held, started_wall, took)
    report = report.replace(
        "\n## Machine\n",
        "\n"
        + render_shared(shared)
        + "\n"
        + render_wakeup(a, wake)
        + "\n"
        + render_sporadic(a, sporadic)
        + "\n## Machine\n",
        1,
    )
    report = add_targets_and_runs(a, report, wake, sporadic)
    print(report)
    if a.out != "-":
        out = Path(a.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(report)
        log(f"wrote {out}")
    if a.json:

        def strip(d: dict) -> dict:
            return {k: v for k, v in d.items() if k not in ("_stderr", "_stdout", "_latency_hist", "_hists")}

        a.json.write_text(
            json.dumps(
                {
                    "machine": info,
                    "cyclictest": ct,
                    "irpd_skip": strip(skip),
                    "irpd_catchup": strip(catch),
                    "irpd_overhead": strip(over),
                    "relative_sleep": relative,
                    "analysis": res,
                    "shared_vars": shared,
                    "process_wakeup": wake,
                    "sporadic": sporadic,
                    "commands": commands,
                },
                indent=1,
                default=str,
            )
            + "\n"
        )
        log(f"wrote {a.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

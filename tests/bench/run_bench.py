#!/usr/bin/env python3
"""run_bench.py -- irpd's wake-up latency against cyclictest's, on the same CPU, in one command.

    .venv/bin/python tests/bench/run_bench.py [--duration S] [--period-ns N] [--cpu N] [--rt-priority P]
                                     [--out docs/benchmark.md] [--build-dir DIR] [--no-build]
                                     [--proc-duration S] [--proc-rounds R] [--sporadic-duration S]
                                     [--only process]
    .venv/bin/python tests/bench/run_bench.py --only dispatch [--dispatch-rounds R]
                                     [--baseline-build-dir DIR --baseline-label TEXT] [--build-dir DIR]

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
     dispatch overhead per module = dispatcher slot work (exec_ns) mean / 100; then the same set
     under `perf record`, its samples put in parts (statistics, clock, loop, ...: dispatch_profile.py);
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

With --only dispatch it runs part 5 alone (the 1-module set for the marginal cost, the 100-module
set in --dispatch-rounds rounds, alternating with --baseline-build-dir's irpd when given, then each
under perf) and rewrites only the dispatch target row and section of --out (rtbench/dispatch_only.py).
`--only process` runs part 7 alone and replaces its section and its target row in --out (an existing
report), saying there when and how that part was measured.

Prints the distributions, the ratios irpd/cyclictest (p50, p99, p99.9, max) and each target's
verdict, and writes them with the machine's description to --out (docs/benchmark.md).  Targets are
reported, not asserted: the exit status is 0 when everything ran, 1 when something failed to run.
Python 3.11 standard library only.  Run as root (SCHED_FIFO, mlockall, /dev/cpu_dma_latency).

The parts are in tests/bench/rtbench/, one module a concern: common.py, machine.py, irpd_stats.py
(irpd's histograms), cyclictest.py (1), irpd_runs.py (2-5), shared_vars.py (6), process_wakeup.py
(7), sporadic.py (8), report.py (the verdicts and docs/benchmark.md), dispatch_only.py (--only dispatch).
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import shutil
import sys
import time
from pathlib import Path

from rtbench.common import ALLOWED_CPUS, LONG_RUN_TARGET_S, PROC_P99_RATIO_TARGET, REPO, BenchError, PmQos, log
from rtbench.cyclictest import merge_cyclictest, run_cyclictest, summarize_cyclictest
from rtbench.dispatch_only import run_dispatch_only, write_dispatch_only
from rtbench.dispatch_profile import render_profile, run_profile
from rtbench.irpd_runs import DISPATCH_TARGETS, build, module_xml, run_irpd, run_relative
from rtbench.irpd_stats import load_stats_layout, merge_irpd_hists, summarize_irpd_hist
from rtbench.machine import machine, read_text
from rtbench.process_wakeup import render_wakeup, run_wakeup_comparison
from rtbench.release_variants import variant_programs
from rtbench.report import add_targets_and_runs, analyse, render, replace_process_section
from rtbench.shared_vars import render_shared, run_shared_vars
from rtbench.sporadic import render_sporadic, run_sporadic


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
        "--proc-variants",
        default="all",
        help="the alternatives of release_variants.cpp run in those rounds: 'all' (default), 'none', or modes "
        "separated by commas (fewer programs a round: more, shorter rounds in the same time)",
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
        "--only",
        choices=("all", "dispatch", "process"),
        default="all",
        help="dispatch: only the dispatch overhead (part 5); process: only part 7 (the process wake-up comparison "
        "and the alternatives); each replaces only its section and its target row in --out (default all)",
    )
    ap.add_argument(
        "--dispatch-rounds", type=int, default=2, help="--only dispatch: rounds of the 100-module set (default 2)"
    )
    ap.add_argument(
        "--baseline-build-dir",
        type=Path,
        default=None,
        help="--only dispatch: also run this build's bin/irpd on the same set, in alternating rounds",
    )
    ap.add_argument(
        "--baseline-label", default="the baseline", help="--only dispatch: what the baseline build is (its commit)"
    )
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
        "dispatch_rounds",
    ):
        if getattr(a, name) < 1:
            ap.error(f"--{name.replace('_', '-')} must be at least 1")
    if a.duration % a.rounds:
        ap.error(f"--duration {a.duration} must be a multiple of --rounds {a.rounds} (cyclictest takes whole seconds)")
    if a.proc_duration % a.proc_rounds:
        ap.error(f"--proc-duration {a.proc_duration} must be a multiple of --proc-rounds {a.proc_rounds}")
    try:
        a.proc_variants = variant_programs(a.proc_variants)
    except ValueError as e:
        ap.error(str(e))
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
    if a.only == "dispatch":
        return dispatch_only(a, commands)
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
            bench / "release_variants",
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

        if a.only == "process":
            if a.out == "-" or not Path(a.out).exists():
                raise BenchError("--only process replaces a section of --out: it must be an existing report")
            with PmQos(a.pm_qos):
                wake = run_wakeup_comparison(a, irpd, bench, one, work, commands)
            info["loadavg_end"] = read_text("/proc/loadavg")
            out = Path(a.out)
            out.write_text(
                replace_process_section(a, out.read_text(), render_wakeup(a, wake), wake, info, commands, started_wall)
            )
            log(f"process target: {wake['ratio_p99']} (≤ {PROC_P99_RATIO_TARGET:g}); wrote {out}")
            return 0
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
            profile = run_profile(a, irpd, many, work, commands)
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
        + render_profile(a, profile)
        + "\n"
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
                    "dispatch_profile": profile,
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


def dispatch_only(a, commands: list[str]) -> int:
    """--only dispatch: part 5 alone, its part of the report rewritten."""
    try:
        if not a.no_build:
            build(a.build_dir, commands, DISPATCH_TARGETS)
        irpd = a.build_dir / "bin" / "irpd"
        bench = a.build_dir / "bench"
        for f in (irpd, bench / "empty.so"):
            if not f.exists():
                raise BenchError(f"{f} is missing: build first (or drop --no-build)")
        others = [c for c in ALLOWED_CPUS if c != a.cpu]
        if others:
            os.sched_setaffinity(0, others)
        one = bench / f"bench-1x{a.period_ns}ns.xml"
        many = bench / f"bench-{a.modules}x{a.overhead_period_ns}ns.xml"
        one.write_text(module_xml(1, a.period_ns))
        many.write_text(module_xml(a.modules, a.overhead_period_ns))
        work = bench / "results"
        work.mkdir(exist_ok=True)
        with PmQos(a.pm_qos):
            d = run_dispatch_only(a, irpd, one, many, work, commands)
        write_dispatch_only(a, d, commands)
    except BenchError as e:
        print(f"run_bench: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

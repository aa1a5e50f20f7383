"""report.py -- the verdicts on the targets and the Markdown report (docs/benchmark.md): irpd against
cyclictest, the relative-sleep contrast, the dispatch overhead, the machine, the exact commands;
then the process and sporadic targets added to its table.
"""

from __future__ import annotations

from .common import (
    LONG_RUN_TARGET_S,
    OVERHEAD_TARGET_NS,
    P99_RATIO_TARGET,
    PROC_P99_RATIO_TARGET,
    REPO,
    BenchError,
    fmt_ratio,
    ratio,
    rel,
    us,
    verdict,
)
from .process_wakeup import process_set_xml
from .sporadic import sporadic_set_xml


def end_text(obs: dict) -> str:
    e = obs.get("end_after_last_due_ns") if obs else None
    return "— (not observed)" if not e else f"{e[0] / 1000:.1f}–{e[1] / 1000:.1f} µs"


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
    res.update(analyse_overhead(over, catch))
    return res


def analyse_overhead(over: dict, one: dict) -> dict:
    """Target 3, the dispatch overhead: the 100-module run against a 1-module run (catch-up)."""
    res = {}
    n = len(over["modules"])
    ex = over["dispatcher"]["exec_ns"]
    res["overhead_mean"] = ex["mean"] / n
    res["overhead_p50"] = ex["p50"] / n
    res["overhead_marginal"] = (ex["mean"] - one["dispatcher"]["exec_ns"]["mean"]) / max(1, n - 1)
    means = [m["exec_ns"]["mean"] for m in over["modules"]]
    p50s = [m["exec_ns"]["p50"] for m in over["modules"]]
    res["module_exec_mean"] = {"min": min(means), "mean": sum(means) / n, "max": max(means)}
    res["module_exec_p50"] = {"min": min(p50s), "mean": sum(p50s) / n, "max": max(p50s)}
    res["t3"] = res["overhead_mean"] <= OVERHEAD_TARGET_NS
    return res


def overhead_target_row(over: dict, res: dict) -> str:
    n = len(over["modules"])
    return (
        f"| dispatch overhead ≤ {OVERHEAD_TARGET_NS:.0f} ns per empty thread module ({n}-module set) | "
        f"slot work mean {over['dispatcher']['exec_ns']['mean']:.0f} ns / {n} = "
        f"{res['overhead_mean']:.1f} ns (p50: {res['overhead_p50']:.1f} ns) | {verdict(res['t3'])} |"
    )


def render_overhead(over: dict, one: dict, res: dict, one_name: str = "catch-up run") -> list[str]:
    """The section "Dispatch overhead": the 100-module run's slot work per module."""
    L: list[str] = []
    w = L.append
    n = len(over["modules"])
    w(f"## Dispatch overhead ({n} empty thread modules at {over['basic_period_ns'] / 1000:g} µs)")
    w("")
    ex = over["dispatcher"]["exec_ns"]
    me, mp = res["module_exec_mean"], res["module_exec_p50"]
    w("| figure | ns |")
    w("| --- | ---: |")
    w(
        f"| slot work (dispatcher `exec_ns`) mean / p50 / p99 / max | {ex['mean']:.0f} / {ex['p50']:.0f} / "
        f"{ex['p99']:.0f} / {ex['max']:.0f} |"
    )
    w(f"| **per module: slot work mean / {n}** | **{res['overhead_mean']:.1f}** |")
    w(f"| per module: slot work p50 / {n} | {res['overhead_p50']:.1f} |")
    one_ex = one["dispatcher"]["exec_ns"]
    w(
        f"| for comparison: slot work of the 1-module set ({one_name}), mean / p50 | {one_ex['mean']:.0f} / {one_ex['p50']:.0f} |"
    )
    w(
        f"| marginal cost of a module: (slot work mean, {n} modules − 1 module) / {n - 1} | {res['overhead_marginal']:.1f} |"
    )
    w(
        f"| per-module `exec_ns` mean, min / average / max over the modules | {me['min']:.0f} / {me['mean']:.0f} / {me['max']:.0f} |"
    )
    w(
        f"| per-module `exec_ns` p50, min / average / max over the modules | {mp['min']:.0f} / {mp['mean']:.0f} / {mp['max']:.0f} |"
    )
    w(
        f"| slots: runs / missed / overruns / skipped | {over['dispatcher']['runs']} / {over['dispatcher']['missed']} / "
        f"{over['dispatcher']['overruns']} / {over['dispatcher']['skipped']} |"
    )
    w("")
    w(
        "The slot work is measured by irpd from its wake-up to the end of the last module of the slot, so it "
        "includes everything the dispatcher does per module: Eq. (1)'s run, a clock read, the call to `run()` "
        "(empty here), the run's sample (jitter, latency, execution time) stored into the executor's sample "
        "ring, which irpd's stats thread folds into the module's histograms and run count on another CPU "
        "(docs/scheduler.md), and the counters. A module's own `exec_ns` is measured from the end of the "
        "previous module, so it too includes that bookkeeping, not only `run()`. The mean includes any stall "
        "of the machine during a slot; the p50 does not."
    )
    w("")
    return L


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
    w(overhead_target_row(over, res))
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
    L.extend(render_overhead(over, catch, res))
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
        ("load average at the end", info.get("loadavg_end", "—")),
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


PROCESS_TARGET_ROW = "| process module wake-up p99 ≤"


def process_target_row(a, wake: dict) -> str:
    """The process target's row of the target table."""
    pw, tw = wake["process"]["wake"], wake["thread"]["wake"]
    return (
        f"{PROCESS_TARGET_ROW} {PROC_P99_RATIO_TARGET:g}× thread module's, same run, "
        f"{a.period_ns / 1000:g} µs | {us(pw.get('p99'))} µs / {us(tw.get('p99'))} µs = "
        f"{fmt_ratio(wake['ratio_p99'])} (signal-based wake-up: {us(wake['signal']['wake'].get('p99'))} µs) | "
        f"{verdict(wake['target'])} |"
    )


def replace_process_section(
    a, report: str, section: str, wake: dict, info: dict, commands: list[str], started: str
) -> str:
    """`run_bench.py --only process`: the process wake-up section and the process target's row of an
    existing report replaced by this run's, the section saying when and how it was measured."""
    start = report.find("\n## Process module wake-up")
    end = report.find("\n## ", start + 1)
    if start < 0 or end < 0:
        raise BenchError("--only process: the report has no process wake-up section to replace (run it whole)")
    said = (
        f"This section and the process target's row come from a later run of this part alone "
        f"(`run_bench.py --only process`, {started}, source `{info['git']}`, load average "
        f"{info['loadavg_start'].split(' ')[0]} at its start and {info.get('loadavg_end', '—').split(' ')[0]} at its "
        "end); the rest of the file is from the whole run the Machine section describes. Its commands:"
    )
    shown = "\n".join(c.replace(str(REPO) + "/", "") for c in commands)
    report = report[: start + 1] + section.rstrip("\n") + f"\n\n{said}\n\n```sh\n{shown}\n```\n" + report[end:]
    lines = report.split("\n")
    rows = [i for i, line in enumerate(lines) if line.startswith(PROCESS_TARGET_ROW)]
    if not rows:
        raise BenchError("--only process: the report's target table has no process row to replace")
    lines[rows[0]] = process_target_row(a, wake)
    return "\n".join(lines)


def add_targets_and_runs(a, report: str, wake: dict, sporadic: dict) -> str:
    """Adds this run's process and sporadic targets to the report's target table, and says in its
    opening paragraph what ran after the 100-module set."""
    lines = report.split("\n")
    for i, line in enumerate(lines):
        if line.startswith("| dispatch overhead ≤"):
            ti = sporadic["thread"]["info"]
            lines[i + 1 : i + 1] = [
                process_target_row(a, wake),
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

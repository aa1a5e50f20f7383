"""release_variants.py -- the alternatives to irpd's wait for a process module's done word
(tests/bench/release_variants.cpp, one mode per program), run in the rounds of the process wake-up
comparison (process_wakeup.py) so that each is compared with irpd's thread module of the same run;
and their table in the report.
"""

from __future__ import annotations

from pathlib import Path

from .common import PROC_P99_RATIO_TARGET, fmt_ratio, quote, ratio, run_checked, two_process_cmd, us
from .irpd_stats import bench_hist, parse_bench_output

# mode -> what it is, for the table (release_variants.cpp says how each is made)
MODES = {
    "bounded": "FUTEX_WAIT with a relative timeout (irpd's wait before issue 28)",
    "bitset": "FUTEX_WAIT_BITSET with the absolute end of the period (irpd's wait for done now)",
    "unbounded": "FUTEX_WAIT without a timeout, the bound left to a watchdog thread (irpd's wait until its "
    "looks were found to delay the other CPU's timers: docs/process-modules.md)",
    "spin": "spin 2 µs on the done word, then as bounded",
    "above": "the process one priority above the dispatcher, then as bounded",
    "yield": "the process at the dispatcher's priority, sched_yield() after the wake, then as bounded",
    "timer": "the process first asleep until the due time by itself (FUTEX_WAIT_BITSET), the FUTEX_WAKE "
    "left out when that timer has expired, then as unbounded (irpd's release now)",
    "timer_wake": "as timer, with the FUTEX_WAKE made at every release",
    "timer_spin": "as timer, the process's timer 2 µs before the due time, then a spin on the release word "
    "(at most until 20 µs past the due time) instead of a sleep",
    "prearmed": "the process one priority above the dispatcher and asleep until the due time by itself; each "
    "release made a period ahead, once the last is done (no FUTEX_WAKE): the process's own timer starts it "
    "before the dispatcher (release → done not measured: the release is made a period ahead)",
}
PROGRAMS = tuple("variant_" + m for m in MODES)


def variant_programs(spec: str) -> tuple[str, ...]:
    """The programs of --proc-variants: 'all', 'none' or modes separated by commas."""
    if spec == "all":
        return PROGRAMS
    if spec == "none":
        return ()
    modes = [m.strip() for m in spec.split(",") if m.strip()]
    unknown = [m for m in modes if m not in MODES]
    if unknown:
        raise ValueError(f"--proc-variants: no mode {', '.join(unknown)}; the modes: {', '.join(MODES)}, or all, none")
    return tuple("variant_" + m for m in modes)


def run_variant(a, bench: Path, program: str, seconds: int, r: int, commands: list[str], add) -> dict:
    """Runs one mode for `seconds`; hands its histograms and counters to add(program, key, value);
    returns its wake-up histogram."""
    mode = program.removeprefix("variant_")
    cmd = two_process_cmd(bench / "release_variants", a, seconds, "--mode", mode)
    commands.append(quote(cmd))
    p = run_checked(cmd, f"release_variants {mode} (round {r}, {seconds} s)", seconds + 60)
    hs, info = parse_bench_output(p.stdout, f"release_variants {mode} (round {r})")
    wake = bench_hist(hs, "variant_wake", "release_variants")
    add(program, "wake", wake)
    add(program, "dispatcher", bench_hist(hs, "variant_dispatcher", "release_variants"))
    add(program, "exec", bench_hist(hs, "variant_exec", "release_variants"))
    di = info.get("variant_dispatcher", {})
    for c in ("releases", "missed", "skipped", "overruns", "not_ready"):
        add(program, c, di.get(c, 0))
    add(program, "realtime", bool(di.get("realtime")) and bool(info.get("variant_wake", {}).get("realtime")))
    return wake


def render_variants(a, w: dict) -> str:
    t = w["thread"]
    tw = t["wake"]
    L: list[str] = []
    add = L.append
    add("### The alternatives, measured in the same rounds")
    add("")
    add(
        "`tests/bench/release_variants.cpp` makes irpd's handshake (a release word + 1 and FUTEX_WAKE; the process "
        "stores its done word and FUTEX_WAKEs) between a dispatcher process at SCHED_FIFO "
        f"{a.rt_priority} on the grid and a worker process on the same CPU, and awaits the done word in one way per "
        "mode. Each mode ran in every round beside irpd's thread and process modules above; the ratio is the "
        f"mode's wake-up p99 over irpd's thread module's ({us(tw.get('p99'))} µs), the target "
        f"≤ {PROC_P99_RATIO_TARGET:g}×. Hand-over: the mode's wake-up p50 − its dispatcher's wake-up p50."
    )
    add("")
    add(
        "| mode | wake-up p50 / p99 / p99.9 / max (µs) | p99 / thread p99 | hand-over p50 (µs) | "
        "release → done p50 / p99 (µs) | releases / not done in the period / not ready |"
    )
    add("| --- | ---: | ---: | ---: | ---: | ---: |")
    rows = [("irpd process module (this build)", w["process"], "process")]
    rows += [
        (f"`{p.removeprefix('variant_')}`: {MODES[p.removeprefix('variant_')]}", w[p], p) for p in PROGRAMS if p in w
    ]
    for title, v, key in rows:
        vw = v["wake"]
        if key == "process":
            counts = f"{v['module_runs']} / {v['module_overruns']} / {v['module_missed']}"
        else:
            counts = f"{v['releases']} / {v['overruns']} / {v['not_ready']}"
        add(
            f"| {title} | "
            + " / ".join(us(vw.get(k)) for k in ("p50", "p99", "p999", "max"))
            + f" | {fmt_ratio(ratio(vw.get('p99'), tw.get('p99')))} | "
            + f"{us(vw.get('p50', 0) - v['dispatcher'].get('p50', 0))} | "
            + f"{us(v['exec'].get('p50'))} / {us(v['exec'].get('p99'))} | {counts} |"
        )
    add("")

    def handover(key: str) -> str:
        if key not in w:
            return "not run"
        return us(w[key]["wake"].get("p50", 0) - w[key]["dispatcher"].get("p50", 0)) + " µs"

    def wake99(key: str):
        return w[key]["wake"].get("p99") if key in w else None

    spin99, timer99 = wake99("variant_timer_spin"), wake99("variant_timer")
    spin_better = spin99 is not None and timer99 is not None and spin99 < timer99
    spin_said = f"its wake-up p99 is {fmt_ratio(ratio(spin99, timer99))} `timer`'s here, " + (
        "better, but at the price of a spin on the dispatcher's CPU each period" if spin_better else "no better"
    )

    add(
        "irpd now releases a process that leads its slot ahead, as `prearmed` does (docs/process-modules.md), "
        "but when its dispatcher would go to sleep until that slot, not a whole period ahead (a release made "
        "then would outrun an online change or a stop), and its dispatcher then sleeps on the process's done "
        "word rather than on a timer of its own, so that at the due time only the process's timer fires; the "
        "process stays one priority below its dispatcher. The release stays irpd's decision: until the process "
        "has claimed it, irpd may take it back (a fault stopped the set) or make it a release now (the process "
        "did not start within 50 µs of its due time). Its hand-over here: "
        f"{handover('process')} at p50 (the process's wake-up p50 − its dispatcher's, which is taken as the "
        "process's start when the process ran first). Before it, irpd used `timer` (hand-over "
        f"{handover('variant_timer')} here; `timer_wake`, the same with the FUTEX_WAKE: "
        f"{handover('variant_timer_wake')}; `unbounded`, irpd's wait for done before that: "
        f"{handover('variant_unbounded')}). `timer_spin` keeps the CPU busy at the "
        f"due time instead of idle: {spin_said}; irpd does not spin. `above` and `yield` switch to "
        "the process before the dispatcher blocks (the wake itself switches to it, or the yield does), but a "
        "process above its dispatcher that then spins would hold the dispatcher's CPU; `prearmed` needs its "
        "worker above the dispatcher because both timers fire at the due time. `spin` cannot help on one "
        "CPU: the process cannot run while its dispatcher spins. Considered and not measured: a futex per "
        "process (irpd already waits on each process's own words, in its own slot); a periodic timer armed once "
        "on the grid so that the wait's timeout never reprograms the timer device (Linux re-arms a periodic "
        "timerfd or POSIX timer only when it is read or its signal taken: a syscall per period again); "
        "FUTEX_WAKE_OP (it wakes a second word in the same call; a release has one word to wake)."
    )
    add("")
    return "\n".join(L)

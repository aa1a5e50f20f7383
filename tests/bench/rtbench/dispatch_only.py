"""dispatch_only.py -- `run_bench.py --only dispatch`: the dispatch overhead alone, optionally against
another build's irpd in the same run, and its part of docs/benchmark.md rewritten in place.

Runs the 1-module set (catch-up) for the marginal cost, then the 100-module set in --dispatch-rounds
rounds, alternating with the baseline irpd (--baseline-build-dir) when given, then each under perf
(dispatch_profile.py).  In the report it replaces the target row "dispatch overhead ≤ …" and the
section "## Dispatch overhead" up to the next "## " heading; everything else stays as the last full
run wrote it.
"""

from __future__ import annotations

import datetime as dt
import time
from pathlib import Path

from .common import REPO, BenchError, log
from .dispatch_profile import PARTS, render_profile, run_profile
from .irpd_runs import run_irpd
from .machine import read_text
from .report import analyse_overhead, overhead_target_row, render_overhead


def merge_overhead(docs: list[dict]) -> dict:
    """The rounds of one irpd as one run: slot-weighted means, and the round with the median mean
    slot work for the percentiles (histograms are not merged here)."""
    docs = sorted(docs, key=lambda d: d["dispatcher"]["exec_ns"]["mean"])
    mid = dict(docs[len(docs) // 2])
    runs = sum(d["dispatcher"]["runs"] for d in docs)
    mid["dispatcher"] = dict(mid["dispatcher"])
    mid["dispatcher"]["exec_ns"] = dict(mid["dispatcher"]["exec_ns"])
    mid["dispatcher"]["exec_ns"]["mean"] = (
        sum(d["dispatcher"]["exec_ns"]["mean"] * d["dispatcher"]["runs"] for d in docs) / runs
    )
    for key in ("runs", "missed", "overruns", "skipped"):
        mid["dispatcher"][key] = sum(d["dispatcher"][key] for d in docs)
    return mid


def run_dispatch_only(a, irpd: Path, one: Path, many: Path, work: Path, commands: list[str]) -> dict:
    base = a.baseline_build_dir / "bin" / "irpd" if a.baseline_build_dir else None
    if base and not base.exists():
        raise BenchError(f"{base} is missing: build the baseline's irpd first")
    who = [("this", irpd)] + ([("baseline", base)] if base else [])
    started = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    load_start = read_text("/proc/loadavg")
    t0 = time.monotonic()
    one_doc = run_irpd(a, irpd, one, a.overhead_duration, None, "dispatch-one", work, commands)
    rounds: dict[str, list[dict]] = {name: [] for name, _ in who}
    for r in range(1, a.dispatch_rounds + 1):
        order = who if r % 2 else list(reversed(who))
        for name, binary in order:
            rounds[name].append(
                run_irpd(a, binary, many, a.overhead_duration, None, f"dispatch-{name}-r{r}", work, commands)
            )
    profiles = {name: run_profile(a, binary, many, work, commands, tag=f"profile-{name}") for name, binary in who}
    out = {"started": started, "load_start": load_start, "load_end": read_text("/proc/loadavg"), "one": one_doc}
    out["took_s"] = time.monotonic() - t0
    out["runs"] = {}
    for name, docs in rounds.items():
        over = merge_overhead(docs)
        out["runs"][name] = {
            "over": over,
            "res": analyse_overhead(over, one_doc),
            "rounds": [analyse_overhead(d, one_doc) for d in docs],
            "profile": profiles.get(name),
        }
    return out


def render_dispatch_only(a, d: dict, commands: list[str]) -> tuple[str, list[str]]:
    """The target row and the section's lines."""
    mine = d["runs"]["this"]
    L = render_overhead(mine["over"], d["one"], mine["res"], one_name="its own run, catch-up")
    L += [
        f"Measured by `.venv/bin/python tests/bench/run_bench.py {' '.join(a.shown_args)}`, run {d['started']} "
        f"(took {d['took_s'] / 60:.1f} min, load average {d['load_start'].split()[0]} at its start and "
        f"{d['load_end'].split()[0]} at its end); the rest of this file is from the last full run. The "
        f"{len(mine['over']['modules'])}-module set ran {a.dispatch_rounds} times {a.overhead_duration} s; the "
        "table above merges the rounds (the mean over all slots; p50 and above from the round with the median mean).",
        "",
    ]
    if "baseline" in d["runs"]:
        base = d["runs"]["baseline"]
        L += [
            f"Against the baseline (`{a.baseline_build_dir}`'s irpd, {a.baseline_label}), in alternating rounds of the "
            "same run, the same set and CPU:",
            "",
            "| round | baseline: per module mean / p50 (ns) | this build: per module mean / p50 (ns) |",
            "| --- | ---: | ---: |",
        ]
        for i, (b, m) in enumerate(zip(base["rounds"], mine["rounds"], strict=True), 1):
            L.append(
                f"| {i} | {b['overhead_mean']:.1f} / {b['overhead_p50']:.1f} | {m['overhead_mean']:.1f} / "
                f"{m['overhead_p50']:.1f} |"
            )
        L.append(
            f"| **all rounds** | **{base['res']['overhead_mean']:.1f}** / {base['res']['overhead_p50']:.1f} | "
            f"**{mine['res']['overhead_mean']:.1f}** / {mine['res']['overhead_p50']:.1f} |"
        )
        L.append("")
    L += render_profile(a, mine["profile"]).split("\n")
    if "baseline" in d["runs"] and mine["profile"] and base["profile"]:
        bp, mp = base["profile"]["parts"], mine["profile"]["parts"]
        L += [
            "The baseline under perf in the same run (ns per module, each part's share × that run's slot work "
            f"mean / {mine['profile']['modules']}):",
            "",
            "| part | baseline | this build |",
            "| --- | ---: | ---: |",
        ]
        L += [f"| {name} | {bp[name]['ns']:.1f} | {mp[name]['ns']:.1f} |" for name, _ in PARTS]
        L.append(
            f"| **all** | **{base['profile']['per_module_ns']:.1f}** | **{mine['profile']['per_module_ns']:.1f}** |"
        )
        both = {k: p["statistics"]["ns"] + p["loop"]["ns"] for k, p in (("base", bp), ("mine", mp))}
        L += [
            "",
            "Statistics and loop are best compared together: the arguments of a histogram update or of a sample "
            "(Eq. (1)'s jitter, the latency, the tagged record word) are computed in executor.cpp and count as "
            "loop, and a cpu-clock sample lands on the instructions after a stalled store rather than on it: "
            f"{both['base']:.1f} ns per module in the baseline, {both['mine']:.1f} ns in this build.",
        ]
        L.append("")
    L += ["The commands of this part:", "", "```sh", *(c.replace(str(REPO) + "/", "") for c in commands), "```", ""]
    return overhead_target_row(mine["over"], mine["res"]), L


def splice(report: str, row: str, section: list[str]) -> str:
    """The report with its dispatch target row and its "## Dispatch overhead" section replaced."""
    lines = report.split("\n")
    rows = [i for i, line in enumerate(lines) if line.startswith("| dispatch overhead ≤")]
    heads = [i for i, line in enumerate(lines) if line.startswith("## Dispatch overhead")]
    if len(rows) != 1 or len(heads) != 1:
        raise BenchError("the report has no single dispatch target row and section: run the whole bench first")
    lines[rows[0]] = row
    start = heads[0]
    end = next((i for i in range(start + 1, len(lines)) if lines[i].startswith("## ")), len(lines))
    lines[start:end] = section
    return "\n".join(lines)


def write_dispatch_only(a, d: dict, commands: list[str]) -> None:
    row, section = render_dispatch_only(a, d, commands)
    print("\n".join([row, "", *section]))
    if a.out == "-":
        return
    out = Path(a.out)
    if not out.exists():
        raise BenchError(f"{out} does not exist: --only dispatch rewrites a part of a full run's report")
    out.write_text(splice(out.read_text(), row, section))
    log(f"rewrote the dispatch part of {out.relative_to(REPO) if out.is_relative_to(REPO) else out}")

"""st_bench.py -- what Structured Text costs (issue 29, item 11):

1. the paper's cell with its PLC in ST (config/sets/plc-robot-st) against the same cell with its PLC
   in C++ (config/sets/plc-robot): the PLC module's execution time per period (irpd's exec_ns), both
   cells cycling (Enable, CycleMode 1, Start), in rounds of the same length, each round one run of
   each cell (which goes first alternates); each round's ratio is the ST PLC's mean over the C++
   PLC's, and the figure is the median of the rounds' ratios, with their min and max (target <= 1.2:
   a quiet machine's rounds still differ by more than 0.1, so a change of 0.1 shows only in the
   median of many rounds: 10 by default with --only cell);
2. generated programs of 100, 1,000 and 10,000 lines: `stc check`, `stc build` (check, layout, C++,
   compile) and their activation into a running irpd (`load`, laid out against the running layout:
   online), each timed; and the 10,000-line program's execution time per period.

Wall times on this machine, with the load average before and after each part; nothing is asserted.

    .venv/bin/python tests/bench/st_bench.py [--seconds 10] [--rounds N] [--only cell|lines] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))
from live_processes import BUILD, ROOT, copy_cell, dispatching, start_irpd, stop, wait_until  # noqa: E402

sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.irpd.client import IrpdClient  # noqa: E402

STC = ROOT / "st" / "stc"
CELL_GLB = ROOT / "config" / "sets" / "plc-robot" / "cell.glb"
ST_MAIN = ROOT / "config" / "sets" / "plc-robot-st" / "main.st"
LINES = (100, 1000, 10000)


def load() -> str:
    return " / ".join(f"{x:.2f}" for x in os.getloadavg())


def stc(*args: str) -> float:
    """Runs stc; its wall time in s (a failure stops the benchmark with stc's message)."""
    t0 = time.monotonic()
    r = subprocess.run([sys.executable, str(STC), *args], capture_output=True, text=True)
    took = time.monotonic() - t0
    if r.returncode != 0:
        raise SystemExit(f"st_bench: stc {args[0]} failed:\n{r.stderr[-3000:]}")
    return took


def exec_figures(stats_json: Path, module: str) -> dict:
    doc = json.loads(stats_json.read_text())
    (m,) = [m for m in doc["modules"] if m["name"] == module]
    return {"runs": m["runs"], **{k: m["exec_ns"][k] for k in ("mean", "p50", "p99", "max")}}


# ---- 1. the cell, C++ against ST ----------------------------------------------------------------
def cell_set(folder: Path, st: bool) -> Path:
    """The plc-robot cell copied (its drive simulator on a free port); with st, its PLC main.so is
    compiled from main.st instead, the other modules kept (as tests/python/cell/test_plc_robot_st.py)."""
    xml, _ = copy_cell(folder)
    if not st:
        return xml
    hand = xml.rename(xml.with_name("hand.xml"))
    stc(
        "build", "-o", str(folder), "--glb", str(CELL_GLB), "--set-layout", str(BUILD / "sets" / "plc-robot" / "layout.json"),
        "--module-xml", str(hand), str(ST_MAIN),
    )  # fmt: skip
    return folder / "module.xml"


def run_cell(xml: Path, tmp: Path, seconds: float, name: str) -> dict:
    sock, stats = tmp / f"{name}.sock", tmp / f"{name}.stats.json"
    irpd = start_irpd(
        sock, xml, f"st-bench-{name}-{os.getpid()}", "--duration", str(seconds + 15), "--stats-json", str(stats)
    )
    control = IrpdClient(str(sock), timeout_s=30)
    try:
        wait_until(lambda: dispatching(control), 30)
        for path, value in (("PLC_IN.Enable", 1), ("PLC_IN.CycleMode", 1), ("PLC_IN.Start", 1)):
            control.request("write", path=f"PLC_ROBOT.{path}", value=value)
        wait_until(lambda: irpd.poll() is not None, seconds + 60, 0.2)  # --duration ends it, stats written
    finally:
        control.close()
        stop(irpd)
    return exec_figures(stats, "main")


def bench_cell(a, tmp: Path) -> dict:
    sets = {"cpp": cell_set(tmp / "cpp", st=False), "st": cell_set(tmp / "st", st=True)}
    rounds = []
    for r in range(a.rounds):
        order = ("cpp", "st") if r % 2 == 0 else ("st", "cpp")
        rounds.append({k: run_cell(sets[k], tmp, a.seconds, f"{k}-{r}") for k in order})
    return cell_summary(rounds)


def cell_summary(rounds: list[dict]) -> dict:
    """The rounds' figures: each round's ST/C++ ratio of the mean (and of the p50) exec_ns, their
    median, min and max; the means over the rounds."""
    ratios = [x["st"]["mean"] / x["cpp"]["mean"] for x in rounds]
    ratios_p50 = [x["st"]["p50"] / x["cpp"]["p50"] for x in rounds]
    return {
        "rounds": rounds,
        "ratios": ratios,
        "ratio_median": statistics.median(ratios),
        "ratio_min": min(ratios),
        "ratio_max": max(ratios),
        "ratio_p50_median": statistics.median(ratios_p50),
        "mean_ns": {k: statistics.fmean(x[k]["mean"] for x in rounds) for k in ("cpp", "st")},
    }


# ---- 2. generated programs ----------------------------------------------------------------------
def generated(lines: int) -> str:
    """A PROGRAM of about `lines` lines, one statement a line, of what PLC code is made of: integer and
    REAL arithmetic, comparisons, IF, timers and counters, bit logic."""
    n = max(1, lines // 10)  # ten statements per group of variables
    decls = [f"  a{i}, b{i} : DINT; r{i} : REAL; x{i} : BOOL; t{i} : TON; c{i} : CTU;" for i in range(n)]
    body = []
    for i in range(n):
        body += [
            f"a{i} := a{i} + {i % 7 + 1};",
            f"IF a{i} > {1000 + i} THEN a{i} := 0; END_IF;",
            f"b{i} := (a{i} * 3 + b{i}) MOD 1000;",
            f"r{i} := r{i} * 0.5 + DINT_TO_REAL(b{i});",
            f"x{i} := (a{i} > b{i}) XOR x{i};",
            f"t{i}(IN := NOT t{i}.Q, PT := T#20ms);",
            f"c{i}(CU := t{i}.Q, R := c{i}.CV > 100, PV := 50);",
            f"IF c{i}.Q THEN b{i} := b{i} + 1; ELSE b{i} := b{i} - 1; END_IF;",
            f"a{i} := MAX(a{i}, LIMIT(0, b{i}, 500));",
            f"x{i} := x{i} AND (r{i} < 1.0E6);",
        ]
    return (
        "PROGRAM Big\nVAR\n" + "\n".join(decls) + "\nEND_VAR\n" + "\n".join(body) + "\nEND_PROGRAM\n"
        "CONFIGURATION Bench\n  RESOURCE Cpu ON PLC\n    TASK Fast (INTERVAL := T#1ms, PRIORITY := 1);\n"
        "    PROGRAM big WITH Fast : Big;\n  END_RESOURCE\nEND_CONFIGURATION\n"
    )


def bench_lines(a, tmp: Path) -> dict:
    base = tmp / "base"
    base.mkdir()
    (base / "base.st").write_text("PROGRAM Idle\nVAR n : DINT; END_VAR\nn := n + 1;\nEND_PROGRAM\n")
    stc("build", "-o", str(base), str(base / "base.st"))
    out = {}
    for lines in LINES:
        folder = tmp / f"lines-{lines}"
        folder.mkdir()
        source = folder / "big.st"
        source.write_text(generated(lines))
        counted = source.read_text().count("\n")
        check_s = stc("check", str(source))
        # activation: irpd runs the small base set; the big one is laid out against its layout and loaded online
        sock, stats = folder / "irpd.sock", folder / "stats.json"
        irpd = start_irpd(
            sock, base / "module.xml", f"st-bench-lines-{lines}-{os.getpid()}", "--stats-json", str(stats),
            "--var-headroom", "8M",  # 10,000 lines: 6,000 variables, a lock each
        )  # fmt: skip
        control = IrpdClient(str(sock), timeout_s=120)
        try:
            wait_until(lambda c=control: dispatching(c), 30)
            build_s = stc("build", "-o", str(folder), "--previous", str(base / "layout.json"), str(source))
            t0 = time.monotonic()
            control.request("load", config=str(folder / "module.xml"))  # online, or an error
            load_s = time.monotonic() - t0
            time.sleep(a.seconds if lines == LINES[-1] else 1)
        finally:
            control.close()
            stop(irpd)
        row = {"lines": counted, "check_s": check_s, "build_s": build_s, "load_s": load_s}
        row["check_build_load_s"] = check_s + build_s + load_s
        if stats.exists():
            row["exec"] = exec_figures(stats, "big")
        out[lines] = row
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=10, help="each cell run, and the 10,000-line program's run")
    ap.add_argument("--rounds", type=int, help="the cell's rounds (default 10 with --only cell, else 3)")
    ap.add_argument("--only", choices=("cell", "lines"))
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()
    if a.rounds is None:
        a.rounds = 10 if a.only == "cell" else 3
    if a.rounds < 1:
        ap.error("--rounds must be at least 1")
    result: dict = {"machine": {"cpus": os.cpu_count(), "load_start": load()}}
    with tempfile.TemporaryDirectory(prefix="st-bench-") as tmp:
        if a.only in (None, "cell"):
            result["cell"] = bench_cell(a, Path(tmp))
            c = result["cell"]
            print(
                f"cell: PLC exec mean C++ {c['mean_ns']['cpp'] / 1e3:.2f} us, ST {c['mean_ns']['st'] / 1e3:.2f} us; "
                f"ST/C++ median of {a.rounds} rounds {c['ratio_median']:.3f} (min {c['ratio_min']:.3f}, "
                f"max {c['ratio_max']:.3f}; of the p50s {c['ratio_p50_median']:.3f}); "
                f"rounds {' '.join(f'{r:.3f}' for r in c['ratios'])}; load average {load()}",
                flush=True,
            )
        if a.only in (None, "lines"):
            result["lines"] = bench_lines(a, Path(tmp))
            for row in result["lines"].values():
                extra = f", exec mean {row['exec']['mean'] / 1e3:.1f} us" if "exec" in row else ""
                print(
                    f"{row['lines']} lines: check {row['check_s']:.2f} s, build {row['build_s']:.2f} s, "
                    f"online activation {row['load_s']:.2f} s{extra}; load average {load()}",
                    flush=True,
                )
    result["machine"]["load_end"] = load()
    if a.json:
        a.json.write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

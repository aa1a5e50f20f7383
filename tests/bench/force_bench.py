#!/usr/bin/env python3
"""force_bench.py -- the cost of forcing (docs/forcing.md): irpd's slot work per forced variable per
period (ns) and its wake-up p99 with --forces forces against none, in alternating rounds of the same
run on the same set (issue 30's target: the p99 ratio at most 1.05).

    .venv/bin/python tests/bench/force_bench.py [--rounds R] [--round-s S] [--forces N] [--modules M]
                                                [--period-ns N] [--cpu N] [--rt-priority P]
                                                [--build-dir DIR] [--no-build] [--json FILE]

The set: --modules empty thread modules (tests/bench/modules/empty.cpp, as run_bench.py's dispatch
overhead set) at --period-ns on a layout of --forces + 100 uint32 variables (glbc, generated here).
Each round runs irpd (`--duration`, `--stats-json`, a control socket) once without forces and once
with --forces of those variables forced right after its dispatchers started (the order alternating
between rounds); a round's figures are its --stats-json: the main dispatcher's wake-up latency p99
(`latency_ns`) and its mean slot work (`exec_ns`).  The modules write none of the forced variables,
so each application is the compare alone, the cost a force adds to every period; a write happens
only after a module wrote the variable.  The cost per forced variable per period is the difference
of the mean slot work divided by --forces; the forces set at the start of a round leave its first
~0.1 s unforced (against --round-s of run).  Run as root for SCHED_FIFO (else the figures are not
real-time, and it says so).  Prints the table and writes the raw figures with --json.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from rtbench.common import REPO, BenchError, log, quote, restore_affinity
from rtbench.irpd_runs import build, module_xml

sys.path.insert(0, str(REPO / "agent"))
from indurop_agent.irpd.client import IrpdClient, IrpdRefused, IrpdUnavailable  # noqa: E402

TARGETS = ["irpd", "empty"]
RATIO_TARGET = 1.05


def make_set(work: Path, a, count: int | None = None) -> Path:
    """The empty modules on a layout of `count` (default a.forces + 100) uint32 variables fb.v000...;
    the module.xml's path (monitor_bench.py's set too)."""
    names = [f"v{i:03d}" for i in range(a.forces + 100 if count is None else count)]
    glb = work / "forces.glb"
    glb.write_text(
        "// force_bench.py: variables to force\nnamespace fb;\n" + "".join(f"uint32_t {n};\n" for n in names)
    )
    subprocess.run([sys.executable, str(REPO / "glb" / "glbc"), str(glb), "-o", str(work)], check=True,
                   stdout=subprocess.DEVNULL)  # fmt: skip
    xml = module_xml(a.modules, a.period_ns).replace("<root>", f"<root>\n  <layout>{work / 'layout.json'}</layout>", 1)
    (work / "empty.so").unlink(missing_ok=True)
    (work / "empty.so").symlink_to((a.build_dir / "bench" / "empty.so").resolve())
    (work / "module.xml").write_text(xml)
    return work / "module.xml"


def run_round(a, irpd: Path, xml: Path, work: Path, tag: str, forces: int) -> dict:
    """irpd on the set for a.round_s seconds, `forces` variables forced once it dispatches."""
    out, sock = work / f"irpd-{tag}.json", work / f"irpd-{tag}.sock"
    cmd = [str(irpd), "--config", str(xml), "--duration", str(a.round_s), "--stats-json", str(out),
           "--cpu", str(a.cpu), "--rt-priority", str(a.rt_priority), "--instance", f"forcebench-{os.getpid()}-{tag}",
           "--control-socket", str(sock)]  # fmt: skip
    if a.period_ns < 50_000:
        cmd += ["--min-basic-period", str(a.period_ns)]
    log(f"irpd ({tag}, {forces} forces): {quote(cmd)}")
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=restore_affinity)
    try:
        client = IrpdClient(str(sock), timeout_s=10)
        deadline = time.monotonic() + 30
        while True:
            try:
                if client.request("status").get("running"):
                    break
            except (IrpdUnavailable, IrpdRefused, OSError):
                pass
            if time.monotonic() > deadline or proc.poll() is not None:
                proc.kill()
                raise BenchError(f"irpd ({tag}) did not start dispatching:\n{proc.communicate()[1][-2000:]}")
            time.sleep(0.02)
        for i in range(forces):
            client.request("force", path=f"fb.v{i:03d}", value=i + 1, by="force_bench")
        if forces and client.request("status")["forces"] != forces:
            raise BenchError(f"irpd ({tag}) does not hold the {forces} forces")
        client.close()
        stdout, stderr = proc.communicate(timeout=a.round_s + 120)
    except BaseException:
        proc.kill()
        proc.communicate()
        raise
    if proc.returncode != 0:
        raise BenchError(f"irpd ({tag}) exited with status {proc.returncode}:\n{stdout[-2000:]}{stderr[-2000:]}")
    doc = json.loads(out.read_text())
    if not doc.get("realtime"):
        log(f"WARNING: irpd ({tag}) did not run SCHED_FIFO (not root?); its figures are not real-time")
    d = doc["dispatcher"]
    return {"forces": forces, "p99_ns": d["latency_ns"]["p99"], "p50_ns": d["latency_ns"]["p50"],
            "exec_mean_ns": d["exec_ns"]["mean"], "runs": d["runs"], "missed": d["missed"],
            "realtime": doc.get("realtime")}  # fmt: skip


def parse(argv: list[str], doc: str, with_what: str, options) -> argparse.Namespace:
    """The options of an alternating-rounds bench on the empty modules' set (this one's and
    monitor_bench.py's): `with_what` names the second run of a round, `options(ap)` adds its own."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=6, help=f"rounds, each one run without and one {with_what} (6)")
    ap.add_argument("--round-s", type=int, default=10, help="seconds of each run (10)")
    options(ap)
    ap.add_argument("--modules", type=int, default=10, help="empty thread modules in the set (10)")
    ap.add_argument("--period-ns", type=int, default=100_000, help="basic period (100000)")
    ap.add_argument("--cpu", type=int, default=None, help="CPU of every run (default: the last one allowed)")
    ap.add_argument("--rt-priority", type=int, default=80)
    ap.add_argument("--build-dir", type=Path, default=REPO / "build-bench", help="CMake build directory (build-bench)")
    ap.add_argument("--no-build", action="store_true", help="use --build-dir as it is")
    ap.add_argument("--json", type=Path, default=None, help="also write every round's figures to this JSON file")
    a = ap.parse_args(argv)
    if a.cpu is None:
        a.cpu = max(os.sched_getaffinity(0))
    a.error = ap.error
    return a


def main(argv: list[str]) -> int:
    a = parse(
        argv,
        __doc__,
        "with forces",
        lambda ap: ap.add_argument(
            "--forces", type=int, default=100, help="variables forced in the runs with forces (100)"
        ),
    )
    if not 1 <= a.forces <= 256:
        a.error("--forces must be 1..256 (max_forces)")
    work = Path(os.environ.get("TMPDIR", "/tmp")) / f"force-bench-{os.getpid()}"
    work.mkdir(parents=True, exist_ok=True)
    try:
        if not a.no_build:
            build(a.build_dir, [], TARGETS)
        irpd = a.build_dir / "bin" / "irpd"
        xml = make_set(work, a)
        rounds = []
        for r in range(a.rounds):
            order = (0, a.forces) if r % 2 == 0 else (a.forces, 0)
            rounds.append({n: run_round(a, irpd, xml, work, f"r{r}-{n}", n) for n in order})
    except BenchError as e:
        print(f"force_bench: {e}", file=sys.stderr)
        return 1
    ratios = [r[a.forces]["p99_ns"] / r[0]["p99_ns"] for r in rounds if r[0]["p99_ns"]]
    costs = [(r[a.forces]["exec_mean_ns"] - r[0]["exec_mean_ns"]) / a.forces for r in rounds]
    print(
        f"| round | wake-up p99 without | with {a.forces} forces | ratio | slot work without | with | per force per period |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for i, r in enumerate(rounds):
        w, f = r[0], r[a.forces]
        print(f"| {i + 1} | {w['p99_ns'] / 1000:.2f} µs | {f['p99_ns'] / 1000:.2f} µs | "
              f"{f['p99_ns'] / w['p99_ns'] if w['p99_ns'] else float('nan'):.3f} | {w['exec_mean_ns']:.0f} ns | "
              f"{f['exec_mean_ns']:.0f} ns | {costs[i]:.1f} ns |")  # fmt: skip
    ratio = statistics.median(ratios) if ratios else float("nan")
    print(f"\nmedian of the rounds: wake-up p99 with {a.forces} forces ÷ without = {ratio:.3f} "
          f"(target ≤ {RATIO_TARGET}: {'met' if ratio <= RATIO_TARGET else 'NOT met'}); cost of forcing "
          f"{statistics.median(costs):.1f} ns per forced variable per period "
          f"({a.modules} modules, {a.modules + 2} application points a period)")  # fmt: skip
    if a.json:
        a.json.write_text(
            json.dumps(
                {
                    "args": {k: str(v) for k, v in vars(a).items() if not callable(v)},
                    "rounds": [{str(k): v for k, v in r.items()} for r in rounds],
                    "p99_ratio": ratio,
                    "ns_per_force": costs,
                },
                indent=1,
            )
        )
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

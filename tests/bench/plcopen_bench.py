"""plcopen_bench.py -- what a ladder program drawn in PLCopen XML costs (issue 31, item 7):

1. import + compile: a generated ladder program of 500 rungs (contacts in series into coils, set and
   reset coils, TON and CTU blocks with EN/ENO, each rung reading the coil of the one before) as a
   PLCopen XML 2.01 file, `stc check` (read, schema, translation, check) and `stc build` (the same,
   then layout, C++ and the compiler), each timed; the same logic written in ST timed beside it;
2. execution: the two programs run in irpd at 1 ms, in rounds of the same length (each round one run
   of each, which goes first alternating); each round's ratio is the LD program's mean exec_ns over
   the ST program's, the figure is the median of the rounds' ratios with their min and max (target
   <= 1.1).

The ladder is drawn with the kit that draws the cell's ladder (config/sets/plc-robot-ld/ladder.py)
and written by the project's exporter.  Wall times on this machine, with the load average before and
after each part; nothing is asserted.

    .venv/bin/python tests/bench/plcopen_bench.py [--rungs 500] [--seconds 10] [--rounds 6] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from st_bench import ROOT, STC, dispatching, exec_figures, load, start_irpd, stc, stop, wait_until  # noqa: E402

sys.path[:0] = [str(ROOT / "st"), str(ROOT / "plcopen"), str(ROOT / "config" / "sets" / "plc-robot-ld")]
from indurop_agent.irpd.client import IrpdClient  # noqa: E402
from ladder import Block, Coil, Contact, Drawing, Rung  # noqa: E402
from plcopen_export import export  # noqa: E402
from plcopen_import.read import q  # noqa: E402
from stc_compiler.parse import parse_text  # noqa: E402

CONFIGURATION = (
    "CONFIGURATION Bench\n  RESOURCE Cpu ON PLC\n    TASK Fast (INTERVAL := T#1ms, PRIORITY := 1);\n"
    "    PROGRAM big WITH Fast : Big;\n  END_RESOURCE\nEND_CONFIGURATION\n"
)


def rung(i: int) -> tuple[Rung, list[str], list[str]]:
    """Rung i: the drawing, its variables' declarations and the same logic in ST."""
    prev = f"y{i - 1}" if i else "osc.Q"
    kind = i % 5
    if kind == 0:  # two contacts in series, one negated, into a coil
        r = Rung(contacts=[Contact(prev), Contact(f"a{i}", negated=True)], coils=[Coil(f"y{i}")])
        return r, [f"y{i}, a{i} : BOOL;"], [f"y{i} := {prev} AND NOT a{i};"]
    if kind == 1:  # set and reset coils
        r = Rung(contacts=[Contact(prev)], coils=[Coil(f"y{i}", "set"), Coil(f"a{i}", "reset")])
        return r, [f"y{i}, a{i} : BOOL;"], [f"IF {prev} THEN y{i} := TRUE; a{i} := FALSE; END_IF;"]
    if kind == 2:  # an on-delay timer fed by a contact chain
        blk = Block("TON", f"t{i}", inputs={"IN": [Contact(prev)], "PT": "T#3ms"}, outputs={"Q": Coil(f"y{i}")})
        return Rung(block=blk), [f"y{i} : BOOL; t{i} : TON;"], [f"t{i}(IN := {prev}, PT := T#3ms);", f"y{i} := t{i}.Q;"]
    if kind == 3:  # a counter with its count out
        blk = Block(
            "CTU",
            f"c{i}",
            inputs={"CU": [Contact(prev)], "R": [Contact(f"a{i}")], "PV": "10"},
            outputs={"Q": Coil(f"y{i}"), "CV": f"n{i}"},
        )
        st = [f"c{i}(CU := {prev}, R := a{i}, PV := 10);", f"y{i} := c{i}.Q;", f"n{i} := c{i}.CV;"]
        return Rung(block=blk), [f"y{i}, a{i} : BOOL; c{i} : CTU; n{i} : INT;"], st
    # three contacts in series, into two coils, one negated
    r = Rung(contacts=[Contact(prev), Contact(f"a{i}"), Contact(f"b{i}", negated=True)], coils=[Coil(f"y{i}")])
    return r, [f"y{i} : BOOL; a{i} : BOOL := TRUE; b{i} : BOOL;"], [f"y{i} := {prev} AND a{i} AND NOT b{i};"]


def programs(rungs: int) -> tuple[bytes, str]:
    """The PLCopen XML file (the program drawn in LD) and the ST source of the same logic."""
    decls, body = ["osc : TON;"], ["osc(IN := NOT osc.Q, PT := T#5ms);"]
    drawing = Drawing()
    osc = Block("TON", "osc", inputs={"IN": [Contact("osc.Q", negated=True)], "PT": "T#5ms"})
    drawing.rung(Rung(block=osc))
    for i in range(rungs):
        r, d, s = rung(i)
        drawing.rung(r)
        decls += d
        body += s
    text = "PROGRAM Big\nVAR\n" + "\n".join(decls) + "\nEND_VAR\n" + "\n".join(body) + "\nEND_PROGRAM\n" + CONFIGURATION
    unit = parse_text("big.st", text)
    program = unit.pous[0]
    program.xml = pou = drawing.ld.makeelement(q("pou"), name=program.name, pouType="program")
    body_el = pou.makeelement(q("body"), {})
    pou.append(body_el)
    body_el.append(drawing.ld)
    return export([unit], {"big.st": text}, name="plcopen-bench"), text


def run(xml: Path, tmp: Path, seconds: float, name: str) -> dict:
    sock, stats = tmp / f"{name}.sock", tmp / f"{name}.stats.json"
    irpd = start_irpd(
        sock, xml, f"plcopen-bench-{name}-{os.getpid()}", "--duration", str(seconds), "--stats-json", str(stats)
    )
    control = IrpdClient(str(sock), timeout_s=30)
    try:
        wait_until(lambda: dispatching(control), 30)
        wait_until(lambda: irpd.poll() is not None, seconds + 60, 0.2)  # --duration ends it, stats written
    finally:
        control.close()
        stop(irpd)
    return exec_figures(stats, "big")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rungs", type=int, default=500)
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--rounds", type=int, default=6)
    p.add_argument("--json", type=Path)
    a = p.parse_args()
    if a.rounds < 1 or a.rungs < 1:
        p.error("--rounds and --rungs must be at least 1")
    out: dict = {"load_before": load()}
    with tempfile.TemporaryDirectory(prefix="plcopen-bench-") as d:
        tmp = Path(d)
        data, text = programs(a.rungs)
        sets = {}
        for kind, name, content in (("ld", "big.xml", data), ("st", "big.st", text.encode())):
            folder = tmp / kind
            folder.mkdir()
            (folder / name).write_bytes(content)
            check_s = stc("check", str(folder / name))
            build_s = stc("build", "-o", str(folder), str(folder / name))
            out[kind] = {"source_bytes": len(content), "check_s": check_s, "build_s": build_s}
            sets[kind] = folder / "module.xml"
        out["load_after_builds"] = load()
        rounds = []
        for r in range(a.rounds):
            order = ("st", "ld") if r % 2 == 0 else ("ld", "st")
            rounds.append({k: run(sets[k], tmp, a.seconds, f"{k}-{r}") for k in order})
        ratios = [x["ld"]["mean"] / x["st"]["mean"] for x in rounds]
        out["rounds"] = rounds
        out["exec_ratio_median"] = statistics.median(ratios)
        out["exec_ratio_min"], out["exec_ratio_max"] = min(ratios), max(ratios)
        out["exec_mean_ns"] = {k: statistics.fmean(x[k]["mean"] for x in rounds) for k in ("ld", "st")}
        out["load_after"] = load()
    print(
        f"{a.rungs} rungs: LD file {out['ld']['source_bytes']} B, check {out['ld']['check_s']:.2f} s, "
        f"build {out['ld']['build_s']:.2f} s (ST: check {out['st']['check_s']:.2f} s, build {out['st']['build_s']:.2f} s)"
    )
    print(
        f"exec per period: LD {out['exec_mean_ns']['ld'] / 1000:.2f} µs, ST {out['exec_mean_ns']['st'] / 1000:.2f} µs; "
        f"LD/ST median of {a.rounds} rounds {out['exec_ratio_median']:.3f} "
        f"(min {out['exec_ratio_min']:.3f}, max {out['exec_ratio_max']:.3f}); load {out['load_before']} -> {out['load_after']}"
    )
    if a.json:
        a.json.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

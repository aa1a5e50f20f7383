"""online_change_bench.py -- what online change of the shared-variable layout costs the RT core:
N hot swaps (default 100), each onto a layout that adds one variable (laid out against the one
before, glbc --previous), while a counter module runs every 100 us and is kept through all of them:
as a user's build does, the counter module is rebuilt against every new layout (the same code, so
irpd keeps the running instance).

With --executors, every other swap also adds an <executor> (its own SCHED_FIFO thread, started
and parked before the swap) and the next one takes it away again (its thread stopped after it).

Reports per swap the periods missed (target 0) and the time from the request to the swap (p50,
p99, max), and at the end checks that the counter module was one instance whose runs + skipped are
every period the dispatcher went through.  Writes a JSON summary (--json) for docs/benchmark-online.md.

    .venv/bin/python tests/bench/online_change_bench.py [--swaps 100] [--period-us 100] [--executors] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))
from live_processes import BUILD, ROOT, start_irpd  # noqa: E402

sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.irpd.client import IrpdClient  # noqa: E402

GLBC = ROOT / "glb" / "glbc"
V1 = ROOT / "tests" / "cpp" / "online" / "v1.glb"
SOURCE = ROOT / "tests" / "cpp" / "online" / "oc_modules.cpp"


def build_counter(layout_dir: Path, out: Path) -> Path:
    """oc_modules.cpp's counter, compiled against the generated.h in layout_dir."""
    subprocess.run(
        [
            "c++",
            "-std=c++20",
            "-O2",
            "-fPIC",
            "-shared",
            "-DOC_COUNTER",
            f"-I{ROOT / 'rtcore' / 'include'}",
            f"-I{layout_dir}",
            str(SOURCE),
            f"-L{BUILD / 'rtcore'}",
            "-lindurop",
            "-o",
            str(out),
        ],
        check=True,
        capture_output=True,
    )
    return out


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(q * (len(ordered) - 1))))]


def layouts(folder: Path, count: int) -> list[tuple[Path, Path]]:
    """v1, then `count` layouts, each one variable more: (layout.json, the counter built against it)."""
    text = V1.read_text()
    previous = None
    out = []
    for k in range(count + 1):
        if k:
            text += f"double grown_{k - 1};\n"
        glb = folder / f"g{k}.glb"
        glb.write_text(text)
        target = folder / f"g{k}"
        subprocess.run(
            [
                sys.executable,
                str(GLBC),
                str(glb),
                "-o",
                str(target),
                *(["--previous", str(previous)] if previous else []),
            ],
            check=True,
            capture_output=True,
        )
        previous = target / "layout.json"
        out.append((previous, build_counter(target, folder / f"counter_{k}.so")))
    return out


def module_xml(folder: Path, name: str, layout: Path, counter: Path, period_ns: int, side: bool = False) -> Path:
    path = folder / f"{name}.xml"
    executor = "  <executor><name>side</name></executor>\n" if side else ""
    path.write_text(
        f"<root>\n  <layout>{layout}</layout>\n{executor}  <module><name>counter</name><filename>"
        f"{counter}</filename><moduletype>thread</moduletype>"
        f"<operationtype>periodic</operationtype><period>{period_ns}</period><priority>1</priority>"
        f"<property><value name=\"journal\">{folder / 'counter.log'}</value></property></module>\n</root>\n"
    )
    return path


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--swaps", type=int, default=100)
    ap.add_argument("--period-us", type=int, default=100)
    ap.add_argument(
        "--executors", action="store_true", help="add an <executor> at every other swap, take it away at the next"
    )
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()
    period_ns = a.period_us * 1000
    with tempfile.TemporaryDirectory(prefix="online-bench-") as tmp:
        folder = Path(tmp)
        t0 = time.monotonic()
        chain = layouts(folder, a.swaps)
        build_s = time.monotonic() - t0
        sock = folder / "irpd.sock"
        stats_json = folder / "stats.json"
        irpd = start_irpd(
            sock,
            module_xml(folder, "start", *chain[0], period_ns),
            f"online-bench-{period_ns}",
            "--stats-json",
            str(stats_json),
        )
        control = IrpdClient(str(sock), timeout_s=60)
        missed, to_swap = [], []

        def lost() -> int:  # periods the main dispatcher missed or skipped so far
            d = control.request("status")
            return d["missed"] + d["skipped"]

        try:
            time.sleep(0.5)
            t_swaps, lost_before = time.monotonic(), lost()
            for k, (layout, counter) in enumerate(chain[1:]):
                side = a.executors and k % 2 == 0
                report = control.request(
                    "load",
                    config=str(module_xml(folder, f"s{k}", layout, counter, period_ns, side)),
                    set_id=f"grown-{k}",
                )
                assert report["kept"] == ["counter"], report
                assert report["variables"]["added"] == [f"oc.grown_{k}"], report["variables"]
                missed.append(report["missed_periods"])
                to_swap.append(report["request_to_swap_ns"] / 1e6)
            swaps_s, lost_swapping = time.monotonic() - t_swaps, lost() - lost_before
            # The reference: as long again without any swap, on the same machine, in the same run.
            lost_before = lost()
            time.sleep(swaps_s)
            lost_idle = lost() - lost_before
        finally:
            control.close()
            irpd.send_signal(signal.SIGTERM)
            irpd.wait(timeout=20)
        stats = json.loads(stats_json.read_text())
        counter, dispatcher = stats["modules"][0], stats["dispatcher"]
        journal = (folder / "counter.log").read_text()
        one_instance = re.fullmatch(r"start\nstop runs=(\d+)\n", journal) is not None
        every_period = counter["runs"] + counter["skipped"] == dispatcher["runs"] + dispatcher["skipped"]
    result = {
        "swaps": a.swaps,
        "period_us": a.period_us,
        "executors_added_and_removed": a.executors,
        "glbc_and_build_s": round(build_s, 1),
        "missed_periods_total": sum(missed),
        "swaps_with_missed_periods": sum(1 for m in missed if m),
        "dispatcher_lost_during_the_swaps": lost_swapping,
        "dispatcher_lost_in_as_long_without_swaps": lost_idle,
        "swaps_s": round(swaps_s, 1),
        "request_to_swap_ms": {
            "p50": round(percentile(to_swap, 0.5), 3),
            "p99": round(percentile(to_swap, 0.99), 3),
            "max": round(max(to_swap), 3),
        },
        "counter": {
            "one_instance": one_instance,
            "runs_plus_skipped_is_every_period": every_period,
            "runs": counter["runs"],
            "skipped": counter["skipped"],
        },
    }
    print(json.dumps(result, indent=1))
    if a.json:
        a.json.write_text(json.dumps(result, indent=1) + "\n")
    return 0 if one_instance and every_period else 1


if __name__ == "__main__":
    sys.exit(main())

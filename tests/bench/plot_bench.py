#!/usr/bin/env python3
"""plot_bench.py -- the scope in a browser: 16 variables streamed at 1 kHz into the Variables
page's live plot, in Debian's chromium, for 60 s.

    .venv/bin/python tests/bench/plot_bench.py [--seconds 60] [--out docs/benchmark-webui.md]

irpd runs config/sets/signals (sixteen waveforms every 1 ms) with the agent serving the built UI
(tests/browser/serve.py); tests/browser/bench/plot-bench.mjs measures in the page:
  reference  10 s of frame intervals on the Overview page, no plot (the same browser, same run);
  plot       SECONDS of frame intervals with one panel plotting SIG.wave[0..15] at every sample;
and reads the stream's drop counter (the agent's exact count) and the page's own sample counters.
Reports frame time p50/p95/p99/max, fps, samples received against the samples irpd produced in
that time, and dropped samples.  Timing figures are never asserted by tests; they are recorded
in docs/.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SET = REPO / "build" / "sets" / "signals" / "module.xml"
PATHS = [f"SIG.wave[{k}]" for k in range(16)]


def pct(xs: list[float], q: float) -> float:
    s = sorted(xs)
    return s[min(len(s) - 1, int(q * len(s)))]


def figures(intervals: list[float]) -> dict:
    return {
        "frames": len(intervals),
        "p50_ms": pct(intervals, 0.5),
        "p95_ms": pct(intervals, 0.95),
        "p99_ms": pct(intervals, 0.99),
        "max_ms": max(intervals),
        "fps": 1000 * len(intervals) / sum(intervals),
    }


def run(seconds: int) -> dict:
    out = Path(tempfile.mkdtemp(prefix="plot-bench-")) / "server.json"
    serve = subprocess.Popen([sys.executable, str(REPO / "tests" / "browser" / "serve.py"), str(out), str(SET)])
    try:
        deadline = time.monotonic() + 60
        while not out.exists():
            if serve.poll() is not None or time.monotonic() > deadline:
                raise SystemExit("plot_bench: irpd + agent did not come up")
            time.sleep(0.1)
        server = json.loads(out.read_text())
        shot = REPO / "build" / "test-artifacts" / "plot-bench.png"
        shot.parent.mkdir(parents=True, exist_ok=True)
        browser = subprocess.run(
            [
                "node",
                str(REPO / "tests" / "browser" / "bench" / "plot-bench.mjs"),
                server["url"],
                server["users"]["viewer"]["name"],
                server["users"]["viewer"]["password"],
                str(seconds),
                *PATHS,
            ],
            cwd=REPO / "tests" / "browser",
            capture_output=True,
            text=True,
            env={**os.environ, "SHOT": str(shot)},
        )
        if browser.returncode != 0:
            raise SystemExit(f"plot_bench: the browser run failed:\n{browser.stderr}")
        return json.loads(browser.stdout.strip().splitlines()[-1])
    finally:
        serve.send_signal(signal.SIGTERM)
        serve.wait(30)


def report(r: dict, seconds: int) -> str:
    ref, plot = figures(r["reference"]), figures(r["plot"])
    b, a = r["before"], r["after"]
    received = a["samples"] - b["samples"]
    produced = r["cycles"]  # irpd's basic periods (1 ms) between the two readings: rows it sampled
    elapsed_s = produced / 1000
    work = sorted(a.get("workMsRecent", []))
    dropped = a["dropped"] - b["dropped"]
    ui_dropped = a.get("uiDropped", 0) - b.get("uiDropped", 0)
    rows = [("reference (Overview, no plot)", ref), (f"plot: 16 variables at 1 kHz, {seconds} s", plot)]
    lines = [
        "# Benchmark: the scope in a browser",
        "",
        "`.venv/bin/python tests/bench/plot_bench.py` — Debian's chromium (headless, Playwright, flags "
        f"`{os.environ.get('CHROMIUM_ARGS', '--disable-gpu --no-sandbox')}`: canvases rasterized by Skia on the CPU, as in a",
        "browser without a GPU), the agent serving the built UI, irpd running `config/sets/signals` (sixteen waveforms",
        "every 1 ms).  One plot panel of the Variables page draws `SIG.wave[0..15]`, every sample, fed",
        "by the agent's stream (decimation 1).  Frame intervals are measured in the page with",
        "`requestAnimationFrame`; the reference is the same browser on a page without a plot, in the",
        "same run.",
        "",
        "| phase | frames | fps | p50 ms | p95 ms | p99 ms | max ms |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for name, f in rows:
        lines.append(
            f"| {name} | {f['frames']} | {f['fps']:.1f} | {f['p50_ms']:.2f} | {f['p95_ms']:.2f} | "
            f"{f['p99_ms']:.2f} | {f['max_ms']:.1f} |"
        )
    lines += [
        "",
        f"- Frame time p95 with the plot: **{plot['p95_ms']:.2f} ms** ({1000 / plot['p95_ms']:.1f} fps at p95; "
        f"mean {plot['fps']:.1f} fps), {plot['p95_ms'] / ref['p95_ms']:.2f} × the reference's p95.  Target: ≥ 55 fps.",
        f"- Samples: {received} rows of 16 values received by the page over {elapsed_s:.1f} s of irpd periods "
        f"({produced} produced); **{dropped} dropped** by the stream (the agent's exact counter), "
        f"{ui_dropped} discarded by the page.  Target: 0 dropped.",
        f"- The page's own work per frame (JavaScript incl. uPlot's drawing, last {len(work)} frames): "
        f"p50 {pct(work, 0.5):.2f} ms, p95 {pct(work, 0.95):.2f} ms."
        if work
        else "",
        "",
        f"Measured {time.strftime('%Y-%m-%d')} on the 2-CPU development VM (noisy, shared).  Rows received and "
        "produced differ by the time between reading irpd's period count and the page's counters; "
        "losses are what the drop counters say.",
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=int, default=60)
    ap.add_argument("--out", type=Path, default=REPO / "docs" / "benchmark-webui.md")
    ap.add_argument("--json", type=Path, help="also write the raw figures here")
    args = ap.parse_args()
    r = run(args.seconds)
    if args.json:
        args.json.write_text(json.dumps(r))
    text = report(r, args.seconds)
    args.out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()

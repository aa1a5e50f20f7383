#!/usr/bin/env python3
"""capture_bench.py -- what a triggered capture costs the agent: the CPU time of evaluating a
trigger on the rows and keeping the pre-trigger buffer, and of writing a shot as an MCAP file
(capture_files.py, as the agent does).

    .venv/bin/python tests/bench/capture_bench.py [--seconds 3] [--channels 64] [--captures 1]

In process, no irpd: synthetic rows of `channels` channels (a square wave on channel 0) are fed
to `captures` armed captures in blocks of 200 rows, what the engine reads every 20 ms at a 100 µs
basic period.  The trigger is an AND of four conditions (an edge, a level, a window and a level
held 10 rows), the pre-trigger buffer the rings' 16 384 rows, post 1 000 rows, repeated.  Prints
the CPU time per row and the share of one CPU at 10 000 rows a second, and the time and size of
writing one shot of 16 384 + 1 + 1 000 rows.  Figures go to docs/recorder.md; tests never assert
them.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "agent"))
from indurop_agent.recorder.capture import Capture  # noqa: E402
from indurop_agent.recorder.capture_files import CaptureFiles  # noqa: E402
from indurop_agent.recorder.store import Store  # noqa: E402

BASIC = 100_000  # 100 µs
BLOCK = 200  # rows per 20 ms poll


def request(channels: int) -> dict:
    paths = [f"c{i}" for i in range(channels)]
    return {
        "name": "bench",
        "variables": paths,
        "trigger": {
            "kind": "condition",
            "combine": "and",
            "conditions": [
                {"kind": "edge", "variable": "c0", "direction": "rising", "threshold": 0},
                {"kind": "level", "variable": "c1", "compare": "above", "value": -2, "hold_rows": 1},
                {"kind": "window", "variable": "c2", "where": "inside", "low": -5, "high": 5, "hold_rows": 1},
                {"kind": "level", "variable": "c3", "compare": "below", "value": 5, "hold_rows": 10},
            ],
        },
        "pre": {"rows": 16384},
        "post": {"rows": 1000},
        "repeat": 0,
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=3.0, help="of rows at 100 µs to feed (default 3)")
    ap.add_argument("--channels", type=int, default=64)
    ap.add_argument("--captures", type=int, default=1)
    a = ap.parse_args()
    shots = []
    spec = request(a.channels)
    captures = [
        Capture(f"b{k}", spec, spec["variables"], BASIC, lambda c, s: shots.append(s)) for k in range(a.captures)
    ]
    for c in captures:
        c.arm(head=0)
    rows = int(a.seconds * 1e9 / BASIC)
    rng = np.random.default_rng(1)
    noise = rng.normal(0, 0.01, (a.channels, BLOCK))
    cpu = 0.0
    for first in range(1, rows + 1, BLOCK):
        seq = np.arange(first, first + BLOCK, dtype=np.int64)
        t_ns = seq * BASIC
        values = noise + np.where((seq // 5000) % 2 == 1, 1.0, -1.0)  # rising every second
        start = time.process_time()
        for c in captures:
            c.feed(seq, t_ns, values)
        cpu += time.process_time() - start
    per_row = cpu / rows
    print(f"{a.captures} capture(s) of {a.channels} channels, {rows} rows in blocks of {BLOCK}: {len(shots)} shots")
    print(f"  evaluate + keep the pre-trigger buffer: {per_row * 1e6:.2f} µs CPU a row")
    print(f"  at 10 000 rows a second: {per_row * 1e4 * 100:.1f} % of one CPU")
    if shots:
        with tempfile.TemporaryDirectory() as folder:
            store = Store(Path(folder), 1 << 40, reserve_bytes=0)
            sink = CaptureFiles(store)
            shot = shots[0]
            seq, t_ns, values = shot.arrays()
            header = {
                "capture": "bench",
                "shot": 1,
                "channels": [{"path": p, "type": "double"} for p in spec["variables"]],
                "basic_period_ns": BASIC,
                "trigger_seq": shot.trigger_seq,
                "cause": shot.cause,
            }
            start = time.perf_counter()
            w = sink.open(header)
            w.rows(seq, t_ns, values)
            w.close(shot.summary())
            took = time.perf_counter() - start
            size = store.get("bench.shot-1").size()
            print(f"  one shot of {len(seq)} rows as MCAP: {took:.2f} s to write, {size / 2**20:.1f} MiB")
            start = time.perf_counter()
            back = sink.read("bench", 1)
            print(f"  read back ({len(back.seq)} rows): {time.perf_counter() - start:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

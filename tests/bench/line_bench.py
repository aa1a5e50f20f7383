#!/usr/bin/env python3
"""line_bench.py -- how long the line takes to tell (docs/dds.md "The line"): from a bridge killed
(SIGKILL) to its controller shown lost in another bridge's view of the line, and from a bridge
stopped cleanly (SIGTERM) to its controller gone from it.  Two bridges on loopback, on a domain of
their own, announcing controllers without irpd (the announcement and its liveliness are the same);
the view is the file the agent reads (line_file), polled every 20 ms.  Short by default.

    .venv/bin/python tests/bench/line_bench.py [--rounds 5] [--lease-s 3] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "python"))
from live_processes import output, start_bridge, stop  # noqa: E402


def seen(view: Path, name: str) -> dict | None:
    try:
        controllers = json.loads(view.read_text())["controllers"]
    except (OSError, ValueError):
        return None
    return next((c for c in controllers if c["name"] == name), None)


def until(what, seconds: float = 60.0) -> float:
    """Polls what() every 20 ms; the monotonic time it first held."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if what():
            return time.monotonic()
        time.sleep(0.02)
    raise SystemExit(f"line_bench: {what.__doc__} did not happen within {seconds:g} s")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--lease-s", type=float, default=3.0)
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="line-bench-"))
    domain = 230 + os.getpid() % 3  # the bench's domains (docs/dds.md)
    common = ["--line-lease-s", str(a.lease_s), "--poll-ms", "5"]
    view = tmp / "a.json"
    watcher = start_bridge(tmp / "none.sock", domain, "--name", "a", *common, line_file=view, log=tmp / "a.log")
    killed, stopped = [], []
    try:
        for _ in range(a.rounds):
            for kind, figures in (("kill", killed), ("stop", stopped)):
                b = start_bridge(tmp / "none.sock", domain, "--name", "b", *common, log=tmp / "b.log")

                def alive():
                    """b alive in a's view"""
                    c = seen(view, "b")
                    return c is not None and c["alive"]

                until(alive)
                time.sleep(1.5)  # a few announcements
                t0 = time.monotonic()
                if kind == "kill":
                    os.kill(b.pid, signal.SIGKILL)
                    b.wait()

                    def lost():
                        """b lost in a's view"""
                        c = seen(view, "b")
                        return c is not None and not c["alive"]

                    figures.append(until(lost) - t0)
                else:
                    b.send_signal(signal.SIGTERM)

                    def gone():
                        """b gone from a's view"""
                        return seen(view, "b") is None

                    figures.append(until(gone) - t0)
                    b.wait(10)
                    if b.returncode not in (0, -signal.SIGTERM):
                        print(output(b), file=sys.stderr)
    finally:
        stop(watcher)
    result = {
        "lease_s": a.lease_s,
        "period_s": 1.0,
        "rounds": a.rounds,
        "killed_to_lost_s": [round(x, 2) for x in killed],
        "stopped_to_gone_s": [round(x, 2) for x in stopped],
        "load_average": os.getloadavg(),
    }
    print(
        f"killed -> lost:  median {statistics.median(killed):.2f} s, max {max(killed):.2f} s (lease {a.lease_s:g} s)\n"
        f"stopped -> gone: median {statistics.median(stopped):.2f} s, max {max(stopped):.2f} s\n"
        f"load average {result['load_average'][0]:.2f}"
    )
    if a.json:
        a.json.write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

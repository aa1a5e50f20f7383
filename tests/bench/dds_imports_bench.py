#!/usr/bin/env python3
"""dds_imports_bench.py -- the latency of a variable shared between two controllers over DDS
(docs/dds.md "Measured"): from A's cycle (the due time of the trace row that carried the value) to
the value in B's shared-variable segment, p50/p99/max, at 1 kHz.

Two controllers on this host, each irpd running the share set (tests/python/dds/share, one module
every 1 ms): A's bridge exports SHARE.count every basic period, B's bridge imports it into
SHARE.IN.count at 1 kHz, loopback only, on a domain of its own.  The module writes count = its
period number, so a value tells its row: A's trace ring gives each value's due time.  Two ways to
see it arrive in B:

- segment: a thread of this process reads B's variable about every 0.1 ms and notes when each
  value first appears (CLOCK_MONOTONIC, the clock of the due times);
- cycle: the due time of B's first trace row that holds the value, i.e. when B's modules can use
  it (quantized to B's basic period, 1 ms).

Counted too: the values A had that B never held (superseded by a newer one before B wrote them)
and B's trace rows with the import stale.  The bridges and this process run off the CPU of irpd's
dispatchers (the last one), as the demo and the units run the bridge (--same-cpu: every CPU).
Short by default; not in CI.

    .venv/bin/python tests/bench/dds_imports_bench.py [--seconds 20] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "python"))
sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.irpd.client import IrpdClient, IrpdRefused  # noqa: E402
from indurop_agent.irpd.trace import TraceRing  # noqa: E402
from indurop_agent.irpd.variables import Segment  # noqa: E402
from live_processes import BUILD, dispatching, start_bridge, start_irpd, stop, wait_until  # noqa: E402

SET = BUILD / "tests" / "sets" / "dds-share"
VALUE, STALE = "SHARE.IN.count", "SHARE.IN.count_stale"


def log(*a) -> None:
    print("dds_imports_bench:", *a, file=sys.stderr, flush=True)


def percentiles(values: list[int]) -> dict:
    v = sorted(values)
    if not v:
        return {"p50_ns": None, "p99_ns": None, "max_ns": None, "n": 0}
    return {"p50_ns": v[len(v) // 2], "p99_ns": v[int(len(v) * 0.99)], "max_ns": v[-1], "n": len(v)}


class Node:
    """irpd on a copy of the share set with `dds`, and its bridge named `name`."""

    def __init__(self, work: Path, name: str, dds: dict, domain: int, prefix: tuple):
        folder = work / name
        shutil.copytree(SET, folder)
        (folder / "dds.json").write_text(json.dumps(dds))
        self.sock = work / f"{name}.sock"
        self.irpd = start_irpd(self.sock, folder / "module.xml", f"{name}-{os.getpid()}", log=work / f"{name}-irpd.log")
        self.control = IrpdClient(str(self.sock), timeout_s=30)
        self.status = wait_until(lambda: (s := dispatching(self.control)) and s.get("running") and s, 60, 0.1)
        self.bridge = start_bridge(self.sock, domain, "--name", name, log=work / f"{name}-bridge.log", prefix=prefix)

    def ring(self, channels: list[str]) -> TraceRing:
        return TraceRing(self.control.request("trace", channels=channels, owner="bench")["shm"])

    def close(self) -> None:
        stop(self.bridge)
        self.control.close()
        stop(self.irpd)


class Rows:
    """Every trace row of a ring since it was opened: (due time, {path: value})."""

    def __init__(self, ring: TraceRing):
        self.ring, self.cursor, self.rows, self.lost = ring, ring.head(), [], 0

    def read(self) -> None:
        read = self.ring.read_since(self.cursor)
        self.cursor, self.lost = read.next, self.lost + read.lost
        for part in read.parts:
            cols = {p: part.columns[i] for i, p in enumerate(part.config.paths)}
            for k in range(part.count):
                self.rows.append((int(part.t_ns[k]), {p: c[k] for p, c in cols.items()}))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=20.0, help="how long to measure (default 20)")
    ap.add_argument("--rate-hz", type=float, default=1000.0, help="A's export and B's import rate (default 1000)")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--same-cpu", action="store_true", help="let the bridges and this process use irpd's CPU too")
    args = ap.parse_args()
    if not (SET / "share.so").exists():
        log(f"the share set is not built ({SET}): bash packaging/build.sh --tests")
        return 2
    work = Path(tempfile.mkdtemp(prefix="dds-imports-bench-"))
    cpus = os.cpu_count() or 1
    off_rt = () if args.same_cpu or cpus < 2 else ("taskset", "-c", f"0-{cpus - 2}")
    if off_rt:
        os.sched_setaffinity(0, range(cpus - 1))
    domain = 40 + os.getpid() % 20
    a_name, b_name = f"bench-a-{os.getpid()}", f"bench-b-{os.getpid()}"
    export = {"joint_states": {"enabled": False}, "export": [{"variable": "SHARE.count", "rate_hz": args.rate_hz}]}
    imports = {
        "joint_states": {"enabled": False},
        "imports": [
            {"from": a_name, "path": "SHARE.count", "variable": VALUE, "stale": STALE, "rate_hz": args.rate_hz}
        ],
    }
    a = b = None
    try:
        a = Node(work, a_name, export, domain, off_rt)
        b = Node(work, b_name, imports, domain, off_rt)
        seg = Segment(b.status["shared_memory"]["variables"])
        deadline = time.monotonic() + 60
        while seg.read(STALE) or not seg.read(VALUE):
            assert time.monotonic() < deadline, "B's import did not follow A within 60 s"
            time.sleep(0.1)
        time.sleep(2.0)  # settled
        a_rows, b_rows = Rows(a.ring(["SHARE.count"])), Rows(b.ring([VALUE, STALE]))
        seen: list[tuple[int, int]] = []  # (CLOCK_MONOTONIC ns, value) when a new value was first read
        stopping = threading.Event()

        def poll() -> None:
            last = None
            while not stopping.is_set():
                v = seg.read(VALUE)
                if v != last:
                    seen.append((time.monotonic_ns(), v))
                    last = v
                time.sleep(0.0001)

        poller = threading.Thread(target=poll, daemon=True)
        poller.start()
        end = time.monotonic() + args.seconds
        while time.monotonic() < end:
            time.sleep(min(2.0, max(0.0, end - time.monotonic())))
            a_rows.read()
            b_rows.read()
        stopping.set()
        poller.join()
        a_rows.read()
        b_rows.read()
        due = {int(v["SHARE.count"]): t for t, v in a_rows.rows}
        first_row: dict[int, int] = {}
        stale_rows = 0
        for t, v in b_rows.rows:
            if v[STALE]:
                stale_rows += 1
            else:
                first_row.setdefault(int(v[VALUE]), t)
        first_seen: dict[int, int] = {}
        for t, v in seen:
            first_seen.setdefault(int(v), t)
        window = [c for c in due if c in first_row or c in first_seen]
        lo, hi = (min(window), max(window)) if window else (0, -1)
        results = {
            "seconds": args.seconds,
            "rate_hz": args.rate_hz,
            "bridge_cpus": "all" if not off_rt else off_rt[-1],
            "segment": percentiles([first_seen[c] - due[c] for c in first_seen if c in due]),
            "cycle": percentiles([first_row[c] - due[c] for c in first_row if c in due]),
            "a_values": hi - lo + 1,
            "never_in_b": sum(1 for c in range(lo, hi + 1) if c not in first_row and c not in first_seen),
            "b_rows_stale": stale_rows,
            "rows_lost": a_rows.lost + b_rows.lost,
            "load_average": os.getloadavg(),
        }
        seg.close()
    finally:
        for n in (b, a):
            if n is not None:
                n.close()
    print(json.dumps(results, indent=1))
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

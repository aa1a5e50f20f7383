#!/usr/bin/env python3
"""dds_bench.py -- the DDS bridge at 1 kHz (docs/dds.md "Measured"): the latency from a sample's
cycle (its due time, the JointState stamp) to a subscriber's receipt, p50/p99, the samples lost,
and irpd's wake-up latency p99 with the bridge publishing every basic period divided by its p99
without the bridge, in the same run (phases alternate: off, on, off, on ...).

irpd runs the plc-robot cell's 1 ms variant (module-1ms.xml); the bridge and the subscriber (a
cyclonedds reader in this process) use loopback only, on a domain of their own, and run off irpd's
dispatcher CPU (the last one) as the demo and the .deb's units run the bridge (--same-cpu: on
every CPU, to see what that costs).  Not in CI: run it
when nothing else loads the machine.

    .venv/bin/python tests/bench/dds_bench.py [--phase-s 20] [--phases 4] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "python"))
sys.path.insert(0, str(ROOT / "agent"))
from cyclonedds.domain import Domain, DomainParticipant  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from indurop_agent.dds import ros2_types  # noqa: E402
from indurop_agent.dds.bridge import QOS  # noqa: E402
from indurop_agent.dds.settings import BridgeSettings, cyclone_config  # noqa: E402
from indurop_agent.irpd.client import IrpdClient, IrpdRefused  # noqa: E402
from live_processes import copy_cell, start_bridge, start_irpd, stop, wait_dispatching  # noqa: E402

BASIC_NS = 1_000_000


def log(*a) -> None:
    print("dds_bench:", *a, file=sys.stderr, flush=True)


def wakeup_p99(before: dict, after: dict) -> float | None:
    """p99 of the main dispatcher's wake-up latency between two `histograms` answers (ns): the
    difference of their buckets, the upper edge of the bucket holding the rank."""

    def buckets(answer):
        (rec,) = [r for r in answer["records"] if r["kind"] == "dispatcher" and r["executor"] == "main"]
        return {(low, width): n for low, width, n in rec["latency_ns"]["buckets"]}

    a, b = buckets(before), buckets(after)
    diff = sorted((low, width, b[k] - a.get(k, 0)) for k in b for low, width in [k] if b[k] - a.get(k, 0) > 0)
    total = sum(n for _, _, n in diff)
    if not total:
        return None
    seen = 0
    for low, width, n in diff:
        seen += n
        if seen >= 0.99 * total:
            return float(low + width)
    return float(diff[-1][0] + diff[-1][1])


class Subscriber:
    """JointState receipts: (receipt on CLOCK_REALTIME, stamp) per sample."""

    def __init__(self, domain: int):
        self.domain = Domain(domain, cyclone_config(BridgeSettings(domain_id=domain)))
        self.participant = DomainParticipant(domain)
        topic = Topic(self.participant, "rt/joint_states", ros2_types.JointState)
        self.reader = DataReader(self.participant, topic, QOS["default"])
        self.samples: list[tuple[int, int, int]] = []  # (phase, receipt, stamp)
        self.on = False
        self.phase = 0
        self.stopping = False
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self) -> None:
        while not self.stopping:
            got = self.reader.take(N=64)
            now = time.time_ns()
            for m in got:
                if self.on and isinstance(m, ros2_types.JointState):
                    stamp = m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
                    self.samples.append((self.phase, now, stamp))
            if not got:
                time.sleep(0.0002)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--phase-s", type=float, default=20.0)
    ap.add_argument("--phases", type=int, default=4, help="pairs of (without, with) the bridge")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--same-cpu", action="store_true", help="let the bridge and the subscriber run on irpd's CPU too")
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="dds-bench-"))
    cpus = os.cpu_count() or 1
    off_rt = [] if args.same_cpu or cpus < 2 else ["taskset", "-c", f"0-{cpus - 2}"]
    xml, _ = copy_cell(work / "plc-robot", "module-1ms.xml")
    sock = work / "irpd.sock"
    irpd = start_irpd(sock, xml, f"dds-bench-{os.getpid()}")
    control = IrpdClient(str(sock), timeout_s=30)
    domain = 150 + os.getpid() % 50
    if off_rt:
        os.sched_setaffinity(0, range(cpus - 1))  # this process and the subscriber's thread
    sub = Subscriber(domain)
    results = {
        "phase_s": args.phase_s,
        "phases": args.phases,
        "bridge_cpus": "all" if not off_rt else off_rt[-1],
        "off_p99_ns": [],
        "on_p99_ns": [],
    }
    try:
        wait_dispatching(control)
        for phase in range(args.phases):
            h0 = control.request("histograms", name="dispatcher")
            time.sleep(args.phase_s)
            off = wakeup_p99(h0, control.request("histograms", name="dispatcher"))
            bridge = start_bridge(sock, domain, log=work / "bridge.log", prefix=tuple(off_rt))
            time.sleep(5)  # started, traced, matched
            sub.phase, sub.on = phase, True
            h0 = control.request("histograms", name="dispatcher")
            time.sleep(args.phase_s)
            on = wakeup_p99(h0, control.request("histograms", name="dispatcher"))
            sub.on = False
            stop(bridge)
            results["off_p99_ns"].append(off)
            results["on_p99_ns"].append(on)
            log(f"phase {phase + 1}: wake-up p99 without the bridge {off} ns, with it {on} ns")
        sub.stopping = True
        sub.thread.join()
        lat = sorted(r - s for _, r, s in sub.samples)
        lost = 0  # per phase: the 1 ms grid from its first to its last stamp, less the stamps received
        for phase in range(args.phases):
            stamps = {s for p, _, s in sub.samples if p == phase}
            if stamps:
                lost += (max(stamps) - min(stamps)) // BASIC_NS + 1 - len(stamps)
        results.update(
            {
                "samples": len(sub.samples),
                "latency_p50_ns": lat[len(lat) // 2] if lat else None,
                "latency_p99_ns": lat[int(len(lat) * 0.99)] if lat else None,
                "latency_max_ns": lat[-1] if lat else None,
                "lost": lost,
                "wakeup_p99_ratio": statistics.median(results["on_p99_ns"]) / statistics.median(results["off_p99_ns"]),
                "load_average": os.getloadavg(),
            }
        )
    finally:
        control.close()
        stop(irpd)
    print(json.dumps(results, indent=1))
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

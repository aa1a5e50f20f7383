#!/usr/bin/env python3
"""agent_bench.py -- what the agent and hot reload cost the RT core, measured in one run.

    python3 tests/bench/agent_bench.py [--seconds 20] [--swaps 100] [--out docs/benchmark-agent.md]

Phases, each on a fresh irpd running the paper's Figure 1 set at 100 µs (pinned, SCHED_FIFO),
with the agent beside it on 127.0.0.1:
  idle        the agent running, no client (the reference of every ratio below);
  stream-1    one WebSocket client streaming 8 variables at the basic period;
  stream-10   ten such clients;
  hammer      one client requesting status, modules and schedule as fast as it can;
  swaps       100 hot reloads of a set whose one module changes each time (its .so rebuilt as
              another version), through the control socket: request-to-swap time and periods
              missed, and whether the kept module missed any run.
For each phase: irpd's wake-up latency p50/p99/max from its own histograms (--stats-json), the
ratio of its p99 to the idle phase's, samples/s received and dropped.  Timing figures are never
asserted by tests; this script records them in docs/.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "tests" / "bench"))
sys.path.insert(0, str(REPO / "agent"))

import run_bench  # noqa: E402  (histogram decoding shared with the core benchmark)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def log(msg: str) -> None:
    print(f"[agent-bench] {msg}", file=sys.stderr, flush=True)


class Control:
    """A client of irpd's control socket (docs/control-protocol.md)."""

    def __init__(self, path: Path, timeout: float = 60):
        self.sock = socket.socket(socket.AF_UNIX)
        self.sock.settimeout(timeout)
        self.sock.connect(str(path))
        self.file = self.sock.makefile("rw")
        self.hello = json.loads(self.file.readline())

    def ask(self, cmd: str, **args):
        self.file.write(json.dumps({"cmd": cmd, **args}) + "\n")
        self.file.flush()
        answer = json.loads(self.file.readline())
        if not answer.get("ok"):
            raise RuntimeError(f"{cmd}: {answer.get('error')}")
        return answer["result"]

    def close(self):
        self.sock.close()


def start_irpd(a, xml: Path, sock: Path, stats: Path, instance: str, extra: list[str] | None = None) -> subprocess.Popen:
    sock.unlink(missing_ok=True)
    cmd = [str(a.irpd), "--config", str(xml), "--control-socket", str(sock), "--instance", instance,
           "--stats-json", str(stats), "--rt-priority", str(a.rt_priority)] + (["--cpu", str(a.cpu)] if a.cpu is not None else []) + (extra or [])
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 20
    while not sock.exists():
        if p.poll() is not None:
            raise RuntimeError(f"irpd exited: {p.stderr.read()}")
        if time.monotonic() > deadline:
            raise RuntimeError("irpd did not open its control socket")
        time.sleep(0.02)
    return p


def stop(p: subprocess.Popen, timeout: float = 20) -> None:
    if p.poll() is None:
        p.send_signal(signal.SIGTERM)
        try:
            p.wait(timeout)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def dispatcher_figures(stats_path: Path) -> dict:
    doc = json.loads(stats_path.read_text())
    d = doc["dispatcher"]
    lat = d["latency_ns"]
    return {"runs": d["runs"], "missed": d["missed"], "skipped": d["skipped"], "overruns": d["overruns"],
            "p50": lat["p50"], "p99": lat["p99"], "max": lat["max"], "realtime": doc["realtime"], "doc": doc}


# ---- hot reload ------------------------------------------------------------------------------

def swap_set(folder: Path) -> Path:
    xml = folder / "module.xml"
    xml.write_text(
        "<root>\n"
        "  <module><name>keep</name><filename>keep.so</filename><moduletype>thread</moduletype>"
        "<operationtype>periodic</operationtype><period>100000</period><priority>1</priority></module>\n"
        "  <module><name>swap</name><filename>swap.so</filename><moduletype>thread</moduletype>"
        "<operationtype>periodic</operationtype><period>1000000</period><priority>2</priority></module>\n"
        "</root>\n")
    return xml


def run_swaps(a, work: Path) -> dict:
    folder = work / "swaps"
    folder.mkdir()
    modules = a.build / "tests" / "cpp" / "modules"
    shutil.copy(modules / "counter_v1.so", folder / "keep.so")
    shutil.copy(modules / "counter_v1.so", folder / "swap.so")
    xml = swap_set(folder)
    sock, stats = folder / "irpd.sock", folder / "stats.json"
    irpd = start_irpd(a, xml, sock, stats, f"bench-swaps-{os.getpid()}", ["--module-cache", str(folder / "cache")])
    control = Control(sock)
    reports = []
    try:
        time.sleep(1)
        for i in range(a.swaps):
            shutil.copy(modules / ("counter_v2.so" if i % 2 == 0 else "counter_v1.so"), folder / "swap.so")
            reports.append(control.ask("load", config=str(xml)))
    finally:
        control.close()
        stop(irpd)
    figures = dispatcher_figures(stats)
    keep = next(m for m in figures["doc"]["modules"] if m["name"] == "keep")
    to_swap = [r["request_to_swap_ns"] for r in reports]
    return {
        "swaps": len(reports),
        "all_kept": all(r["kept"] == ["keep"] and r["started"] == ["swap"] for r in reports),
        "request_to_swap_ms": {"p50": statistics.median(to_swap) / 1e6,
                               "p99": sorted(to_swap)[max(0, int(len(to_swap) * 0.99) - 1)] / 1e6,
                               "max": max(to_swap) / 1e6},
        "total_ms_p50": statistics.median(r["total_ns"] for r in reports) / 1e6,
        "missed_periods": sum(r["missed_periods"] for r in reports),
        "swaps_with_misses": sum(1 for r in reports if r["missed_periods"]),
        "keep_runs": keep["runs"], "keep_skipped": keep["skipped"], "keep_missed": keep["missed"],
        "dispatcher_periods": figures["runs"] + figures["skipped"],
        "realtime": figures["realtime"],
    }

#!/usr/bin/env python3
"""monitor_bench.py -- what monitoring costs the RT core (docs/programming.md "Monitoring"): irpd's
wake-up p99 while the agent serves --values monitored values at --rate-hz (POST /variables/read
with --values paths, as the ST editor's monitor and the Watch page poll it) against the same run
without, in alternating rounds of the same set (issue 30's target: the p99 ratio at most 1.05).

    .venv/bin/python tests/bench/monitor_bench.py [--rounds R] [--round-s S] [--values N] [--rate-hz H]
                                                  [--modules M] [--period-ns N] [--cpu N] [--rt-priority P]
                                                  [--build-dir DIR] [--no-build] [--json FILE]

The set: --modules empty thread modules at --period-ns on a layout of --values uint32 variables
(force_bench.py's set).  The agent runs once, beside irpd on every CPU but irpd's (as a deployment
runs it); each round runs irpd (`--duration`, `--stats-json`) once with the agent idle and once with
a client reading the --values paths at --rate-hz (the order alternating between rounds).  The values
come from the shared-variable segment (the agent's reader, lock-free for the writers), never from a
request to irpd's RT threads.  Run as root for SCHED_FIFO (else the figures are not real-time, and
it says so).  Prints the table and writes the raw figures with --json.  Measures; asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from types import SimpleNamespace

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parent))
from agent_bench import dispatcher_figures, free_port, keep_thread_off, off_rt, start_irpd, stop
from force_bench import make_set, parse
from rtbench.common import REPO, BenchError, log
from rtbench.irpd_runs import build

TARGETS = ["irpd", "empty"]
RATIO_TARGET = 1.05


class Reader(threading.Thread):
    """POST /variables/read of `paths` every 1/rate_hz s, start to start, off irpd's CPU."""

    def __init__(self, url: str, token: str, paths: list[str], rate_hz: float, cpu: int):
        super().__init__(daemon=True)
        self.url, self.paths, self.every, self.cpu = url, paths, 1 / rate_hz, cpu
        self.headers = {"Authorization": f"Bearer {token}"}
        self.done = threading.Event()
        self.requests, self.errors = 0, []

    def run(self) -> None:
        keep_thread_off(self.cpu)
        with httpx.Client(headers=self.headers, timeout=10) as client:
            while not self.done.is_set():
                started = time.monotonic()
                r = client.post(f"{self.url}/api/v1/variables/read", json={"paths": self.paths})
                if r.status_code != 200 or r.json()["errors"]:
                    self.errors.append(r.text[:200])
                self.requests += 1
                self.done.wait(max(0.0, self.every - (time.monotonic() - started)))


def start_agent(a, work: Path, sock: Path) -> tuple[subprocess.Popen, str, str]:
    port, data = free_port(), work / "agent-data"
    cmd = off_rt(a) + [sys.executable, "-m", "indurop_agent", "--host", "127.0.0.1", "--port", str(port),
                       "--data-dir", str(data), "--irpd-socket", str(sock)]  # fmt: skip
    agent = subprocess.Popen(cmd, cwd=REPO / "agent", stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 30
    while not (data / "admin-token").exists() or not _up(url):
        if agent.poll() is not None or time.monotonic() > deadline:
            stop(agent)
            raise BenchError("the agent did not start")
        time.sleep(0.1)
    return agent, url, (data / "admin-token").read_text().strip()


def _up(url: str) -> bool:
    try:
        return httpx.get(f"{url}/api/v1/health", timeout=2).status_code == 200
    except httpx.HTTPError:
        return False


def run_round(a, xml: Path, work: Path, agent: tuple, tag: str, monitored: bool) -> dict:
    _, url, token = agent
    sock, stats = work / "irpd.sock", work / f"irpd-{tag}.json"
    irpd = start_irpd(a, xml, sock, stats, f"monbench-{os.getpid()}", ["--duration", str(a.round_s + 3)])
    reader = None
    try:
        deadline = time.monotonic() + 20
        while httpx.get(f"{url}/api/v1/health", timeout=5).json().get("irpd") != "ok":  # reconnected
            if time.monotonic() > deadline:
                raise BenchError("the agent did not reconnect to irpd")
            time.sleep(0.1)
        paths = [f"fb.v{i:03d}" for i in range(a.values)]
        reader = Reader(url, token, paths, a.rate_hz, a.cpu) if monitored else None
        log(f"irpd ({tag}): {a.round_s} s, {'reading ' + str(a.values) + ' values' if monitored else 'agent idle'}")
        if reader:
            reader.start()
        # the reads stop before irpd's --duration ends it (round_s + 3 s): a read after would fail
        time.sleep(a.round_s)
        if reader:
            reader.done.set()
            reader.join()
        irpd.wait(60)
    finally:
        if reader:
            reader.done.set()
        stop(irpd)
    figures = dispatcher_figures(stats)
    if not figures.pop("doc").get("realtime"):
        log(f"WARNING: irpd ({tag}) did not run SCHED_FIFO (not root?); its figures are not real-time")
    if reader and reader.errors:
        raise BenchError(f"reads failed: {reader.errors[:3]}")
    return {**figures, "monitored": monitored, "reads": reader.requests if reader else 0}


def options(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--values", type=int, default=200, help="values read per request (200)")
    ap.add_argument("--rate-hz", type=float, default=5.0, help="reads a second (5: the monitor's refresh)")


def main(argv: list[str]) -> int:
    a = parse(argv, __doc__, "monitored", options)
    a.irpd = a.build_dir / "bin" / "irpd"
    with tempfile.TemporaryDirectory(prefix="indurop-monitor-bench-") as tmp:
        work = Path(tmp)
        try:
            if not a.no_build:
                build(a.build_dir, [], TARGETS)
            xml = make_set(
                work, SimpleNamespace(modules=a.modules, period_ns=a.period_ns, build_dir=a.build_dir), a.values
            )
            agent = start_agent(a, work, work / "irpd.sock")
            try:
                rounds = []
                for r in range(a.rounds):
                    order = (False, True) if r % 2 == 0 else (True, False)
                    rounds.append(
                        {m: run_round(a, xml, work, agent, f"r{r}-{'mon' if m else 'idle'}", m) for m in order}
                    )
            finally:
                stop(agent[0])
        except BenchError as e:
            print(f"monitor_bench: {e}", file=sys.stderr)
            return 1
    ratios = [r[True]["p99"] / r[False]["p99"] for r in rounds if r[False]["p99"]]
    print(f"| round | wake-up p99 agent idle | reading {a.values} values at {a.rate_hz:g} Hz | ratio | reads |")
    print("| --- | --- | --- | --- | --- |")
    for i, r in enumerate(rounds):
        idle, mon = r[False], r[True]
        ratio = mon["p99"] / idle["p99"] if idle["p99"] else float("nan")
        print(f"| {i + 1} | {idle['p99'] / 1000:.2f} µs | {mon['p99'] / 1000:.2f} µs | {ratio:.3f} | {mon['reads']} |")
    ratio = statistics.median(ratios) if ratios else float("nan")
    print(f"\nmedian of the rounds: wake-up p99 with {a.values} monitored values ÷ without = {ratio:.3f} "
          f"(target ≤ {RATIO_TARGET}: {'met' if ratio <= RATIO_TARGET else 'NOT met'})")  # fmt: skip
    if a.json:
        body = {
            "args": {k: str(v) for k, v in vars(a).items() if not callable(v)},
            "rounds": [{str(k): v for k, v in r.items()} for r in rounds],
        }
        a.json.write_text(json.dumps({**body, "p99_ratio": ratio}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

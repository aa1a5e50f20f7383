#!/usr/bin/env python3
"""agent_bench.py -- what the agent and hot reload cost the RT core, measured in one run.

    .venv/bin/python tests/bench/agent_bench.py [--seconds 20] [--swaps 100] [--out docs/benchmark-agent.md]

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

from indurop_agent.irpd.client import IrpdClient  # noqa: E402  (the control socket, as the agent speaks it)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def log(msg: str) -> None:
    print(f"[agent-bench] {msg}", file=sys.stderr, flush=True)


def start_irpd(
    a, xml: Path, sock: Path, stats: Path, instance: str, extra: list[str] | None = None
) -> subprocess.Popen:
    sock.unlink(missing_ok=True)
    cmd = (
        [
            str(a.irpd),
            "--config",
            str(xml),
            "--control-socket",
            str(sock),
            "--instance",
            instance,
            "--stats-json",
            str(stats),
            "--rt-priority",
            str(a.rt_priority),
        ]
        + (["--cpu", str(a.cpu)] if a.cpu is not None else [])
        + (extra or [])
    )
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
    return {
        "runs": d["runs"],
        "missed": d["missed"],
        "skipped": d["skipped"],
        "overruns": d["overruns"],
        "p50": lat["p50"],
        "p99": lat["p99"],
        "max": lat["max"],
        "realtime": doc["realtime"],
        "doc": doc,
    }


# ---- hot reload ------------------------------------------------------------------------------


def swap_set(folder: Path) -> Path:
    xml = folder / "module.xml"
    xml.write_text(
        "<root>\n"
        "  <module><name>keep</name><filename>keep.so</filename><moduletype>thread</moduletype>"
        "<operationtype>periodic</operationtype><period>100000</period><priority>1</priority></module>\n"
        "  <module><name>swap</name><filename>swap.so</filename><moduletype>thread</moduletype>"
        "<operationtype>periodic</operationtype><period>1000000</period><priority>2</priority></module>\n"
        "</root>\n"
    )
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
    control = IrpdClient(str(sock), timeout_s=60)
    reports = []
    try:
        time.sleep(1)
        # Misses on the same machine without swaps, for comparison: one interval as long as the swaps take.
        quiet_from = control.request("status")
        swaps_started = time.monotonic()
        for i in range(a.swaps):
            shutil.copy(modules / ("counter_v2.so" if i % 2 == 0 else "counter_v1.so"), folder / "swap.so")
            reports.append(control.request("load", config=str(xml)))
        swaps_took = time.monotonic() - swaps_started
        quiet_start = control.request("status")
        time.sleep(swaps_took)
        quiet_end = control.request("status")
    finally:
        control.close()
        stop(irpd)
    figures = dispatcher_figures(stats)
    keep = next(m for m in figures["doc"]["modules"] if m["name"] == "keep")
    to_swap = [r["request_to_swap_ns"] for r in reports]
    return {
        "swaps": len(reports),
        "all_kept": all(r["kept"] == ["keep"] and r["started"] == ["swap"] for r in reports),
        "request_to_swap_ms": {
            "p50": statistics.median(to_swap) / 1e6,
            "p99": sorted(to_swap)[max(0, int(len(to_swap) * 0.99) - 1)] / 1e6,
            "max": max(to_swap) / 1e6,
        },
        "total_ms_p50": statistics.median(r["total_ns"] for r in reports) / 1e6,
        "missed_periods": sum(r["missed_periods"] for r in reports),
        "swaps_seconds": swaps_took,
        "missed_while_swapping": quiet_start["missed"]
        + quiet_start["skipped"]
        - quiet_from["missed"]
        - quiet_from["skipped"],
        "missed_while_quiet": quiet_end["missed"]
        + quiet_end["skipped"]
        - quiet_start["missed"]
        - quiet_start["skipped"],
        "swaps_with_misses": sum(1 for r in reports if r["missed_periods"]),
        "keep_runs": keep["runs"],
        "keep_skipped": keep["skipped"],
        "keep_missed": keep["missed"],
        "dispatcher_periods": figures["runs"] + figures["skipped"],
        "realtime": figures["realtime"],
    }


# ---- the agent under load ------------------------------------------------------------------------


def rt_cpu(a) -> int:
    return a.cpu


def keep_thread_off(cpu: int) -> None:
    """The clients stand for browsers and scripts on other machines: each client thread keeps off
    irpd's CPU (Linux applies the affinity to the calling thread only)."""
    rest = os.sched_getaffinity(0) - {cpu}
    if rest:
        os.sched_setaffinity(0, rest)


def off_rt(a) -> list[str]:
    """taskset for the agent: every CPU but irpd's, as the demo and a deployment run it."""
    rest = sorted(os.sched_getaffinity(0) - {rt_cpu(a)})
    return ["taskset", "-c", ",".join(map(str, rest))] if rest else []


class Clients:
    """Load on the agent while one irpd phase runs: stream clients and/or a query hammer."""

    def __init__(self, url: str, token: str, paths: list[str], cpu: int):
        from indurop_agent.cli.client import Client

        self.Client, self.url, self.token, self.paths, self.cpu = Client, url, token, paths, cpu
        self.stop = threading.Event()
        self.threads: list[threading.Thread] = []
        self.samples = [0]
        self.dropped: list[int] = []
        self.requests = [0]
        self.errors: list[str] = []
        self.lock = threading.Lock()

    def stream(self, count: int) -> None:
        for _ in range(count):
            self.dropped.append(0)
            self.threads.append(threading.Thread(target=self._stream, args=(len(self.dropped) - 1,), daemon=True))

    def hammer(self) -> None:
        self.threads.append(threading.Thread(target=self._hammer, daemon=True))

    def _stream(self, me: int) -> None:
        keep_thread_off(self.cpu)
        client = self.Client(self.url, self.token)
        try:
            with client.watch(self.paths, 1) as s:
                for frame in s.frames():
                    with self.lock:
                        self.samples[0] += len(frame.t_ns) * len(frame.columns)
                        self.dropped[me] = frame.dropped
                    if self.stop.is_set():
                        break
        except Exception as e:  # noqa: BLE001 -- reported in the results
            self.errors.append(f"stream {me}: {e}")

    def _hammer(self) -> None:
        keep_thread_off(self.cpu)
        client = self.Client(self.url, self.token)
        while not self.stop.is_set():
            for call in (client.status, client.modules, client.schedule):
                try:
                    call()
                    self.requests[0] += 1
                except Exception as e:  # noqa: BLE001
                    self.errors.append(f"hammer: {e}")
                    time.sleep(0.05)

    def __enter__(self):
        for t in self.threads:
            t.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        for t in self.threads:
            t.join(10)


def run_phase(
    a,
    work: Path,
    name: str,
    agent_url: str,
    token: str,
    paths: list[str],
    sock: Path,
    streams: int = 0,
    hammer: bool = False,
) -> dict:
    stats = work / f"{name}.json"
    irpd = start_irpd(a, a.fig1, sock, stats, f"bench-agent-{os.getpid()}", ["--duration", str(a.seconds + 3)])
    from indurop_agent.cli.client import Client

    client = Client(agent_url, token)
    deadline = time.monotonic() + 20
    while client.health().get("irpd") != "ok":  # the agent reconnects to the new irpd
        if time.monotonic() > deadline:
            raise RuntimeError("the agent did not reconnect to irpd")
        time.sleep(0.1)
    time.sleep(1)
    load = Clients(agent_url, token, paths, a.cpu)
    if streams:
        load.stream(streams)
    if hammer:
        load.hammer()
    started = time.monotonic()
    with load:
        time.sleep(a.seconds)
        elapsed = time.monotonic() - started
    irpd.wait(a.seconds + 60)
    figures = dispatcher_figures(stats)
    figures.pop("doc")
    return {
        "name": name,
        "streams": streams,
        "hammer": hammer,
        **figures,
        "samples_per_s": load.samples[0] / elapsed,
        "dropped": sum(load.dropped),
        "requests_per_s": load.requests[0] / elapsed,
        "errors": load.errors[:5],
    }


def run_agent_phases(a, work: Path) -> list[dict]:
    sock, data = work / "irpd.sock", work / "agent-data"
    port = free_port()
    irpd = start_irpd(a, a.fig1, sock, work / "warmup.json", f"bench-agent-{os.getpid()}", ["--duration", "60"])
    agent = subprocess.Popen(
        off_rt(a)
        + [
            sys.executable,
            "-m",
            "indurop_agent",
            "--host",
            "127.0.0.1",
            "--port",
            str(port),
            "--data-dir",
            str(data),
            "--irpd-socket",
            str(sock),
        ],
        cwd=REPO / "agent",
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    url = f"http://127.0.0.1:{port}"
    try:
        from indurop_agent.cli.client import Client

        deadline = time.monotonic() + 30
        while True:
            try:
                Client(url).health()
                break
            except Exception:  # noqa: BLE001 -- not up yet
                if time.monotonic() > deadline:
                    raise RuntimeError("the agent did not start") from None
                time.sleep(0.1)
        token = (data / "admin-token").read_text().strip()
        paths = [v["path"] for v in Client(url, token).variables()["variables"]][:8]
        stop(irpd)
        runs = []
        for r in range(a.rounds):  # rounds alternate the phases, so that the VM's slow minutes hit all of them
            for name, streams, hammer in (
                ("idle", 0, False),
                ("stream-1", 1, False),
                ("stream-10", 10, False),
                ("hammer", 0, True),
            ):
                log(f"round {r + 1}/{a.rounds}, phase {name}: {a.seconds} s")
                runs.append(run_phase(a, work, name, url, token, paths, sock, streams, hammer))
        return runs, paths
    finally:
        stop(agent)
        stop(irpd)


# ---- the report -------------------------------------------------------------------------------------


def us(ns: float) -> str:
    return f"{ns / 1000:.2f}"


def combine(runs: list[dict]) -> list[dict]:
    """One line per phase over its rounds: median p50 and p99, worst max, sums and means."""
    phases = []
    for name in dict.fromkeys(r["name"] for r in runs):
        mine = [r for r in runs if r["name"] == name]
        phases.append(
            {
                "name": name,
                "streams": mine[0]["streams"],
                "hammer": mine[0]["hammer"],
                "p50": statistics.median(r["p50"] for r in mine),
                "p99": statistics.median(r["p99"] for r in mine),
                "p99s": [r["p99"] for r in mine],
                "max": max(r["max"] for r in mine),
                "missed": sum(r["missed"] + r["skipped"] for r in mine),
                "samples_per_s": statistics.mean(r["samples_per_s"] for r in mine),
                "dropped": sum(r["dropped"] for r in mine),
                "requests_per_s": statistics.mean(r["requests_per_s"] for r in mine),
                "realtime": all(r["realtime"] for r in mine),
                "errors": [e for r in mine for e in r["errors"]],
            }
        )
    return phases


def render(a, runs: list[dict], paths: list[str], swaps: dict) -> str:
    phases = combine(runs)
    reference = next(p["p99"] for p in phases if p["name"] == "idle")
    lines = [
        "# Benchmark: the agent and hot reload against the RT core",
        "",
        f"Measured by `.venv/bin/python tests/bench/agent_bench.py --seconds {a.seconds} --rounds {a.rounds} --swaps {a.swaps}` on "
        f"{time.strftime('%Y-%m-%d')} ({os.cpu_count()} CPUs, `{os.uname().release}`; irpd on CPU "
        f"{rt_cpu(a)}, SCHED_FIFO {a.rt_priority}, Figure 1's set at 100 µs; irpd's non-RT threads, the agent "
        "and its clients on the other CPUs). A shared, noisy VM: wake-up latency spikes of milliseconds happen; "
        "the ratios compare phases of one run.",
        "",
        "## irpd's wake-up latency while the agent works",
        "",
        f"Each phase is a fresh irpd for {a.seconds} s with the agent beside it, {a.rounds} rounds of the four phases "
        "in turn; a phase's p50 and p99 are the medians over its rounds, its max the worst, its misses the sum. "
        "Streams carry "
        f"{len(paths)} variables ({', '.join(paths)}) at every basic period (10 000 samples/s each). "
        "Latency = the dispatcher's wake-up minus its due time, from irpd's own histogram. The reference is the "
        f"idle phase's p99 ({us(reference)} µs). Target: p99 ratio ≤ 1.1.",
        "",
        "| phase | clients | samples/s received | samples dropped | requests/s | p50 µs | p99 µs (each round) | max µs | p99 / idle | missed + skipped | realtime |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for p in phases:
        clients = (
            f"{p['streams']} stream" + ("s" if p["streams"] != 1 else "")
            if p["streams"]
            else ("query hammer" if p["hammer"] else "none")
        )
        ratio = p["p99"] / reference if reference else float("nan")
        lines.append(
            f"| {p['name']} | {clients} | {p['samples_per_s']:.0f} | {p['dropped']} | {p['requests_per_s']:.0f} | "
            f"{us(p['p50'])} | {us(p['p99'])} ({', '.join(us(x) for x in p['p99s'])}) | {us(p['max'])} | {ratio:.2f} | {p['missed']} | {p['realtime']} |"
        )
    idle = next(p for p in phases if p["name"] == "idle")
    low, high = min(idle["p99s"]), max(idle["p99s"])
    lines += [
        "",
        f"Resolution: the idle phase's own p99 ranged {us(low)}–{us(high)} µs over its rounds "
        f"({(low / reference - 1) * 100:+.0f} % to {(high / reference - 1) * 100:+.0f} % of its median); a ratio "
        "inside that range cannot be told from this machine's noise.",
    ]
    errors = [e for p in phases for e in p["errors"]]
    if errors:
        lines += ["", "Client errors: " + "; ".join(errors)]
    lines += [
        "",
        "## Hot reload",
        "",
        f"{swaps['swaps']} swaps through the control socket, each a set whose module `swap` (1 ms) was rebuilt as "
        "the other version, beside a kept module `keep` at the 100 µs basic period. Request-to-swap is the time "
        "from the `load` request to the switch of the tables (it includes hashing, copying, dlopen, initialize and "
        "start, and waiting for the next macro-period boundary at least 2 ms ahead).",
        "",
        "| figure | value |",
        "| --- | --- |",
        f"| swaps that kept `keep` and replaced `swap` | {swaps['swaps'] if swaps['all_kept'] else 'NOT all'} of {swaps['swaps']} |",
        f"| request to swap, p50 / p99 / max | {swaps['request_to_swap_ms']['p50']:.2f} / {swaps['request_to_swap_ms']['p99']:.2f} / "
        f"{swaps['request_to_swap_ms']['max']:.2f} ms |",
        f"| whole request (with retiring the old module), p50 | {swaps['total_ms_p50']:.2f} ms |",
        f"| dispatcher periods missed or skipped in the swap windows (request to one macro period after) | {swaps['missed_periods']} ({swaps['swaps_with_misses']} swaps with any) |",
        f"| dispatcher periods missed or skipped over the {swaps['swaps_seconds']:.1f} s of the {swaps['swaps']} swaps, against the same time right after without swaps | "
        f"{swaps['missed_while_swapping']} against {swaps['missed_while_quiet']} |",
        f"| `keep`: runs + skipped vs the dispatcher's periods | {swaps['keep_runs']} + {swaps['keep_skipped']} = "
        f"{swaps['keep_runs'] + swaps['keep_skipped']} of {swaps['dispatcher_periods']} |",
        f"| `keep`: deadline misses (started a whole period late) | {swaps['keep_missed']} |",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=int, default=15, help="length of each agent phase (default 15)")
    ap.add_argument("--rounds", type=int, default=3, help="rounds of the four agent phases (default 3)")
    ap.add_argument("--swaps", type=int, default=100, help="hot reloads to time (default 100)")
    ap.add_argument("--cpu", type=int, default=None, help="irpd's CPU (default: the last one allowed)")
    ap.add_argument("--rt-priority", type=int, default=80)
    ap.add_argument("--build", type=Path, default=REPO / "build", help="the build folder (default build/)")
    ap.add_argument("--out", type=Path, default=REPO / "docs" / "benchmark-agent.md")
    a = ap.parse_args(argv)
    a.irpd = a.build / "bin" / "irpd"
    a.fig1 = a.build / "sets" / "paper-fig1" / "module.xml"
    subprocess.run(
        ["cmake", "--build", str(a.build), "--target", "all", "tests/all"], check=False, stdout=subprocess.DEVNULL
    )
    for needed in (a.irpd, a.fig1, a.build / "tests" / "cpp" / "modules" / "counter_v1.so"):
        if not needed.exists():
            print(f"agent_bench: {needed} is missing: run `bash packaging/build.sh --tests` first", file=sys.stderr)
            return 2
    if a.cpu is None:
        a.cpu = max(os.sched_getaffinity(0))
    with tempfile.TemporaryDirectory(prefix="indurop-agent-bench-") as tmp:
        work = Path(tmp)
        log(f"{a.swaps} hot reloads")
        swaps = run_swaps(a, work)
        phases, paths = run_agent_phases(a, work)
    report = render(a, phases, paths, swaps)
    a.out.write_text(report)
    print(report)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

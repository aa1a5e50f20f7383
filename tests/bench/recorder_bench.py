#!/usr/bin/env python3
"""recorder_bench.py -- the recorder at 64 channels x 10 kHz (docs/recorder.md "Benchmark"): rows
dropped (must be 0), file size per minute, the agent's CPU share and RSS over time, and irpd's
wake-up p99 during the recording divided by its p99 without it, in the same run (phases alternate:
off, on, off, on ...; each "on" is one recording of its whole phase).  Then, in this process, the
cost of writing a row (McapOut: JSON by orjson, zstd chunks) without irpd or the agent.

irpd runs tests/bench/recorder (rec_source.so: rec.row and 63 doubles, every one changing every
period) at 100 us on its dispatcher CPU (the last one); the agent and this script run on the other
CPUs, as the demo and the .deb's units run the agent.  Not in CI: run it when nothing else loads
the machine.  The issue's record is 10 minutes of recording:

    .venv/bin/python tests/bench/recorder_bench.py [--minutes 1] [--phases 2] [--json out.json]
    .venv/bin/python tests/bench/recorder_bench.py --encode-only
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "python"))
sys.path.insert(0, str(ROOT / "agent"))
sys.path.insert(0, str(ROOT / "tests" / "bench"))
import httpx  # noqa: E402
from dds_bench import wakeup_p99  # noqa: E402
from indurop_agent.irpd.client import IrpdClient, IrpdRefused  # noqa: E402
from indurop_agent.recorder import mcap_read  # noqa: E402
from indurop_agent.recorder.mcap_out import McapOut, Variable  # noqa: E402
from live_processes import BUILD, free_port, start_agent, start_irpd, stop, wait_dispatching  # noqa: E402

SOURCE = BUILD / "bench" / "recorder"
BASIC_NS = 100_000
CHANNELS = ["rec.row", *(f"rec.ch[{k}]" for k in range(63))]
MODULE_XML = f"""<?xml version="1.0" encoding="UTF-8"?>
<root>
<module>
  <filename>./rec_source.so</filename>
  <moduletype>thread</moduletype>
  <operationtype>periodic</operationtype>
  <period>{BASIC_NS}</period>
  <priority>1</priority>
</module>
</root>
"""


def log(*a) -> None:
    print("recorder_bench:", *a, file=sys.stderr, flush=True)


class ProcessSampler:
    """The agent's CPU time and RSS every `every_s` (from /proc), tagged with the phase."""

    def __init__(self, pid: int, every_s: float = 5.0):
        self.pid, self.every_s = pid, every_s
        self.samples: list[tuple[str, float, float, int]] = []  # (phase, monotonic, cpu seconds, rss bytes)
        self.phase = "off"
        self.stopping = threading.Event()
        self.ticks = os.sysconf("SC_CLK_TCK")
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def read(self) -> tuple[float, int]:
        fields = Path(f"/proc/{self.pid}/stat").read_text().rsplit(")", 1)[1].split()
        cpu = (int(fields[11]) + int(fields[12])) / self.ticks  # utime + stime
        rss = next(
            int(line.split()[1]) * 1024
            for line in Path(f"/proc/{self.pid}/status").read_text().splitlines()
            if line.startswith("VmRSS:")
        )
        return cpu, rss

    def run(self) -> None:
        while not self.stopping.is_set():
            cpu, rss = self.read()
            self.samples.append((self.phase, time.monotonic(), cpu, rss))
            self.stopping.wait(self.every_s)

    def share(self, phase: str) -> float | None:
        """The agent's CPU time over wall time in the phases named `phase` (1.0: one whole CPU)."""
        busy = wall = 0.0
        for (p0, t0, c0, _), (p1, t1, c1, _) in zip(self.samples, self.samples[1:]):
            if p0 == p1 == phase:
                busy, wall = busy + c1 - c0, wall + t1 - t0
        return busy / wall if wall else None


class ApiProbe:
    """GET /health every 0.2 s: how long the agent takes to answer, tagged with the phase."""

    def __init__(self, url: str, sampler: ProcessSampler):
        self.url, self.sampler = url, sampler
        self.samples: list[tuple[str, float]] = []
        self.stopping = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self) -> None:
        with httpx.Client(timeout=30) as client:
            while not self.stopping.wait(0.2):
                t0 = time.perf_counter()
                client.get(f"{self.url}/health")
                self.samples.append((self.sampler.phase, time.perf_counter() - t0))

    def percentiles(self, on: bool) -> dict:
        got = sorted(s for p, s in self.samples if p.startswith("on") == on)
        if not got:
            return {}
        return {"p50_ms": got[len(got) // 2] * 1e3, "p99_ms": got[int(len(got) * 0.99)] * 1e3, "count": len(got)}


def encode_cost(rows: int = 20_000) -> dict:
    """Writing rows of 64 channels with McapOut, in this process: microseconds per row, bytes per row."""
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "encode.mcap"
        out = McapOut(path, [Variable(p, "double") for p in CHANNELS], title="bench", basic_period_ns=BASIC_NS)
        block, spent = 2000, 0.0
        for first in range(1, rows + 1, block):
            seqs = range(first, first + block)
            columns = [[float(s) for s in seqs]] + [[math.sin(0.001 * s * (k + 1)) for s in seqs] for k in range(63)]
            t0 = time.perf_counter()
            out.add_rows(seqs, [s * BASIC_NS for s in seqs], columns)
            spent += time.perf_counter() - t0
        t0 = time.perf_counter()
        out.flush()
        spent += time.perf_counter() - t0
        size = out.close()
    return {"rows": rows, "us_per_row": spent / rows * 1e6, "bytes_per_row": size / rows}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=1.0, help="minutes of recording in all (the issue's record: 10)")
    ap.add_argument("--phases", type=int, default=2, help="pairs of (without, with) a recording")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--encode-only", action="store_true", help="only the cost of writing rows, in this process")
    ap.add_argument("--keep", action="store_true", help="keep the recordings (in a folder under /tmp) for a look")
    args = ap.parse_args()
    results: dict = {"encode": encode_cost()}
    log(
        f"writing a row of 64 channels: {results['encode']['us_per_row']:.1f} us, {results['encode']['bytes_per_row']:.0f} B"
    )
    if args.encode_only:
        print(json.dumps(results, indent=1))
        return 0
    if not (SOURCE / "rec_source.so").exists():
        sys.exit(f"recorder_bench: {SOURCE}/rec_source.so is not built: bash packaging/build.sh --tests")
    phase_s = args.minutes * 60 / args.phases
    work = Path(tempfile.mkdtemp(prefix="recorder-bench-"))
    (SOURCE / "module.xml").write_text(MODULE_XML)
    cpus = os.cpu_count() or 1
    sock = work / "irpd.sock"
    irpd = start_irpd(sock, SOURCE / "module.xml", f"rec-bench-{os.getpid()}")
    if cpus > 1:
        os.sched_setaffinity(0, range(cpus - 1))  # this process and the agent it starts: off irpd's CPU
    control = IrpdClient(str(sock), timeout_s=30)
    wait_dispatching(control)
    port = free_port()
    config = work / "agent.json"  # room for the 10 minutes (about 0.5 GB a minute)
    config.write_text(json.dumps({"recordings_quota_bytes": 64 << 30}))
    agent = start_agent(port, work / "data", sock, "--config", str(config), log=work / "agent.log")
    api = f"http://127.0.0.1:{port}/api/v1"
    auth = {"Authorization": f"Bearer {(work / 'data' / 'admin-token').read_text().strip()}"}
    sampler = ProcessSampler(agent.pid)
    probe = ApiProbe(api, sampler)
    results.update(phase_s=phase_s, phases=args.phases, channels=len(CHANNELS), basic_period_ns=BASIC_NS)
    results.update(off_p99_ns=[], on_p99_ns=[], recordings=[])
    try:
        for phase in range(args.phases):
            sampler.phase = "off"
            h0 = control.request("histograms", name="dispatcher")
            time.sleep(phase_s)
            off = wakeup_p99(h0, control.request("histograms", name="dispatcher"))
            name = f"bench-{phase + 1}"
            body = {"name": name, "variables": CHANNELS, "stop": {"duration_s": phase_s}}
            r = httpx.post(f"{api}/recordings", json=body, headers=auth, timeout=30)
            r.raise_for_status()
            sampler.phase = f"on-{phase + 1}"
            h0 = control.request("histograms", name="dispatcher")
            while httpx.get(f"{api}/recordings/{name}", headers=auth, timeout=30).json()["state"] == "recording":
                time.sleep(1)
            on = wakeup_p99(h0, control.request("histograms", name="dispatcher"))
            done = httpx.get(f"{api}/recordings/{name}", headers=auth, timeout=30).json()
            found = mcap_read.scan(work / "data" / "recordings" / name / "part-0001.mcap")
            contiguous = found.last_seq - found.first_seq + 1 == found.rows if found.rows else False
            rss = [s[3] for s in sampler.samples if s[0] == sampler.phase]
            results["off_p99_ns"].append(off)
            results["on_p99_ns"].append(on)
            results["recordings"].append(
                {
                    "name": name,
                    "state": done["state"],
                    "cause": done["cause"],
                    "rows": done["rows"],
                    "rows_expected": round(phase_s * 1e9 / BASIC_NS),
                    "drops": done["drops"],
                    "gaps": len(done["gaps"]),
                    "rows_in_file": found.rows,
                    "contiguous": contiguous,
                    "size": done["size"],
                    "mb_per_minute": done["size"] / 1e6 / (phase_s / 60),
                    "agent_cpu_share": sampler.share(sampler.phase),
                    "agent_rss_mb": [round(x / 2**20, 1) for x in rss],
                }
            )
            log(f"phase {phase + 1}: wake-up p99 without {off} ns, with {on} ns; {results['recordings'][-1]}")
        results["agent_cpu_share_off"] = sampler.share("off")
        results["api_health_off"], results["api_health_on"] = probe.percentiles(False), probe.percentiles(True)
        results["wakeup_p99_ratio"] = statistics.median(results["on_p99_ns"]) / statistics.median(results["off_p99_ns"])
        results["load_average"] = os.getloadavg()
    finally:
        sampler.stopping.set()
        probe.stopping.set()
        control.close()
        stop(agent)
        stop(irpd)
        (SOURCE / "module.xml").unlink(missing_ok=True)
        if args.keep:
            log(f"the recordings are in {work / 'data' / 'recordings'}")
        else:
            shutil.rmtree(work, ignore_errors=True)
    print(json.dumps(results, indent=1))
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

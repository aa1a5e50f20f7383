#!/usr/bin/env python3
"""soak.py -- the plc-robot cell run for a long time under load, as an appliance runs for months.

    .venv/bin/python tests/bench/soak.py [--minutes 10] [--cell module.xml] [--out-json F] [--out-md F]

One run, in this order, on a machine with at least two CPUs:
  1. irpd runs build/sets/plc-robot (pinned to --cpu, SCHED_FIFO) with its drive simulator, the
     agent beside it on the other CPU(s), the PLC cycle started and repeating (PLC_IN.Enable,
     CycleMode, I0 through the agent's API);
  2. for --minutes: stress-ng loads the other CPU(s) (at nice 19: see --stress-nice), --clients WebSocket clients stream 8 joint
     variables at every basic period, and every --reload-s a hot reload changes the PLC program's
     priority (3 <-> 4: a swap at a macro-period boundary that keeps every module);
     the RSS of irpd and of the agent is sampled every --rss-every-s;
  3. irpd's figures are read (GET /jitter, /jitter/histograms) and irpd stopped;
  4. cyclictest runs --cyclictest-minutes on the same CPU, at the same priority and interval,
     under the same stress-ng load and with the agent and its clients still connected: the
     reference of the wake-up latency.
Reports (JSON and a markdown table): irpd's wake-up latency and Eq. (1) jitter (max, p99.99)
against cyclictest's latency, overruns, misses, samples received and dropped, RSS growth as a
least-squares slope after the first minute, swaps done and the periods missed during swaps.
Timing figures are never asserted by tests: docs/soak.md records a run.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import httpx

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "tests" / "python"))
sys.path.insert(0, str(REPO / "agent"))

import live_processes  # noqa: E402  (copy_cell, start_irpd, stop: as the cell's tests run it)
from indurop_agent.cli.client import Client  # noqa: E402

STREAMED = [f"PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[{i}]" for i in range(6)] + [
    "PLC_ROBOT.PLC_OUT.Step",
    "PLC_ROBOT.PLC_OUT.Cycles",
]
RELOADED = ("main", 3, 4)  # the PLC program: lowest priority already, so 3 <-> 4 changes no order


def log(msg: str) -> None:
    print(f"[soak] {msg}", file=sys.stderr, flush=True)


def within(seconds: float, condition) -> bool:
    """Whether `condition()` holds within `seconds` (asked every 100 ms)."""
    deadline = time.monotonic() + seconds
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.1)
    return True


def rss_kib(pid: int) -> int | None:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    except OSError:
        return None
    return None


def slope_per_min(points: list[tuple[float, int]]) -> float | None:
    """Least-squares slope of (seconds, KiB) in KiB per minute."""
    if len(points) < 3:
        return None
    n = len(points)
    mx = sum(t for t, _ in points) / n
    my = sum(v for _, v in points) / n
    sxx = sum((t - mx) ** 2 for t, _ in points)
    return 60 * sum((t - mx) * (v - my) for t, v in points) / sxx if sxx else None


def percentile_from_buckets(h: dict, q: float, absolute: bool = False) -> float | None:
    """The upper edge of the bucket holding quantile q of an irpd histogram (GET /jitter/histograms);
    absolute: of |x| (a negative bucket [low, low + width) holds |x| up to |low|)."""
    edges = [
        (abs(b["low_ns"]) if absolute and b["low_ns"] < 0 else b["low_ns"] + b["width_ns"], b["count"])
        for b in h["buckets"]
    ]
    total = sum(n for _, n in edges)
    if not total:
        return None
    top = max(abs(h["min"]), abs(h["max"])) if absolute else h["max"]
    seen = 0
    for edge, n in sorted(edges):
        seen += n
        if seen >= q * total:
            return min(edge, top)
    return top


def cyclictest(cpu: int, priority: int, interval_us: int, seconds: int, work: Path) -> dict:
    """cyclictest's wake-up latency (µs histogram up to 20 ms): samples, p99.99, max, overflows."""
    hist = work / "cyclictest-hist.txt"
    cmd = [
        "cyclictest",
        "-m",
        "-q",
        "-p",
        str(priority),
        "-i",
        str(interval_us),
        "-a",
        str(cpu),
        "-t",
        "1",
        "-D",
        str(seconds),
        "-h",
        "20000",
        f"--histfile={hist}",
    ]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=seconds + 60)
    if done.returncode != 0:
        raise RuntimeError(f"cyclictest failed: {done.stderr.strip()}")
    counts, maximum, overflows = {}, None, 0
    for line in hist.read_text().splitlines():
        if line.startswith("# Max Latencies"):
            maximum = int(line.split(":")[1].split()[0])
        elif line.startswith("# Histogram Overflows"):
            overflows = int(line.split(":")[1].split()[0])
        elif line and line[0].isdigit():
            us, n = line.split()[:2]
            counts[int(us)] = int(n)
    total = sum(counts.values()) + overflows
    seen, p9999 = 0, None
    for us in sorted(counts):
        seen += counts[us]
        if seen >= 0.9999 * total:
            p9999 = us + 1
            break
    # p99.99 beyond the histogram (more than 0.01 % of the samples over 20 ms): None, shown as "> 20 ms".
    return {
        "samples": total,
        "p99_99_ns": p9999 * 1000 if p9999 is not None else None,
        "max_ns": maximum * 1000 if maximum is not None else None,
        "overflows": overflows,
        "command": " ".join(cmd[:-1]),
    }


class Streams:
    """--clients stream clients, each in its own thread, counting samples and the server's drop counter."""

    def __init__(self, url: str, token: str, count: int, other_cpus: set[int]):
        self.url, self.token, self.other = url, token, other_cpus
        self.stop = threading.Event()
        self.samples = [0] * count
        self.dropped = [0] * count
        self.errors: list[str] = []
        self.threads = [threading.Thread(target=self._run, args=(i,), daemon=True) for i in range(count)]

    def start(self) -> None:
        for t in self.threads:
            t.start()

    def _run(self, me: int) -> None:
        os.sched_setaffinity(0, self.other)
        while not self.stop.is_set():
            try:
                with Client(self.url, self.token, timeout=30).watch(STREAMED, 1) as s:
                    for frame in s.frames():
                        self.samples[me] += len(frame.t_ns)
                        self.dropped[me] = max(self.dropped[me], frame.dropped)
                        if self.stop.is_set():
                            return
            except Exception as e:  # noqa: BLE001 -- a lost stream is reported, then reopened
                self.errors.append(f"client {me}: {e}")
                time.sleep(1)

    def finish(self) -> None:
        """Stops counting; a client blocked on a silent stream (irpd stopped) is left to die with the
        script (daemon threads), after 10 s for all of them together."""
        self.stop.set()
        deadline = time.monotonic() + 10
        for t in self.threads:
            t.join(max(0.0, deadline - time.monotonic()))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--cell", default="module.xml", help="module.xml (10 ms) or module-1ms.xml (1 ms) of the cell")
    ap.add_argument("--clients", type=int, default=10)
    ap.add_argument("--reload-s", type=float, default=10.0)
    ap.add_argument("--rss-every-s", type=float, default=10.0)
    ap.add_argument("--cyclictest-minutes", type=float, default=None, help="default: min(--minutes, 2)")
    ap.add_argument("--cpu", type=int, default=max(os.sched_getaffinity(0)), help="irpd's (and cyclictest's) CPU")
    ap.add_argument("--rt-priority", type=int, default=80)
    ap.add_argument(
        "--comm-timeout-s",
        type=float,
        default=10.0,
        help="silence of the simulated drives before comm loss (a shared VM starves them at times)",
    )
    ap.add_argument(
        "--drives-priority",
        type=int,
        default=10,
        help="SCHED_FIFO priority of the drive simulator (0: as the cell's module.xml has it, 10).  Real drives run on "
        "their own CPUs; on the shared CPU the agent's load would starve the simulator and the "
        "robot stop with a following error or lost communication",
    )
    ap.add_argument(
        "--no-restart",
        dest="restart_cell",
        action="store_false",
        help="leave the cell stopped when the PLC reports an error (by default the soak resets and "
        "starts it again, as an operator would, and counts it)",
    )
    ap.add_argument("--no-stress", action="store_true", help="without stress-ng (to compare)")
    ap.add_argument(
        "--stress-nice",
        type=int,
        default=19,
        help="stress-ng's nice value: at 19 it takes every cycle the agent, its clients and the drive "
        "simulator (which stands for drives on the network) leave",
    )
    ap.add_argument(
        "--tracemalloc",
        type=int,
        default=0,
        metavar="FRAMES",
        help="trace the agent's Python allocations (slows it): a snapshot at --snapshot-min and one at "
        "the end, and the call sites that grew between them in the report",
    )
    ap.add_argument("--snapshot-min", type=float, default=2.0)
    ap.add_argument("--out-json", type=Path)
    ap.add_argument("--out-md", type=Path)
    a = ap.parse_args()
    other = os.sched_getaffinity(0) - {a.cpu}
    if not other:
        ap.error("the soak needs two CPUs: one for irpd, one for the load, the agent and its clients")
    for tool in ("cyclictest",) + (() if a.no_stress else ("stress-ng",)):
        if not shutil.which(tool):
            ap.error(f"{tool} is not installed (bash packaging/deps.sh installs it)")
    if not live_processes.IRPD.exists():
        ap.error(f"irpd is not built ({live_processes.IRPD}); bash packaging/build.sh")
    seconds = int(a.minutes * 60)
    ct_seconds = int(60 * (a.cyclictest_minutes if a.cyclictest_minutes is not None else min(a.minutes, 2)))

    work = Path(tempfile.mkdtemp(prefix="indurop-soak-"))
    procs: list[subprocess.Popen] = []
    streams = None
    ok = False
    try:
        # The drive simulator stands for drives on the network but shares this machine's CPUs: give
        # it --comm-timeout-s of silence before the I/O dispatcher calls the drives lost.
        period_ms = 1 if "1ms" in a.cell else 10
        config, _ = live_processes.copy_cell(
            work / "cell", a.cell, fail_limit=min(1000, max(1, int(a.comm_timeout_s * 1000 / period_ms)))
        )
        sock = work / "irpd.sock"
        irpd = live_processes.start_irpd(
            sock,
            config,
            f"soak-{os.getpid()}",
            "--cpu",
            str(a.cpu),
            "--rt-priority",
            str(a.rt_priority),
            log=work / "irpd.log",
            module_output=True,
        )
        procs.append(irpd)
        os.sched_setaffinity(0, other)  # this script, its threads and what it starts next stay off irpd's CPU
        drives = live_processes.drive_simulator_realtime(irpd.pid, a.drives_priority)
        port = live_processes.free_port()
        # on the other CPUs (this script's affinity, inherited), as a deployment runs it; with
        # --tracemalloc, Python's tracer runs in it (memtrace.py: SIGUSR2 writes a snapshot)
        tracing = {"PYTHONTRACEMALLOC": str(a.tracemalloc)} if a.tracemalloc else {}
        agent = live_processes.start_agent(
            port,
            work / "data",
            sock,
            log=work / "agent.log",
            env=tracing,
            timeout_s=live_processes.START_TIMEOUT_S * (3 if tracing else 1),
        )  # tracing imports slowly
        procs.append(agent)
        url = f"http://127.0.0.1:{port}/api/v1"
        token = (work / "data" / "admin-token").read_text().strip()
        api = httpx.Client(base_url=url, headers={"Authorization": f"Bearer {token}"}, timeout=60)

        def write(path: str, value) -> None:
            r = api.put(f"/variables/{path}", json={"value": value})
            if r.status_code != 200:
                raise RuntimeError(f"writing {path}: {r.status_code} {r.text}")

        r = api.get("/status")
        if r.status_code != 200:
            raise RuntimeError(f"GET /status: {r.status_code} {r.text}")
        status = r.json()
        basic_ns = status["basic_period_ns"]
        log(f"irpd runs {a.cell} (basic period {basic_ns / 1e6:g} ms) on CPU {a.cpu}; agent on {sorted(other)}")

        def read(path: str):
            return api.get(f"/variables/PLC_ROBOT.{path}").json().get("value")

        if not within(30, lambda: read("IO_STATUS.comm_lost[0]") == 0 and read("IO_STATUS.cycles")):
            raise RuntimeError("the drive simulator did not answer within 30 s")
        if read("ROBOT_MODULE_STATE.ErrorID"):  # the drives answered late at start: clear the latched error
            write("PLC_ROBOT.PLC_IN.Reset", 1)
            time.sleep(0.5)
            write("PLC_ROBOT.PLC_IN.Reset", 0)
        write("PLC_ROBOT.PLC_IN.Enable", 1)
        write("PLC_ROBOT.PLC_IN.CycleMode", 1)
        if not within(30, lambda: read("PLC_OUT.Powered") == 1):
            seen = {
                v: read(v)
                for v in (
                    "ROBOT_MODULE_STATE.Powered",
                    "ROBOT_MODULE_STATE.ErrorID",
                    "PLC_OUT.ErrorID",
                    "IO_STATUS.comm_lost[0]",
                )
            }
            raise RuntimeError(f"the drives did not power up within 30 s: {seen}")
        write("PLC_ROBOT.I0", 1)

        def restart_cell() -> bool:
            """What an operator does when the cell stopped on an error: Reset, power on, Start."""
            for path, value in (("PLC_IN.Enable", 0), ("I0", 0), ("PLC_IN.Reset", 1)):
                write(f"PLC_ROBOT.{path}", value)
            within(5, lambda: not read("PLC_OUT.Error"))
            write("PLC_ROBOT.PLC_IN.Reset", 0)
            write("PLC_ROBOT.PLC_IN.Enable", 1)
            within(10, lambda: read("PLC_OUT.Powered") == 1)
            write("PLC_ROBOT.I0", 1)
            return read("PLC_OUT.Powered") == 1 and not read("PLC_OUT.Error")

        io_before = {"cycles": read("IO_STATUS.cycles"), "errors": read("IO_STATUS.errors[0]")}
        plc_faults = []
        stress = None
        if not a.no_stress:
            stress = subprocess.Popen(
                [
                    "nice",
                    "-n",
                    str(a.stress_nice),
                    "stress-ng",
                    "--cpu",
                    str(len(other)),
                    "--vm",
                    "1",
                    "--vm-bytes",
                    "128M",
                    "--taskset",
                    ",".join(map(str, sorted(other))),
                    "--timeout",
                    str(seconds + ct_seconds + 120),
                    "--quiet",
                ],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
            procs.append(stress)
        streams = Streams(url, token, a.clients, other)
        streams.start()

        before = api.get("/jitter").json()
        rss = {"irpd": [], "agent": []}
        swaps = []
        swap_errors = []
        started = time.monotonic()
        next_reload = started + a.reload_s
        next_rss = started
        flip = 0
        snapshot_at = started + 60 * a.snapshot_min if a.tracemalloc else None
        log(
            f"soaking for {a.minutes:g} min: {a.clients} stream clients, a hot reload every {a.reload_s:g} s"
            f"{'' if a.no_stress else ', stress-ng on the other CPU(s)'}"
        )
        while (now := time.monotonic()) < started + seconds:
            if now >= next_rss:
                for name, p in (("irpd", irpd), ("agent", agent)):
                    kib = rss_kib(p.pid)
                    if kib is not None:
                        rss[name].append((round(now - started, 1), kib))
                next_rss += a.rss_every_s
                if a.restart_cell and read("PLC_OUT.Error"):
                    fault = {
                        "at_s": round(now - started, 1),
                        "error_id": read("PLC_OUT.ErrorID"),
                        "robot_error_id": read("ROBOT_MODULE_STATE.ErrorID"),
                        "io_errors_so_far": read("IO_STATUS.errors[0]") - io_before["errors"],
                    }
                    fault["restarted"] = restart_cell()
                    plc_faults.append(fault)
            if now >= next_reload:
                flip ^= 1
                name, low, high = RELOADED
                t0 = time.monotonic()
                r = api.patch(f"/modules/{name}", json={"priority": high if flip else low})
                if r.status_code == 200:
                    body = r.json()
                    reports = body.get("reports") or [body]
                    swaps.append(
                        {
                            "at_s": round(t0 - started, 1),
                            "took_s": round(time.monotonic() - t0, 3),
                            "missed_periods": sum(x.get("missed_periods") or 0 for x in reports),
                            "kept": len(reports[-1].get("kept") or []),
                        }
                    )
                else:
                    swap_errors.append(f"{r.status_code}: {r.text[:200]}")
                next_reload += a.reload_s
            if snapshot_at is not None and now >= snapshot_at:
                agent.send_signal(signal.SIGUSR2)
                snapshot_at = None
            if irpd.poll() is not None or agent.poll() is not None:
                raise RuntimeError("irpd or the agent stopped during the soak")
            time.sleep(0.2)

        memory = None
        if a.tracemalloc:
            agent.send_signal(signal.SIGUSR2)
            memory = agent_memory_growth(work / "data" / "memtrace", rss["agent"], a.snapshot_min)
        after = api.get("/jitter").json()
        hist = api.get("/jitter/histograms", params={"name": "dispatcher"}).json()["records"][0]
        cycles = api.get("/variables/PLC_ROBOT.PLC_OUT.Cycles").json()["value"]
        io = {
            "cycles": read("IO_STATUS.cycles") - io_before["cycles"],
            "failed_transactions_device_0": read("IO_STATUS.errors[0]") - io_before["errors"],
        }
        plc_error = api.get("/variables/PLC_ROBOT.PLC_OUT.ErrorID").json()["value"]
        events = api.get("/events", params={"limit": 1000}).json()
        live_processes.stop(irpd)
        log(f"irpd stopped; cyclictest for {ct_seconds} s on CPU {a.cpu} under the same load")
        reference = cyclictest(a.cpu, a.rt_priority, basic_ns // 1000, ct_seconds, work)
        streams.finish()

        disp_b = before["executors"][0]
        disp_a = after["executors"][0]
        lat, jit = hist["latency_ns"], hist["jitter_ns"]
        irpd_fig = {
            "periods": disp_a["runs"] - disp_b["runs"],
            "latency_p99_99_ns": percentile_from_buckets(lat, 0.9999),
            "latency_max_ns": lat["max"],
            "jitter_p99_99_ns": percentile_from_buckets(jit, 0.9999, absolute=True),
            "jitter_max_abs_ns": max(abs(jit["max"]), abs(jit["min"])),
            "overruns": disp_a["overruns"] - disp_b["overruns"],
            "missed": disp_a["missed"] - disp_b["missed"],
            "skipped": (disp_a.get("skipped") or 0) - (disp_b.get("skipped") or 0),
            "module_overruns": {
                m["name"]: m["overruns"] - b["overruns"] for m, b in zip(after["modules"], before["modules"])
            },
            "module_missed": {
                m["name"]: m["missed"] - b["missed"] for m, b in zip(after["modules"], before["modules"])
            },
            "histograms_since": "irpd's start (percentiles and max); counters: the soak only",
        }
        result = {
            "cell": a.cell,
            "basic_period_ns": basic_ns,
            "minutes": a.minutes,
            "clients": a.clients,
            "stress": not a.no_stress,
            "cpu": a.cpu,
            "realtime": status.get("realtime"),
            "irpd": irpd_fig,
            "cyclictest": reference,
            "ratio_latency_p99_99": (
                irpd_fig["latency_p99_99_ns"] / reference["p99_99_ns"] if reference["p99_99_ns"] else None
            ),
            "ratio_latency_max": irpd_fig["latency_max_ns"] / reference["max_ns"] if reference["max_ns"] else None,
            "stream": {
                "samples_received": sum(streams.samples),
                "dropped": sum(streams.dropped),
                "per_client_dropped": streams.dropped,
                "errors": streams.errors[:10],
            },
            "swaps": {
                "done": len(swaps),
                "failed": len(swap_errors),
                "errors": swap_errors[:5],
                "missed_periods": sum(s["missed_periods"] for s in swaps),
                "swaps_with_misses": sum(1 for s in swaps if s["missed_periods"]),
                "took_s_max": max((s["took_s"] for s in swaps), default=None),
            },
            "rss_kib": {
                name: {
                    "first": pts[0][1] if pts else None,
                    "last": pts[-1][1] if pts else None,
                    "slope_kib_per_min_after_1min": slope_per_min([p for p in pts if p[0] >= 60]),
                    "samples": pts,
                }
                for name, pts in rss.items()
            },
            "plc": {"cycles": cycles, "error_id": plc_error, "faults": plc_faults},
            "io": io,
            "drive_simulator": drives,
            "agent_memory_trace": memory,
            "irpd_events": sorted({e["kind"] for e in events.get("events", [])}),
        }
        ok = True
    finally:
        if streams is not None:
            streams.stop.set()
        for p in reversed(procs):
            live_processes.stop(p) if p.poll() is None else None
        if ok:
            shutil.rmtree(work, ignore_errors=True)
        else:
            log(f"failed: irpd's and the agent's output are kept in {work} (irpd.log, agent.log)")

    table = markdown(result)
    print(table)
    if a.out_json:
        a.out_json.write_text(json.dumps(result, indent=1))
    if a.out_md:
        a.out_md.write_text(table)
    return 0


def agent_memory_growth(folder: Path, rss: list[tuple[float, int]], from_min: float) -> dict:
    """The two snapshots' comparison (memtrace.growth) beside the RSS growth over the same span."""
    from indurop_agent.system import memtrace

    deadline = time.monotonic() + 120  # a snapshot of a big heap takes a while
    while len(snaps := sorted(folder.glob("*.snap"), key=lambda p: int(p.stem.rsplit("-", 1)[1]))) < 2:
        if time.monotonic() > deadline:
            return {"error": f"{len(snaps)} snapshots in {folder} after 120 s"}
        time.sleep(0.5)
    g = memtrace.growth(snaps[0], snaps[-1], top=10)
    span = [kib for t, kib in rss if t >= from_min * 60]
    g["rss_kib_over_the_same_span"] = {"first": span[0], "last": span[-1]} if span else None
    return g


def ms(ns) -> str:
    return "> 20 ms (past the histogram)" if ns is None else f"{ns / 1e6:.3f} ms"


def ratio(value) -> str:
    return "–" if value is None else f"{value:.2f}"


def per_min(slope) -> str:
    return "– (under a minute)" if slope is None else f"{slope:+.1f} KiB/min"


def markdown(r: dict) -> str:
    i, c, s, w = r["irpd"], r["cyclictest"], r["stream"], r["swaps"]
    rows = [
        (
            "run",
            f"{r['minutes']:g} min, {r['cell']} (basic period {r['basic_period_ns'] / 1e6:g} ms), CPU {r['cpu']}, "
            f"{r['clients']} stream clients, {'stress-ng on the other CPU' if r['stress'] else 'no stress-ng'}",
        ),
        ("irpd periods run", f"{i['periods']}"),
        (
            "wake-up latency p99.99: irpd / cyclictest",
            f"{ms(i['latency_p99_99_ns'])} / {ms(c['p99_99_ns'])} (ratio {ratio(r['ratio_latency_p99_99'])})",
        ),
        (
            "wake-up latency max: irpd / cyclictest",
            f"{ms(i['latency_max_ns'])} / {ms(c['max_ns'])} (ratio {ratio(r['ratio_latency_max'])})",
        ),
        ("jitter, Eq. (1), |p99.99| / max |·|", f"{ms(i['jitter_p99_99_ns'])} / {ms(i['jitter_max_abs_ns'])}"),
        ("cyclictest samples", f"{c['samples']} ({c['overflows']} over 20 ms)"),
        ("dispatcher overruns / missed / skipped", f"{i['overruns']} / {i['missed']} / {i['skipped']}"),
        ("module overruns", ", ".join(f"{k} {v}" for k, v in i["module_overruns"].items())),
        (
            "stream samples received / dropped",
            f"{s['samples_received']} / {s['dropped']}"
            f"{' (errors: ' + str(len(s['errors'])) + ')' if s['errors'] else ''}",
        ),
        ("hot reloads done / failed", f"{w['done']} / {w['failed']}"),
        ("periods missed during swaps", f"{w['missed_periods']} ({w['swaps_with_misses']} swaps with a miss)"),
        (
            "RSS irpd: first → last, slope after 1 min",
            f"{r['rss_kib']['irpd']['first']} → {r['rss_kib']['irpd']['last']} KiB, "
            f"{per_min(r['rss_kib']['irpd']['slope_kib_per_min_after_1min'])}",
        ),
        (
            "RSS agent: first → last, slope after 1 min",
            f"{r['rss_kib']['agent']['first']} → {r['rss_kib']['agent']['last']} KiB, "
            f"{per_min(r['rss_kib']['agent']['slope_kib_per_min_after_1min'])}",
        ),
        ("PLC cycles completed, ErrorID at the end", f"{r['plc']['cycles']}, {r['plc']['error_id']}"),
        (
            "PLC stopped on an error, restarted",
            f"{len(r['plc'].get('faults', []))} times (ErrorIDs "
            f"{sorted({f['error_id'] for f in r['plc'].get('faults', [])})}), "
            f"{sum(f['restarted'] for f in r['plc'].get('faults', []))} restarts succeeded",
        ),
        (
            "I/O cycles, failed Modbus transactions (drives)",
            f"{r['io']['cycles']}, {r['io']['failed_transactions_device_0']}" if r.get("io") else "–",
        ),
        ("drive simulator", r.get("drive_simulator", "a normal process")),
    ]
    m = r.get("agent_memory_trace")
    if m and "error" not in m:
        rows.append(
            (
                "agent: Python-traced memory, snapshot → end",
                f"{m['traced_kib']['old']} → {m['traced_kib']['new']} KiB (RSS {m['rss_kib_over_the_same_span']})",
            )
        )
        rows += [
            (f"grew: {d['where'][-1]}", f"{d['size_diff_kib']:+.1f} KiB, {d['count_diff']:+d} blocks")
            for d in m["top"][:5]
        ]
    elif m:
        rows.append(("agent memory trace", m["error"]))
    return "| figure | value |\n| --- | --- |\n" + "".join(f"| {k} | {v} |\n" for k, v in rows)


if __name__ == "__main__":
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(1))
    sys.exit(main())

#!/usr/bin/env python3
"""io_load.py -- the plc-robot cell's I/O path under load: the shipped cell (its ioconfig.xml as
shipped: timeout 4 ms, 3 failed rounds make comm loss), cycling, with the Robot and Variables pages
open in chromium on the same machine and stress-ng on the CPU(s) irpd's dispatcher does not use.
It counts the Modbus transactions and the failed ones and finds where each slow one lost its time.

Where the time goes, measured from three sides:
- the wire: tcpdump on loopback (kernel timestamps) gives each request's send time and its
  answer's, paired by the Modbus TCP transaction id: the simulator's answer time;
- iodispat: IO_STATUS.errors and cycles (its own count of failed transactions and rounds);
- the kernel: the simulator's run-queue wait (/proc/PID/schedstat), the machine's steal time
  (/proc/stat: the hypervisor ran something else) and the simulator's CPU, sampled every second.

    .venv/bin/python tests/bench/io_load.py --minutes 30 --out-json io-30.json --out-md io-30.md

Needs two CPUs, root (SCHED_FIFO, tcpdump), stress-ng and tcpdump (packaging/deps.sh), the web UI
built, Playwright's node package (tests/browser) and Debian's chromium.  docs/io-load.md reads the
results."""

from __future__ import annotations

import argparse
import json
import os
import secrets
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import dpkt
import httpx

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))
import kernel_trace  # noqa: E402
import live_processes  # noqa: E402
from live_processes import BUILD, ROOT  # noqa: E402
from rtbench.cyclictest import parse_cyclictest_hist  # noqa: E402

sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.irpd.variables import Segment  # noqa: E402

NS = "PLC_ROBOT."
JOINTS = [f"{NS}ROBOT_MODULE_STATE.dCurJoint[{i}]" for i in range(6)]


def log(msg: str) -> None:
    print(f"io_load: {msg}", file=sys.stderr, flush=True)


def within(seconds: float, condition) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        try:
            if condition():
                return True
        except (httpx.HTTPError, KeyError, ValueError):
            pass
        time.sleep(0.2)
    return False


def steal_ticks() -> int:
    """The machine's steal time so far (USER_HZ ticks, all CPUs): the hypervisor ran another guest."""
    return int(Path("/proc/stat").read_text().split("\n")[0].split()[8])


def schedstat(pid: int) -> tuple[int, int] | None:
    """(ns on the CPU, ns waiting on a run queue) of `pid` so far."""
    try:
        run, wait, _ = Path(f"/proc/{pid}/schedstat").read_text().split()
        return int(run), int(wait)
    except (OSError, ValueError):
        return None


def cpus_allowed(pid: int) -> str:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("Cpus_allowed_list:"):
            return line.split(":", 1)[1].strip()
    return "?"


def policy(pid: int) -> str:
    try:
        p = os.sched_getscheduler(pid)
        prio = os.sched_getparam(pid).sched_priority
        return {
            os.SCHED_OTHER: "SCHED_OTHER",
            os.SCHED_FIFO: f"SCHED_FIFO {prio}",
            os.SCHED_RR: f"SCHED_RR {prio}",
        }.get(p, str(p))
    except OSError:
        return "gone"


def transactions(pcap: Path, port: int) -> list[dict]:
    """Every Modbus TCP request to `port` and its answer, from a capture: the request's and the
    answer's kernel timestamps (ns) paired by transaction id on one connection; `answer` None when
    no answer came.  dpkt reads the pcap; the 7-byte MBAP header's first field is the id."""
    pending: dict[tuple, dict] = {}
    out: list[dict] = []
    with open(pcap, "rb") as f:
        reader = dpkt.pcap.Reader(f)
        for ts, frame in reader:
            t = int(ts * 1_000_000_000)  # a Decimal for a nanosecond capture, a float otherwise
            try:
                ip = dpkt.ethernet.Ethernet(frame).data
            except dpkt.UnpackError:
                continue
            if not isinstance(ip, dpkt.ip.IP) or not isinstance(ip.data, dpkt.tcp.TCP):
                continue
            tcp = ip.data
            payload = bytes(tcp.data)
            if len(payload) < 8:
                continue
            tid = int.from_bytes(payload[0:2], "big")
            if tcp.dport == port:  # a request
                conn = tcp.sport
                r = {"conn": conn, "tid": tid, "function": payload[7], "request": t, "answer": None}
                pending[(conn, tid)] = r
                out.append(r)
            elif tcp.sport == port:
                r = pending.pop((tcp.dport, tid), None)
                if r is not None and r["answer"] is None:
                    r["answer"] = t
    return out


def pct(values: list[float], q: float) -> float | None:
    if not values:
        return None
    s = sorted(values)
    return s[min(len(s) - 1, int(q * len(s)))]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, default=5.0)
    ap.add_argument("--cpu", type=int, default=max(os.sched_getaffinity(0)), help="irpd's dispatcher CPU")
    ap.add_argument("--no-stress", action="store_true")
    ap.add_argument("--no-browser", action="store_true")
    ap.add_argument("--drivesim-args", default=None, help="replace the set's drive simulator arguments (to compare)")
    ap.add_argument(
        "--kernel-trace",
        action="store_true",
        help="record the scheduler's events (ftrace) and explain each late answer; about 0.5 MB/s",
    )
    ap.add_argument(
        "--no-cyclictest",
        action="store_true",
        help="without cyclictest at SCHED_FIFO 99 on the simulator's CPU (what the machine lets a woken thread wait)",
    )
    ap.add_argument("--keep", action="store_true", help="keep the work folder (the capture, the logs)")
    ap.add_argument("--out-json", type=Path)
    ap.add_argument("--out-md", type=Path)
    a = ap.parse_args()
    other = os.sched_getaffinity(0) - {a.cpu}
    if not other:
        ap.error("needs two CPUs: one for irpd's dispatcher, one for the load")
    for tool in ("tcpdump",) + (() if a.no_stress else ("stress-ng",)) + (() if a.no_browser else ("node",)):
        if not shutil.which(tool):
            ap.error(f"{tool} is not installed (bash packaging/deps.sh installs it)")
    seconds = int(a.minutes * 60)
    work = Path(tempfile.mkdtemp(prefix="indurop-io-load-"))
    procs: list[subprocess.Popen] = []
    ktrace = None
    try:
        # The cell as shipped; only the simulator's port is a free one.
        cell = work / "plc-robot"
        shutil.copytree(BUILD / "sets" / "plc-robot", cell)
        port = live_processes.free_port()
        for name in ("ioconfig.xml", "module.xml"):
            (cell / name).write_text((cell / name).read_text().replace("15020", str(port)))
        if a.drivesim_args is not None:
            xml = cell / "module.xml"
            text = xml.read_text()
            start = text.index('<value name="args">') + len('<value name="args">')
            xml.write_text(
                text[:start] + a.drivesim_args.replace("15020", str(port)) + text[text.index("</value>", start) :]
            )
        ioconfig = (cell / "ioconfig.xml").read_text()
        timeout_ms = float(ioconfig.split('timeout_ms="')[1].split('"')[0])

        pcap = work / "modbus.pcap"
        tcpdump = subprocess.Popen(
            ["taskset", "-c", ",".join(map(str, sorted(other))), "tcpdump", "-i", "lo", "-n", "-B", "16384",
             "--time-stamp-precision=nano", "-w", str(pcap), f"tcp port {port}"],
            stdout=subprocess.DEVNULL, stderr=open(work / "tcpdump.log", "w"),
        )  # fmt: skip
        procs.append(tcpdump)
        time.sleep(1)

        # irpd as the demo starts it: its defaults (the dispatcher on the last CPU).
        sock = work / "irpd.sock"
        irpd = live_processes.start_irpd(
            sock, cell / "module.xml", f"io-load-{os.getpid()}", "--cpu", str(a.cpu),
            log=work / "irpd.log", module_output=True,
        )  # fmt: skip
        procs.append(irpd)
        os.sched_setaffinity(0, other)
        sim = live_processes.child_named(irpd.pid, b"drivesim")
        agent_port = live_processes.free_port()
        agent = live_processes.start_agent(agent_port, work / "data", sock, log=work / "agent.log")
        procs.append(agent)
        url = f"http://127.0.0.1:{agent_port}"
        token = (work / "data" / "admin-token").read_text().strip()
        api = httpx.Client(base_url=f"{url}/api/v1", headers={"Authorization": f"Bearer {token}"}, timeout=60)
        # the browser signs in as a person would: a user made with the admin token
        viewer = {"name": "bench", "role": "viewer", "password": f"pw-{secrets.token_urlsafe(12)}"}
        api.post("/users", json=viewer).raise_for_status()
        vars_ = Segment(api.get("/status").json()["shared_memory"]["variables"])

        def read(path: str):
            return vars_.read(NS + path)

        def write(path: str, value) -> None:
            r = api.put(f"/variables/{NS}{path}", json={"value": value})
            if r.status_code != 200:
                raise RuntimeError(f"writing {path}: {r.status_code} {r.text}")

        if not within(30, lambda: read("IO_STATUS.comm_lost[0]") == 0 and read("IO_STATUS.cycles") > 0):
            raise RuntimeError("the drive simulator did not answer within 30 s")
        write("PLC_IN.Enable", 1)
        write("PLC_IN.CycleMode", 1)
        if not within(30, lambda: read("PLC_OUT.Powered") == 1):
            raise RuntimeError(f"the drives did not power up: PLC ErrorID {read('PLC_OUT.ErrorID')}")
        write("I0", 1)
        if not within(30, lambda: read("PLC_OUT.Running") == 1):
            raise RuntimeError("the cycle did not start")
        sim_cpus = cpus_allowed(sim)
        log(
            f"cell cycling; irpd on CPU {a.cpu}, simulator pid {sim} ({policy(sim)}, CPUs {sim_cpus}), load on CPUs {sorted(other)}"
        )

        # stress-ng runs until it is stopped; the browser and cyclictest end by themselves after
        # `seconds` and write their figures.
        stress = None
        if not a.no_stress:
            stress = subprocess.Popen(
                ["taskset", "-c", ",".join(map(str, sorted(other))), "stress-ng", "--cpu", str(len(other)),
                 "--vm", "1", "--vm-bytes", "128M", "--timeout", f"{seconds + 30}s", "--quiet"],
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
            )  # fmt: skip
            procs.append(stress)
        timed: list[subprocess.Popen] = []
        browser_out = work / "browser.json"
        if not a.no_browser:
            browser = subprocess.Popen(
                ["node", str(ROOT / "tests" / "browser" / "bench" / "io-load-pages.mjs"), url, viewer["name"],
                 viewer["password"], str(seconds), *JOINTS[:3], f"{NS}PLC_OUT.Step"],
                cwd=ROOT / "tests" / "browser",
                # a browser is not pinned: it runs on every CPU, irpd's dispatcher's too
                preexec_fn=lambda: os.sched_setaffinity(0, range(os.cpu_count() or 1)),
                stdout=open(browser_out, "w"), stderr=open(work / "browser.log", "w"), start_new_session=True,
            )  # fmt: skip
            procs.append(browser)
            timed.append(browser)

            def opened() -> bool:
                return "pages are open" in (work / "browser.log").read_text()

            within(120, lambda: opened() or browser.poll() is not None)
            if not opened():  # the pages are open, or the run is not the one asked for
                raise RuntimeError(f"chromium's pages did not open: {(work / 'browser.log').read_text()[-2000:]}")

        # The reference: how late the machine wakes the highest-priority thread on the simulator's CPU.
        sim_cpu = int(sim_cpus.split(",")[0].split("-")[0])
        if not a.no_cyclictest:
            cyclictest = subprocess.Popen(
                ["cyclictest", "-m", "-q", "-p", "99", "-i", "1000", "-a", str(sim_cpu), "-t", "1", "-D", str(seconds),
                 "-h", "20000", f"--histfile={work / 'cyclictest.hist'}"],
                stdout=subprocess.DEVNULL, stderr=open(work / "cyclictest.log", "w"), start_new_session=True,
            )  # fmt: skip
            procs.append(cyclictest)
            timed.append(cyclictest)
        if a.kernel_trace:
            ktrace = kernel_trace.KernelTrace(work / "sched.trace", sim)
            ktrace.start()
        realtime_offset = time.clock_gettime_ns(time.CLOCK_REALTIME) - time.clock_gettime_ns(time.CLOCK_MONOTONIC)

        # Every second: iodispat's counts, the simulator's run-queue wait, the steal time.
        samples = []
        t0 = time.monotonic()
        errors0, cycles0, steal0, sched0 = (
            read("IO_STATUS.errors[0]"),
            read("IO_STATUS.cycles"),
            steal_ticks(),
            schedstat(sim),
        )
        prev = (errors0, steal0, sched0)
        comm_lost_seen = 0
        while time.monotonic() - t0 < seconds:
            time.sleep(1.0)
            errors, steal, sched = read("IO_STATUS.errors[0]"), steal_ticks(), schedstat(sim)
            lost = read("IO_STATUS.comm_lost[0]")
            comm_lost_seen += 1 if lost else 0
            samples.append({
                "t": round(time.monotonic() - t0, 3),
                "errors": errors - prev[0],
                "steal_ms": (steal - prev[1]) * 1000 / os.sysconf("SC_CLK_TCK"),
                "sim_wait_ms": (sched[1] - prev[2][1]) / 1e6 if sched and prev[2] else None,
                "sim_cpu_ms": (sched[0] - prev[2][0]) / 1e6 if sched and prev[2] else None,
                "comm_lost": lost,
                "plc_error": read("PLC_OUT.ErrorID") if read("PLC_OUT.Error") else 0,
            })  # fmt: skip
            prev = (errors, steal, sched)
            if samples[-1]["plc_error"] and (len(samples) == 1 or not samples[-2]["plc_error"]):
                log(f"{samples[-1]['t']:.0f} s: the PLC stopped with ErrorID {samples[-1]['plc_error']}")
            if len(samples) % 60 == 0:
                log(f"{len(samples) // 60} min: {read('IO_STATUS.errors[0]') - errors0} failed transactions")
        errors_total = read("IO_STATUS.errors[0]") - errors0
        rounds = read("IO_STATUS.cycles") - cycles0
        plc_cycles = read("PLC_OUT.Cycles")
        history = api.get("/alarms/history", params={"limit": 1000}).json()
        comm_alarms = [
            e for e in history["transitions"]
            if e.get("event") == "raise" and (e.get("key", "").endswith("/100") or e.get("key") == "main/8")
        ]  # fmt: skip
        sim_policy = policy(sim)
        for p in timed:
            try:
                p.wait(timeout=60)
            except subprocess.TimeoutExpired:
                pass
        load = [p for p in (stress, *timed) if p is not None]
        for p in load:
            os.killpg(p.pid, signal.SIGTERM) if p.poll() is None else None
        for p in load:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
        vars_.close()
        live_processes.stop(agent)
        live_processes.stop(irpd)
        tcpdump.send_signal(signal.SIGINT)
        tcpdump.wait(timeout=30)
        dropped = (work / "tcpdump.log").read_text()

        if ktrace:
            ktrace.stop()
        hist = work / "cyclictest.hist"
        ct = parse_cyclictest_hist(hist.read_text()) if hist.exists() and hist.stat().st_size else None
        tx = transactions(pcap, port)
        answered = [(r["answer"] - r["request"]) / 1e6 for r in tx if r["answer"] is not None]
        late = [r for r in tx if r["answer"] is None or (r["answer"] - r["request"]) / 1e6 > timeout_ms]
        bad_seconds = [s for s in samples if s["errors"]]
        browser = (
            json.loads(browser_out.read_text() or "{}") if browser_out.exists() and browser_out.stat().st_size else {}
        )
        result = {
            "minutes": a.minutes,
            "cpu": a.cpu,
            "load": {"stress_ng": not a.no_stress, "browser": not a.no_browser, "browser_result": browser},
            "simulator": {"pid": sim, "policy": sim_policy, "cpus": sim_cpus},
            "timeout_ms": timeout_ms,
            "rounds": rounds,
            "requests_captured": len(tx),
            "failed_transactions": errors_total,
            "failed_per_10000": round(errors_total * 10000 / max(1, len(tx)), 3),
            "comm_loss_alarms": len(comm_alarms),
            "seconds_comm_lost": comm_lost_seen,
            "plc_cycles": plc_cycles,
            "answer_ms": {
                "p50": pct(answered, 0.5),
                "p99": pct(answered, 0.99),
                "p99.99": pct(answered, 0.9999),
                "max": max(answered) if answered else None,
                "mean": statistics.fmean(answered) if answered else None,
            },  # fmt: skip
            "late_or_unanswered": len(late),
            "unanswered": sum(1 for r in late if r["answer"] is None),
            "seconds_with_failures": [
                {k: s[k] for k in ("t", "errors", "steal_ms", "sim_wait_ms", "sim_cpu_ms", "comm_lost")}
                for s in bad_seconds
            ][:50],
            "sim_wait_ms_per_s": {
                "all_p50": pct([s["sim_wait_ms"] for s in samples if s["sim_wait_ms"] is not None], 0.5),
                "all_max": max((s["sim_wait_ms"] or 0) for s in samples) if samples else None,
                "failing_seconds_p50": pct(
                    [s["sim_wait_ms"] for s in bad_seconds if s["sim_wait_ms"] is not None], 0.5
                ),
            },
            "steal_ms_per_s": {
                "all_max": max(s["steal_ms"] for s in samples) if samples else None,
                "failing_seconds_p50": pct([s["steal_ms"] for s in bad_seconds], 0.5),
            },
            "cyclictest": None
            if ct is None
            else {
                "cpu": sim_cpu,
                "samples": ct["count"],
                "max_us": ct["max"],
                "over_timeout": sum(n for us, n in ct["counts"].items() if us >= timeout_ms * 1000) + ct["overflows"],
            },
            "tcpdump": dropped.strip().splitlines()[-3:],
        }
        if ktrace:
            windows = sorted(
                (
                    r["request"] - realtime_offset - 1_000_000,
                    (r["answer"] or r["request"] + 20_000_000) - realtime_offset + 1_000_000,
                )
                for r in late[:30]
            )
            wakeups, switches = kernel_trace.read(work / "sched.trace", sim, windows)
            explained = kernel_trace.explain(late[:30], wakeups, switches, sim, realtime_offset)
            woken_in_time = [e for e in explained if e.get("first_wakeup", {}).get("ms", 99) < 0.5 and "first_run" in e]
            result["kernel"] = {
                "trace_overruns": ktrace.overruns,
                "explained": len(explained),
                # woken at the request, yet a normal-priority task kept the CPU for milliseconds: the
                # guest kernel preempts it at once for a SCHED_FIFO wake-up, so the virtual CPU did not run
                "woken_in_time_run_late": len(woken_in_time),
                "run_after": sorted({e["first_run"]["after"] for e in woken_in_time}),
                "late": explained,
            }
        print(json.dumps(result, indent=1))
        if a.out_json:
            a.out_json.write_text(json.dumps({**result, "samples": samples}, indent=1))
        if a.out_md:
            a.out_md.write_text(markdown(result))
        return 0
    finally:
        if ktrace:
            ktrace.stop()  # never leave the machine tracing
        for p in procs:
            if p.poll() is None:
                try:
                    os.killpg(p.pid, signal.SIGTERM) if p.pid == os.getpgid(p.pid) else p.terminate()
                except ProcessLookupError:
                    pass
        for p in procs:
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
        if a.keep:
            log(f"kept {work}")
        else:
            shutil.rmtree(work, ignore_errors=True)


def markdown(r: dict) -> str:
    a = r["answer_ms"]
    ms = lambda v: "–" if v is None else f"{v:.3f} ms"  # noqa: E731
    rows = [
        ("run", f"{r['minutes']:g} min; load: stress-ng {'on' if r['load']['stress_ng'] else 'off'}, "
                f"chromium {'on' if r['load']['browser'] else 'off'}; irpd's dispatcher on CPU {r['cpu']}"),
        ("drive simulator", f"{r['simulator']['policy']}, CPUs {r['simulator']['cpus']}"),
        ("Modbus requests captured / I/O rounds", f"{r['requests_captured']} / {r['rounds']}"),
        ("failed transactions (iodispat's count)", f"{r['failed_transactions']} ({r['failed_per_10000']} per 10,000)"),
        ("comm-loss alarms raised", str(r["comm_loss_alarms"])),
        ("answer time p50 / p99 / p99.99 / max", f"{ms(a['p50'])} / {ms(a['p99'])} / {ms(a['p99.99'])} / {ms(a['max'])}"),
        (f"answers later than the {r['timeout_ms']:g} ms timeout, or none", str(r["late_or_unanswered"])),
        ("simulator's run-queue wait per second: median / max", f"{ms(r['sim_wait_ms_per_s']['all_p50'])} / {ms(r['sim_wait_ms_per_s']['all_max'])}"),
        ("… in the seconds with a failure: median", ms(r["sim_wait_ms_per_s"]["failing_seconds_p50"])),
        ("steal time per second: max; in the seconds with a failure: median",
         f"{ms(r['steal_ms_per_s']['all_max'])}; {ms(r['steal_ms_per_s']['failing_seconds_p50'])}"),
        ("cyclictest (SCHED_FIFO 99, 1 ms) on the simulator's CPU: max; wake-ups later than the timeout",
         "–" if not r["cyclictest"] else f"{r['cyclictest']['max_us'] / 1000:.3f} ms; {r['cyclictest']['over_timeout']} of {r['cyclictest']['samples']}"),
        ("PLC cycles completed", str(r["plc_cycles"])),
    ]  # fmt: skip
    return "| figure | value |\n| --- | --- |\n" + "".join(f"| {k} | {v} |\n" for k, v in rows)


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""supervision_bench.py -- how fast irpd's supervision reacts, measured on this machine.

    .venv/bin/python tests/bench/supervision_bench.py [--build-dir build] [--trials N] [--watchdog-ms W]
                                             [--out docs/supervision.md]

This script plays systemd (an AF_UNIX datagram socket as NOTIFY_SOCKET, WATCHDOG_USEC) and measures three things (docs/supervision.md):

  1. watchdog detection: irpd runs a set whose module on executor "side" blocks for good once a
     file exists; after READY=1 and a random wait (so the stall falls at any phase of the ping
     cycle) the file is created.  systemd would kill irpd WatchdogSec after the last ping it got:
     detection = last ping + WatchdogSec - stall.  Bound: (WatchdogSec/2 - 20 ms, WatchdogSec +
     the window], the window being 2 basic periods + 40 ms (44 ms here).  Also counted: pings later
     than the window after the stall (expected: none).
  2. crash -> record: a module on executor "side" dereferences null once a file exists; from
     creating the file to irpd's death by SIGSEGV with <instance>.crash written in --state-dir.
  3. restart -> running: irpd started on the plc-robot cell (build/sets/plc-robot, its drive
     simulator on a free port) after a crash record, to READY=1 (the set loaded, every dispatcher
     through its first slot); the stop in between is SIGTERM.

Figures are reported, not asserted; they go between the markers <!-- supervision-figures -->
of --out.  Python 3.11 standard library only.  Run as root (SCHED_FIFO).
"""

from __future__ import annotations

import argparse
import os
import platform
import random
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

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "python"))
from live_processes import module_entry as module  # noqa: E402

# The stalled executor's window: 2 basic periods (2 ms) + 2 of the main thread's 20 ms ticks.
WINDOW_S = 0.044


class FakeSystemd:
    """The receiving end of sd_notify: every datagram with its CLOCK_MONOTONIC arrival time."""

    def __init__(self, path: Path):
        self.path = path
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.sock.bind(str(path))
        self.sock.settimeout(0.05)
        self.messages: list[tuple[float, str]] = []
        self.lock = threading.Lock()
        self.stop = False
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.thread.start()

    def _read(self):
        while not self.stop:
            try:
                data = self.sock.recv(4096)
            except TimeoutError:
                continue
            with self.lock:
                self.messages.append((time.monotonic(), data.decode(errors="replace")))

    def times(self, line: str) -> list[float]:
        with self.lock:
            return [t for t, m in self.messages if line in m.split("\n")]

    def wait_for(self, line: str, count: int = 1, limit: float = 30) -> bool:
        end = time.monotonic() + limit
        while time.monotonic() < end:
            if len(self.times(line)) >= count:
                return True
            time.sleep(0.005)
        return False

    def close(self):
        self.stop = True
        self.thread.join()
        self.sock.close()


def trigger_set(folder: Path, fixture: Path, trigger: Path) -> Path:
    """healthy (1 ms) on main; `bad` (2 ms) on executor side, misbehaving once `trigger` exists."""
    shutil.copy(fixture, folder / "bad.so")
    shutil.copy(fixture, folder / "healthy.so")
    never = f'<property><value name="trigger">{folder / "never"}</value></property>'
    armed = f'<property><value name="trigger">{trigger}</value></property><executor>side</executor>'
    xml = folder / "module.xml"
    xml.write_text(
        "<root>\n  <executor><name>side</name></executor>\n"
        + module("healthy", "healthy.so", 1_000_000, 1, never)
        + module("bad", "bad.so", 2_000_000, 2, armed)
        + "</root>\n"
    )
    return xml


def start(
    irpd: Path,
    config: Path,
    folder: Path,
    instance: str,
    notify: Path,
    watchdog_us: int = 0,
    extra: tuple[str, ...] = (),
) -> subprocess.Popen:
    """irpd as systemd starts it (without WATCHDOG_PID, which sd_watchdog_enabled then does not check)."""
    env = {k: v for k, v in os.environ.items() if k not in ("WATCHDOG_PID", "WATCHDOG_USEC")}
    env["NOTIFY_SOCKET"] = str(notify)
    if watchdog_us:
        env["WATCHDOG_USEC"] = str(watchdog_us)

    def no_core():
        import resource

        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))  # the crashes here are on purpose

    return subprocess.Popen(
        [
            str(irpd),
            "--config",
            str(config),
            "--instance",
            instance,
            "--state-dir",
            str(folder / "state"),
            "--module-cache",
            str(folder / "cache"),
            *extra,
        ],
        env=env,
        preexec_fn=no_core,
        stdout=subprocess.DEVNULL,
        stderr=open(folder / "irpd.log", "a"),
    )


def stop(p: subprocess.Popen, instance: str, sig=signal.SIGKILL):
    """Stops irpd by its pid; the shared memory a killed one leaves behind goes too."""
    if p.poll() is None:
        p.send_signal(sig)
    p.wait(timeout=30)
    for leftover in Path("/dev/shm").glob(f"indurop.{instance}.*"):
        leftover.unlink(missing_ok=True)


def describe(values: list[float]) -> str:
    ms = sorted(v * 1000 for v in values)
    return (
        f"n={len(ms)}, min {ms[0]:.1f} ms, median {statistics.median(ms):.1f} ms, "
        f"p90 {ms[int(0.9 * (len(ms) - 1))]:.1f} ms, max {ms[-1]:.1f} ms"
    )


def watchdog_trials(irpd: Path, fixtures: Path, trials: int, watchdog_s: float) -> tuple[list[float], int]:
    detections, pings_after = [], 0
    for i in range(trials):
        with tempfile.TemporaryDirectory(prefix="indurop-sup-bench-") as tmp:
            folder = Path(tmp)
            systemd = FakeSystemd(folder / "notify")
            xml = trigger_set(folder, fixtures / "stall_on_trigger.so", folder / "stall")
            instance = f"supbench-{os.getpid()}-w{i}"
            p = start(irpd, xml, folder, instance, folder / "notify", int(watchdog_s * 1e6))
            try:
                if not systemd.wait_for("READY=1") or not systemd.wait_for("WATCHDOG=1", 3, 10):
                    raise RuntimeError(f"irpd did not get ready or ping: {(folder / 'irpd.log').read_text()}")
                time.sleep(random.uniform(0, watchdog_s))
                stalled = time.monotonic()
                (folder / "stall").write_text("now\n")
                time.sleep(watchdog_s * 2 + 0.5)
                pings = systemd.times("WATCHDOG=1")
                before = [t for t in pings if t <= stalled]
                # a ping may still come within the window (progress seen just before the stall):
                # the last ping is what counts
                after = [t for t in pings if t > stalled]
                last = max(before + after)
                pings_after += sum(1 for t in after if t > stalled + WINDOW_S)
                detections.append(last + watchdog_s - stalled)
            finally:
                stop(p, instance)
                systemd.close()
    return detections, pings_after


def crash_trials(irpd: Path, fixtures: Path, trials: int) -> list[float]:
    took = []
    for i in range(trials):
        with tempfile.TemporaryDirectory(prefix="indurop-sup-bench-") as tmp:
            folder = Path(tmp)
            systemd = FakeSystemd(folder / "notify")
            xml = trigger_set(folder, fixtures / "crash_on_trigger.so", folder / "crash")
            instance = f"supbench-{os.getpid()}-c{i}"
            p = start(irpd, xml, folder, instance, folder / "notify")
            try:
                if not systemd.wait_for("READY=1"):
                    raise RuntimeError((folder / "irpd.log").read_text())
                time.sleep(0.2)
                t0 = time.monotonic()
                (folder / "crash").write_text("now\n")
                record = folder / "state" / f"{instance}.crash"
                while p.poll() is None or not record.exists():
                    if time.monotonic() - t0 > 10:
                        raise RuntimeError("irpd did not die of the crash")
                    time.sleep(0.0005)
                took.append(time.monotonic() - t0)
                if p.returncode != -signal.SIGSEGV or "module=bad" not in record.read_text():
                    raise RuntimeError(f"unexpected end {p.returncode}: {record.read_text()}")
            finally:
                stop(p, instance)
                systemd.close()
    return took


def cell_copy(folder: Path, build: Path) -> Path:
    shutil.copytree(build / "sets" / "plc-robot", folder / "cell")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    io = folder / "cell" / "ioconfig.xml"
    io.write_text(io.read_text().replace("15020", str(port)))
    xml = folder / "cell" / "module.xml"
    xml.write_text(xml.read_text().replace("--port 15020", f"--port {port}"))
    return xml


def restart_trials(irpd: Path, build: Path, trials: int) -> list[float]:
    took = []
    with tempfile.TemporaryDirectory(prefix="indurop-sup-bench-") as tmp:
        folder = Path(tmp)
        xml = cell_copy(folder, build)
        instance = f"supbench-{os.getpid()}-cell"
        for i in range(trials):
            notify = folder / f"notify{i}"
            systemd = FakeSystemd(notify)
            t0 = time.monotonic()
            p = start(irpd, xml, folder, instance, notify)
            try:
                if not systemd.wait_for("READY=1", 1, 60):
                    raise RuntimeError((folder / "irpd.log").read_text()[-2000:])
                took.append(systemd.times("READY=1")[0] - t0)
            finally:
                stop(p, instance, signal.SIGTERM)
                systemd.close()
    return took


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build-dir", default=str(ROOT / "build"))
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--watchdog-ms", type=int, default=1000)
    ap.add_argument("--out", default=str(ROOT / "docs" / "supervision.md"))
    args = ap.parse_args()
    build = Path(args.build_dir)
    irpd, fixtures = build / "bin" / "irpd", build / "tests" / "cpp" / "modules"
    watchdog_s = args.watchdog_ms / 1000

    detections, pings_after = watchdog_trials(irpd, fixtures, args.trials, watchdog_s)
    crashes = crash_trials(irpd, fixtures, args.trials)
    restarts = restart_trials(irpd, build, args.trials)

    inside = sum(1 for d in detections if watchdog_s / 2 - 0.02 <= d <= watchdog_s + WINDOW_S)
    lines = [
        f"Measured {time.strftime('%Y-%m-%d')} on {platform.node()} ({os.cpu_count()} CPUs, "
        f"Linux {platform.release()}), {args.trials} trials each, by `.venv/bin/python tests/bench/supervision_bench.py "
        f"--trials {args.trials} --watchdog-ms {args.watchdog_ms}` (the machine shared with other work):",
        "",
        "| what | figure |",
        "| --- | --- |",
        f"| watchdog detection, WatchdogSec = {args.watchdog_ms} ms: stall → systemd's kill deadline | "
        f"{describe(detections)}; {inside} of {len(detections)} within (WatchdogSec/2 − 20 ms, WatchdogSec + "
        f"{WINDOW_S * 1000:.0f} ms]; pings later than that after the stall: {pings_after} |",
        f"| crash → record written and irpd dead of SIGSEGV | {describe(crashes)} |",
        f"| restart → READY=1, plc-robot cell (3 thread modules, drive simulator process) | {describe(restarts)} |",
        "",
        "Total time from a thread module's crash to the cell running again under systemd: the crash "
        "figure + systemd's `RestartSec=` + the restart figure.  From a hang: the detection figure + "
        "systemd's stop (`SIGABRT`, then `SIGKILL` after `TimeoutAbortSec=`) + `RestartSec=` + the restart figure; "
        "the restart leaves the stuck module out (the watchdog's kill names it), so it happens once.",
    ]
    text = "\n".join(lines)
    print(text)
    out = Path(args.out)
    doc = out.read_text()
    marker = "<!-- supervision-figures -->"
    head, _, rest = doc.partition(marker)
    _, _, tail = rest.partition(marker)
    out.write_text(head + marker + "\n" + text + "\n" + marker + tail)
    return 0


if __name__ == "__main__":
    sys.exit(main())

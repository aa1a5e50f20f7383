#!/usr/bin/env python3
"""faults.py -- what each fault costs: detection time, time to safe outputs, restart time.

    .venv/bin/python tests/bench/faults.py [--rounds N] [--build-dir DIR] [--write docs/faults.md]

Each scenario runs irpd (and for the device side the drive simulator, started apart) N times
and reports min / median / max over the rounds:

  overrun      a thread module (tests/cpp/modules/overrun.cpp, 2 ms period, <overrun_limit> 2 ms)
               spins 20 ms in one run; on_overrun=warn.  Detection = how far past its limit the
               watchdog saw it still running (the watchdog's own clock: the event says how long
               the run had been going).
  stop         the plc-robot cell with the drive simulator apart, the six axes enabled, and a
               module that spins 3 s in its 500th run (5 s in) with on_overrun=stop.  Time to safe outputs =
               from the overrun deadline (the spin's start + the limit, CLOCK_MONOTONIC) to the
               moment a Modbus client polling the simulator's holding registers (FC 3, every
               ~0.2 ms, on loopback) sees every controlword at 0.
  irpd killed  the same cell, irpd killed -9 (SIGKILL): from the kill to every axis reporting a
               fault (the drives' own comm timeout, 100 ms, polled the same way).
  process      a periodic process module (tests/cpp/processes/periodic.cpp, 1 ms) that crashes
               (SIGSEGV), or hangs with on_overrun=restart (<overrun_limit> 5 ms): restart time =
               basic periods from the faulty release to the first release of the new process
               (restart_delay_ms=1; the default 100 ms adds its delay); for the hang, detection =
               how far past its limit the release was seen (irpd's main thread looks every 20 ms).

Timing figures are measured here, never asserted in tests.  Standard library only; run as root
(SCHED_FIFO) after `bash packaging/build.sh --tests`.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import socket
import statistics
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "tests" / "python"))
from live_processes import module_entry as module  # noqa: E402
from live_processes import stop


class Control:
    """irpd's control socket: one JSON request per line."""

    def __init__(self, path: Path):
        deadline = time.monotonic() + 20
        while True:
            try:
                self.s = socket.socket(socket.AF_UNIX)
                self.s.connect(str(path))
                break
            except OSError:
                assert time.monotonic() < deadline, f"no control socket at {path}"
                time.sleep(0.02)
        self.f = self.s.makefile("rw")
        self.f.readline()  # hello
        while True:  # until irpd dispatches (it answers "starting" before)
            self.f.write('{"cmd": "status"}\n')
            self.f.flush()
            if json.loads(self.f.readline()).get("ok"):
                break
            assert time.monotonic() < deadline, "irpd did not start dispatching"
            time.sleep(0.02)

    def ask(self, cmd: str, **args):
        self.f.write(json.dumps({"cmd": cmd, **args}) + "\n")
        self.f.flush()
        answer = json.loads(self.f.readline())
        if not answer.get("ok"):
            raise RuntimeError(f"{cmd}: {answer}")
        return answer.get("result")

    def events(self, kind: str) -> list[dict]:
        return [e for e in self.ask("events", limit=4096)["events"] if e["kind"] == kind]

    def close(self):
        self.s.close()


class Modbus:
    """A minimal Modbus TCP client for reading the simulator's registers (FC 3 and 4)."""

    def __init__(self, port: int):
        self.s = socket.create_connection(("127.0.0.1", port))
        self.s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.tid = 0

    def read(self, function: int, address: int, count: int) -> list[int]:
        self.tid = (self.tid + 1) & 0xFFFF
        self.s.sendall(struct.pack(">HHHBBHH", self.tid, 0, 6, 1, function, address, count))
        want = 9 + 2 * count
        data = b""
        while len(data) < want:
            chunk = self.s.recv(want - len(data))
            assert chunk, "the simulator closed the connection"
            data += chunk
        return list(struct.unpack(f">{count}H", data[9:]))

    def close(self):
        self.s.close()


def start(argv: list[str], folder: Path, name: str) -> subprocess.Popen:
    out = open(folder / f"{name}.out", "w+")
    p = subprocess.Popen(argv, stdout=out, stderr=subprocess.STDOUT, cwd=folder, text=True)
    p.out = folder / f"{name}.out"
    return p


def wait_for(what, seconds: float = 20.0, every: float = 0.005):
    deadline = time.monotonic() + seconds
    while True:
        value = what()
        if value:
            return value
        if time.monotonic() > deadline:
            raise TimeoutError(what.__doc__ or str(what))
        time.sleep(every)


def irpd(build: Path, xml: Path, folder: Path, name: str) -> tuple[subprocess.Popen, Control]:
    sock = folder / f"{name}.sock"
    p = start(
        [
            str(build / "bin" / "irpd"),
            "--config",
            str(xml),
            "--control-socket",
            str(sock),
            "--instance",
            f"faults-bench-{os.getpid()}-{name}",
            "--module-cache",
            str(folder / "cache"),
        ],
        folder,
        name,
    )
    return p, Control(sock)


def value(name: str, v: str) -> str:
    return f'<value name="{name}">{v}</value>'


# ---- scenarios --------------------------------------------------------------------------------


def overrun_detection(build: Path, folder: Path) -> float:
    """ms past the limit at which the watchdog saw the run still going."""
    shutil.copy(build / "tests/cpp/modules/counter_v1.so", folder / "keep.so")
    shutil.copy(build / "tests/cpp/modules/overrun.so", folder / "overrun.so")
    xml = folder / "module.xml"
    xml.write_text(
        "<root>\n"
        + module("keep", "keep.so", 1_000_000, 1)
        + module(
            "stuck",
            "overrun.so",
            2_000_000,
            2,
            "<on_overrun>warn</on_overrun><overrun_limit>2000000</overrun_limit><property>"
            + value("journal", str(folder / "stuck.log"))
            + value("hang_at", "100")
            + value("hang_ms", "20")
            + "</property>",
        )
        + "</root>\n"
    )
    p, c = irpd(build, xml, folder, "irpd")
    try:
        seen = wait_for(lambda: [e for e in c.events("overrun") if "still running" in e["message"]])
        m = re.search(r"still running after ([\d.]+) ms, past its overrun limit ([\d.]+) ms", seen[0]["message"])
        return float(m.group(1)) - float(m.group(2))
    finally:
        c.close()
        stop(p)


def plc_cell(build: Path, folder: Path, port: int, extra: str) -> Path:
    cell = build / "sets" / "plc-robot"
    for f in ("main.so", "Robot.so", "libiodispat.so", "indurop6.urdf", "robot.json", "layout.json"):
        shutil.copy(cell / f, folder / f)
    xml = re.sub(r"<module>\s*<name>drivesim</name>.*?</module>", "", (cell / "module.xml").read_text(), flags=re.S)
    (folder / "module.xml").write_text(xml.replace("</root>", extra + "</root>"))
    (folder / "ioconfig.xml").write_text((cell / "ioconfig.xml").read_text().replace('port="15020"', f'port="{port}"'))
    return folder / "module.xml"


def drivesim(build: Path, folder: Path, *args: str) -> tuple[subprocess.Popen, int]:
    p = start([str(build / "bin" / "indurop-drivesim"), "--port", "0", *args], folder, "drivesim")
    text = wait_for(lambda: re.search(r"listening on [\d.]+:(\d+)", p.out.read_text()))
    return p, int(text.group(1))


def enable(c: Control, sim: Modbus) -> None:
    c.ask("write", path="PLC_ROBOT.PLC_IN.Enable", value=1)
    wait_for(lambda: all((sim.read(4, 8 * a, 1)[0] & 0x6F) == 0x27 for a in range(6)))


def time_to_safe_outputs(build: Path, folder: Path) -> tuple[float, float]:
    """(ms from the overrun deadline to every controlword 0 at the simulator, ms of the stop hook)."""
    # (the drives' own comm timeout is not what is measured here: 1 s, as in the cell's tests)
    sim_p, port = drivesim(build, folder, "--quiet", "--comm-timeout", "1000")
    shutil.copy(build / "tests/cpp/modules/overrun.so", folder / "overrun.so")
    xml = plc_cell(
        build,
        folder,
        port,
        module(
            "stuck",
            "./overrun.so",
            10_000_000,
            0,
            "<on_overrun>stop</on_overrun><property>"
            + value("journal", str(folder / "stuck.log"))
            + value("hang_at", "500")
            + value("hang_ms", "3000")
            + "</property>",
        ),
    )
    sim = Modbus(port)
    p, c = irpd(build, xml, folder, "irpd")
    try:
        enable(c, sim)
        # Poll the controlwords (holding registers 0, 4, ..., 20) as fast as loopback allows.
        while True:
            regs = sim.read(3, 0, 24)
            if all(regs[4 * a] == 0 for a in range(6)):
                arrived = time.monotonic_ns()
                break
        log = wait_for(
            lambda: re.search(
                r"spin began at (\d+) ns", (folder / "stuck.log").read_text() if (folder / "stuck.log").exists() else ""
            ),
            seconds=10,
        )
        deadline = int(log.group(1)) + 10_000_000  # the limit: the period
        assert arrived > deadline - 10_000_000, "the controlwords were 0 before the module got stuck"
        stopped = c.events("stopped")[0]["message"]
        hook = re.search(r"driven to safe values in (\d+) us", stopped)
        return (arrived - deadline) / 1e6, int(hook.group(1)) / 1e3
    finally:
        c.close()
        stop(p)
        sim.close()
        stop(sim_p)


def irpd_killed(build: Path, folder: Path) -> float:
    """ms from SIGKILL of irpd to every axis in fault (their comm timeout, 100 ms)."""
    sim_p, port = drivesim(build, folder, "--quiet", "--comm-timeout", "100")
    xml = plc_cell(build, folder, port, "")
    sim = Modbus(port)
    p, c = irpd(build, xml, folder, "irpd")
    try:
        enable(c, sim)
        killed = time.monotonic_ns()
        p.kill()
        while True:
            regs = sim.read(4, 0, 48)
            if all(regs[8 * a] & 0x08 for a in range(6)):  # the fault bit (fault reaction, then fault)
                return (time.monotonic_ns() - killed) / 1e6
    finally:
        c.close()
        p.wait()
        sim.close()
        stop(sim_p)


def process_fault(build: Path, folder: Path, args: str, extra: str = "") -> tuple[float, float | None]:
    """(restart time in ms, detection past the limit in ms for a hang)."""
    shutil.copy(build / "tests/cpp/modules/counter_v1.so", folder / "keep.so")
    exe = build / "tests/cpp/processes/bin/proc_periodic.exe"
    xml = folder / "module.xml"
    xml.write_text(
        "<root>\n"
        + module("keep", "keep.so", 1_000_000, 1)
        + module(
            "p",
            str(exe),
            1_000_000,
            2,
            extra + "<property>" + value("args", args) + value("restart_delay_ms", "1") + "</property>",
            kind="process",
        )
        + "</root>\n"
    )
    p, c = irpd(build, xml, folder, "irpd")
    try:
        wait_for(lambda: c.events("process_restart"))

        def periods() -> list[tuple[str, str]]:
            return re.findall(r"\[p\] period n=(\d+) cycle=(\d+)", p.out.read_text())

        wait_for(lambda: [n for n, _ in periods()].count("1") >= 2)
        out = periods()
        faulty = next(int(cy) for n, cy in out if n == "5")
        first_again = [int(cy) for n, cy in out if n == "1"][1]
        hang = None
        if "hang" in args:
            m = re.search(
                r"not completed after (\d+) us, past its overrun limit (\d+) us", c.events("process_hang")[0]["message"]
            )
            hang = (int(m.group(1)) - int(m.group(2))) / 1e3
        return float(first_again - faulty), hang  # basic period 1 ms: cycles are ms
    finally:
        c.close()
        stop(p)


def summary(values: list[float]) -> str:
    return f"{min(values):.3f} / {statistics.median(values):.3f} / {max(values):.3f}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--build-dir", type=Path, default=REPO / "build")
    ap.add_argument("--write", type=Path, help="replace the figures block of this page (docs/faults.md)")
    a = ap.parse_args()
    build = a.build_dir.resolve()
    rows: dict[str, list[float]] = {}

    def run(label: str, fn, *args):
        for r in range(a.rounds):
            for attempt in range(3):  # a round the loaded machine spoiled (a start stall) is run again
                try:
                    with tempfile.TemporaryDirectory(prefix="indurop-faults-") as d:
                        result = fn(build, Path(d), *args)
                    break
                except (TimeoutError, AssertionError) as e:
                    print(f"{label} round {r + 1}: attempt {attempt + 1} failed ({e}); again", flush=True)
            else:
                raise RuntimeError(f"{label}: three attempts failed")
            if not isinstance(result, tuple):
                result = (result,)
            for sub, v in zip(label.split("|"), result):
                if v is not None:
                    rows.setdefault(sub, []).append(v)
            print(f"{label} round {r + 1}: {result}", flush=True)

    run("thread overrun (warn): detection past the limit", overrun_detection)
    run(
        "stop: overrun deadline -> safe outputs at the drive simulator|stop: safe_outputs() hooks (irpd's own time)",
        time_to_safe_outputs,
    )
    run("irpd killed -9: kill -> every drive in fault (comm timeout 100 ms)", irpd_killed)
    run("process SIGSEGV: faulty release -> first release after the restart", process_fault, "--crash-at 5")
    run(
        "process hang (on_overrun=restart, limit 5 ms): faulty release -> first release after the restart"
        "|process hang: detection past the limit",
        process_fault,
        "--hang-at 5",
        "<on_overrun>restart</on_overrun><overrun_limit>5000000</overrun_limit>",
    )

    uname = os.uname()
    lines = [
        f"Measured with `.venv/bin/python tests/bench/faults.py --rounds {a.rounds}` on {uname.nodename} "
        f"({os.cpu_count()} CPUs, {uname.release}), {time.strftime('%Y-%m-%d')}; min / median / max in ms "
        f"over {a.rounds} rounds.",
        "",
        "| fault | figure (ms) |",
        "| --- | --- |",
    ]
    lines += [f"| {k} | {summary(v)} |" for k, v in rows.items()]
    text = "\n".join(lines)
    print("\n" + text)
    if a.write:
        page = a.write.read_text()
        begin, end = "<!-- faults.py figures: begin -->", "<!-- faults.py figures: end -->"
        head, rest = page.split(begin)
        _, tail = rest.split(end)
        a.write.write_text(head + begin + "\n" + text + "\n" + end + tail)
    return 0


if __name__ == "__main__":
    sys.exit(main())

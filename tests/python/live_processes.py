"""live_processes.py -- real irpd and agent processes for the Python tests: started on loopback,
on free ports, with their own instance names, and stopped by pid."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.irpd.client import IrpdRefused  # noqa: E402

BUILD = Path(os.environ.get("INDUROP_BUILD", ROOT / "build"))
IRPD = BUILD / "bin" / "irpd"
FIG1 = BUILD / "sets" / "paper-fig1" / "module.xml"
SIGNALS = BUILD / "sets" / "signals"  # the sample counter SIG.sample and sixteen waves, every 1 ms
ALARMING = BUILD / "tests" / "cpp" / "modules" / "alarming.so"  # raises its `ids` while `trigger` exists
API = "/api/v1"


CELL = BUILD / "sets" / "plc-robot"


def copy_cell(
    folder: Path,
    xml: str = "module.xml",
    extra_drivesim: list[str] | None = None,
    fail_limit: int | None = None,
    port: int | None = None,
    cell: Path = CELL,
) -> tuple[Path, int]:
    """The PLC + robot cell (`cell`: a built set of it, plc-robot or plc-robot-st) copied to `folder` with its drive simulator on a free port (irpd starts
    it; two cells never share one), and room for the test machine's stalls: a shared VM starves the
    simulator for a fraction of a second at times, and a late answer must not read as a dead drive
    (1 s of silence before comm loss, whatever the period, unless `fail_limit` says how many failed
    cycles; the drives' own comm watchdog gets the same 1 s).  A starved simulator also sees the
    commanded position jump by what the trajectory moved during the stall, and the robot module
    sees the measured joints lag the commanded ones: the simulator's following-error limit and the
    robot's are 2 rad instead of 0.1 and 0.35 (real drives are not starved).  Returns the
    module.xml to run and the port."""
    shutil.copytree(cell, folder)
    port = port or free_port()
    fail_limit = fail_limit or (1000 if "1ms" in xml else 100)
    ioconfig = folder / "ioconfig.xml"
    ioconfig.write_text(
        ioconfig.read_text()
        .replace("15020", str(port))
        .replace('timeout_ms="4" fail_limit="3"', f'timeout_ms="8" fail_limit="{fail_limit}"')
    )
    config = folder / xml
    config.write_text(
        config.read_text()
        .replace(
            '<value name="urdf">indurop6.urdf</value>',
            '<value name="urdf">indurop6.urdf</value><value name="following_error">2</value>',
        )
        .replace(
            "--port 15020 --quiet",
            " ".join(
                [
                    "--port",
                    str(port),
                    "--quiet",
                    "--comm-timeout",
                    "1000",
                    "--following-limit",
                    "2",
                    *(extra_drivesim or []),
                ]
            ),
        )
    )
    return config, port


def module_entry(name: str, file: str, period_ns: int, priority: int, extra: str = "", kind: str = "thread") -> str:
    """One periodic <module> of a module.xml; `extra` is added inside it (properties, <executor>,
    <on_overrun>...)."""
    return (
        f"  <module><name>{name}</name><filename>{file}</filename><moduletype>{kind}</moduletype>"
        f"<operationtype>periodic</operationtype><period>{period_ns}</period><priority>{priority}</priority>"
        f"{extra}</module>\n"
    )


def signals_with_an_alarm(folder: Path) -> Path:
    """The signals set copied to `folder` with the module `conveyor`, which raises its high alarm 5
    "Conveyor jammed" while the file folder/jam exists; its module.xml."""
    shutil.copytree(SIGNALS, folder, dirs_exist_ok=True)
    shutil.copy(ALARMING, folder / "alarming.so")
    conveyor = module_entry(
        "conveyor",
        "./alarming.so",
        1_000_000,
        2,
        f'<property><value name="ids">5</value><value name="trigger">{folder / "jam"}</value></property>'
        '<alarm id="5" severity="high">Conveyor jammed</alarm>',
    )
    xml = folder / "module.xml"
    xml.write_text(xml.read_text().replace("</root>", conveyor + "</root>"))
    return xml


# Listening ports come from below the kernel's ephemeral range (ip_local_port_range, 32768-60999
# on Debian), which every outgoing connection of every test takes its local port from: a port the
# kernel handed out as free could be some worker's client socket a moment later, before our server
# binds it.  Each pytest-xdist worker (PYTEST_XDIST_WORKER=gwN) has its own slice, so two workers
# never hand out the same port; within a slice the process walks on from a pid-based start and
# skips any port something already holds (the slices start above the fixed ports tests use, e.g. the
# cell's drive simulator on 15020).
_PORTS_LOW, _PORTS_HIGH, _PORTS_SLICES = 20000, 32000, 8
_next_port: list[int] = []


def free_port() -> int:
    """A port of 127.0.0.1 that nothing holds, from this worker's slice of 20000-31999."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0").removeprefix("gw")
    width = (_PORTS_HIGH - _PORTS_LOW) // _PORTS_SLICES
    low = _PORTS_LOW + (int(worker) % _PORTS_SLICES if worker.isdigit() else 0) * width
    if not _next_port:
        _next_port.append(os.getpid() % width)
    for _ in range(width):
        port = low + _next_port[0] % width
        _next_port[0] += 1
        with socket.socket() as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                continue
            return port
    raise RuntimeError(f"free_port: no free port in {low}-{low + width - 1}")


# Every process started here, in order: tests/python/conftest.py stops the ones a fixture started
# before its setup failed (irpd up, the agent not), so they do not hold the next test's instance.
STARTED: list[subprocess.Popen] = []
# How long a start may take: a loaded 2-CPU machine has taken more than 20 s to import the agent.
START_TIMEOUT_S = 60


def _output_file(log: Path | None):
    """Where a started process writes: `log`, or a temporary file (never a pipe nobody reads)."""
    return open(log, "a+") if log else tempfile.TemporaryFile("w+")


def start_irpd(
    sock: Path,
    config: Path = FIG1,
    instance: str | None = None,
    *extra: str,
    log: Path | None = None,
    module_output: bool = False,
    prefix: tuple | list = (),
) -> subprocess.Popen:
    """irpd running `config` with its control socket at `sock`; returns once the socket is there.
    Its stderr goes to `log` when given, else to a temporary file: output(p); its stdout (the
    modules' irp::printf lines) too with module_output, else nowhere.  The plc-robot cell's drive
    simulator runs at the SCHED_FIFO priority its module.xml gives (--rt-priority).  `prefix` goes
    before the command (ip netns exec NAME ...)."""
    sock.unlink(missing_ok=True)
    out = _output_file(log)
    p = subprocess.Popen(
        [
            *prefix,
            str(IRPD),
            "--config",
            str(config),
            "--control-socket",
            str(sock),
            "--instance",
            instance or f"agent-test-{os.getpid()}",
            *extra,
        ],
        stdout=out if module_output else subprocess.DEVNULL,
        stderr=out,
        text=True,
    )
    STARTED.append(p)
    p.log = out
    p.instance = instance or f"agent-test-{os.getpid()}"  # its segments' names (remove_shm)
    deadline = time.monotonic() + START_TIMEOUT_S
    while not listening(sock):
        assert p.poll() is None, output(p)
        assert time.monotonic() < deadline, "irpd did not open its control socket"
        time.sleep(0.02)
    return p


def listening(sock: Path) -> bool:
    """Whether the Unix socket `sock` accepts connections: irpd binds it (which makes the file)
    before it listens, and a client connecting in between is refused (seen on a loaded machine)."""
    if not sock.exists():
        return False
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
        try:
            s.connect(str(sock))
            return True
        except OSError:
            return False


def start_agent(
    port: int,
    data: Path,
    sock: Path,
    *extra: str,
    log: Path | None = None,
    env: dict[str, str] | None = None,
    timeout_s: float = START_TIMEOUT_S,
    ca: Path | None = None,
) -> subprocess.Popen:
    """`python -m indurop_agent` on 127.0.0.1:port; returns once /health answers.  Its output goes
    to `log` when given, else to a temporary file, never a pipe nobody reads (a full pipe would stop
    the agent): output(p).  `env` is added to this process's environment.  An agent that exits or
    does not answer within `timeout_s` is stopped (not left loading the machine) and the start
    fails with its output.  `ca`: the agent serves HTTPS (--tls-cert in `extra`), checked with this
    certificate."""
    out = _output_file(log)
    p = subprocess.Popen(
        [
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
            *extra,
        ],
        cwd=ROOT / "agent",
        stdout=out,
        stderr=subprocess.STDOUT,
        text=True,
        env={**os.environ, **(env or {})},
    )
    STARTED.append(p)
    p.log = out
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            scheme = "https" if ca else "http"
            health = httpx.get(f"{scheme}://127.0.0.1:{port}{API}/health", timeout=1, verify=str(ca) if ca else True)
            if health.status_code == 200:
                return p
        except httpx.HTTPError:
            pass
        if p.poll() is not None or time.monotonic() > deadline:
            exited = p.poll() is not None
            stop(p)
            raise AssertionError(
                f"the agent {'exited' if exited else f'did not answer within {timeout_s:g} s'}: {output(p)}"
            )
        time.sleep(0.05)


def start_bridge(
    sock: Path,
    domain: int,
    *extra: str,
    log: Path | None = None,
    prefix: tuple | list = (),
    line_file: Path | None = None,
) -> subprocess.Popen:
    """indurop-dds-bridge (`python -m indurop_agent.dds`) for the irpd at `sock`, on DDS domain
    `domain`, loopback only (its default); `prefix` goes before the command (taskset ...).  Its
    view of the line goes to `line_file` (none without it).  Its output goes to `log` when given,
    else to a temporary file: output(p)."""
    out = _output_file(log)
    p = subprocess.Popen(
        [*prefix, sys.executable, "-m", "indurop_agent.dds", "--irpd-socket", str(sock), "--domain-id", str(domain)]
        + ["--line-file", str(line_file or "")]
        + list(extra),
        cwd=ROOT / "agent",
        stdout=out,
        stderr=subprocess.STDOUT,
    )
    STARTED.append(p)
    p.log = out
    return p


def start_opcua(sock: Path, data: Path, port: int, *extra: str, log: Path | None = None) -> subprocess.Popen:
    """indurop-opcua (`python -m indurop_agent.opcua`) for the irpd at `sock` on 127.0.0.1:port,
    with the agent's data folder `data`; returns once it listens (its status file is written after
    its first poll of irpd).  Its output goes to `log` when given, else to a temporary file: output(p)."""
    out = _output_file(log)
    p = subprocess.Popen(
        [sys.executable, "-m", "indurop_agent.opcua", "--irpd-socket", str(sock), "--data-dir", str(data)]
        + ["--host", "127.0.0.1", "--port", str(port), *extra],
        cwd=ROOT / "agent",
        stdout=out,
        stderr=subprocess.STDOUT,
    )
    STARTED.append(p)
    p.log = out
    deadline = time.monotonic() + START_TIMEOUT_S
    while True:
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=1):
                return p
        except OSError:
            pass
        if p.poll() is not None or time.monotonic() > deadline:
            stop(p)
            raise AssertionError(f"indurop-opcua did not listen on {port}: {output(p)}")
        time.sleep(0.1)


def child_named(parent: int, name: bytes, seconds: float = 10) -> int:
    """The pid of `parent`'s child whose program's path contains `name` (irpd's process modules
    are its children); RuntimeError when none appears within `seconds`."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        for task in Path(f"/proc/{parent}/task").glob("*/children"):
            for child in task.read_text().split():
                try:
                    if name in Path(f"/proc/{child}/cmdline").read_bytes().split(b"\0")[0]:
                        return int(child)
                except OSError:
                    pass  # gone meanwhile
        time.sleep(0.1)
    raise RuntimeError(f"no child {name.decode()} of pid {parent} within {seconds:g} s")


def drive_simulator_realtime(irpd_pid: int, priority: int) -> str:
    """Gives the drive simulator (irpd's process module, its child) SCHED_FIFO `priority` on the
    CPUs it runs on, another than the --rt-priority of the cell's module.xml (the soak's
    --drives-priority); returns what was done, for a report.  RuntimeError when it cannot (not
    found within 10 s, or not permitted)."""
    if priority <= 0:
        return "as the cell's module.xml has it (--rt-priority)"
    sim = child_named(irpd_pid, b"drivesim")
    try:
        os.sched_setscheduler(sim, os.SCHED_FIFO, os.sched_param(priority))
    except PermissionError as e:
        raise RuntimeError(f"the drive simulator cannot run at SCHED_FIFO {priority}: {e}") from e
    return f"SCHED_FIFO {priority}, CPUs {sorted(os.sched_getaffinity(sim))}"


def wait_until(what, seconds: float = 20.0, every: float = 0.01):
    """Polls what() until it is truthy; returns its value.  Fails naming what() (its docstring)
    after `seconds`."""
    deadline = time.monotonic() + seconds
    while True:
        value = what()
        if value:
            return value
        assert time.monotonic() < deadline, f"timed out waiting for {what.__doc__ or what}"
        time.sleep(every)


def dispatching(control) -> dict | None:
    """irpd's status once it dispatches its set; None while it answers "starting" (its socket opens
    before its dispatchers run).  `control`: an IrpdClient."""
    try:
        return control.request("status")
    except IrpdRefused:
        return None


def wait_dispatching(control, seconds: float = 60.0) -> dict:
    """irpd's status, once it dispatches its set."""
    return wait_until(lambda: dispatching(control), seconds, 0.05)


def output(p: subprocess.Popen) -> str:
    """What irpd (its stderr) or an agent started here printed so far."""
    p.log.seek(0)
    return p.log.read()


def stop(p: subprocess.Popen) -> None:
    """SIGTERM by pid, SIGKILL if it does not end within 10 s; an irpd's shared memory is removed
    when it did not remove it (remove_shm)."""
    if p.poll() is None:
        p.send_signal(signal.SIGTERM)
        try:
            p.wait(10)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()
    if getattr(p, "instance", None):
        wait_for_orphans(p.instance)
        remove_shm(p.instance)


def _ppid(pid: int) -> int:
    """`pid`'s parent (0 when it has ended)."""
    try:
        return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])
    except (OSError, IndexError, ValueError):
        return 0


def _is_irpd(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/exe").resolve().name == "irpd"
    except OSError:
        return False


def wait_for_orphans(instance: str, seconds: float = 5.0) -> None:
    """Waits until no process left behind by a killed irpd maps its segments: a process module (a
    child of irpd, ended by its parent-death signal) still maps them for a moment after irpd dies,
    and remove_shm leaves a segment someone maps.  Only orphans are waited for (a mapper that is
    not an irpd and whose parent is not one either): an irpd started again on the instance keeps
    its own modules."""
    prefix = f"/dev/shm/indurop.{instance}."
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        orphans = [
            pid
            for pid, files in _mappers().items()
            if any(f.startswith(prefix) for f in files) and not _is_irpd(pid) and not _is_irpd(_ppid(pid))
        ]
        if not orphans:
            return
        time.sleep(0.02)


def _mappers() -> dict[int, set[str]]:
    """The /dev/shm files each live process maps (/proc/*/maps)."""
    found: dict[int, set[str]] = {}
    for maps in Path("/proc").glob("[0-9]*/maps"):
        try:
            files = {
                line.split(maxsplit=5)[5].rstrip() for line in maps.read_text().splitlines() if "/dev/shm/" in line
            }
        except (OSError, IndexError):
            continue  # ended meanwhile, or an anonymous mapping
        if files:
            found[int(maps.parent.name)] = files
    return found


def mapped_files() -> set[str]:
    """Every file a live process maps (/proc/*/maps), e.g. the /dev/shm segments in use."""
    return set().union(*_mappers().values())


def remove_shm(instance: str) -> list[str]:
    """Removes the segments of irpd `instance` (/dev/shm/indurop.<instance>.*, docs/shared-memory.md)
    that no live process maps: what an irpd killed with SIGKILL (or that crashed) leaves, as irpd
    removes them only when it stops.  An irpd started again on the same instance keeps its own.
    Returns the names removed."""
    left = sorted(Path("/dev/shm").glob(f"indurop.{instance}.*"))
    if not left:
        return []
    in_use = mapped_files()
    removed = []
    for f in left:
        if str(f) not in in_use:
            f.unlink(missing_ok=True)
            removed.append(f.name)
    return removed

"""live_processes.py -- real irpd and agent processes for the Python tests: started on loopback,
on free ports, with their own instance names, and stopped by pid."""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("INDUROP_BUILD", ROOT / "build"))
IRPD = BUILD / "bin" / "irpd"
FIG1 = BUILD / "sets" / "paper-fig1" / "module.xml"
API = "/api/v1"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _output(log: Path | None):
    """Where a process's output goes: a file for long runs (a pipe nobody reads would fill)."""
    return open(log, "w") if log else subprocess.PIPE


def _read(p: subprocess.Popen, log: Path | None) -> str:
    return log.read_text() if log else (p.stdout or p.stderr).read()


def start_irpd(sock: Path, config: Path = FIG1, instance: str | None = None, *extra: str,
               log: Path | None = None) -> subprocess.Popen:
    """irpd running `config` with its control socket at `sock`; returns once the socket is there.
    Its stderr goes to `log` when given."""
    sock.unlink(missing_ok=True)
    p = subprocess.Popen([str(IRPD), "--config", str(config), "--control-socket", str(sock),
                          "--instance", instance or f"agent-test-{os.getpid()}", *extra],
                         stdout=subprocess.DEVNULL, stderr=_output(log), text=True)
    deadline = time.monotonic() + 20
    while not sock.exists():
        assert p.poll() is None, _read(p, log)
        assert time.monotonic() < deadline, "irpd did not open its control socket"
        time.sleep(0.02)
    return p


def start_agent(port: int, data: Path, sock: Path, *extra: str, log: Path | None = None) -> subprocess.Popen:
    """`python -m indurop_agent` on 127.0.0.1:port; returns once /health answers.  Its output goes
    to `log` when given."""
    p = subprocess.Popen([sys.executable, "-m", "indurop_agent", "--host", "127.0.0.1", "--port", str(port),
                          "--data-dir", str(data), "--irpd-socket", str(sock), *extra],
                         cwd=ROOT / "agent", stdout=_output(log), stderr=subprocess.STDOUT, text=True)
    deadline = time.monotonic() + 20
    while True:
        try:
            if httpx.get(f"http://127.0.0.1:{port}{API}/health", timeout=1).status_code == 200:
                return p
        except httpx.HTTPError:
            pass
        assert p.poll() is None, _read(p, log)
        assert time.monotonic() < deadline, "the agent did not come up"
        time.sleep(0.05)


def stop(p: subprocess.Popen) -> None:
    """SIGTERM by pid, SIGKILL if it does not end within 10 s."""
    if p.poll() is None:
        p.send_signal(signal.SIGTERM)
        try:
            p.wait(10)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()



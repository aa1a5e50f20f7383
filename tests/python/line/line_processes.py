"""line_processes.py -- one controller of the line tests (docs/dds.md "The line"): irpd, its agent
and its DDS bridge, on loopback or inside a network namespace (tests/python/netns.py), each started,
killed and started again by pid; its agent asked over HTTP (from inside its namespace when it has
one) and through irpctl."""

from __future__ import annotations

import json
import os
import secrets
import signal
import subprocess
import sys
import time
from pathlib import Path

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import API, ROOT, STARTED, free_port, output, start_bridge, start_irpd, stop  # noqa: E402
from netns import Namespace  # noqa: E402

IRPCTL = Path(sys.executable).with_name("irpctl")


class LineNode:
    """A controller named `name` on DDS domain `domain`: irpd running `config`, its agent and its
    bridge (`bridge_args` added), in namespace `ns` (its interface, multicast discovery) or on
    loopback."""

    def __init__(self, tmp: Path, name: str, domain: int, config: Path, ns: Namespace | None = None, bridge_args=()):
        self.name, self.domain, self.config, self.ns = name, domain, config, ns
        self.dir = tmp / name
        self.dir.mkdir(parents=True, exist_ok=True)
        self.prefix = ns.prefix if ns else []
        self.sock = self.dir / "irpd.sock"
        self.line_file = self.dir / "line.json"
        self.instance = f"line-{os.getpid()}-{name}-{secrets.token_hex(2)}"
        self.host = ns.address if ns else "127.0.0.1"
        self.port = 8080 if ns else free_port()
        self.url = f"http://{self.host}:{self.port}"
        self.bridge_args = list(bridge_args)
        self.irpd = self.agent = self.bridge = None

    # ---- processes -----------------------------------------------------------------------------
    def start(self) -> LineNode:
        self.start_irpd()
        self.start_agent()
        self.start_bridge()
        self.wait_agent()
        return self

    def start_irpd(self) -> None:
        self.irpd = start_irpd(self.sock, self.config, self.instance, log=self.dir / "irpd.log", prefix=self.prefix)

    def start_agent(self) -> None:
        log = open(self.dir / "agent.log", "a+")
        self.agent = subprocess.Popen(
            [
                *self.prefix,
                sys.executable,
                "-m",
                "indurop_agent",
                "--host",
                self.host,
                "--port",
                str(self.port),
                "--data-dir",
                str(self.dir / "data"),
                "--irpd-socket",
                str(self.sock),
                "--line-file",
                str(self.line_file),
            ],
            cwd=ROOT / "agent",
            stdout=log,
            stderr=subprocess.STDOUT,
        )
        self.agent.log = log
        STARTED.append(self.agent)

    def wait_agent(self, seconds: float = 90) -> None:
        deadline = time.monotonic() + seconds
        while True:
            assert self.agent.poll() is None, f"the agent of {self.name} exited: {output(self.agent)}"
            try:
                self.get("/health", token=False)
                return
            except (AssertionError, httpx.HTTPError, subprocess.TimeoutExpired, ValueError):
                assert time.monotonic() < deadline, f"the agent of {self.name} did not answer: {output(self.agent)}"
            time.sleep(0.2)

    def start_bridge(self) -> None:
        args = ["--name", self.name, "--agent-url", f"{self.url}/", "--line-lease-s", "3", "--poll-ms", "5"]
        if self.ns:
            args += ["--interface", self.ns.interface]
        self.bridge = start_bridge(
            self.sock,
            self.domain,
            *args,
            *self.bridge_args,
            log=self.dir / "bridge.log",
            prefix=tuple(self.prefix),
            line_file=self.line_file,
        )

    def kill(self, which: str) -> None:
        """SIGKILL to irpd, the agent or the bridge, by pid; a killed irpd's shared memory is removed."""
        p = getattr(self, which)
        os.kill(p.pid, signal.SIGKILL)
        p.wait()
        if which == "irpd":
            self.remove_shm()

    def stop(self, which: str) -> None:
        stop(getattr(self, which))
        if which == "irpd":
            self.remove_shm()

    def remove_shm(self) -> None:
        for leftover in Path("/dev/shm").glob(f"indurop.{self.instance}.*"):
            leftover.unlink(missing_ok=True)

    def close(self) -> None:
        for which in ("bridge", "agent", "irpd"):
            if getattr(self, which) is not None:
                self.stop(which)

    # ---- asking the agent --------------------------------------------------------------------
    @property
    def token(self) -> str:
        return (self.dir / "data" / "admin-token").read_text().strip()

    def get(self, path: str, token: bool = True) -> dict:
        """GET path (under /api/v1) of this controller's agent, as JSON; from inside its namespace."""
        headers = {"Authorization": f"Bearer {self.token}"} if token else {}
        if not self.ns:
            r = httpx.get(f"{self.url}{API}{path}", headers=headers, timeout=10)
            assert r.status_code == 200, r.text
            return r.json()
        curl = ["curl", "-sS", "-f", "-m", "10", *(f"-H{k}: {v}" for k, v in headers.items()), f"{self.url}{API}{path}"]
        r = self.ns.run(*curl, timeout=30)
        assert r.returncode == 0, f"{path}: {r.stderr}"
        return json.loads(r.stdout)

    def line(self) -> dict:
        return self.get("/line")

    def controllers(self) -> dict[str, dict]:
        """{name: controller} of this agent's GET /line (empty while its bridge is off)."""
        return {c["name"]: c for c in self.line()["controllers"]}

    def irpctl(self, *args: str) -> subprocess.CompletedProcess:
        env = {**os.environ, "INDUROP_URL": self.url, "INDUROP_TOKEN_FILE": str(self.dir / "data" / "admin-token")}
        return subprocess.run([*self.prefix, str(IRPCTL), *args], capture_output=True, text=True, timeout=60, env=env)

    def logs(self) -> str:
        parts = []
        for which in ("irpd", "agent", "bridge"):
            p = getattr(self, which)
            if p is not None:
                parts.append(f"--- {self.name} {which}:\n{output(p)[-3000:]}")
        return "\n".join(parts)

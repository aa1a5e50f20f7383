"""netns.py -- network namespaces for tests: `count` namespaces, each joined by a veth pair to a
"switch" namespace holding a Linux bridge, with addresses of a private /24 that exist only inside
them, multicast on (DDS discovery), and removed at the end, processes and all.  Names are unique per
run (a random tag), so that a leftover of a killed run never collides with the next one.

    with Switch(3) as net:                 # or: net = Switch(3).create(); ...; net.close()
        a = net.spaces[0]                  # a.name, a.interface, a.address (10.x.y.1)
        p = subprocess.Popen([*a.prefix, "irpd", ...])   # runs inside a's namespace
        a.run("curl", "-s", f"http://{a.address}:8080/")

unavailable() says why namespaces cannot be made here (not root, no `ip`), or None.
"""

from __future__ import annotations

import os
import random
import secrets
import shutil
import signal
import subprocess
import time
from dataclasses import dataclass


def unavailable() -> str | None:
    """Why this process cannot make network namespaces, or None when it can."""
    if os.geteuid() != 0:
        return "network namespaces need root (ip netns add)"
    if not shutil.which("ip"):
        return "iproute2's ip is not installed"
    probe = f"idp-probe-{secrets.token_hex(3)}"
    r = subprocess.run(["ip", "netns", "add", probe], capture_output=True, text=True)
    if r.returncode != 0:
        return f"ip netns add fails here: {r.stderr.strip()}"
    subprocess.run(["ip", "netns", "del", probe], capture_output=True)
    return None


def ip(*args: str) -> None:
    r = subprocess.run(["ip", *args], capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"ip {' '.join(args)}: {r.stderr.strip()}")


@dataclass
class Namespace:
    name: str
    interface: str  # its end of the veth pair
    address: str  # on the switch's /24

    @property
    def prefix(self) -> list[str]:
        """Put before a command to run it inside this namespace."""
        return ["ip", "netns", "exec", self.name]

    def run(self, *cmd: str, timeout: float = 60, **kw) -> subprocess.CompletedProcess:
        return subprocess.run([*self.prefix, *cmd], capture_output=True, text=True, timeout=timeout, **kw)


class Switch:
    """`count` namespaces on one Linux bridge (in a namespace of its own), 10.a.b.1 .. 10.a.b.count/24."""

    def __init__(self, count: int):
        self.tag = secrets.token_hex(3)
        self.subnet = f"10.{random.randint(64, 250)}.{random.randint(1, 254)}"
        self.switch = f"idp-{self.tag}-sw"
        self.bridge = f"br{self.tag}"
        self.spaces = [
            Namespace(f"idp-{self.tag}-{i}", f"ve{self.tag}{i}", f"{self.subnet}.{i + 1}") for i in range(count)
        ]
        self.made: list[str] = []

    def create(self) -> Switch:
        try:
            self._create()
        except BaseException:
            self.close()
            raise
        return self

    def _create(self) -> None:
        ip("netns", "add", self.switch)
        self.made.append(self.switch)
        ip("-n", self.switch, "link", "set", "lo", "up")
        # No IGMP snooping: without a querier it would stop forwarding the discovery's multicast.
        ip("-n", self.switch, "link", "add", self.bridge, "type", "bridge", "mcast_snooping", "0")
        ip("-n", self.switch, "link", "set", self.bridge, "up")
        for i, ns in enumerate(self.spaces):
            ip("netns", "add", ns.name)
            self.made.append(ns.name)
            ip("-n", ns.name, "link", "set", "lo", "up")
            port = f"sw{self.tag}{i}"
            ip("-n", ns.name, "link", "add", ns.interface, "type", "veth", "peer", "name", port, "netns", self.switch)
            ip("-n", self.switch, "link", "set", port, "master", self.bridge, "up")
            ip("-n", ns.name, "addr", "add", f"{ns.address}/24", "dev", ns.interface)
            ip("-n", ns.name, "link", "set", ns.interface, "multicast", "on", "up")
            ip("-n", ns.name, "route", "add", "224.0.0.0/4", "dev", ns.interface)

    def close(self) -> None:
        """Ends every process left in the namespaces (the test's own), then removes them; the veth
        pairs and the bridge go with them."""
        for name in reversed(self.made):
            pids = subprocess.run(["ip", "netns", "pids", name], capture_output=True, text=True).stdout.split()
            for pid in pids:
                try:
                    os.kill(int(pid), signal.SIGKILL)
                except (ProcessLookupError, ValueError):
                    pass
            for _ in range(50):
                if not subprocess.run(["ip", "netns", "pids", name], capture_output=True, text=True).stdout.split():
                    break
                time.sleep(0.1)
            subprocess.run(["ip", "netns", "del", name], capture_output=True)
        self.made.clear()

    def __enter__(self) -> Switch:
        return self.create()

    def __exit__(self, *exc) -> None:
        self.close()

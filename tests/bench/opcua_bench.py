#!/usr/bin/env python3
"""opcua_bench.py -- indurop-opcua under a SCADA's load (docs/opcua.md "Benchmark"): on the running
plc-robot cell (10 ms), 1,000 monitored items at 100 ms from one client and 16 at 10 ms from another
(asyncua's client, Basic256Sha256 SignAndEncrypt): the notifications delivered per second, the latency
from a value's cycle (its SourceTimestamp: the row's due time for items fed from the trace rings, the
read for the others) to the client's receipt p50/p99, the server's and the agent's CPU share and RSS,
and irpd's wake-up p99 with the load divided by its p99 without it, in the same run (phases alternate:
off -- no OPC UA server --, on -- the server and both clients --, off, on ...).

irpd runs on its dispatcher CPU (the last one); the agent, the server and this script (the clients)
on the others, as the demo and the .deb's units run them.  Not in CI: run it when nothing else loads
the machine.  Short by default (2 x 30 s phases of each kind):

    .venv/bin/python tests/bench/opcua_bench.py [--phase-s 30] [--phases 2] [--json out.json]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import re
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "python"))
sys.path.insert(0, str(ROOT / "tests" / "python" / "opcua"))
sys.path.insert(0, str(ROOT / "agent"))
sys.path.insert(0, str(ROOT / "tests" / "bench"))
import httpx  # noqa: E402
from asyncua import Client, ua  # noqa: E402
from asyncua.crypto.security_policies import SecurityPolicyBasic256Sha256  # noqa: E402
from dds_bench import wakeup_p99  # noqa: E402
from indurop_agent.irpd.client import IrpdClient, IrpdRefused  # noqa: E402
from live_processes import copy_cell, free_port, start_agent, start_irpd, start_opcua, stop, wait_dispatching  # noqa: E402
from opcua_helpers import NAMESPACE, make_client_certificate  # noqa: E402
from recorder_bench import ProcessSampler  # noqa: E402

SLOW, FAST = (1000, 100.0), (16, 10.0)  # (items, sampling interval ms)
PASSWORD = "turn-the-crank-42x"


def log(*a) -> None:
    print("opcua_bench:", *a, file=sys.stderr, flush=True)


class Receipts:
    """asyncua's handler: every data change's receipt time and SourceTimestamp, per phase."""

    def __init__(self, kind: str):
        self.kind = kind
        self.phase: str | None = None
        self.got: list[tuple[str, float, float]] = []  # (phase, receipt, source), Unix seconds

    def datachange_notification(self, node, value, data):
        if self.phase is not None:
            source = data.monitored_item.Value.SourceTimestamp
            self.got.append((self.phase, time.time(), source.timestamp() if source else float("nan")))


class Load:
    """The two clients and their items (made at the start of an "on" phase, closed at its end)."""

    def __init__(self, url: str, cert: Path, key: Path, paths: list[str], fast: list[str]):
        self.url, self.cert, self.key, self.paths, self.fast = url, cert, key, paths, fast
        self.slow_notes, self.fast_notes = Receipts("slow"), Receipts("fast")
        self.clients: list[Client] = []

    async def client(self) -> Client:
        c = Client(self.url, timeout=60)
        c.application_uri = "urn:indurop:bench:client"
        c.set_user("bench")
        c.set_password(PASSWORD)
        await c.set_security(
            SecurityPolicyBasic256Sha256, str(self.cert), str(self.key), mode=ua.MessageSecurityMode.SignAndEncrypt
        )
        await c.connect()
        self.clients.append(c)
        return c

    async def start(self, phase: str) -> dict:
        slow, fast = await self.client(), await self.client()
        ns = await slow.get_namespace_index(NAMESPACE)
        nodes = [slow.get_node(ua.NodeId(self.paths[i % len(self.paths)], ns)) for i in range(SLOW[0])]
        sub = await slow.create_subscription(SLOW[1], self.slow_notes)
        made = await sub.subscribe_data_change(nodes, sampling_interval=SLOW[1], queuesize=10)
        quick = await fast.create_subscription(20, self.fast_notes)
        made_fast = await quick.subscribe_data_change(
            [fast.get_node(ua.NodeId(p, ns)) for p in self.fast], sampling_interval=FAST[1], queuesize=10
        )
        bad = [m for m in made + made_fast if not isinstance(m, int)]
        self.slow_notes.phase = self.fast_notes.phase = phase
        return {"items": len(made) + len(made_fast), "refused": len(bad)}

    async def stop(self) -> None:
        self.slow_notes.phase = self.fast_notes.phase = None
        for c in self.clients:
            try:
                await c.disconnect()
            except Exception:
                pass
        self.clients = []


def percentiles(values: list[float]) -> dict:
    v = sorted(values)
    if not v:
        return {}
    return {"p50_ms": v[len(v) // 2] * 1e3, "p99_ms": v[int(len(v) * 0.99)] * 1e3, "max_ms": v[-1] * 1e3}


def setup(work: Path, started: list) -> tuple:
    """irpd on the cell (started), the agent with the user "bench" (operator), a client certificate
    the server trusts: (control, agent, api, auth, cert, key); what it starts is added to `started`."""
    xml, _ = copy_cell(work / "plc-robot")
    sock = work / "irpd.sock"
    started.append(start_irpd(sock, xml, f"opcua-bench-{os.getpid()}"))
    cpus = os.cpu_count() or 1
    if cpus > 1:
        os.sched_setaffinity(0, range(cpus - 1))  # this process and what it starts now: off irpd's CPU
    control = IrpdClient(str(sock), timeout_s=30)
    wait_dispatching(control)
    port = free_port()
    agent = start_agent(port, work / "data", sock, log=work / "agent.log")
    started.insert(0, agent)
    api = f"http://127.0.0.1:{port}/api/v1"
    auth = {"Authorization": f"Bearer {(work / 'data' / 'admin-token').read_text().strip()}"}
    body = {"name": "bench", "role": "operator", "password": PASSWORD}
    httpx.post(f"{api}/users", json=body, headers=auth, timeout=30).raise_for_status()
    key, cert = work / "client-key.pem", work / "client-cert.der"
    asyncio.run(make_client_certificate(key, cert, "urn:indurop:bench:client"))
    trusted = work / "data" / "opcua" / "pki" / "trusted"
    trusted.mkdir(parents=True)
    shutil.copy(cert, trusted / "bench-client.der")
    return control, agent, api, auth, cert, key


def start_cell(api: str, auth: dict) -> None:
    """The cell running, as the README starts it: PLC_IN.Enable, the drives powered, then I0."""

    def put(path, value):
        httpx.put(f"{api}/variables/{path}", json={"value": value}, headers=auth, timeout=30).raise_for_status()

    def get(path):
        return httpx.get(f"{api}/variables/{path}", headers=auth, timeout=30).json()["value"]

    put("PLC_ROBOT.PLC_IN.Enable", 1)
    deadline = time.monotonic() + 60
    while get("PLC_ROBOT.PLC_OUT.Powered") != 1:
        assert time.monotonic() < deadline, "the drives did not power up"
        time.sleep(0.2)
    put("PLC_ROBOT.I0", 1)


def variables(api: str, auth: dict) -> tuple[list[str], list[str]]:
    """(every variable node's path, 16 scalars that change most often) from GET /variables and two
    reads of the cell's values half a second apart."""
    leaves = [v["path"] for v in httpx.get(f"{api}/variables", headers=auth, timeout=30).json()["variables"]]

    def values() -> dict:
        got = httpx.get(f"{api}/variables/PLC_ROBOT", headers=auth, timeout=30).json()["values"]
        return {v["path"]: v["value"] for v in got}

    first = values()
    time.sleep(0.5)
    second = values()
    # an element of an array of scalars ("a.b[2]", "m[1][2]") is its array's node; "a.s[3].x" is a node
    nodes = sorted({re.sub(r"(\[\d+\])+$", "", p) for p in leaves})
    scalars = [p for p in leaves if not p.endswith("]")]
    changing = [p for p in scalars if first.get(p) != second.get(p)]
    fast = (changing + [p for p in scalars if p not in changing])[: FAST[0]]
    return nodes, fast


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--phase-s", type=float, default=30.0)
    ap.add_argument("--phases", type=int, default=2, help="pairs of (without, with) the OPC UA load")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="opcua-bench-"))
    started: list = []  # stopped by pid in this order at the end: the agent, irpd
    results: dict = {"phase_s": args.phase_s, "phases": args.phases, "slow": SLOW, "fast": FAST}
    results.update(off_p99_ns=[], on_p99_ns=[], on=[])
    loop = asyncio.new_event_loop()
    control = agent_cpu = None
    try:
        control, agent, api, auth, cert, key = setup(work, started)
        agent_cpu = ProcessSampler(agent.pid, every_s=2.0)
        start_cell(api, auth)
        nodes, fast = variables(api, auth)
        results.update(variable_nodes=len(nodes), fast_paths=fast)
        for phase in range(args.phases):
            agent_cpu.phase = "off"
            h0 = control.request("histograms", name="dispatcher")
            time.sleep(args.phase_s)
            off = wakeup_p99(h0, control.request("histograms", name="dispatcher"))
            port = free_port()
            server = start_opcua(work / "irpd.sock", work / "data", port, log=work / f"opcua-{phase + 1}.log")
            started.insert(0, server)
            load = Load(f"opc.tcp://127.0.0.1:{port}/", cert, key, nodes, fast)
            name = f"on-{phase + 1}"
            made = loop.run_until_complete(load.start(name))
            loop.run_until_complete(asyncio.sleep(3))  # the first values, the channels granted
            server_cpu = ProcessSampler(server.pid, every_s=2.0)
            server_cpu.phase = agent_cpu.phase = name
            h0 = control.request("histograms", name="dispatcher")
            t0 = time.time()
            loop.run_until_complete(asyncio.sleep(args.phase_s))
            t1 = time.time()
            on = wakeup_p99(h0, control.request("histograms", name="dispatcher"))
            status = json.loads((work / "data" / "opcua" / "status.json").read_text())
            loop.run_until_complete(load.stop())
            server_cpu.stopping.set()
            stop(server)
            counted = {}
            for notes in (load.slow_notes, load.fast_notes):
                got = [(r, s) for p, r, s in notes.got if p == name and t0 <= r <= t1]
                counted[notes.kind] = {"per_s": len(got) / (t1 - t0), **percentiles([r - s for r, s in got])}
            rss = [s[3] for s in server_cpu.samples]
            results["off_p99_ns"].append(off)
            results["on_p99_ns"].append(on)
            results["on"].append(
                {
                    **made,
                    "notifications_per_s": sum(c["per_s"] for c in counted.values()),
                    "latency": counted,
                    "server_cpu_share": server_cpu.share(name),
                    "server_rss_mb": round(max(rss) / 2**20, 1) if rss else None,
                    "agent_cpu_share": agent_cpu.share(name),
                    "sampling": status.get("sampling"),
                }
            )
            log(f"phase {phase + 1}: wake-up p99 without {off} ns, with {on} ns; {results['on'][-1]}")
        results["agent_cpu_share_off"] = agent_cpu.share("off")
        results["wakeup_p99_ratio"] = statistics.median(results["on_p99_ns"]) / statistics.median(results["off_p99_ns"])
        results["load_average"] = os.getloadavg()
    finally:
        if agent_cpu is not None:
            agent_cpu.stopping.set()
        loop.close()
        if control is not None:
            control.close()
        for p in started:
            stop(p)
        shutil.rmtree(work, ignore_errors=True)
    print(json.dumps(results, indent=1))
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

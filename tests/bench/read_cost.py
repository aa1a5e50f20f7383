#!/usr/bin/env python3
"""read_cost.py -- the agent's CPU work for one POST /variables/read of --values leaves, counted rather
than timed (docs/programming.md "Monitoring"): the agent's application in this process (no server, no
background threads) answers --requests reads over ASGI against a real irpd on force_bench.py's set.

    .venv/bin/python tests/bench/read_cost.py [--values N] [--requests R] [--profile] [--build-dir DIR]

Instructions per read, deterministic on a shared machine: callgrind counts the reads alone (the script
calls os.getppid() just before them and os.getpgrp() just after: the counters are zeroed at the
first and dumped at the second), and the total divided by --requests is the figure:

    PYTHONHASHSEED=0 valgrind --tool=callgrind --callgrind-out-file=/tmp/rc.%p \\
        --zero-before=os_getppid --dump-before=os_getpgrp .venv/bin/python tests/bench/read_cost.py
    grep -h totals /tmp/rc.*.1   # the dump of the reads (".1"; the rest of the run is in the last file)

Every read runs in this process: the HTTP client's side (httpx over ASGI) is counted too, the same
for any version of the route; irpd's answer to the agent's request is not (another process).

--profile prints cProfile's view of the reads instead (where the work goes).  irpd runs its set at a
1 ms period on its own; it is asked nothing but what the agent asks.  Measures; asserts nothing.
"""

from __future__ import annotations

import argparse
import asyncio
import cProfile
import os
import pstats
import subprocess
import sys
import tempfile
from pathlib import Path
from types import SimpleNamespace

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parent))
from agent_bench import stop
from force_bench import make_set
from indurop_agent.api.app import create_app
from indurop_agent.config import Settings
from rtbench.common import REPO

# httpx's ASGI transport imports sniffio at every request to ask whether trio runs; without sniffio
# installed that is a search of sys.path each time, which is no part of the agent's work
sys.modules.setdefault("sniffio", None)


async def reads(app, token: str, paths: list[str], count: int) -> None:
    transport = httpx.ASGITransport(app=app)
    headers = {"Authorization": f"Bearer {token}"}
    async with httpx.AsyncClient(transport=transport, base_url="http://agent", headers=headers) as client:
        for _ in range(count):
            r = await client.post("/api/v1/variables/read", json={"paths": paths})
            # the answer is not parsed (that is the client's work): every value read, no error
            if (
                r.status_code != 200
                or not r.content.endswith(b'"errors":[]}')
                or r.content.count(b'"path"') != len(paths)
            ):
                raise SystemExit(f"read_cost: the read failed: {r.status_code} {r.text[:300]}")


def inline_threads() -> None:
    """The sync routes and dependencies run on the event loop's thread, where cProfile sees them."""
    import anyio.to_thread

    async def run_sync(func, *args, **_):
        return func(*args)

    anyio.to_thread.run_sync = run_sync


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--values", type=int, default=200, help="leaves per read (200)")
    ap.add_argument("--requests", type=int, default=100, help="reads (100), after one read not counted apart")
    ap.add_argument("--profile", action="store_true", help="print cProfile's top functions of the reads")
    ap.add_argument("--build-dir", type=Path, default=REPO / "build", help="where bin/irpd and bench/empty.so are")
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="indurop-read-cost-") as tmp:
        work = Path(tmp)
        xml = make_set(work, SimpleNamespace(modules=1, period_ns=1_000_000, build_dir=a.build_dir), a.values)
        sock = work / "irpd.sock"
        irpd = subprocess.Popen(
            [str(a.build_dir / "bin" / "irpd"), "--config", str(xml), "--control-socket", str(sock),
             "--instance", f"readcost-{work.name}"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )  # fmt: skip
        try:
            app = create_app(Settings(data_dir=work / "data", irpd_socket=str(sock)), restore=False)
            token = app.state.tokens.ensure_admin().read_text().strip()
            paths = [f"fb.v{i:03d}" for i in range(a.values)]
            for _ in range(200):  # irpd's socket appears once it runs
                if sock.exists():
                    break
                subprocess.run(["sleep", "0.05"], check=True)
            asyncio.run(reads(app, token, paths, 1))  # the first read opens the connection and the segment
            print(f"read_cost: the agent of {Path(create_app.__code__.co_filename).parents[2]}", file=sys.stderr)
            if a.profile:
                inline_threads()
                profile = cProfile.Profile()
                profile.runcall(asyncio.run, reads(app, token, paths, a.requests))
                pstats.Stats(profile).sort_stats("tottime").print_stats(25)
            else:
                os.getppid()  # callgrind --zero-before=os_getppid
                asyncio.run(reads(app, token, paths, a.requests))
                os.getpgrp()  # callgrind --dump-before=os_getpgrp
        finally:
            stop(irpd)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

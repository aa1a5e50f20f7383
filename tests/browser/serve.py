"""serve.py -- the real irpd + agent the browser tests run against: irpd on the PLC + robot cell,
the agent serving the built UI on a free loopback port, one token per role.  Writes what the tests
need as JSON to the file named by argv[1], then runs until SIGTERM and stops both by pid."""
from __future__ import annotations

import json
import os
import signal
import sys
import tempfile
import threading
from pathlib import Path

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))
from live_processes import API, BUILD, free_port, start_agent, start_irpd, stop  # noqa: E402

CELL = BUILD / "sets" / "plc-robot" / "module.xml"


def main(out: Path, config: Path, viewer: str) -> None:
    work = Path(tempfile.mkdtemp(prefix="indurop-browser-"))
    sock, data = work / "irpd.sock", work / "data"
    data.mkdir()
    irpd = start_irpd(sock, config, f"browser-{os.getpid()}", log=work / "irpd.log")
    port = free_port()
    agent = start_agent(port, data, sock, "--viewer", viewer, log=work / "agent.log")
    url = f"http://127.0.0.1:{port}"
    admin = (data / "admin-token").read_text().strip()
    tokens = {"admin": admin}
    for role in ("operator", "viewer"):
        r = httpx.post(f"{url}{API}/tokens", json={"name": f"browser-{role}", "role": role},
                       headers={"Authorization": f"Bearer {admin}"})
        r.raise_for_status()
        tokens[role] = r.json()["token"]
    out.write_text(json.dumps({"url": url, "tokens": tokens, "work": str(work),
                               "pids": {"irpd": irpd.pid, "agent": agent.pid, "serve": os.getpid()}}))
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: done.set())
    signal.signal(signal.SIGINT, lambda *_: done.set())
    while not done.wait(0.5):
        if irpd.poll() is not None or agent.poll() is not None:
            print(f"serve.py: irpd or the agent ended; logs in {work}", file=sys.stderr)
            break
    stop(agent)
    stop(irpd)


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]) if len(sys.argv) > 2 else CELL,
         os.environ.get("INDUROP_VIEWER", "viser"))

"""serve.py -- the real irpd + agent the browser tests run against: irpd on the PLC + robot cell,
the agent serving the built UI on a free loopback port with the viser 3D view, one user (name and
password, to sign in through the form) and one token (for the tests' own API calls) per role, and
a second agent on the same irpd with the meshcat view.  The cell's DDS bridge (loopback, a domain
of its own) announces it on the line as browser-cell and writes the line's view the first agent
reads; a second bridge, "ghost", without an irpd, stands for another controller of the line (the
second agent reads no view: its Line page says the bridge is off).  With --opcua, indurop-opcua
too, on the first agent's data folder (its users sign in there).  Writes what the tests need as
JSON to the file named by argv[1], then runs until SIGTERM and stops them all by pid.

    serve.py OUT.json [module.xml] [--opcua]"""
from __future__ import annotations

import json
import os
import secrets
import signal
import sys
import tempfile
import threading
import time
from pathlib import Path

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))
from live_processes import (  # noqa: E402
    API,
    BUILD,
    copy_cell,
    free_port,
    start_agent,
    start_bridge,
    start_irpd,
    start_opcua,
    stop,
)

CELL = BUILD / "sets" / "plc-robot" / "module.xml"
USERS = {"admin": "anna", "operator": "otto", "viewer": "vera"}


def tokens_for(url: str, admin: str) -> dict:
    tokens = {"admin": admin}
    for role in ("operator", "viewer"):
        r = httpx.post(f"{url}{API}/tokens", json={"name": f"browser-{role}", "role": role},
                       headers={"Authorization": f"Bearer {admin}"})
        r.raise_for_status()
        tokens[role] = r.json()["token"]
    return tokens


def users_for(url: str, admin: str) -> dict:
    """One user per role, created with the admin token as the first admin would be: {role: {name, password}}."""
    users = {}
    for role, name in USERS.items():
        password = f"pw-{secrets.token_urlsafe(12)}"
        r = httpx.post(f"{url}{API}/users", json={"name": name, "role": role, "password": password},
                       headers={"Authorization": f"Bearer {admin}"})
        r.raise_for_status()
        users[role] = {"name": name, "password": password}
    return users


def wait_for_drives(url: str, token: str) -> None:
    """Until the I/O dispatcher talks to the drive simulator (irpd started it with the set): a
    power-on before that fails with ErrorID 8, as it would with a real drive switched off."""
    def read(path: str):
        r = httpx.get(f"{url}{API}/variables/PLC_ROBOT.IO_STATUS.{path}", headers={"Authorization": f"Bearer {token}"})
        return r.json()["value"] if r.status_code == 200 else None

    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        if read("comm_lost[0]") == 0 and (read("cycles") or 0) > 0:
            return
        time.sleep(0.1)
    raise SystemExit("serve.py: the I/O dispatcher did not reach the drive simulator within 30 s")


def main(out: Path, config: Path, opcua: bool = False) -> None:
    work = Path(tempfile.mkdtemp(prefix="indurop-browser-"))
    sock, data = work / "irpd.sock", work / "data"
    cell = config == CELL
    if cell:  # a copy with its drive simulator on a free port, patient with a loaded machine
        config, _ = copy_cell(work / "plc-robot")
    # chromium's load must not starve the simulated drives into a fault mid-test
    irpd = start_irpd(sock, config, f"browser-{os.getpid()}", log=work / "irpd.log")
    agents, urls, tokens, users = [], {}, {}, {}
    line_file = work / "line.json"
    for viewer in ("viser", "meshcat"):
        port, vdata = free_port(), data / viewer
        vdata.mkdir(parents=True)
        log = work / f"agent-{viewer}.log"
        # the System page's logs: the files irpd and this agent write here
        line = line_file if viewer == "viser" else work / "no-bridge.json"
        agents.append(start_agent(port, vdata, sock, "--viewer", viewer, "--irpd-log", str(work / "irpd.log"),
                                  "--agent-log", str(log), "--line-file", str(line), log=log))
        urls[viewer] = f"http://127.0.0.1:{port}"
        admin = (vdata / "admin-token").read_text().strip()
        tokens[viewer] = tokens_for(urls[viewer], admin)
        users[viewer] = users_for(urls[viewer], admin)
    domain = 5 + os.getpid() % 15  # the browser tests' DDS domains: 5..19 (docs/dds.md)
    bridges = [
        start_bridge(sock, domain, "--name", "browser-cell", "--agent-url", f"{urls['viser']}/", "--poll-ms", "10",
                     log=work / "bridge.log", line_file=line_file),
        start_bridge(work / "no-irpd.sock", domain, "--name", "ghost", "--agent-url", "http://127.0.0.1:9/",
                     log=work / "ghost.log"),
    ]
    servers = []
    opcua_info = None
    if opcua:
        port = free_port()
        servers.append(start_opcua(sock, data / "viser", port, log=work / "opcua.log"))
        opcua_info = {"url": f"opc.tcp://127.0.0.1:{port}/", "data": str(data / "viser")}
    if cell:
        wait_for_drives(urls["viser"], tokens["viser"]["viewer"])
    out.write_text(json.dumps({"url": urls["viser"], "tokens": tokens["viser"], "users": users["viser"],
                               "work": str(work), "opcua": opcua_info,
                               "meshcat": {"url": urls["meshcat"], "tokens": tokens["meshcat"],
                                           "users": users["meshcat"]},
                               "pids": {"irpd": irpd.pid, "agent": agents[0].pid, "agent_meshcat": agents[1].pid,
                                        "bridge": bridges[0].pid, "ghost": bridges[1].pid,
                                        "serve": os.getpid()}}))
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: done.set())
    signal.signal(signal.SIGINT, lambda *_: done.set())
    while not done.wait(0.5):
        if irpd.poll() is not None or any(a.poll() is not None for a in agents):
            print(f"serve.py: irpd or an agent ended; logs in {work}", file=sys.stderr)
            break
    for p in (*servers, *bridges, *agents):
        stop(p)
    stop(irpd)


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "--opcua"]
    main(Path(args[0]), Path(args[1]) if len(args) > 1 else CELL, "--opcua" in sys.argv[1:])

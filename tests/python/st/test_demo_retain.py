# test_demo_retain.py -- RETAIN values of a Structured Text program survive a restart of the demo
# (issue 29's "Done when"): irpd started as packaging/demo.sh starts it (packaging/demo-irpd.sh: its
# state folder in the demo's data folder, whoever runs it), the agent beside it on the same data
# folder; irpd stopped as Ctrl-C stops the demo and started again the same way, the agent reads the
# retained value going on from where it was and the plain one back at its initial value.

from __future__ import annotations

import os

import httpx
from live_processes import API, ROOT, free_port, remove_shm, start_agent, start_irpd, stop, wait_until
from st_live import stc_build

DEMO_IRPD = ROOT / "packaging" / "demo-irpd.sh"
ST = """
PROGRAM Keep
VAR RETAIN kept : DINT := 1000; END_VAR
VAR plain : DINT := 5; END_VAR
  kept := kept + 1;
  plain := plain + 1;
END_PROGRAM
"""


def test_retain_values_survive_a_restart_of_the_demos_irpd_as_the_agent_reads_them(tmp_path):
    built = stc_build(tmp_path, {"keep.st": ST})
    assert built.returncode == 0, built.stdout + built.stderr
    data = tmp_path / "data"  # the demo's INDUROP_DATA
    data.mkdir()
    sock, instance = data / "irpd.sock", f"demo-retain-{os.getpid()}"

    def start():
        """irpd on the set, as demo.sh starts it"""
        prefix = ("bash", str(DEMO_IRPD), str(data))
        return start_irpd(sock, tmp_path / "set" / "module.xml", instance, log=tmp_path / "irpd.log", prefix=prefix)

    irpd = start()
    port = free_port()
    agent = start_agent(port, data, sock)
    token = (data / "admin-token").read_text().strip()

    def read() -> dict:
        """Keep's variables in one read of the agent (GET /variables of the group), {} while it has none"""
        r = httpx.get(f"http://127.0.0.1:{port}{API}/variables/Keep", headers={"Authorization": f"Bearer {token}"})
        return {v["path"]: v["value"] for v in r.json()["values"]} if r.status_code == 200 else {}

    try:
        wait_until(lambda: read().get("Keep.kept", 0) > 1050, 60, 0.05)
        stop(irpd)  # as the demo's Ctrl-C: SIGTERM, irpd writes the retained values at its stop
        remove_shm(instance)
        copies = sorted(p.name for p in (data / "state").glob(f"{instance}.retain.*"))
        # the two copies are written in turn: one of them at least, in the demo's data folder
        assert copies and set(copies) <= {f"{instance}.retain.a", f"{instance}.retain.b"}, copies
        irpd = start()
        now = wait_until(read, 60, 0.05)  # the agent reads the new irpd
        # both count once a period since this start: the retained one from its restored value (over
        # 1050), the plain one from its initial value 5, so over 1045 apart; without RETAIN the
        # retained one would start at 1000 too, 995 apart
        assert now["Keep.kept"] - now["Keep.plain"] > 1020, now
    finally:
        stop(agent)
        stop(irpd)
        remove_shm(instance)

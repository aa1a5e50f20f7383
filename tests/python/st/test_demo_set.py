# test_demo_set.py -- the demo makes the cell with its PLC program in Structured Text (plc-robot-st,
# its default) the active set of the agent's set store, its sources with it (issue 30: the Programs
# page edits the active set's .st files): packaging/demo-set.sh picks the set as demo.sh does, irpd
# starts on it as demo.sh starts it (packaging/demo-irpd.sh), the agent beside it, and demo-set.sh
# stores and activates it as demo.sh does once the agent answers.  Started again, the demo runs the
# stored set and uploads nothing; an edit activated since through the agent is kept, until the cell
# is built anew; INDUROP_SET=plc-robot runs the C++ cell instead.

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import httpx
import pytest
from live_processes import API, BUILD, ROOT, copy_cell, free_port, remove_shm, start_agent, start_irpd, stop

ST_CELL = BUILD / "sets" / "plc-robot-st"
DEMO_SET = ROOT / "packaging" / "demo-set.sh"
DEMO_IRPD = ROOT / "packaging" / "demo-irpd.sh"
IRPCTL = Path(sys.executable).parent / "irpctl"  # the venv's, as demo.sh runs it

pytestmark = pytest.mark.skipif(not (ST_CELL / "main.so").exists(), reason=f"the ST cell is not built ({ST_CELL})")


def demo_set(*args, name: str | None = "plc-robot-st") -> str:
    """demo-set.sh as demo.sh runs it, with INDUROP_SET=`name` (None: unset); what it printed."""
    env = {k: v for k, v in os.environ.items() if k != "INDUROP_SET"} | ({"INDUROP_SET": name} if name else {})
    r = subprocess.run(["bash", str(DEMO_SET), *map(str, args)], env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    return r.stdout.strip()


def test_the_demo_makes_the_st_cell_the_active_set_with_its_sources(tmp_path):
    sets, data = tmp_path / "sets", tmp_path / "data"  # the build's sets, the demo's INDUROP_DATA
    data.mkdir()
    copy_cell(sets / "plc-robot")  # the C++ cell; each drive simulator on a port of its own
    copy_cell(sets / "plc-robot-st", cell=ST_CELL)
    sock, instance, port = data / "irpd.sock", f"demo-set-{os.getpid()}", free_port()
    url = f"http://127.0.0.1:{port}"
    prefix = ("bash", str(DEMO_IRPD), str(data))
    running: list = []

    def start(config: Path, n: int) -> None:
        """irpd and the agent, as demo.sh starts them; the previous ones stopped, as by Ctrl-C"""
        for p in running:
            stop(p)
        remove_shm(instance)
        running[:] = [start_irpd(sock, config, instance, log=tmp_path / f"irpd{n}.log", prefix=prefix)]
        running.append(start_agent(port, data, sock, log=tmp_path / f"agent{n}.log"))

    def get(path: str):
        token = (data / "admin-token").read_text().strip()
        return httpx.get(f"{url}{API}{path}", headers={"Authorization": f"Bearer {token}"}, timeout=30).json()

    try:
        # the first start, without INDUROP_SET: the cell with its PLC program in ST, stored and
        # activated with its sources
        config = Path(demo_set("pick", data, sets, name=None))
        assert config == sets / "plc-robot-st" / "module.xml"
        start(config, 1)
        demo_set("store", data, config.parent, url, IRPCTL, name=None)
        active = get("/sets/active")
        kinds = {f["path"]: f["kind"] for f in active["files"]}
        assert (kinds.get("main.st"), kinds.get("cell.glb"), kinds.get("main.so")) == ("st", "glb", "thread_module")
        assert get("/status")["set_id"] == active["id"]

        # started again, with INDUROP_SET=plc-robot-st or without: the demo stored this build of the
        # cell already, so irpd starts on the stored set itself and nothing is uploaded
        for name in (None, "plc-robot-st"):
            assert Path(demo_set("pick", data, sets, name=name)) == data / "active" / "module.xml"
        start(data / "active" / "module.xml", 2)
        assert get("/sets/active")["id"] == active["id"] == get("/status")["set_id"]
        assert len(get("/sets")) == 1

        # an edit of the program activated through the agent (as the Programs page makes one) is
        # what the same command starts next time; a new build of the cell is stored over it
        edited = tmp_path / "edited"
        shutil.copytree(sets / "plc-robot-st", edited)
        main = edited / "main.st"
        main.write_text(main.read_text().replace("  LastStep : DINT;\n", "  LastStep : DINT;\n  Edited : DINT;\n", 1))
        env = {**os.environ, "INDUROP_URL": url, "INDUROP_TOKEN_FILE": str(data / "admin-token")}
        upload = [str(IRPCTL), "upload", str(edited), "--activate", "--mode", "auto"]
        r = subprocess.run(upload, env=env, capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stdout + r.stderr
        edit = get("/sets/active")["id"]
        assert edit != active["id"]
        assert Path(demo_set("pick", data, sets)) == data / "active" / "module.xml"
        start(data / "active" / "module.xml", 4)
        assert get("/status")["set_id"] == edit
        (sets / "plc-robot-st" / "main.st").write_text(main.read_text())  # the cell built anew
        assert Path(demo_set("pick", data, sets)) == sets / "plc-robot-st" / "module.xml"

        # INDUROP_SET=plc-robot: the same cell with its PLC program in C++, over the active set
        config = Path(demo_set("pick", data, sets, name="plc-robot"))
        assert config == sets / "plc-robot" / "module.xml"
        start(config, 5)
        demo_set("store", data, config.parent, url, IRPCTL, name="plc-robot")
        assert "main.st" not in {f["path"] for f in get("/sets/active")["files"]}
        assert get("/status")["set_id"] == get("/sets/active")["id"]
    finally:
        for p in running:
            stop(p)
        remove_shm(instance)

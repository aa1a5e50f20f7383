"""test_opcua_st.py -- a Structured Text set (stc build) in a real irpd, with the agent and
indurop-opcua in front: the compiler's own variable `Main._stc_init` (the init flag, layout.json's
`"internal": true`) is in the running layout, which an online change lays out against, but neither
GET /api/v1/variables nor OPC UA's browse shows it, and the agent neither reads nor writes it; the
program's own variables are listed, browsed and written as usual."""

from __future__ import annotations

import asyncio
import json
import sys
from pathlib import Path

import httpx
import pytest
from asyncua import ua

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "st"))
from live_processes import IRPD
from opcua_helpers import Controller, leaves_under, ns_of
from st_live import stc_build

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")

ST = """
PROGRAM Main
VAR count : DINT; limit : INT := 5; END_VAR
  count := count + 1;
END_PROGRAM
"""


@pytest.fixture(scope="module")
def st_controller(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("opcua-st")
    built = stc_build(tmp, {"main.st": ST})
    assert built.returncode == 0, built.stdout + built.stderr
    c = Controller(tmp, tmp / "set" / "module.xml", "opcua-st")
    yield c
    c.close()


def test_the_init_flag_is_laid_out_but_hidden_from_the_variables_api_and_opc_ua(st_controller):
    c = st_controller
    running = httpx.get(f"{c.api}/layout", headers=c.admin, timeout=30).json()
    internal = {v["path"]: v.get("internal") for v in running["variables"]}
    assert internal == {"Main.count": None, "Main.limit": None, "Main._stc_init": True}  # kept in the layout

    listed = [v["path"] for v in c.rest("/variables")["variables"]]
    assert listed == ["Main.count", "Main.limit"]
    r = httpx.get(f"{c.api}/variables/Main._stc_init", headers=c.admin, timeout=30)
    assert r.status_code == 404 and "no variable 'Main._stc_init'" in r.json()["detail"], r.text
    r = httpx.put(f"{c.api}/variables/Main._stc_init", json={"value": False}, headers=c.admin, timeout=30)
    assert r.status_code == 404 and "no variable 'Main._stc_init'" in r.json()["detail"], r.text
    r = httpx.put(f"{c.api}/variables/Main.limit", json={"value": 9}, headers=c.admin, timeout=30)
    assert r.status_code == 200, r.text  # the program's own variables are written as ever

    async def browse():
        client = await c.connect("view")
        try:
            ns = await ns_of(client)
            return sorted(
                node.nodeid.Identifier for node in await leaves_under(client, client.get_node(ua.NodeId("Main", ns)))
            )
        finally:
            await client.disconnect()

    assert asyncio.run(browse()) == ["Main.count", "Main.limit"]
    assert json.loads((c.tmp / "set" / "layout.json").read_text())["variables"][-1]["internal"] is True

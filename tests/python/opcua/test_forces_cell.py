"""test_forces_cell.py -- forcing through the agent's API in front of a real irpd running the PLC +
robot cell, with indurop-opcua beside it (docs/forcing.md): an operator signed in forces the cell's
inputs (PLC_IN.Enable, I0) and the PLC reacts (powered, cycles); the forced value is what GET
/variables and an OPC UA read give, flagged forced there and by the node's Forced property; a write
to it (the API's, OPC UA's) is refused naming who forced it; a viewer cannot force; irpctl lists the
forces; unforce with restore brings the value before back; the audit log has the force and the
unforce with the user's name; an OPC UA write of an array with a forced element writes none of its
elements; irpd restarts with no forces and the agent notes those lost.  What is asserted is the state reached, never how fast."""

from __future__ import annotations

import asyncio
import sys
import time
from pathlib import Path

import httpx
import pytest
from asyncua import ua

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from indurop_agent.cli import irpctl as cli
from live_processes import wait_until
from opcua_helpers import NO_CELL, PASSWORDS, live_cell, ns_of

pytestmark = NO_CELL
ENABLE, I0 = "PLC_ROBOT.PLC_IN.Enable", "PLC_ROBOT.I0"


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    c = live_cell(tmp_path_factory, "forces-cell")
    yield c
    c.close()


def signed_in(cell, name: str) -> dict:
    """The headers of a browser session of `name` (its cookie and CSRF token)."""
    r = httpx.post(f"{cell.api}/session", json={"name": name, "password": PASSWORDS[name]}, timeout=30)
    assert r.status_code == 200, r.text
    return {"Cookie": f"indurop_session={r.cookies['indurop_session']}", "X-CSRF-Token": r.json()["csrf_token"]}


def call(cell, headers: dict, method: str, path: str, **kw) -> httpx.Response:
    return httpx.request(method, f"{cell.api}{path}", headers=headers, timeout=30, **kw)


async def opcua_read_and_write(cell):
    c = await cell.connect("oper")
    try:
        ns = await ns_of(c)
        node = c.get_node(ua.NodeId(I0, ns))
        value = await node.read_value()
        forced = await c.get_node(ua.NodeId(f"{I0}@Forced", ns)).read_value()
        with pytest.raises(ua.uaerrors.BadUserAccessDenied):
            await node.write_value(ua.Variant(0, ua.VariantType.Int16))
        return value, forced
    finally:
        await c.disconnect()


def test_an_operator_forces_the_cells_inputs_and_the_plc_reacts(cell, capsys):
    oper, view = signed_in(cell, "oper"), signed_in(cell, "view")
    cycles = cell.rest("/variables/PLC_ROBOT.PLC_OUT.Cycles")["value"]
    r = call(cell, oper, "PUT", f"/forces/{ENABLE}", json={"value": 1})
    assert r.status_code == 200, r.text
    assert r.json()["by"] == "oper" and r.json()["value"] == 1 and r.json()["before"] == 0
    wait_until(lambda: cell.rest("/variables/PLC_ROBOT.PLC_OUT.Powered")["value"] == 1, 60, 0.05)
    assert call(cell, oper, "PUT", f"/forces/{I0}", json={"value": 1}).status_code == 200
    wait_until(lambda: cell.rest("/variables/PLC_ROBOT.PLC_OUT.Cycles")["value"] > cycles, 60, 0.05)

    # What every reader sees, flagged forced.
    leaf = cell.rest(f"/variables/{I0}")
    assert leaf["value"] == 1 and leaf["forced"] is True
    listed = {v["path"]: v["forced"] for v in cell.rest("/variables")["variables"]}
    assert listed[I0] and listed[ENABLE] and not listed["PLC_ROBOT.PLC_OUT.Cycles"]
    group = {v["path"]: v for v in cell.rest("/variables/PLC_ROBOT.PLC_IN")["values"]}
    assert group[ENABLE]["forced"] is True and group[ENABLE]["value"] == 1
    value, forced = asyncio.run(opcua_read_and_write(cell))
    assert value == 1
    wait_until(lambda: asyncio.run(opcua_forced_flag(cell)), 30, 0.2)

    # A write is refused with who forced it; a viewer may not force.
    refused = call(cell, oper, "PUT", f"/variables/{I0}", json={"value": 0})
    assert refused.status_code == 409 and "forced by oper" in refused.text and "unforce it first" in refused.text
    assert call(cell, view, "PUT", f"/forces/{I0}", json={"value": 0}).status_code == 403
    assert call(cell, view, "DELETE", f"/forces/{I0}").status_code == 403
    assert call(cell, view, "GET", "/forces").json()["forces"][0]["path"] == ENABLE
    whole = call(cell, oper, "PUT", "/forces/PLC_ROBOT.PLC_IN", json={"value": 1})
    assert whole.status_code == 409 and "give one of its members" in whole.text

    capsys.readouterr()
    assert cli.main(["--url", f"http://127.0.0.1:{cell.agent_port}", "--token-file", str(cell.data / "admin-token"),
                     "forces"]) == 0  # fmt: skip
    out = capsys.readouterr().out
    assert "2 forces active" in out and I0 in out and "oper" in out

    # Unforce with restore: the value before the force comes back; without: the forced one stays.
    r = call(cell, oper, "DELETE", f"/forces/{I0}", params={"restore": "true"})
    assert r.status_code == 200 and r.json()["restored"] is True and r.json()["left"] == 0, r.text
    assert cell.rest(f"/variables/{I0}") == {**leaf, "value": 0, "forced": False}
    r = call(cell, oper, "DELETE", f"/forces/{ENABLE}", params={"restore": "false"})
    assert r.status_code == 200 and r.json()["left"] == 1
    assert cell.rest("/forces")["forces"] == []
    # the last force gone (irpd's status counts none): the Forced property follows
    wait_until(lambda: not asyncio.run(opcua_forced_flag(cell, ENABLE)), 30, 0.2)
    assert call(cell, oper, "DELETE", f"/forces/{ENABLE}").status_code == 404

    audit = [e for e in cell.audit() if e["action"] in ("force", "unforce") and e["result"] == "ok"]
    assert [(e["action"], e["target"], e["who"]["user"]) for e in audit] == [
        ("force", ENABLE, "oper"),
        ("force", I0, "oper"),
        ("unforce", I0, "oper"),
        ("unforce", ENABLE, "oper"),
    ]
    assert audit[0]["value"] == 1 and audit[2]["restore"] is True
    writes = [e for e in cell.audit() if e["action"] == "write_variable" and e["target"] == I0]
    api_refusal = [e for e in writes if e["who"]["via"] == "session"][-1]
    assert (
        api_refusal["result"] == "error" and api_refusal["status"] == 409 and "forced by oper" in api_refusal["detail"]
    )
    opcua_refusal = [e for e in writes if e["who"]["via"] == "opcua"][-1]
    assert opcua_refusal["opcua_status"] == "BadUserAccessDenied" and "forced by oper" in opcua_refusal["detail"]
    # irpd's own refusal (its error code `forced`), not a second copy of the rule in the agent
    assert "a write would be undone by the force" in opcua_refusal["detail"], opcua_refusal


TARGET = "PLC_ROBOT.ROBOT_MODULE_SERVICE.dTarget"


async def opcua_write_array(cell, values: list[float]) -> str:
    c = await cell.connect("oper")
    try:
        node = c.get_node(ua.NodeId(TARGET, await ns_of(c)))
        try:
            await node.write_value(ua.Variant(values, ua.VariantType.Double))
        except ua.uaerrors.UaStatusCodeError as e:
            return type(e).__name__
        return "Good"
    finally:
        await c.disconnect()


def test_an_opcua_write_of_an_array_with_a_forced_element_writes_none_of_it(cell):
    oper = signed_in(cell, "oper")
    before = [cell.rest(f"/variables/{TARGET}[{i}]")["value"] for i in range(6)]
    r = call(cell, oper, "PUT", f"/forces/{TARGET}[3]", json={"value": 0.5})
    assert r.status_code == 200, r.text
    try:
        status = asyncio.run(opcua_write_array(cell, [1.25, 1.5, 1.75, 2.0, 2.25, 2.5]))
        assert status == "BadUserAccessDenied"
        after = [cell.rest(f"/variables/{TARGET}[{i}]")["value"] for i in range(6)]
        assert after[:3] + after[4:] == before[:3] + before[4:], "elements before and after the forced one were written"
        assert after[3] == 0.5
        refusal = [e for e in cell.audit() if e["action"] == "write_variable" and e["target"] == TARGET][-1]
        assert refusal["result"] == "error" and f"'{TARGET}[3]' is forced by oper" in refusal["detail"], refusal
    finally:
        r = call(cell, oper, "DELETE", f"/forces/{TARGET}[3]", params={"restore": "true"})
        assert r.status_code == 200, r.text
    assert asyncio.run(opcua_write_array(cell, [0.0] * 6)) == "Good"
    assert [cell.rest(f"/variables/{TARGET}[{i}]")["value"] for i in range(6)] == [0.0] * 6


async def opcua_forced_flag(cell, path: str = I0) -> bool:
    c = await cell.connect("view")
    try:
        return await c.get_node(ua.NodeId(f"{path}@Forced", await ns_of(c))).read_value() is True
    finally:
        await c.disconnect()


def test_irpd_restarts_with_no_forces_and_the_agent_notes_the_ones_lost(cell):
    oper = signed_in(cell, "oper")
    assert call(cell, oper, "PUT", "/forces/PLC_ROBOT.PLC_IN.Override", json={"value": 0.25}).status_code == 200
    before = cell.rest("/status")
    # The agent's watcher has seen the force (its status poll) before irpd restarts.
    wait_until(lambda: any(e.get("kind") == "force_set" for e in cell.rest("/events")["events"]), 60, 0.2)
    time.sleep(2)
    assert cell.control.request("restart", config=str(cell.xml), timeout=60)["restarting"] is True

    def restarted() -> bool:
        r = httpx.get(f"{cell.api}/status", headers=cell.admin, timeout=30)
        return r.status_code == 200 and r.json()["uptime_ns"] < before["uptime_ns"]

    wait_until(restarted, 120, 0.2)
    assert cell.rest("/forces")["forces"] == []
    # the last force gone (irpd's status counts none): the Forced property follows
    wait_until(lambda: not asyncio.run(opcua_forced_flag(cell, ENABLE)), 30, 0.2)
    wait_until(lambda: any(e.get("kind") == "forces_lost" for e in cell.rest("/events")["events"]), 60, 0.2)
    lost = [e for e in cell.rest("/events")["events"] if e.get("kind") == "forces_lost"][-1]
    assert "the 1 forces it held are gone" in lost["message"]

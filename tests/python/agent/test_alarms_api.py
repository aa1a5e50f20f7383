"""test_alarms_api.py -- the alarm routes of an in-process agent (docs/alarms.md): who may
acknowledge and shelve (operator and up) and that it is audited with the user, the ISA-18.2
states through their transitions, the history's filters, paging and CSV, alarms that survive an
agent restart, and floods that neither grow memory nor push the older history out."""

from __future__ import annotations

import csv
import io
import time

import pytest
from agent_helpers import API

PLC = [
    {
        "module": "PLC",
        "declared": [{"id": 8, "severity": "high", "text": "drive communication lost", "origin": "module.xml"}],
    }
]


def alarms_of(agent):
    return agent.client.app.state.alarms


def raise_plc8(agent, detail: str = "comm lost: Invalid data", value: float = 22.0) -> None:
    m = alarms_of(agent)
    m.declare(PLC)
    m.raise_alarm("PLC", "8", time.time_ns(), detail=detail, value=value)


def get(agent, path: str, role: str = "viewer", **params):
    r = agent.client.get(f"{API}{path}", headers=agent.h(role), params=params)
    assert r.status_code == 200, r.text
    return r.json()


def post(agent, path: str, role: str, json=None):
    return agent.client.post(f"{API}{path}", headers=agent.h(role), json=json)


def test_acknowledgement_by_a_viewer_is_refused_and_by_an_operator_audited(agent):
    raise_plc8(agent)
    r = post(agent, "/alarms/PLC/8/ack", "viewer")
    assert r.status_code == 403, r.text
    assert "needs the operator role" in r.json()["detail"]
    assert get(agent, "/alarms")["alarms"][0]["state"] == "active_unacknowledged"
    r = post(agent, "/alarms/PLC%2F8/ack", "operator")  # the key URL-encoded, as the web UI sends it
    assert r.status_code == 200, r.text
    assert r.json()["state"] == "active_acknowledged"
    assert r.json()["acknowledged_by"]["name"] == "test-operator"
    audit = [e for e in agent.audit() if e["action"] == "alarm_ack"]
    assert len(audit) == 1, audit
    assert audit[0]["target"] == "PLC/8" and audit[0]["result"] == "ok"
    assert audit[0]["who"]["name"] == "test-operator" and audit[0]["who"]["role"] == "operator"
    # the viewer's refusal changed nothing and was not the operator's
    history = get(agent, "/alarms/history")["transitions"]
    assert [(t["event"], t["state"]) for t in history] == [
        ("acknowledge", "active_acknowledged"),
        ("raise", "active_unacknowledged"),
    ]
    assert history[0]["who"]["name"] == "test-operator"


def test_confirmation_needs_an_acknowledgement_and_an_operator_and_is_audited(agent):
    """POST /alarms/{key}/confirm (OPC UA's Confirm over REST): 409 before the acknowledgement,
    403 for a viewer, then held with who confirmed, without changing the state; once only."""
    raise_plc8(agent)
    r = post(agent, "/alarms/PLC/8/confirm", "operator")
    assert r.status_code == 409 and "acknowledge it first" in r.json()["detail"], r.text
    assert post(agent, "/alarms/PLC/8/ack", "operator").status_code == 200
    r = post(agent, "/alarms/PLC/8/confirm", "viewer")
    assert r.status_code == 403 and "needs the operator role" in r.json()["detail"], r.text
    r = post(agent, "/alarms/PLC%2F8/confirm", "operator")
    assert r.status_code == 200, r.text
    alarm = r.json()
    assert alarm["confirmed"] is True and alarm["confirmed_by"]["name"] == "test-operator"
    assert alarm["state"] == "active_acknowledged"
    assert post(agent, "/alarms/PLC/8/confirm", "operator").status_code == 409  # confirmed already
    lines = agent.audit()
    done = [(e["result"], e["who"]["role"]) for e in lines if e["action"] == "alarm_confirm"]
    assert done == [("error", "operator"), ("ok", "operator"), ("error", "operator")], done
    refused = [e for e in lines if e["action"] == "refused" and "/confirm" in e["target"]]
    assert [(e["kind"], e["who"]["role"]) for e in refused] == [("forbidden", "viewer")], refused
    events = [t["event"] for t in reversed(get(agent, "/alarms/history")["transitions"])]
    assert events == ["raise", "acknowledge", "confirm"]


def test_shelving_needs_an_operator_is_audited_and_comes_back_on_unshelve(agent):
    raise_plc8(agent)
    body = {"minutes": 30, "reason": "drive swapped, commissioning"}
    r = post(agent, "/alarms/PLC/8/shelve", "viewer", body)
    assert r.status_code == 403 and "needs the operator role" in r.json()["detail"], r.text
    r = post(agent, "/alarms/PLC/8/shelve", "operator", body)
    assert r.status_code == 200, r.text
    assert r.json()["state"] == "shelved" and r.json()["condition"] == "active_unacknowledged"
    assert r.json()["shelve_reason"] == body["reason"]
    counts = get(agent, "/alarms")["counts"]
    assert (counts["active"], counts["unacknowledged"], counts["shelved"]) == (0, 0, 1)
    audit = [e for e in agent.audit() if e["action"] == "alarm_shelve"]
    assert audit[-1]["target"] == "PLC/8" and audit[-1]["reason"] == body["reason"] and audit[-1]["minutes"] == 30
    assert post(agent, "/alarms/PLC/8/unshelve", "operator").json()["state"] == "active_unacknowledged"
    assert [e["action"] for e in agent.audit()][-1] == "alarm_unshelve"
    assert post(agent, "/alarms/PLC/8/unshelve", "operator").status_code == 409


def test_a_shelf_of_no_time_or_no_reason_is_refused(agent):
    raise_plc8(agent)
    for body in (
        {"minutes": 0, "reason": "x"},
        {"minutes": 10, "reason": ""},
        {"minutes": 10},
        {"minutes": 1e9, "reason": "x"},
    ):
        assert post(agent, "/alarms/PLC/8/shelve", "operator", body).status_code == 422, body


def test_the_states_follow_isa_18_2(agent):
    m = alarms_of(agent)
    raise_plc8(agent)
    assert get(agent, "/alarms")["alarms"][0]["state"] == "active_unacknowledged"
    m.clear_alarm("PLC", "8", time.time_ns())
    listed = get(agent, "/alarms")
    assert listed["alarms"][0]["state"] == "cleared_unacknowledged"
    assert (listed["counts"]["active"], listed["counts"]["unacknowledged"]) == (0, 1)
    m.raise_alarm("PLC", "8", time.time_ns(), detail="again")  # back before anyone looked
    assert get(agent, "/alarms")["alarms"][0]["raises"] == 2
    assert post(agent, "/alarms/PLC/8/ack", "operator").json()["state"] == "active_acknowledged"
    assert post(agent, "/alarms/PLC/8/ack", "operator").status_code == 409  # acknowledged already
    m.clear_alarm("PLC", "8", time.time_ns())
    listed = get(agent, "/alarms")
    assert listed["alarms"] == [] and listed["counts"]["unacknowledged"] == 0  # normal: nothing to show
    assert post(agent, "/alarms/PLC/8/ack", "operator").status_code == 404
    events = [t["event"] for t in reversed(get(agent, "/alarms/history")["transitions"])]
    assert events == ["raise", "clear", "raise", "acknowledge", "clear"]


def test_acknowledge_all_takes_every_unacknowledged_alarm(agent):
    m = alarms_of(agent)
    raise_plc8(agent)
    m.raise_alarm("ROBOT", "3", time.time_ns())
    m.raise_alarm("ROBOT", "4", time.time_ns())
    m.clear_alarm("ROBOT", "4", time.time_ns())
    assert post(agent, "/alarms/ack", "viewer").status_code == 403
    r = post(agent, "/alarms/ack", "operator", {"module": "ROBOT"})
    assert r.status_code == 200 and r.json()["acknowledged"] == ["ROBOT/3", "ROBOT/4"], r.text
    r = post(agent, "/alarms/ack", "admin")
    assert r.json()["acknowledged"] == ["PLC/8"] and r.json()["counts"]["unacknowledged"] == 0
    assert [e["target"] for e in agent.audit() if e["action"] == "alarm_ack_all"] == ["ROBOT", "*"]


def test_alarms_and_their_history_survive_an_agent_restart(make_agent, tmp_path):
    first = make_agent()
    raise_plc8(first)
    alarms_of(first).raise_alarm("ROBOT", "3", time.time_ns())
    assert post(first, "/alarms/PLC/8/ack", "operator").status_code == 200
    post(first, "/alarms/ROBOT/3/shelve", "operator", {"minutes": 60, "reason": "maintenance"})
    before = get(first, "/alarms")
    history = get(first, "/alarms/history")
    first.client.close()
    first.client.app.state.alarms.store.close()
    # a new agent on the same data folder
    from fastapi.testclient import TestClient
    from indurop_agent.api.app import create_app
    from indurop_agent.config import Settings

    app = create_app(Settings(data_dir=first.data, irpd_socket=str(tmp_path / "none.sock")), restore=False)
    again = type(first)(TestClient(app), first.data, first.tokens)
    after = get(again, "/alarms")
    assert [(a["key"], a["state"], a["acknowledged_by"]) for a in after["alarms"]] == [
        (a["key"], a["state"], a["acknowledged_by"]) for a in before["alarms"]
    ]
    assert after["alarms"][0]["detail"] == "comm lost: Invalid data" and after["alarms"][0]["value"] == 22.0
    assert after["counts"] == before["counts"]
    assert get(again, "/alarms/history") == history
    # and it goes on from there: the cleared alarm, acknowledged, leaves
    alarms_of(again).clear_alarm("PLC", "8", time.time_ns())
    assert get(again, "/alarms")["alarms"][0]["key"] == "ROBOT/3"
    again.client.close()


def test_the_history_filters_pages_and_exports_csv(agent):
    m = alarms_of(agent)
    m.declare(PLC)
    t0 = time.time_ns() // 1000 * 1000  # whole microseconds, as ISO times give them
    for i in range(5):
        m.raise_alarm("PLC", "8", t0 + i * 2_000_000_000, detail=f"=cmd|' /C calc'!A{i}")  # a formula, for the CSV
        m.clear_alarm("PLC", "8", t0 + i * 2_000_000_000 + 1_000_000_000)
    m.raise_alarm("ROBOT", "3", t0, severity="low")
    page = get(agent, "/alarms/history", module="PLC", limit=4)
    assert page["total"] == 10 and len(page["transitions"]) == 4
    assert [t["event"] for t in page["transitions"]] == ["clear", "raise"] * 2
    rest = get(agent, "/alarms/history", module="PLC", limit=4, offset=8)
    assert len(rest["transitions"]) == 2 and rest["transitions"][-1]["time_ns"] == t0
    assert get(agent, "/alarms/history", severity="low")["total"] == 1
    assert get(agent, "/alarms/history", state="cleared_unacknowledged")["total"] == 5
    iso = lambda ns: time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(ns / 1e9)) + f".{ns % 1_000_000_000 // 1000:06d}Z"  # noqa: E731
    window = get(agent, "/alarms/history", module="PLC", since=iso(t0 + 2_000_000_000), until=iso(t0 + 5_000_000_000))
    assert [t["time_ns"] - t0 for t in reversed(window["transitions"])] == [2e9, 3e9, 4e9, 5e9]
    newest = page["transitions"][0]["seq"]
    assert get(agent, "/alarms/history", after=newest)["total"] == 1  # ROBOT/3 came after
    r = agent.client.get(f"{API}/alarms/history.csv", headers=agent.h("viewer"), params={"module": "PLC"})
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/csv")
    assert "attachment" in r.headers["content-disposition"]
    rows = list(csv.DictReader(io.StringIO(r.text)))
    assert len(rows) == 10 and rows[0]["event"] == "raise" and rows[0]["key"] == "PLC/8"
    assert rows[0]["detail"].startswith("'=")  # never a formula in a spreadsheet
    assert rows[0]["text"] == "drive communication lost"
    assert (
        agent.client.get(f"{API}/alarms/history", headers=agent.h(), params={"severity": "urgent"}).status_code == 422
    )
    # times beyond what 64-bit nanoseconds hold select everything or nothing, never a 500
    assert get(agent, "/alarms/history", since="2263-01-01T00:00:00Z")["total"] == 0
    assert get(agent, "/alarms/history", since="0001-01-01T00:00:00Z")["total"] == 11
    for big in ({"offset": 2**63}, {"after": 2**63}):  # beyond SQLite's integers: refused, not a 500
        assert agent.client.get(f"{API}/alarms/history", headers=agent.h(), params=big).status_code == 422
    assert get(agent, "/alarms/history", offset=2**63 - 1)["transitions"] == []


def test_a_flood_is_counted_not_recorded_and_keeps_the_older_history(make_agent):
    agent = make_agent(alarm_history_per_s=50, alarm_history_rows=500)
    m = alarms_of(agent)
    raise_plc8(agent)
    assert post(agent, "/alarms/PLC/8/ack", "operator").status_code == 200
    t = (time.time_ns() // 1_000_000_000 - 10) * 1_000_000_000  # seconds that are over: their flood rows are due
    for second in range(3):  # 20,000 transitions a second from one module, for 3 seconds
        with m.batch():
            for i in range(20_000):  # each of 1000 ids raised and cleared, ten times
                at = t + second * 1_000_000_000 + i * 50_000
                (m.raise_alarm if i % 2 == 0 else m.clear_alarm)("FLOOD", str(1 + i // 2 % 1000), at)
    m.flush_floods()
    history = get(agent, "/alarms/history", limit=1000)
    assert history["total"] <= 500
    assert any(x["key"] == "PLC/8" and x["event"] == "acknowledge" for x in history["transitions"])
    flood = [x for x in history["transitions"] if x["event"] == "flood"]
    recorded = [x for x in history["transitions"] if x["module"] == "FLOOD" and x["event"] != "flood"]
    assert len(recorded) == 3 * 50
    assert sum(x["count"] for x in flood) + len(recorded) == 60_000
    listed = get(agent, "/alarms")
    assert listed["segment"]["suppressed"] == 60_000 - 150
    # the states are right all the same: every id ended cleared, unacknowledged
    assert listed["counts"]["active"] == 1  # PLC/8
    assert listed["counts"]["unacknowledged"] == 1000  # FLOOD/1 .. /1000 cleared, unacknowledged
    assert len(m.alarms) == 1001  # memory: the alarms that need attention, nothing per transition


def test_the_live_push_sends_a_snapshot_then_every_transition_with_the_counts(agent):
    raise_plc8(agent)
    with agent.client.websocket_connect(f"{API}/alarms/live", headers=agent.h("viewer")) as ws:
        first = ws.receive_json()
        assert [a["key"] for a in first["snapshot"]["alarms"]] == ["PLC/8"]
        assert first["snapshot"]["counts"]["unacknowledged"] == 1
        alarms_of(agent).raise_alarm("ROBOT", "3", time.time_ns(), detail="joint 3 limit")
        message = ws.receive_json()
        assert [(t["key"], t["event"]) for t in message["transitions"]] == [("ROBOT/3", "raise")]
        assert message["changed"][0]["state"] == "active_unacknowledged"
        assert message["counts"]["active"] == 2 and message["counts"]["unacknowledged"] == 2
        assert post(agent, "/alarms/ack", "operator").status_code == 200
        message = ws.receive_json()
        assert [t["event"] for t in message["transitions"]] == ["acknowledge", "acknowledge"]
        assert message["counts"]["unacknowledged"] == 0


def test_the_live_push_needs_a_token(agent):
    from starlette.websockets import WebSocketDisconnect

    with agent.client.websocket_connect(f"{API}/alarms/live", headers={"Authorization": "Bearer nonsense"}) as ws:
        with pytest.raises(WebSocketDisconnect) as closed:
            ws.receive_json()
    assert closed.value.code == 4401
    # a token in the URL is refused whatever it is: URLs end up in logs and browser histories
    with agent.client.websocket_connect(f"{API}/alarms/live?token={agent.tokens['viewer']}") as ws:
        with pytest.raises(WebSocketDisconnect) as closed:
            ws.receive_json()
    assert closed.value.code == 4401 and "?token= is not accepted" in closed.value.reason

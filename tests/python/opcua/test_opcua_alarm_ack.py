"""test_opcua_alarm_ack.py -- alarms acknowledged and confirmed over OPC UA as an HMI does it: an
asyncua client subscribed to the alarm events calls Acknowledge and Confirm (EventId, Comment) on an
active alarm's ConditionId.  Against a real irpd (the signals set with a module that raises an alarm
while a file exists), the agent and indurop-opcua: a viewer is refused (BadUserAccessDenied) and
audited; an operator's acknowledgement is the agent's (GET /alarms, the history's note, the audit
line with the user via opcua) and the next event carries AckedState; a second one is
BadConditionBranchAlreadyAcked, an unknown EventId BadEventIdUnknown; Confirm likewise; and an
acknowledgement in the web UI's API turns up as the condition's AckedState (docs/opcua.md "Alarms")."""

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
from live_processes import ALARMING, SIGNALS, signals_with_an_alarm
from opcua_helpers import NO_SIGNALS, Controller, live_signals, ns_of

LIMIT_S = 60
KEY = "conveyor/5"
ACKNOWLEDGE = ua.NodeId(ua.ObjectIds.AcknowledgeableConditionType_Acknowledge)
CONFIRM = ua.NodeId(ua.ObjectIds.AcknowledgeableConditionType_Confirm)

pytestmark = NO_SIGNALS


@pytest.fixture(scope="module")
def signals(tmp_path_factory):
    c = live_signals(tmp_path_factory, "opcua-ack")
    yield c
    c.close()


class Events:
    def __init__(self):
        self.events: list = []

    def event_notification(self, event):
        if getattr(event, "ConditionName", "") == KEY:
            self.events.append(event)


async def until(what, seconds: float = LIMIT_S):
    deadline = time.monotonic() + seconds
    while not (got := what()):
        assert time.monotonic() < deadline, f"timed out waiting for {what.__doc__ or what}"
        await asyncio.sleep(0.05)
    return got


def held(signals) -> dict | None:
    """The alarm as GET /alarms has it (None: normal)."""
    return next((a for a in signals.rest("/alarms")["alarms"] if a["key"] == KEY), None)


async def call(c, condition: ua.NodeId, method: ua.NodeId, event_id: bytes, comment: str) -> str:
    try:
        await c.get_node(condition).call_method(
            method,
            ua.Variant(event_id, ua.VariantType.ByteString),
            ua.Variant(ua.LocalizedText(comment), ua.VariantType.LocalizedText),
        )
    except ua.UaStatusCodeError as e:
        return type(e).__name__
    return "Good"


def test_acknowledge_and_confirm_over_opcua_are_the_agents_checked_and_audited(signals):
    jam = signals.folder / "jam"

    async def go():
        oper, view = await signals.connect("oper"), await signals.connect("view")
        try:
            seen = Events()
            sub = await oper.create_subscription(50, seen)
            await sub.subscribe_events(oper.nodes.server, ua.ObjectIds.AlarmConditionType, queuesize=100)
            await asyncio.sleep(0.5)
            jam.touch()
            raised = await until(lambda: next((e for e in seen.events if e.ActiveState.Text == "Active"), None))
            assert raised.AckedState.Text == "Unacknowledged" and raised.Retain is True
            assert raised.ConfirmedState.Text == "Unconfirmed"
            await until(lambda: held(signals))  # the agent has read the raise
            condition, event_id = raised.NodeId, raised.EventId
            assert condition == ua.NodeId(f"@Controller.Alarms.{KEY}", await ns_of(oper))

            out = {"viewer": await call(view, condition, ACKNOWLEDGE, event_id, "a viewer tries")}
            out["unacked after viewer"] = held(signals)["acknowledged"]
            out["unknown event"] = await call(oper, condition, ACKNOWLEDGE, b"not-an-event-id", "")
            out["confirm first"] = await call(oper, condition, CONFIRM, event_id, "too early")
            out["operator"] = await call(oper, condition, ACKNOWLEDGE, event_id, "seen from the HMI")
            out["alarm"] = held(signals)
            acked = await until(lambda: next((e for e in seen.events if e.AckedState.Text == "Acknowledged"), None))
            out["acked event"] = (getattr(acked, "AckedState/Id"), acked.ClientUserId, acked.Comment.Text, acked.Retain)
            out["again"] = await call(oper, condition, ACKNOWLEDGE, acked.EventId, "twice")
            out["confirm"] = await call(oper, condition, CONFIRM, acked.EventId, "belt cleared")
            confirmed = await until(
                lambda: next((e for e in seen.events if e.ConfirmedState.Text == "Confirmed"), None)
            )
            out["confirmed event"] = getattr(confirmed, "ConfirmedState/Id")
            out["confirmed alarm"] = held(signals)

            # The web UI's acknowledgement (the agent's API) reaches the OPC UA condition too.
            jam.unlink()
            await until(lambda: held(signals) is None)  # cleared and acknowledged: normal
            await until(lambda: seen.events[-1].ActiveState.Text == "Inactive")  # and the clear's event
            count = len(seen.events)
            jam.touch()
            await until(lambda: (a := held(signals)) and a["active"])
            r = httpx.post(f"{signals.api}/alarms/{KEY}/ack", headers=signals.admin, timeout=30)
            assert r.status_code == 200, r.text
            later = await until(lambda: [e for e in seen.events[count:] if e.AckedState.Text == "Acknowledged"])
            out["web ack event"] = (later[0].ActiveState.Text, getattr(later[0], "AckedState/Id"))
            return out
        finally:
            jam.unlink(missing_ok=True)
            await oper.disconnect()
            await view.disconnect()

    out = asyncio.run(go())
    assert out["viewer"] == "BadUserAccessDenied" and out["unacked after viewer"] is False
    assert out["unknown event"] == "BadEventIdUnknown"
    assert out["confirm first"] == "BadInvalidState"  # not acknowledged yet
    assert out["operator"] == "Good"
    alarm = out["alarm"]
    assert alarm["acknowledged"] and alarm["state"] == "active_acknowledged"
    assert alarm["acknowledged_by"]["name"] == "oper" and alarm["acknowledged_by"]["via"] == "opcua"
    assert out["acked event"] == (True, "oper", "seen from the HMI", True)  # still active: retained
    assert out["again"] == "BadConditionBranchAlreadyAcked"
    assert out["confirm"] == "Good" and out["confirmed event"] is True
    assert out["confirmed alarm"]["confirmed"] and out["confirmed alarm"]["confirmed_by"]["name"] == "oper"
    assert out["web ack event"] == ("Active", True)

    lines = [a for a in signals.audit() if a["action"] in ("alarm_ack", "alarm_confirm") and a["target"] == KEY]
    view_line = next(a for a in lines if a["who"]["name"] == "view")
    assert view_line["result"] == "error" and view_line["status"] == 403 and view_line["who"]["via"] == "opcua"
    oper_ack = next(
        a for a in lines if a["who"]["name"] == "oper" and a["action"] == "alarm_ack" and a["result"] == "ok"
    )
    assert oper_ack["who"]["via"] == "opcua" and oper_ack["comment"] == "seen from the HMI"
    assert oper_ack["opcua_client"] == "127.0.0.1" and oper_ack["who"]["id"].startswith("opcua-session-")
    assert any(a["action"] == "alarm_confirm" and a["result"] == "ok" for a in lines)
    history = signals.rest(f"/alarms/history?key={KEY}")["transitions"]
    assert "seen from the HMI" in [t["note"] for t in history if t["event"] == "acknowledge"]
    assert [t["note"] for t in history if t["event"] == "confirm"] == ["belt cleared"]


def test_only_the_servers_token_is_let_into_the_opcua_routes(signals):
    body = {"user": "oper", "method": "password", "role": "operator", "session": "x", "client": "10.0.0.9"}
    for headers in ({}, signals.admin, {"Authorization": "Bearer not-the-servers-token"}):
        r = httpx.post(f"{signals.api}/opcua/alarms/{KEY}/ack", json=body, headers=headers, timeout=30)
        assert r.status_code == 401, (headers, r.text)
        assert httpx.get(f"{signals.api}/opcua/alarms", headers=headers, timeout=30).status_code == 401
    token = signals.data / "opcua-token"
    assert token.stat().st_mode & 0o777 == 0o600

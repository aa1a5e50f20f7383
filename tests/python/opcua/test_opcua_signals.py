"""test_opcua_signals.py -- indurop-opcua in front of a real irpd running the signals set (the sample
counter SIG.sample and sixteen waves every 1 ms) with a module that raises an alarm while a file
exists: a monitored item at 10 ms on the 1 kHz counter gets every tenth row's value from the trace
rings (each one 10 more than the one before: nothing skipped, nothing twice), stamped 10 ms apart on
the period grid; an element of an array (an IndexRange) the same; items at 10 ms and 50 ms on the same variable each see their own rate; a queue
smaller than a publishing interval's values keeps the newest with the Overflow bit; the alarm's
raise and clear arrive as AlarmConditionType events with their severity (docs/opcua.md)."""

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

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "agent"))
from indurop_agent.access.auth import now_iso

LIMIT_S = 60

pytestmark = NO_SIGNALS


@pytest.fixture(scope="module")
def signals(tmp_path_factory):
    c = live_signals(tmp_path_factory, "opcua-signals")
    yield c
    c.close()


class Notes:
    def __init__(self):
        self.values: dict[int, list[ua.DataValue]] = {}
        self.events: list = []

    def datachange_notification(self, node, value, data):
        self.values.setdefault(data.subscription_data.server_handle, []).append(data.monitored_item.Value)

    def event_notification(self, event):
        self.events.append(event)


def sampling_since(signals, since: str) -> dict:
    """The server's sampling counts from a status.json written after `since` (ISO time), else {}."""
    status = signals.server_status()
    return status.get("sampling", {}) if status.get("updated", "") > since else {}


async def until(what, seconds: float = LIMIT_S):
    deadline = time.monotonic() + seconds
    while not what():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        await asyncio.sleep(0.05)


def test_a_1khz_counter_monitored_at_10ms_gets_every_tenth_row(signals):
    async def go():
        c = await signals.connect("view")
        try:
            ns = await ns_of(c)
            sample = c.get_node(ua.NodeId("SIG.sample", ns))
            notes = Notes()
            sub = await c.create_subscription(100, notes)
            # An item's values come from the segment until irpd traces its variable for the server:
            # once it does, a new item's values after its first come from the rings alone.
            await sub.subscribe_data_change(sample, sampling_interval=1000)
            since = now_iso()
            await until(lambda: sampling_since(signals, since).get("from_trace_rings") == 1)
            fast = await sub.subscribe_data_change(sample, sampling_interval=10, queuesize=100)
            slow = await sub.subscribe_data_change(sample, sampling_interval=50, queuesize=100)
            await until(lambda: len(notes.values.get(fast, [])) >= 300)
            await sub.delete()
            return notes.values[fast], notes.values[slow]
        finally:
            await c.disconnect()

    fast, slow = asyncio.run(go())
    # The first value is the variable as it was when the item was made (read from the segment); from
    # then on every tenth row of the rings, each 10 samples later than the one before.
    counts = [dv.Value.Value for dv in fast[1:]]
    steps = {b - a for a, b in zip(counts, counts[1:])}
    assert steps == {10}, f"steps between notifications: {sorted(steps)[:10]}"
    times = [dv.SourceTimestamp for dv in fast[1:]]
    gaps = {round((b - a).total_seconds() * 1000) for a, b in zip(times, times[1:])}
    assert gaps == {10}, gaps  # due times of rows ten periods apart (the grid, not when read)
    assert all(dv.StatusCode.is_good() for dv in fast)
    slow_counts = [dv.Value.Value for dv in slow[1:]]
    assert {b - a for a, b in zip(slow_counts, slow_counts[1:])} == {50}


def test_an_element_of_an_array_is_monitored_and_read_by_index_range(signals):
    async def go():
        c = await signals.connect("view")
        try:
            ns = await ns_of(c)
            waves = c.get_node(ua.NodeId("SIG.wave", ns))
            notes = Notes()
            sub = await c.create_subscription(100, notes)
            request = sub._make_monitored_item_request(
                waves, ua.AttributeIds.Value, None, 100, ua.MonitoringMode.Reporting, 10
            )
            request.ItemToMonitor.IndexRange = "0"  # the 1 Hz sine: a new value every row
            (sine,) = await sub.create_monitored_items([request])
            since = now_iso()
            await until(lambda: sampling_since(signals, since).get("from_trace_rings") == 1)
            count = len(notes.values.get(sine, []))
            await until(lambda: len(notes.values.get(sine, [])) >= count + 100)
            values = notes.values[sine][count + 1 :]  # from the rings now
            rv = ua.ReadValueId(NodeId=waves.nodeid, AttributeId=ua.AttributeIds.Value, IndexRange="4:5")
            params = ua.ReadParameters(NodesToRead=[rv])
            (two,) = await c.uaclient.read(params)
            await sub.delete()
            return values, two
        finally:
            await c.disconnect()

    values, two = asyncio.run(go())
    assert all(isinstance(dv.Value.Value, float) for dv in values)
    gaps = {round((b.SourceTimestamp - a.SourceTimestamp).total_seconds() * 1000) for a, b in zip(values, values[1:])}
    assert gaps == {10}, gaps  # every tenth row of the rings
    assert two.StatusCode.is_good() and len(two.Value.Value) == 2


def test_a_queue_smaller_than_a_publishing_intervals_values_keeps_the_newest_with_the_overflow_bit(signals):
    async def go():
        c = await signals.connect("view")
        try:
            ns = await ns_of(c)
            notes = Notes()
            sub = await c.create_subscription(500, notes)  # 50 values of a 10 ms item per publish
            await sub.subscribe_data_change(c.get_node(ua.NodeId("SIG.sample", ns)), sampling_interval=10, queuesize=5)
            await until(lambda: sum(len(v) for v in notes.values.values()) >= 20)
            await sub.delete()
            return [dv for values in notes.values.values() for dv in values]
        finally:
            await c.disconnect()

    values = asyncio.run(go())
    flagged = [dv for dv in values if dv.StatusCode.value & 0x0480 == 0x0480]
    assert flagged, "no value carried the Overflow bit"
    # discardOldest (the default): the oldest kept value of a full queue carries the bit
    counts = [dv.Value.Value for dv in values[1:]]
    assert counts == sorted(counts)


def test_an_alarm_raised_and_cleared_by_a_module_arrives_as_condition_events_with_its_severity(signals):
    jam = signals.folder / "jam"

    async def go():
        c = await signals.connect("view")
        try:
            notes = Notes()
            sub = await c.create_subscription(100, notes)
            await sub.subscribe_events(c.nodes.server, ua.ObjectIds.AlarmConditionType)
            await asyncio.sleep(1)
            jam.touch()
            await until(lambda: any(getattr(e, "ConditionName", "") == "conveyor/5" for e in notes.events))
            jam.unlink()
            await until(lambda: len([e for e in notes.events if getattr(e, "ConditionName", "") == "conveyor/5"]) >= 2)
            ns = await ns_of(c)
            return notes.events, await c.get_node(ua.NodeId("@Controller.Alarms.ActiveCount", ns)).read_value()
        finally:
            await c.disconnect()

    events, active = asyncio.run(go())
    raised, cleared = [e for e in events if getattr(e, "ConditionName", "") == "conveyor/5"][:2]
    assert raised.Severity == 750 and raised.SourceName == "conveyor"
    assert "Conveyor jammed" in raised.Message.Text
    assert raised.ActiveState.Text == "Active" and cleared.ActiveState.Text == "Inactive"
    assert active == 0


def test_an_active_alarm_is_a_retained_condition_that_condition_refresh_sends_again(signals):
    """Runs last: it restarts the server.  A SCADA that subscribes after an alarm was raised calls
    ConditionRefresh and gets it between RefreshStart and RefreshEnd, with its ConditionId; so does
    one that connects to a server started while the alarm was already active; once the alarm is
    cleared it is sent Inactive and Unacknowledged, and once acknowledged (through the agent, as the
    web UI does) not at all."""
    jam = signals.folder / "jam"
    types = [ua.ObjectIds.AlarmConditionType, ua.ObjectIds.RefreshStartEventType, ua.ObjectIds.RefreshEndEventType]
    start, end = ua.NodeId(ua.ObjectIds.RefreshStartEventType), ua.NodeId(ua.ObjectIds.RefreshEndEventType)

    async def refreshed(c, method=ua.ObjectIds.ConditionType_ConditionRefresh) -> list:
        """The events one refresh brings: from RefreshStart to RefreshEnd."""
        notes = Notes()
        sub = await c.create_subscription(50, notes)
        handle = await sub.subscribe_events(c.nodes.server, types, queuesize=100)
        await asyncio.sleep(0.5)  # nothing is raised or cleared meanwhile: anything now is the refresh's
        args = [ua.Variant(sub.subscription_id, ua.VariantType.UInt32)]
        if method == ua.ObjectIds.ConditionType_ConditionRefresh2:
            args.append(ua.Variant(handle, ua.VariantType.UInt32))
        await c.get_node(ua.ObjectIds.ConditionType).call_method(ua.NodeId(method), *args)
        await until(lambda: any(e.EventType == end for e in notes.events))
        await sub.delete()
        kinds = [e.EventType for e in notes.events]
        assert start in kinds and kinds.index(start) < kinds.index(end), kinds
        # (a raise or clear whose event went out after the subscription was made comes before the start)
        between = notes.events[kinds.index(start) + 1 : kinds.index(end)]
        return [e for e in between if getattr(e, "ConditionName", "") == "conveyor/5"]

    async def active_count(c) -> int:
        return await c.get_node(ua.NodeId("@Controller.Alarms.ActiveCount", await ns_of(c))).read_value()

    async def go(step: str):
        c = await signals.connect("view")
        try:
            # ActiveCount follows the segment's bitmaps, the events its ring, a poll later: a
            # subscription made before the raise's event went out would get it without a refresh
            if step == "raise":
                before = signals.fresh_status()["alarm_events"]
                jam.touch()
                await until_async(lambda: active_count(c), 1)
                await until(lambda: signals.fresh_status()["alarm_events"] > before)
            elif step == "restarted":
                await until(lambda: signals.fresh_status()["alarm_events"] >= 1)  # announced at attach
            elif step == "clear":
                jam.unlink(missing_ok=True)  # (the finally below may have)
                await until_async(lambda: active_count(c), 0)
            elif step == "bad id":  # none such, and another session's
                other = await signals.connect("view")
                try:
                    theirs = (await other.create_subscription(100, Notes())).subscription_id
                    codes = []
                    for sid in (987654, theirs):
                        with pytest.raises(ua.UaStatusCodeError) as e:
                            await c.get_node(ua.ObjectIds.ConditionType).call_method(
                                ua.NodeId(ua.ObjectIds.ConditionType_ConditionRefresh),
                                ua.Variant(sid, ua.VariantType.UInt32),
                            )
                        codes.append(e.value.code)
                    return codes
                finally:
                    await other.disconnect()
            return await refreshed(c), await refreshed(c, ua.ObjectIds.ConditionType_ConditionRefresh2), await ns_of(c)
        finally:
            await c.disconnect()

    try:  # a failure must not leave the alarm raised for the next tests
        for step in ("raise", "restarted"):
            if step == "restarted":
                signals.restart_server()  # the alarm is active while the new server attaches
            first, second, ns = asyncio.run(go(step))
            for events in (first, second):
                assert len(events) == 1, (step, events)
                e = events[0]
                assert e.ActiveState.Text == "Active" and e.Retain is True and e.Severity == 750
                assert e.NodeId == ua.NodeId("@Controller.Alarms.conveyor/5", ns)
    finally:
        jam.unlink(missing_ok=True)
    first, second, _ = asyncio.run(go("clear"))
    for events in (first, second):
        assert [(e.ActiveState.Text, e.AckedState.Text, e.Retain) for e in events] == [
            ("Inactive", "Unacknowledged", True)
        ]
    r = httpx.post(f"{signals.api}/alarms/conveyor/5/ack", headers=signals.admin, timeout=30)
    assert r.status_code == 200, r.text
    deadline = time.monotonic() + LIMIT_S  # the server asks the agent every second
    while (refreshes := asyncio.run(go("acknowledged"))[:2]) != ([], []):
        assert time.monotonic() < deadline, refreshes
    assert asyncio.run(go("bad id")) == [ua.StatusCodes.BadSubscriptionIdInvalid] * 2


async def until_async(read, want, seconds: float = LIMIT_S):
    deadline = time.monotonic() + seconds
    while (got := await read()) != want:
        assert time.monotonic() < deadline, f"timed out waiting for {want} (last {got})"
        await asyncio.sleep(0.05)

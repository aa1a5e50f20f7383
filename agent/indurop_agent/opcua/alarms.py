"""alarms.py -- the modules' alarms as OPC UA Alarms & Conditions events (docs/opcua.md "Alarms").

The alarm segment's ring is read as the agent reads it (alarms/segment.py: RingReader), every poll;
each record -- a module raised or cleared alarm <id> -- becomes an event of AlarmConditionType,
emitted by the Server object and by Controller.Alarms: ConditionName and SourceName the alarm's key
(<module>/<id>) and module, Message its declared text (irpd's `alarms`) and the record's detail,
Severity 250/500/750/1000 for low/medium/high/critical, ActiveState "Active" or "Inactive" with its
Id, Time the record's, and the ConditionId (the event's NodeId) `@Controller.Alarms.<key>`.
Controller.Alarms.ActiveCount counts the active alarms of the sources' bitmaps, written before a
poll's events go out (a client that reads it on an event sees it agree) and at every status poll.

Active alarms are retained conditions: ConditionRefresh and ConditionRefresh2 (the ConditionType's
methods, which a SCADA calls when it subscribes) send each one's last event again to that
subscription's event items, between RefreshStartEvent and RefreshEndEvent.  The alarms already
active when the segment is attached (the server or irpd started) are announced then, and a new
segment clears the conditions the old one left.

Acknowledging is the agent's (its alarm manager holds the state the web UI shows): each event
carries AckedState and ConfirmedState as the agent has them (asked every ACK_POLL_S; an
acknowledgement in the web UI sends the condition's event again with AckedState true), and a
condition is retained while it is active or unacknowledged.  Acknowledge and Confirm called on a
ConditionId go to the agent as the session's user (acks.py); done, the condition's event goes out
with the new state, the user (ClientUserId) and the comment.
"""

from __future__ import annotations

import asyncio
import copy
import time
from collections import deque
from dataclasses import dataclass, field
from datetime import UTC, datetime

from asyncua import Server, ua

from ..alarms.segment import AlarmSegment, AlarmSegmentError, RingReader
from ..irpd.client import IrpdClient, IrpdRefused, IrpdUnavailable
from ..irpd.shm_layout import LayoutError
from .acks import METHODS, AgentAlarms, AgentUnavailable

SEVERITY = {"low": 250, "medium": 500, "high": 750, "critical": 1000}
MAX_PER_POLL = 256  # records turned into events per poll; the rest wait for the next
ACK_POLL_S = 1.0  # how often the agent is asked the alarms' acknowledgement
RECENT_EVENTS = 16  # EventIds of a condition that Acknowledge and Confirm accept


def agent_state(alarm: dict) -> tuple[bool, bool]:
    """(acknowledged, confirmed) of an alarm as the agent answers it (AlarmPublic)."""
    return alarm["acknowledged"], alarm["confirmed"]


@dataclass
class Condition:
    """A retained condition (active, or not acknowledged) and what its next event repeats."""

    module: str
    id: int
    active: bool
    acked: bool
    confirmed: bool
    severity: str
    detail: str
    events: list = field(default_factory=list)  # its last event, per emitter (ConditionRefresh)
    event_ids: deque = field(default_factory=lambda: deque(maxlen=RECENT_EVENTS))

    @property
    def key(self) -> str:
        return f"{self.module}/{self.id}"


class AlarmEvents:
    def __init__(self, server: Server, space, irpd: IrpdClient, agent: AgentAlarms):
        self.server = server
        self.agent = agent
        self.agent_states: dict[str, dict] | None = None  # the agent's alarms by key, once asked
        self.agent_error: str | None = None
        self.next_sync = 0.0
        self.space = space
        self.irpd = irpd
        self.segment: AlarmSegment | None = None
        self.reader: RingReader | None = None
        self.generators = []
        self.refresh_events: dict[int, object] = {}  # RefreshStart/EndEventType -> its generator
        self.declared: dict[tuple[str, int], dict] = {}  # (module, id) -> {"text", "severity"}
        self.names: dict[int, str] = {}  # source -> module
        self.retained: dict[tuple[str, int], Condition] = {}
        self.active_node = None
        self.emitted = 0
        self.refreshes = 0

    async def init(self) -> None:
        for emitter in (self.server.nodes.server, self.space.alarms_node):
            self.generators.append(await self.server.get_event_generator(ua.ObjectIds.AlarmConditionType, emitter))
        for etype in (ua.ObjectIds.RefreshStartEventType, ua.ObjectIds.RefreshEndEventType):
            self.refresh_events[etype] = await self.server.get_event_generator(etype, self.server.nodes.server)
        for method in (ua.ObjectIds.ConditionType_ConditionRefresh, ua.ObjectIds.ConditionType_ConditionRefresh2):
            self.server.link_method(self.server.get_node(method), self.refresh)
        self.active_node = await self.space.alarms_node.add_variable(
            self.space.nodeid("@Controller.Alarms.ActiveCount"),
            ua.QualifiedName("ActiveCount", self.space.ns),
            ua.Variant(0, ua.VariantType.UInt32),
        )

    async def follow(self, status: dict, set_changed: bool) -> None:
        """irpd's status: the segment to read (a new one when irpd restarted); the declarations
        again when the set changed."""
        name = (status.get("shared_memory") or {}).get("alarms")
        if self.segment is not None and (name != self.segment.name or self.segment.replaced()):
            self.segment.close()
            self.segment = self.reader = None
        attached = False
        if self.segment is None and name:
            try:
                self.segment = AlarmSegment(name)
            except (AlarmSegmentError, LayoutError, OSError):
                return
            self.reader = RingReader(self.segment, cursor=self.segment.head())  # from now on
            set_changed = attached = True
        if set_changed:
            try:
                answer = await asyncio.to_thread(self.irpd.request, "alarms")
            except (IrpdUnavailable, IrpdRefused):
                return
            self.declared = {
                (s.get("module"), d.get("id")): d for s in answer.get("sources", []) for d in s.get("declared", [])
            }
        if self.segment is not None:
            active = await self._count_active()
            if attached:
                await self._announce(active)

    async def _count_active(self) -> set[tuple[str, int]]:
        """Writes ActiveCount; the active alarms, (module, id)."""
        sources = self.segment.sources()
        self.names = {s.index: s.name for s in sources}
        active = {(s.name, i) for s in sources for i in s.active}
        await self.active_node.write_value(ua.Variant(len(active), ua.VariantType.UInt32))
        return active

    async def _announce(self, active: set[tuple[str, int]]) -> None:
        """A new segment: the conditions the old one left are cleared, its active alarms raised."""
        now = datetime.now(UTC)
        for module, id_ in sorted({k for k, c in self.retained.items() if c.active} - active):
            await self._emit(module, id_, False, None, now, "the controller restarted")
        for module, id_ in sorted(active - set(self.retained)):
            held = (self.agent_states or {}).get(f"{module}/{id_}")
            states = agent_state(held) if held else (False, False)
            await self._emit(module, id_, True, None, now, "active when the server attached", states)

    async def step(self) -> None:
        if time.monotonic() >= self.next_sync:
            self.next_sync = time.monotonic() + ACK_POLL_S
            await self.sync()
        if self.reader is None:
            return
        read = self.reader.read(limit=MAX_PER_POLL)
        if read.records:  # ActiveCount as it is when the events go out, not a status poll later
            await self._count_active()
        for r in read.records:
            module = self.names.get(r.source, f"source {r.source}")
            when = datetime.fromtimestamp(r.time_ns / 1e9, UTC)
            await self._emit(module, r.id, r.raised, r.severity, when, r.text)

    async def _emit(
        self, module: str, id_: int, raised: bool, severity: str | None, when, detail: str,
        states: tuple[bool, bool] | None = None, by: tuple[str, str] | None = None,
    ) -> None:  # fmt: skip
        """One event of the condition (module, id_): active or not, acknowledged and confirmed as
        `states` says (else: a raise is neither, a clear keeps what the condition had), `by`:
        (user, comment) of an Acknowledge or Confirm."""
        key = f"{module}/{id_}"
        held = self.retained.get((module, id_))
        if states is None:
            states = (False, False) if raised else (held.acked, held.confirmed) if held else (True, True)
        acked, confirmed = states
        declared = self.declared.get((module, id_), {})
        severity = severity or declared.get("severity") or "medium"
        text = declared.get("text") or f"alarm {id_} of {module} (not declared)"
        condition = self.space.nodeid(f"@Controller.Alarms.{key}")  # the ConditionId
        c = Condition(module, id_, raised, acked, confirmed, severity, detail)
        c.event_ids = held.event_ids if held else c.event_ids
        for gen in self.generators:
            gen.event = e = copy.copy(gen.event)  # a retained condition keeps its own event
            e.NodeId = condition
            e.SourceName = module
            e.ConditionName = key
            e.Severity = SEVERITY.get(severity, 500)
            e.Retain = raised or not acked
            for name, value, true, false in (
                ("ActiveState", raised, "Active", "Inactive"),
                ("AckedState", acked, "Acknowledged", "Unacknowledged"),
                ("ConfirmedState", confirmed, "Confirmed", "Unconfirmed"),
            ):
                setattr(e, name, ua.LocalizedText(true if value else false))
                setattr(e, f"{name}/Id", value)
            e.ClientUserId, e.Comment = (by[0], ua.LocalizedText(by[1])) if by else (None, ua.LocalizedText(""))
            await gen.trigger(time_attr=when, message=f"{text}: {detail}" if detail else text)
            c.events.append(e)
            c.event_ids.append(e.EventId.Value if isinstance(e.EventId, ua.Variant) else e.EventId)
        if raised or not acked:
            self.retained[module, id_] = c
        else:
            self.retained.pop((module, id_), None)
        self.emitted += 1

    async def sync(self) -> None:
        """The agent's acknowledgement states: a retained condition whose state there changed (in
        the web UI, by irpctl, over OPC UA) gets an event with it."""
        try:
            self.agent_states = await self.agent.states()
            self.agent_error = None
        except AgentUnavailable as e:
            self.agent_error = str(e)
            return
        now = datetime.now(UTC)
        for c in list(self.retained.values()):
            held = self.agent_states.get(c.key)
            if held is None and c.active:
                continue  # the agent has not read the raise yet
            states = agent_state(held) if held else (True, True)  # else: normal there
            if states != (c.acked, c.confirmed):
                await self._emit(c.module, c.id, c.active, c.severity, now, c.detail, states)

    async def respond(self, session, request: ua.CallMethodRequest) -> ua.CallMethodResult:
        """Acknowledge or Confirm (EventId, Comment) called on a ConditionId, for `session`."""

        def answer(code: int) -> ua.CallMethodResult:
            return ua.CallMethodResult(StatusCode=ua.StatusCode(code))

        c = next((c for c in self.retained.values() if c.events and c.events[0].NodeId == request.ObjectId), None)
        if c is None:
            return answer(ua.StatusCodes.BadNodeIdUnknown)  # no such condition, or not retained any more
        args = [a.Value for a in request.InputArguments or []]
        if len(args) < 2:
            return answer(ua.StatusCodes.BadArgumentsMissing)
        event_id, comment = args[0], args[1]
        comment = comment.Text if isinstance(comment, ua.LocalizedText) else comment
        if not isinstance(event_id, bytes) or not isinstance(comment, str | None):
            return answer(ua.StatusCodes.BadTypeMismatch)
        if event_id not in c.event_ids:
            return answer(ua.StatusCodes.BadEventIdUnknown)
        status, alarm = await self.agent.act(METHODS[request.MethodId], c.key, session, comment or "")
        if status == ua.StatusCodes.BadConditionBranchAlreadyConfirmed and not c.acked:
            status = ua.StatusCodes.BadInvalidState  # the agent's 409: not acknowledged yet
        if alarm is not None:
            by = (getattr(session.user, "name", "") or "", comment or "")
            states = agent_state(alarm)
            await self._emit(c.module, c.id, c.active, c.severity, datetime.now(UTC), c.detail, states, by)
        return answer(status)

    async def refresh(self, parent, subscription_id, monitored_item_id=None):
        """ConditionRefresh(SubscriptionId) and ConditionRefresh2(SubscriptionId, MonitoredItemId)."""
        sid = subscription_id.Value
        sub = self.server.iserver.subscription_service.subscriptions.get(sid)
        if sub is None:
            return ua.StatusCode(ua.StatusCodes.BadSubscriptionIdInvalid)
        items = sub.monitored_item_srv
        mid = None if monitored_item_id is None else monitored_item_id.Value
        if mid is not None and mid not in items._monitored_items:
            return ua.StatusCode(ua.StatusCodes.BadMonitoredItemIdInvalid)
        self.refreshes += 1
        await self.refresh_events[ua.ObjectIds.RefreshStartEventType].trigger(subscription_id=sid)
        for c in list(self.retained.values()):
            for e in c.events:
                await items.trigger_event(e, mid)
        await self.refresh_events[ua.ObjectIds.RefreshEndEventType].trigger(subscription_id=sid)
        return []

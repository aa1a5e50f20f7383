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
segment clears the conditions the old one left.  Acknowledging stays the agent's (POST
/alarms/{key}/ack): the conditions have no Acknowledge here.
"""

from __future__ import annotations

import asyncio
import copy
from datetime import UTC, datetime

from asyncua import Server, ua

from ..alarms.segment import AlarmSegment, AlarmSegmentError, RingReader
from ..irpd_client import IrpdClient, IrpdRefused, IrpdUnavailable
from ..shm_layout import LayoutError

SEVERITY = {"low": 250, "medium": 500, "high": 750, "critical": 1000}
MAX_PER_POLL = 256  # records turned into events per poll; the rest wait for the next


class AlarmEvents:
    def __init__(self, server: Server, space, irpd: IrpdClient):
        self.server = server
        self.space = space
        self.irpd = irpd
        self.segment: AlarmSegment | None = None
        self.reader: RingReader | None = None
        self.generators = []
        self.refresh_events: dict[int, object] = {}  # RefreshStart/EndEventType -> its generator
        self.declared: dict[tuple[str, int], dict] = {}  # (module, id) -> {"text", "severity"}
        self.names: dict[int, str] = {}  # source -> module
        self.retained: dict[tuple[str, int], list] = {}  # (module, id) active -> its last event, per emitter
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
        for module, id_ in sorted(set(self.retained) - active):
            await self._emit(module, id_, False, None, now, "the controller restarted")
        for module, id_ in sorted(active - set(self.retained)):
            await self._emit(module, id_, True, None, now, "active when the server attached")

    async def step(self) -> None:
        if self.reader is None:
            return
        read = self.reader.read(limit=MAX_PER_POLL)
        if read.records:  # ActiveCount as it is when the events go out, not a status poll later
            await self._count_active()
        for r in read.records:
            module = self.names.get(r.source, f"source {r.source}")
            when = datetime.fromtimestamp(r.time_ns / 1e9, UTC)
            await self._emit(module, r.id, r.raised, r.severity, when, r.text)

    async def _emit(self, module: str, id_: int, raised: bool, severity: str | None, when, detail: str) -> None:
        key = f"{module}/{id_}"
        declared = self.declared.get((module, id_), {})
        severity = severity or declared.get("severity") or "medium"
        text = declared.get("text") or f"alarm {id_} of {module} (not declared)"
        condition = self.space.nodeid(f"@Controller.Alarms.{key}")  # the ConditionId
        events = []
        for gen in self.generators:
            gen.event = e = copy.copy(gen.event)  # a retained condition keeps its own event
            e.NodeId = condition
            e.SourceName = module
            e.ConditionName = key
            e.Severity = SEVERITY.get(severity, 500)
            e.Retain = raised
            e.ActiveState = ua.LocalizedText("Active" if raised else "Inactive")
            setattr(e, "ActiveState/Id", raised)
            await gen.trigger(time_attr=when, message=f"{text}: {detail}" if detail else text)
            events.append(e)
        if raised:
            self.retained[module, id_] = events
        else:
            self.retained.pop((module, id_), None)
        self.emitted += 1

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
        for events in list(self.retained.values()):
            for e in events:
                await items.trigger_event(e, mid)
        await self.refresh_events[ua.ObjectIds.RefreshEndEventType].trigger(subscription_id=sid)
        return []

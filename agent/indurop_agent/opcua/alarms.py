"""alarms.py -- the modules' alarms as OPC UA Alarms & Conditions events (docs/opcua.md "Alarms").

The alarm segment's ring is read as the agent reads it (alarms/segment.py: RingReader), every poll;
each record -- a module raised or cleared alarm <id> -- becomes an event of AlarmConditionType,
emitted by the Server object and by Controller.Alarms: ConditionName and SourceName the alarm's key
(<module>/<id>) and module, Message its declared text (irpd's `alarms`) and the record's detail,
Severity 250/500/750/1000 for low/medium/high/critical, ActiveState "Active" or "Inactive" with its
Id, Time the record's.  Controller.Alarms.ActiveCount counts the active alarms of the sources'
bitmaps, written before a poll's events go out (a client that reads it on an event sees it agree)
and at every status poll.  Acknowledging stays the agent's (POST /alarms/{key}/ack): events here are read only.
"""

from __future__ import annotations

import asyncio
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
        self.declared: dict[tuple[str, int], dict] = {}  # (module, id) -> {"text", "severity"}
        self.names: dict[int, str] = {}  # source -> module
        self.active_node = None
        self.emitted = 0

    async def init(self) -> None:
        for emitter in (self.server.nodes.server, self.space.alarms_node):
            self.generators.append(await self.server.get_event_generator(ua.ObjectIds.AlarmConditionType, emitter))
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
        if self.segment is None and name:
            try:
                self.segment = AlarmSegment(name)
            except (AlarmSegmentError, LayoutError, OSError):
                return
            self.reader = RingReader(self.segment, cursor=self.segment.head())  # from now on
            set_changed = True
        if set_changed:
            try:
                answer = await asyncio.to_thread(self.irpd.request, "alarms")
            except (IrpdUnavailable, IrpdRefused):
                return
            self.declared = {
                (s.get("module"), d.get("id")): d for s in answer.get("sources", []) for d in s.get("declared", [])
            }
        if self.segment is not None:
            await self._count_active()

    async def _count_active(self) -> None:
        sources = self.segment.sources()
        self.names = {s.index: s.name for s in sources}
        active = sum(len(s.active) for s in sources)
        await self.active_node.write_value(ua.Variant(active, ua.VariantType.UInt32))

    async def step(self) -> None:
        if self.reader is None:
            return
        read = self.reader.read(limit=MAX_PER_POLL)
        if read.records:  # ActiveCount as it is when the events go out, not a status poll later
            await self._count_active()
        for r in read.records:
            module = self.names.get(r.source, f"source {r.source}")
            declared = self.declared.get((module, r.id), {})
            severity = r.severity or declared.get("severity") or "medium"
            text = declared.get("text") or f"alarm {r.id} of {module} (not declared)"
            message = f"{text}: {r.text}" if r.text else text
            for gen in self.generators:
                e = gen.event
                e.SourceName = module
                e.ConditionName = f"{module}/{r.id}"
                e.Severity = SEVERITY.get(severity, 500)
                e.Retain = r.raised
                e.ActiveState = ua.LocalizedText("Active" if r.raised else "Inactive")
                setattr(e, "ActiveState/Id", r.raised)
                await gen.trigger(time_attr=datetime.fromtimestamp(r.time_ns / 1e9, UTC), message=message)
            self.emitted += 1

"""segment.py -- read-only access to irpd's alarm segment (<indurop/alarms.h>, docs/alarms.md).

The segment holds the sources (irpd, then each module of the running set) with their active
bitmaps and counters, and a ring of records that many writers fill and nobody waits on.  The agent
maps it read-only, takes every offset from irpd's description (shm_layout.json) and follows the
reader protocol of alarms.h:

- record s sits at index s % capacity; its writer sets `seq` to 0 while it writes and stores
  `seq` = s last, with release;
- the reader copies record s after loading seq == s, then loads seq again: the copy is intact iff
  both loads gave s;
- seq < s: not written yet -- read it again later; once head has moved capacity past s the slot
  belongs to a later lap and the record is counted in `lost`.  A record that stays unwritten for
  `stall_s` (1 s; a write takes microseconds) is skipped and counted in `abandoned`: its writer
  died in it (a process module killed in the middle of one) or collided with another and wrote
  nothing, and it must not hold back every other module's alarms.  Either way the caller
  reconciles from the bitmaps;
- seq > s: overwritten before it was read (counted in `lost`).

Records are handed over in seq order.  A segment replaced by a restarted irpd is a new file:
`replaced()` tells, and the caller opens the new one and reconciles.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from functools import cache

from ..irpd.shm_layout import LayoutError, Mapped, SegmentLayout, segment


class AlarmSegmentError(Exception):
    """A segment that is not there, or not an alarm segment this agent reads."""


@cache
def layout() -> SegmentLayout:
    """The alarm segment's description (shm_layout.json); LayoutError when it has none."""
    return segment("alarms")


@dataclass(frozen=True)
class Record:
    """One record of the ring: a source raised or cleared alarm `id` at `time_ns` (CLOCK_REALTIME)."""

    seq: int
    time_ns: int
    cycle: int
    source: int
    source_generation: int
    id: int
    raised: bool  # False: cleared
    severity: str | None  # None: the declared one
    undeclared: bool
    truncated: bool
    value: float
    text: str


COUNTERS = ("recorded", "rate_dropped", "undeclared", "bad_ids", "truncated", "collided")  # each atomic, u64


@dataclass(frozen=True)
class Source:
    """One source: irpd (0) or a module of the running set (1 + its index), with its bitmaps and counters."""

    index: int
    name: str
    generation: int
    declared: frozenset[int]
    active: frozenset[int]
    recorded: int
    rate_dropped: int
    undeclared: int
    bad_ids: int
    truncated: int
    collided: int = 0

    def counters(self) -> dict[str, int]:
        return {c: getattr(self, c) for c in COUNTERS}

    @property
    def unrecorded(self) -> int:
        """Transitions whose record was not written (the rate limit, a ring slot taken): only the bitmap has them."""
        return self.rate_dropped + self.collided


@dataclass
class RingRead:
    records: list[Record] = field(default_factory=list)
    lost: int = 0  # records overwritten before they were read
    abandoned: int = 0  # records skipped: their writer died in them (or stalled past stall_s)


def _ids(words) -> frozenset[int]:
    """The bits set in a bitmap of 64-bit words: bit id of the bitmap is alarm id."""
    return frozenset(w * 64 + b for w, word in enumerate(words) if word for b in range(64) if word >> b & 1)


class AlarmSegment(Mapped):
    """The mapped segment: its geometry, the head, single records and the sources."""

    def __init__(self, name: str, description: SegmentLayout | None = None):
        try:
            self.layout = description or layout()
            super().__init__(self.layout, name)
        except LayoutError as e:
            raise AlarmSegmentError(str(e)) from e
        header = self.layout.header
        self.record_layout = self.layout.struct("indurop_alarm_record")
        self.source_layout = self.layout.struct("indurop_alarm_source")

        def read(f: str) -> int:
            return header.read(self.mm, f)

        self.capacity, self.source_max = read("capacity"), read("source_max")
        self.record_size, self.source_size = read("record_size"), read("source_size")
        self.records_offset, self.sources_offset = read("records_offset"), read("sources_offset")
        self.rate_limit, self.owner_pid = read("rate_limit"), read("owner_pid")
        wrong = (self.record_size, self.source_size) != (self.record_layout.size, self.source_layout.size)
        end = max(
            self.records_offset + self.capacity * self.record_size,
            self.sources_offset + self.source_max * self.source_size,
        )
        if wrong or not self.capacity or end > len(self.mm):
            self.close()
            raise AlarmSegmentError(
                f"{name} has {self.record_size}-byte records and {self.source_size}-byte sources in "
                f"{len(self.mm)} bytes; this agent's description says {self.record_layout.size} and "
                f"{self.source_layout.size}: run the agent that came with this irpd"
            )
        # Fields the writers change are read as one aligned 8-byte load each (Mapped._word).
        self._head = header.offset("head")
        self._seq = self.record_layout.offset("seq")
        src = self.source_layout
        self._generation = src.offset("generation")
        self._words = src.field("active")["count"]
        self._bitmaps = src.offset("declared"), src.offset("active")
        self._counters = {c: src.offset(c) for c in COUNTERS if c in src.fields}
        if any(o % 8 for o in (self._head, self._seq, self._generation, *self._bitmaps, *self._counters.values())):
            self.close()
            raise AlarmSegmentError(
                "the alarm segment's head, seq, generation, bitmaps and counters must be 8-byte aligned"
            )
        self.actions = self.layout.enum("indurop_alarm_action")
        severities = self.layout.enum("indurop_alarm_severity")
        self.severities = {number: name for name, number in severities.items() if number}
        flags = self.layout.enum("indurop_alarm_flags")
        self.flag_undeclared, self.flag_truncated = flags["undeclared"], flags["truncated"]

    def head(self) -> int:
        """The last sequence number claimed (0: none yet)."""
        return self._word(self._head)

    # ---- records --------------------------------------------------------------------------------
    def record(self, s: int) -> Record | int:
        """Record s as the protocol allows: the Record when the copy is intact, else the seq its
        slot holds (< s: not written yet; > s: overwritten)."""
        at = self.records_offset + (s % self.capacity) * self.record_size
        first = self._word(at + self._seq)
        if first != s:
            return first
        raw = bytes(self.mm[at : at + self.record_size])  # the copy
        again = self._word(at + self._seq)  # x86: not reordered before the copy's loads
        if again != s:
            return again
        r = self.record_layout
        flags = r.read(raw, "flags")
        return Record(
            seq=s,
            time_ns=r.read(raw, "time_ns"),
            cycle=r.read(raw, "cycle"),
            source=r.read(raw, "source"),
            source_generation=r.read(raw, "source_generation"),
            id=r.read(raw, "id"),
            raised=r.read(raw, "action") == self.actions["raise"],
            severity=self.severities.get(r.read(raw, "severity")),
            undeclared=bool(flags & self.flag_undeclared),
            truncated=bool(flags & self.flag_truncated),
            value=r.read(raw, "value"),
            text=r.text(raw, "text"),
        )

    # ---- sources --------------------------------------------------------------------------------
    def sources(self) -> list[Source]:
        """Every source in use (generation > 0), each read consistently (its generation the same
        before and after)."""
        out = []
        for i in range(self.source_max):
            base = self.sources_offset + i * self.source_size
            for _ in range(1000):
                generation = self._word(base + self._generation)
                if not generation:
                    break
                name = self.source_layout.text(self.mm, "name", base)
                declared, active = ([self._word(base + b + 8 * w) for w in range(self._words)] for b in self._bitmaps)
                counters = {c: self._word(base + o) for c, o in self._counters.items()}
                if self._word(base + self._generation) == generation:
                    out.append(Source(i, name, generation, _ids(declared), _ids(active), **counters))
                    break
        return out


class RingReader:
    """Follows the ring from a cursor (the last seq handed over), by the protocol above."""

    def __init__(self, seg: AlarmSegment, cursor: int = 0, stall_s: float = 1.0, clock=time.monotonic):
        self.segment = seg
        self.cursor = cursor
        self.stall_s = stall_s
        self.clock = clock
        self._waiting: tuple[int, float] | None = None  # (seq not yet written, since when)
        self.lost = self.abandoned = 0  # totals

    def read(self, limit: int | None = None) -> RingRead:
        """The records after the cursor that are there now (at most `limit`), in seq order."""
        seg, out = self.segment, RingRead()
        head = seg.head()
        if head < self.cursor:  # a cursor from another ring: start again
            self.cursor = 0
        oldest = head - seg.capacity + 1
        if self.cursor + 1 < oldest:
            out.lost += oldest - (self.cursor + 1)
            self.cursor = oldest - 1
        s = self.cursor + 1
        while s <= head and (limit is None or len(out.records) < limit):
            got = seg.record(s)
            if isinstance(got, Record):
                out.records.append(got)
            elif got > s:
                out.lost += 1
            elif seg.head() >= s + seg.capacity or self._stalled(s):
                out.abandoned += 1
            else:
                break  # being written: read it again next time
            s += 1
        self.cursor = s - 1
        self.lost += out.lost
        self.abandoned += out.abandoned
        return out

    def _stalled(self, s: int) -> bool:
        now = self.clock()
        if self._waiting is None or self._waiting[0] != s:
            self._waiting = (s, now)
            return False
        return now - self._waiting[1] >= self.stall_s

"""alarm_writer.py -- a test writer of irpd's alarm segment: a file in /dev/shm laid out from the
description in shm_layout.json (every offset from there, as the agent's reader takes them), with
sources, bitmaps and records written as libindurop writes them -- and, on purpose, as a writer that
dies in the middle of a record leaves them."""

from __future__ import annotations

import mmap
import os
import struct
import time
from pathlib import Path

from indurop_agent.irpd.shm_layout import SegmentLayout


def _align(n: int) -> int:
    return (n + 63) // 64 * 64


class AlarmWriter:
    def __init__(
        self, name: str, layout: SegmentLayout, capacity: int = 8, source_max: int = 4, rate_limit: int = 1000
    ):
        self.name, self.layout = name, layout
        self.path = Path("/dev/shm") / name.lstrip("/")
        self.header = layout.header
        self.rec = layout.struct("indurop_alarm_record")
        self.src = layout.struct("indurop_alarm_source")
        self.capacity, self.source_max = capacity, source_max
        self.sources_offset = _align(self.header.size)
        self.records_offset = _align(self.sources_offset + source_max * self.src.size)
        size = self.records_offset + capacity * self.rec.size
        with open(self.path, "wb") as f:
            f.truncate(size)
        self.fd = os.open(self.path, os.O_RDWR)
        self.mm = mmap.mmap(self.fd, size)
        h = {
            "magic": layout.magic,
            "version": layout.version,
            "header_size": self.header.size,
            "total_size": size,
            "capacity": capacity,
            "record_size": self.rec.size,
            "source_size": self.src.size,
            "source_max": source_max,
            "rate_limit": rate_limit,
            "sources_offset": self.sources_offset,
            "records_offset": self.records_offset,
            "owner_pid": os.getpid(),
        }
        for field, value in h.items():
            self._put(self.header, 0, field, value)
        self.actions = layout.enum("indurop_alarm_action")
        self.severities = layout.enum("indurop_alarm_severity")

    def _put(self, s, base: int, field: str, value) -> None:
        f = s.field(field)
        if f["type"] == "char":
            raw = value.encode()[: f["size"] - 1]
            self.mm[base + f["offset"] : base + f["offset"] + f["size"]] = raw.ljust(f["size"], b"\0")
        elif "count" in f:
            struct.pack_into(s.format(field), self.mm, base + f["offset"], *value)
        else:
            struct.pack_into(s.format(field), self.mm, base + f["offset"], value)

    def _get(self, s, base: int, field: str):
        return s.read(self.mm, field, base)

    def close(self) -> None:
        self.mm.close()
        os.close(self.fd)
        self.path.unlink(missing_ok=True)

    # ---- sources -------------------------------------------------------------------------------
    def source(self, index: int, name: str, generation: int = 1, declared=()) -> None:
        base = self.sources_offset + index * self.src.size
        self._put(self.src, base, "name", name)
        self._put(self.src, base, "declared", self._bitmap(declared))
        self._put(self.src, base, "generation", generation)

    def _bitmap(self, ids) -> list[int]:
        words = [0] * self.src.field("active")["count"]
        for i in ids:
            words[i // 64] |= 1 << (i % 64)
        return words

    def set_active(self, index: int, ids) -> None:
        self._put(self.src, self.sources_offset + index * self.src.size, "active", self._bitmap(ids))

    def active(self, index: int) -> set[int]:
        words = self._get(self.src, self.sources_offset + index * self.src.size, "active")
        return {w * 64 + b for w, word in enumerate(words) for b in range(64) if word >> b & 1}

    def count(self, index: int, counter: str, add: int = 1) -> None:
        base = self.sources_offset + index * self.src.size
        self._put(self.src, base, counter, self._get(self.src, base, counter) + add)

    # ---- records -------------------------------------------------------------------------------
    @property
    def head(self) -> int:
        return self._get(self.header, 0, "head")

    def claim(self) -> int:
        """fetch_add(&head, 1) + 1."""
        s = self.head + 1
        self._put(self.header, 0, "head", s)
        return s

    def write(
        self,
        s: int,
        source: int,
        alarm_id: int,
        raised: bool = True,
        text: str = "",
        value: float = 0.0,
        severity: str = "declared",
        flags: int = 0,
        time_ns: int | None = None,
        publish: bool = True,
    ) -> None:
        """Writes record s at index s % capacity; its seq last (publish=False: a writer that died
        before storing it)."""
        base = self.records_offset + (s % self.capacity) * self.rec.size
        generation = self._get(self.src, self.sources_offset + source * self.src.size, "generation")
        for field, value_ in (
            ("time_ns", time_ns if time_ns is not None else time.time_ns()),
            ("cycle", 0),
            ("source_generation", generation),
            ("source", source),
            ("id", alarm_id),
            ("action", self.actions["raise" if raised else "clear"]),
            ("severity", self.severities[severity]),
            ("flags", flags),
            ("value", value),
            ("text", text),
        ):
            self._put(self.rec, base, field, value_)
        if publish:
            self._put(self.rec, base, "seq", s)

    def transition(self, source: int, alarm_id: int, raised: bool = True, **kw) -> int:
        """What irp::raiseAlarm / clearAlarm do: flip the bit, claim, write, publish."""
        ids = self.active(source)
        self.set_active(source, ids | {alarm_id} if raised else ids - {alarm_id})
        s = self.claim()
        self.write(s, source, alarm_id, raised, **kw)
        self.count(source, "recorded")
        return s

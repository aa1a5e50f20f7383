"""trace.py -- read-only access to irpd's trace rings (<indurop/trace.h>, docs/trace-and-stream.md).

irpd's main dispatcher writes one row per basic period: seq (1, 2, ...), the CLOCK_MONOTONIC due
time of the period, and one double per traced variable.  The agent maps the segment read-only and
follows the single-writer protocol without ever writing or waiting: read `head`, copy rows, read
`head` again; rows the sampler may have overwritten meanwhile are dropped and counted as lost.
Which variable a column holds is told by the two channel configurations in the segment; a row
belongs to the latest configuration put in force at or before its seq.
"""
from __future__ import annotations

import mmap
import os
import struct
from array import array
from dataclasses import dataclass, field
from pathlib import Path

MAGIC = 0x3143415254505249  # "IRPTRAC1"
VERSION = 1
NO_SEQ = (1 << 64) - 1
# Header offsets and sizes, pinned by static_asserts in <indurop/trace.h>.
H_CAPACITY, H_CHANNEL_MAX, H_CHANNEL_SIZE, H_CONFIG_SIZE = 24, 32, 36, 40
H_CONFIGS, H_SEQ, H_TIME, H_VALUES, H_OWNER_PID, H_BASIC = 48, 56, 64, 72, 80, 88
H_HEAD, H_CONFIG_GENERATION, H_CONFIG_SEQ, H_ACTIVE, H_TORN = 128, 136, 144, 152, 160
C_GENERATION, C_FIRST_SEQ, C_COUNT, C_CHANNELS = 0, 8, 16, 64
CH_PATH_CHARS, CH_TYPE = 232, 240
# enum indurop_trace_type, by the layout's spelling of the same scalar.
TYPES = {1: "float", 2: "double", 3: "int8_t", 4: "int16_t", 5: "int32_t", 6: "int64_t", 7: "uint8_t",
         8: "uint16_t", 9: "uint32_t", 10: "uint64_t", 11: "bool"}


class TraceError(Exception):
    """A segment that is not there or not a trace segment of a version this agent reads."""


@dataclass(frozen=True)
class Channel:
    index: int
    path: str
    type: str


@dataclass(frozen=True)
class Config:
    generation: int
    first_seq: int  # NO_SEQ: not (yet) in force
    channels: tuple[Channel, ...]

    @property
    def paths(self) -> list[str]:
        return [c.path for c in self.channels]


@dataclass
class Part:
    """Consecutive rows sampled with one configuration: column i holds config.channels[i]."""
    config: Config
    first_seq: int
    t_ns: array          # array('q'), one due time per row
    columns: list[array]  # array('d') per channel

    @property
    def count(self) -> int:
        return len(self.t_ns)


@dataclass
class TraceRead:
    since: int
    next: int                # pass it to the next read_since()
    lost: int                # rows after `since` overwritten (or of a configuration gone) before they were read
    parts: list[Part] = field(default_factory=list)

    @property
    def first_seq(self) -> int:
        """The seq of the first row returned (or next + 1 when none)."""
        return self.parts[0].first_seq if self.parts else self.next + 1


class TraceRing:
    def __init__(self, name: str):
        self.name = name
        self.path = Path("/dev/shm") / name.lstrip("/")
        try:
            with open(self.path, "rb") as f:
                self.inode = os.fstat(f.fileno()).st_ino
                self.mm = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
        except (OSError, ValueError) as e:
            raise TraceError(f"trace rings {name}: {e}") from e
        if len(self.mm) < 256 or struct.unpack_from("<Q", self.mm, 0)[0] != MAGIC:
            self.mm.close()
            raise TraceError(f"{name} is not an indurop trace segment")
        version, = struct.unpack_from("<I", self.mm, 8)
        if version != VERSION:
            self.mm.close()
            raise TraceError(f"{name} is trace layout version {version}; this agent reads version {VERSION}")
        self.capacity, = struct.unpack_from("<Q", self.mm, H_CAPACITY)
        self.channel_max, self.channel_size, self.config_size = struct.unpack_from("<III", self.mm, H_CHANNEL_MAX)
        self.configs_offset, self.seq_offset, self.time_offset, self.values_offset = \
            struct.unpack_from("<QQQQ", self.mm, H_CONFIGS)
        self.owner_pid, = struct.unpack_from("<q", self.mm, H_OWNER_PID)
        # 8-byte fields that the sampler changes are read as one aligned load each (memoryview
        # item access copies the whole word at once, unlike struct's '<Q', which goes byte by byte).
        self._u64 = memoryview(self.mm).cast("Q")

    def close(self) -> None:
        self._u64.release()
        self.mm.close()

    def _word(self, offset: int) -> int:
        return self._u64[offset // 8]

    def head(self) -> int:
        """The seq of the newest complete row (0: none yet)."""
        return self._word(H_HEAD)

    @property
    def basic_period_ns(self) -> int:
        return struct.unpack_from("<q", self.mm, H_BASIC)[0]

    @property
    def torn_skips(self) -> int:
        return self._word(H_TORN)

    def replaced(self) -> bool:
        """True when /dev/shm no longer holds this segment (irpd stopped or restarted)."""
        try:
            return os.stat(self.path).st_ino != self.inode
        except OSError:
            return True

    # ---- configurations ---------------------------------------------------------------------
    def _channels_of(self, i: int) -> tuple[Channel, ...]:
        base = self.configs_offset + i * self.config_size
        count, = struct.unpack_from("<I", self.mm, base + C_COUNT)
        channels = []
        for k in range(min(count, self.channel_max)):
            at = base + C_CHANNELS + k * self.channel_size
            raw = self.mm[at:at + CH_PATH_CHARS]
            kind, = struct.unpack_from("<I", self.mm, at + CH_TYPE)
            channels.append(Channel(k, raw.split(b"\0", 1)[0].decode("utf-8", "replace"), TYPES.get(kind, "?")))
        return tuple(channels)

    def configs(self) -> list[Config]:
        """Both configurations, read consistently (neither rewritten meanwhile)."""
        gen = [self.configs_offset + i * self.config_size + C_GENERATION for i in (0, 1)]
        first = [self.configs_offset + i * self.config_size + C_FIRST_SEQ for i in (0, 1)]
        for _ in range(1000):
            g = [self._word(o) for o in gen]
            f = [self._word(o) for o in first]
            if 0 in g:
                continue  # the control thread is rewriting one
            contents = [self._channels_of(i) for i in (0, 1)]
            if [self._word(o) for o in gen] == g and [self._word(o) for o in first] == f:
                return [Config(g[i], f[i], contents[i]) for i in (0, 1)]
        raise TraceError(f"{self.name}: the channel configuration keeps changing; try again")

    def in_force(self) -> Config | None:
        """The configuration the newest rows are sampled with."""
        applied = [c for c in self.configs() if c.first_seq != NO_SEQ]
        return max(applied, key=lambda c: (c.first_seq, c.generation)) if applied else None

    # ---- rows -----------------------------------------------------------------------------------
    def _ring(self, offset: int, a: int, b: int) -> bytes:
        """The 8-byte items of rows a..b (inclusive) of the ring at `offset`, unwrapped."""
        cap = self.capacity
        i, j = a % cap, b % cap
        if i <= j:
            return self.mm[offset + 8 * i:offset + 8 * (j + 1)]
        return self.mm[offset + 8 * i:offset + 8 * cap] + self.mm[offset:offset + 8 * (j + 1)]

    def read_since(self, since: int) -> TraceRead:
        """Every row after `since` that is still in the rings, split where the configuration
        changes, and how many rows after `since` are gone.  A `since` beyond head (the rings were
        restarted) reads nothing and returns next = head."""
        cap = self.capacity
        h1 = self.head()
        if h1 <= since:
            return TraceRead(since, min(since, h1), 0)
        configs = sorted((c for c in self.configs() if c.first_seq != NO_SEQ),
                         key=lambda c: (c.first_seq, c.generation))  # read after h1: they cover rows up to h1
        start = max(since + 1, h1 + 2 - cap, 1)
        seqs = self._ring(self.seq_offset, start, h1)
        times = self._ring(self.time_offset, start, h1)
        pieces = []  # (config, first, last, [column bytes])
        for n, c in enumerate(configs):
            a = max(start, c.first_seq)
            b = h1 if n + 1 == len(configs) else min(h1, configs[n + 1].first_seq - 1)
            if a > b:
                continue
            cols = [self._ring(self.values_offset + k * cap * 8, a, b) for k in range(len(c.channels))]
            pieces.append((c, a, b, cols))
        h2 = self.head()  # x86: these loads are not reordered before the copies above
        # Rows up to h2 + 1 - cap may have been overwritten while copying; so may rows whose
        # stored seq is not theirs.  Either way the damage is a prefix.
        valid = max(start, h2 + 2 - cap)
        stored = array("Q")
        stored.frombytes(seqs)
        if stored != array("Q", range(start, h1 + 1)):
            for k in range(len(stored) - 1, -1, -1):
                if stored[k] != start + k:
                    valid = max(valid, start + k + 1)
                    break
        all_times = array("q")
        all_times.frombytes(times)
        parts = []
        for c, a, b, cols in pieces:
            a2 = max(a, valid)
            if a2 > b:
                continue
            skip = a2 - a
            t = all_times[a2 - start:b - start + 1]
            columns = []
            for raw in cols:
                col = array("d")
                col.frombytes(raw[8 * skip:])
                columns.append(col)
            parts.append(Part(c, a2, t, columns))
        first_kept = parts[0].first_seq if parts else h1 + 1
        return TraceRead(since, h1, first_kept - (since + 1), parts)

"""trace.py -- read-only access to irpd's trace rings (<indurop/trace.h>, docs/trace-and-stream.md).

irpd's main dispatcher writes one row per basic period: seq (1, 2, ...), the CLOCK_MONOTONIC due
time of the period, and one double per traced variable.  The agent maps the segment read-only and
follows the single-writer protocol without ever writing or waiting: read `head`, copy rows, read
`head` again; rows the sampler may have overwritten meanwhile are dropped and counted as lost.
Which variable a column holds is told by the two channel configurations in the segment; a row
belongs to the latest configuration put in force at or before its seq.
"""

from __future__ import annotations

from array import array
from dataclasses import dataclass, field

from .shm_layout import LayoutError, Mapped, segment

# Every offset, size and constant from irpd's description of the segment (shm_layout.py).
LAYOUT = segment("trace")
HEADER = LAYOUT.header
CONFIG = LAYOUT.struct("indurop_trace_config")
CHANNEL = LAYOUT.struct("indurop_trace_channel")
NO_SEQ = LAYOUT.constant("no_seq")
MAX_CHANNELS = LAYOUT.constant("channels")  # channels irpd traces, for all owners together
# enum indurop_trace_type: each value is named as layout.json names the type.
TYPES = {number: name for name, number in LAYOUT.enum("indurop_trace_type").items() if number}
# Fields the sampler changes, read as one aligned 8-byte load each (see TraceRing._word).
H_HEAD, H_TORN = HEADER.offset("head"), HEADER.offset("torn_skips")
C_GENERATION, C_FIRST_SEQ = CONFIG.offset("generation"), CONFIG.offset("first_seq")
if any(o % 8 for o in (H_HEAD, H_TORN, C_GENERATION, C_FIRST_SEQ)):
    raise LayoutError("the trace segment's head, torn_skips, generation and first_seq must be 8-byte aligned")


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
    t_ns: array  # array('q'), one due time per row
    columns: list[array]  # array('d') per channel

    @property
    def count(self) -> int:
        return len(self.t_ns)


@dataclass
class TraceRead:
    since: int
    next: int  # pass it to the next read_since()
    lost: int  # rows after `since` overwritten (or of a configuration gone) before they were read
    parts: list[Part] = field(default_factory=list)

    @property
    def first_seq(self) -> int:
        """The seq of the first row returned (or next + 1 when none)."""
        return self.parts[0].first_seq if self.parts else self.next + 1


class TraceRing(Mapped):
    def __init__(self, name: str):
        try:
            super().__init__(LAYOUT, name)
        except LayoutError as e:
            raise TraceError(str(e)) from e

        def read(field: str) -> int:
            return HEADER.read(self.mm, field)

        self.capacity, self.channel_max = read("capacity"), read("channel_max")
        self.channel_size, self.config_size = read("channel_size"), read("config_size")
        self.configs_offset, self.seq_offset = read("configs_offset"), read("seq_offset")
        self.time_offset, self.values_offset = read("time_offset"), read("values_offset")
        self.owner_pid = read("owner_pid")
        if (self.channel_size, self.config_size) != (CHANNEL.size, CONFIG.size):
            self.close()
            raise TraceError(
                f"{name} has {self.config_size}-byte configurations of {self.channel_size}-byte "
                f"channels; this agent's description says {CONFIG.size} and {CHANNEL.size}"
            )

    def head(self) -> int:
        """The seq of the newest complete row (0: none yet)."""
        return self._word(H_HEAD)

    @property
    def basic_period_ns(self) -> int:
        return HEADER.read(self.mm, "basic_period_ns")

    @property
    def torn_skips(self) -> int:
        return self._word(H_TORN)

    # ---- configurations ---------------------------------------------------------------------
    def _channels_of(self, i: int) -> tuple[Channel, ...]:
        base = self.configs_offset + i * self.config_size
        count = CONFIG.read(self.mm, "channel_count", base)
        channels = []
        for k in range(min(count, self.channel_max)):
            at = base + CONFIG.offset("channels") + k * self.channel_size
            kind = CHANNEL.read(self.mm, "type", at)
            channels.append(Channel(k, CHANNEL.text(self.mm, "path", at), TYPES.get(kind, "?")))
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
            return self.mm[offset + 8 * i : offset + 8 * (j + 1)]
        return self.mm[offset + 8 * i : offset + 8 * cap] + self.mm[offset : offset + 8 * (j + 1)]

    def read_since(self, since: int) -> TraceRead:
        """Every row after `since` that is still in the rings, split where the configuration
        changes, and how many rows after `since` are gone.  A `since` beyond head (the rings were
        restarted) reads nothing and returns next = head."""
        cap = self.capacity
        h1 = self.head()
        if h1 <= since:
            return TraceRead(since, min(since, h1), 0)
        configs = sorted(
            (c for c in self.configs() if c.first_seq != NO_SEQ), key=lambda c: (c.first_seq, c.generation)
        )  # read after h1: they cover rows up to h1
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
            t = all_times[a2 - start : b - start + 1]
            columns = []
            for raw in cols:
                col = array("d")
                col.frombytes(raw[8 * skip :])
                columns.append(col)
            parts.append(Part(c, a2, t, columns))
        first_kept = parts[0].first_seq if parts else h1 + 1
        return TraceRead(since, h1, first_kept - (since + 1), parts)


class TraceFollower:
    """The rings read on from where the last read stopped, as the DDS bridge and the OPC UA server
    read them: open() (again) when irpd's segment is another or was replaced, from its newest row;
    read() the rows since then, moving past them."""

    def __init__(self):
        self.ring: TraceRing | None = None
        self.cursor = 0  # the last seq handed over

    def open(self, name: str | None) -> bool:
        """Follows the rings `name` (None: none); True when that changed what is followed.  A
        TraceError when they cannot be opened leaves nothing followed (open again later)."""
        if self.ring is None and not name:
            return False
        if self.ring is not None and self.ring.name == name and not self.ring.replaced():
            return False
        self.close()
        if name:
            self.ring = TraceRing(name)
            self.cursor = self.ring.head()
        return True

    def stale(self) -> bool:
        """No rings, or irpd replaced them (restarted): open() again."""
        return self.ring is None or self.ring.replaced()

    def head(self) -> int:
        return self.ring.head() if self.ring is not None else 0

    def read(self) -> TraceRead | None:
        """The rows after the cursor, and how many are gone (None: no rings, or their configuration
        kept changing while read: the next read has them)."""
        if self.ring is None:
            return None
        try:
            read = self.ring.read_since(self.cursor)
        except TraceError:
            return None
        self.cursor = read.next
        return read

    def skip(self) -> None:
        """Nothing wanted for now: the next read starts after the newest row."""
        self.cursor = self.head()

    def close(self) -> None:
        if self.ring is not None:
            self.ring.close()
            self.ring = None

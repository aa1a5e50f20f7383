"""sampling.py -- what feeds the monitored items of shared variables (docs/opcua.md "Subscriptions").

A monitored item samples at its revised interval, a multiple of the basic period (at least
min_sampling_interval_ms).  Scalar variables are sampled from irpd's trace rings: the server asks
irpd to trace them as the owner "opcua" (irpd traces the union of every owner's channels, at most
64 for all owners together), reads the rings every poll_ms, and hands an item every row whose seq is
a multiple of its decimation (interval / basic period) whose value differs from the one it last
had: every change at that rate, stamped with the row's due time.  The server never takes channels
from other owners: it asks only for channels that are free, or traced already by someone else, the
items with the shortest intervals first.  The rest -- items over the budget, arrays, and items whose
channel is not in force yet -- are sampled from the variable segment at their interval (the value
at that moment, stamped with the time it was read).

Everything here runs in the server's event loop; irpd is asked (`trace`) in a worker thread.
"""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass

from asyncua import ua

from ..irpd.client import IrpdClient, IrpdRefused, IrpdUnavailable
from ..irpd.trace import MAX_CHANNELS, TraceError, TraceFollower
from ..irpd.variables import VariableError
from .values import Var, Variables, clock_offset_ns, narrowed, typed, variant, wall

_NOTHING = object()
IDLE_S = 0.05  # how often the loop wakes while nothing is monitored
Deliver = Callable[[int, ua.DataValue], Awaitable[None]]


@dataclass(eq=False)
class Item:
    """One monitored item of a shared variable."""

    handle: int
    node: Var  # the variable node monitored
    interval_ms: float  # revised: a multiple of the basic period
    deliver: Deliver  # hands a DataValue to the monitored item (subscriptions.py)
    picked: range | None = None  # an IndexRange of a 1-D array: those elements only
    last: object = _NOTHING  # the value delivered last (typed), to deliver changes only
    next_due: float = 0.0  # shm sampling: when (monotonic s) it is sampled next
    after_seq: int = 0  # ring sampling: rows up to this seq were covered by a read of the segment
    ring: bool = False  # fed from the trace rings now
    decimation: int = 1
    gone: bool = False  # its variable left the layout: it gets no more values

    def __post_init__(self) -> None:
        self.var = narrowed(self.node, self.picked)  # what is sampled: the node, or its elements picked

    @property
    def scalar(self) -> bool:
        return not self.var.dims


@dataclass
class SamplerStats:
    rows_lost: int = 0  # trace rows overwritten before the server read them
    delivered: int = 0  # values handed to monitored items
    irpd_errors: int = 0
    refused: str = ""  # irpd's last refusal of the server's trace request


class Sampler:
    def __init__(self, variables: Variables, irpd: IrpdClient, owner: str, poll_ms: float):
        self.variables = variables
        self.irpd = irpd
        self.owner = owner
        self.poll_s = poll_ms / 1000
        self.items: dict[int, Item] = {}
        self.trace = TraceFollower()
        self.basic_ns = 0
        self.clock_offset_ns = clock_offset_ns()  # rows' due times (CLOCK_MONOTONIC) onto the wall clock
        self.granted: list[str] = []  # the channels irpd traces for us
        self.in_force: set[str] = set()  # the paths of the configuration the newest rows have
        self.stats = SamplerStats()
        self._dirty = True  # the items changed: the channels asked for may have to change
        self._arranging: asyncio.Task | None = None

    # ---- items ------------------------------------------------------------------------------
    def revise(self, requested_ms: float, publishing_ms: float, min_ms: float, max_ms: float) -> float:
        """A sampling interval as the server runs it: -1 (or any negative) the publishing interval, 0
        the fastest, clamped to [min_ms, max_ms], then up to a multiple of the basic period."""
        ms = publishing_ms if requested_ms < 0 else requested_ms
        ms = min(max(ms, min_ms), max_ms)
        if self.basic_ns > 0:
            basic_ms = self.basic_ns / 1e6
            ms = math.ceil(ms / basic_ms - 1e-9) * basic_ms
        return ms

    def add(self, item: Item) -> None:
        self.items[item.handle] = item
        item.decimation = self._decimation(item.interval_ms)
        item.next_due = time.monotonic()
        item.after_seq = self.trace.head()
        self._dirty = True

    def prime(self, item: Item) -> ua.DataValue:
        """The item's first value: the variable as it is now (the first notification of an item)."""
        now = wall()
        try:
            flat = self.variables.read(list(item.var.leaves))
        except (VariableError, KeyError):
            return self.variables.data_value(item.var)  # the bad status that says why
        current = [typed(item.var.variant, v) for v in flat]
        item.last = current[0] if item.scalar else tuple(current)
        return ua.DataValue(variant(item.var, flat), SourceTimestamp=now, ServerTimestamp=now)

    def change(self, handle: int, interval_ms: float) -> None:
        item = self.items.get(handle)
        if item is not None:
            item.interval_ms = interval_ms
            item.decimation = self._decimation(interval_ms)
            self._dirty = True

    def remove(self, handle: int) -> None:
        if self.items.pop(handle, None) is not None:
            self._dirty = True

    def _decimation(self, interval_ms: float) -> int:
        return max(1, round(interval_ms * 1e6 / self.basic_ns)) if self.basic_ns > 0 else 1

    def retarget(self, variables: dict[str, Var]) -> list[Item]:
        """After the layout changed: items keep their node when its variable is still there with the
        same type and shape (its leaves are taken anew); the others are returned, marked gone."""
        gone = []
        for item in self.items.values():
            new = variables.get(item.node.path)
            if new is None or new.signature != item.node.signature:
                if not item.gone:
                    item.gone = True
                    gone.append(item)
            else:
                item.node, item.var, item.gone = new, narrowed(new, item.picked), False
        self._dirty = True
        return gone

    # ---- irpd --------------------------------------------------------------------------------
    def follow(self, status: dict) -> None:
        """irpd's status (every status_s): the rings to read, the basic period, the wall clock."""
        name = (status.get("shared_memory") or {}).get("trace")
        try:
            opened = self.trace.open(name)
        except TraceError:
            opened = True  # none followed; tried again at the next status
        if opened:
            self.granted, self.in_force, self._dirty = [], set(), True
        basic = int(status.get("basic_period_ns") or 0)
        if basic and basic != self.basic_ns:
            self.basic_ns = basic
            for item in self.items.values():
                item.decimation = self._decimation(item.interval_ms)
        offset = clock_offset_ns()
        if abs(offset - self.clock_offset_ns) > 1_000_000:  # the wall clock was stepped
            self.clock_offset_ns = offset
        if self.trace.ring is not None:
            self._dirty = True  # check now and then that what we asked for still holds

    def wanted(self) -> list[str]:
        """The scalar paths monitored, the shortest interval first."""
        best: dict[str, float] = {}
        for item in self.items.values():
            if item.scalar and not item.gone:
                p = item.var.leaves[0]
                best[p] = min(best.get(p, math.inf), item.interval_ms)
        return sorted(best, key=lambda p: (best[p], p))

    async def arrange(self) -> None:
        """Asks irpd to trace what fits of what is monitored (never more than is free)."""
        self._dirty = False
        if self.trace.ring is None:
            return
        wanted = self.wanted()
        try:
            described = await asyncio.to_thread(self.irpd.request, "trace")
            owners = described.get("owners") or {}
            others = {p for owner, paths in owners.items() if owner != self.owner for p in paths}
            free = MAX_CHANNELS - len(others)
            pick = [p for p in wanted if p in others] + [p for p in wanted if p not in others][: max(0, free)]
            if pick == self.granted and set(owners.get(self.owner, [])) == set(pick):
                return
            await asyncio.to_thread(self.irpd.request, "trace", channels=pick, owner=self.owner)
            self.granted, self.stats.refused = pick, ""
        except IrpdRefused as e:  # another owner took channels meanwhile, or a path irpd does not trace
            self.stats.refused = str(e)
            self.granted = []
            try:
                await asyncio.to_thread(self.irpd.request, "trace", channels=[], owner=self.owner)
            except (IrpdRefused, IrpdUnavailable):
                pass
        except (IrpdUnavailable, AttributeError):
            self.stats.irpd_errors += 1
            self._dirty = True

    async def withdraw(self) -> None:
        try:
            await asyncio.to_thread(self.irpd.request, "trace", channels=[], owner=self.owner)
        except (IrpdUnavailable, IrpdRefused):
            pass

    # ---- the loop ----------------------------------------------------------------------------
    async def run(self) -> None:
        while True:
            start = time.monotonic()
            if self._dirty and (self._arranging is None or self._arranging.done()):
                self._arranging = asyncio.create_task(self.arrange())
            try:
                await self.step()
            except Exception as e:  # a bug must not stop every subscription
                print(f"indurop-opcua: sampling: {type(e).__name__}: {e}", flush=True)
            period = self.poll_s if self.items else IDLE_S
            await asyncio.sleep(max(0.0, period - (time.monotonic() - start)))

    async def step(self) -> None:
        if not self.items:
            self.trace.skip()
            return
        await self._from_rings()
        await self._from_segment()

    async def _from_rings(self) -> None:
        if self.trace.stale():
            self.in_force = set()
            return
        read = self.trace.read()
        if read is None:
            return
        self.stats.rows_lost += read.lost
        if read.parts:
            self.in_force = set(read.parts[-1].config.paths)
        by_path: dict[str, list[Item]] = {}
        for item in self.items.values():
            ring = item.scalar and not item.gone and item.var.leaves[0] in self.in_force
            if ring and not item.ring:
                item.after_seq = max(item.after_seq, self.trace.cursor)  # its segment samples cover up to now
            item.ring = ring
            if ring:
                by_path.setdefault(item.var.leaves[0], []).append(item)
        now = wall()
        for part in read.parts:
            index = {p: i for i, p in enumerate(part.config.paths)}
            for path, items in by_path.items():
                i = index.get(path)
                if i is None:
                    continue
                column, times = part.columns[i], part.t_ns
                for item in items:
                    d = item.decimation
                    first = max(part.first_seq, item.after_seq + 1)
                    start = first - part.first_seq + (-first) % d
                    for k in range(start, part.count, d):
                        value = typed(item.var.variant, column[k])
                        if value == item.last or value is None:
                            continue
                        item.last = value
                        dv = ua.DataValue(
                            ua.Variant(value, item.var.variant),
                            SourceTimestamp=wall(times[k] + self.clock_offset_ns),
                            ServerTimestamp=now,
                        )
                        await item.deliver(item.handle, dv)
                        self.stats.delivered += 1

    async def _from_segment(self) -> None:
        now = time.monotonic()
        due = [i for i in self.items.values() if not i.ring and not i.gone and i.next_due <= now]
        if not due:
            return
        leaves = [p for item in due for p in item.var.leaves]
        try:
            values = self.variables.read(leaves)
        except (VariableError, KeyError):
            for item in due:
                item.next_due = now + item.interval_ms / 1000
            return
        stamp = wall()
        at = 0
        for item in due:
            n = len(item.var.leaves)
            mine, at = values[at : at + n], at + n
            item.next_due += item.interval_ms / 1000
            if item.next_due < now:  # fell behind (a stall): sample on from now
                item.next_due = now + item.interval_ms / 1000
            current = [typed(item.var.variant, v) for v in mine]
            key = current[0] if item.scalar else tuple(current)
            if key == item.last:
                continue
            item.last = key
            dv = ua.DataValue(variant(item.var, mine), SourceTimestamp=stamp, ServerTimestamp=stamp)
            await item.deliver(item.handle, dv)
            self.stats.delivered += 1

    def counts(self) -> dict:
        ring = sum(1 for i in self.items.values() if i.ring)
        return {
            "monitored_variables": len(self.items),
            "from_trace_rings": ring,
            "from_segment": len(self.items) - ring,
            "traced_channels": len(self.granted),
            "rows_lost": self.stats.rows_lost,
            "delivered": self.stats.delivered,
            "trace_refused": self.stats.refused,
        }

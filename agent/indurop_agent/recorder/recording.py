"""recording.py -- one running recording as the recorder's thread holds it (docs/recorder.md): which
rows of the trace rings it takes, its current part (an McapOut), its counters, its stop conditions,
and its entry.json, kept in step with what is on disk.

Every method runs on the recorder's thread (or with its lock held).  A row is taken when it carries
every one of the recording's channels, its seq is a multiple of the decimation, and it is newer
than the last row handled (`last`): so no row is ever written twice, also across a resume.
"""

from __future__ import annotations

import bisect
import time
from dataclasses import dataclass, field

from ..irpd.trace import TraceRead
from .mcap_out import Joint, McapOut, Variable
from .store import Entry, now

STATES = ("recording", "stopped", "failed")
# why a recording ended: asked to, its duration or size reached, the quota or the disk full, its
# variables gone from irpd's layout, a write that failed
CAUSES = ("manual", "duration", "size", "quota", "disk_full", "variables", "error")


def multiples(a: int, b: int, n: int) -> int:
    """How many seq in [a, b] are multiples of n (the rows a recording with decimation n takes)."""
    return b // n - (a - 1) // n if b >= a else 0


@dataclass
class Recording:
    entry: Entry
    variables: list[Variable]
    decimation: int
    duration_ns: int | None
    max_bytes: int | None
    joints: list[Joint]
    joint_every: int
    basic_period_ns: int
    out: McapOut | None = None
    part: dict | None = None  # its record in entry.meta["parts"]
    last: int = 0  # the newest seq handled (written, or counted as dropped) in this irpd run
    started: bool = False  # a row carrying every channel was seen in this irpd run
    irpd_pid: int | None = None  # the irpd run `last` counts in
    gap: dict | None = None  # a gap to record with the next rows: {"last_seq", "reason"}
    resuming: bool = False  # taken up again at the agent's start, not yet connected to irpd
    pending: list[dict] = field(default_factory=list)  # notes waiting for the next part to open
    done: tuple[str, str, str] | None = None  # (state, cause, reason) once it should end
    last_save: float = 0.0

    @property
    def name(self) -> str:
        return self.entry.name

    @property
    def paths(self) -> list[str]:
        return [v.path for v in self.variables]

    @property
    def meta(self) -> dict:
        return self.entry.meta

    # ---- rows -----------------------------------------------------------------------------------
    def feed(self, read: TraceRead, irpd_pid: int | None) -> None:
        """Takes what is new for it in one read of the rings."""
        n = self.decimation
        if read.lost:
            lo, hi = max(read.since + 1, self.last + 1), read.since + read.lost
            if self.started and self.gap is None and hi >= lo:
                self.drop(lo, hi, "rows overwritten in the trace rings before the recorder read them")
            self.last = max(self.last, hi)
        for part in read.parts:
            last = part.first_seq + part.count - 1
            if last <= self.last or self.done:
                continue
            lo = max(part.first_seq, self.last + 1)
            index = {c.path: c.index for c in part.config.channels}
            cols = [index.get(p) for p in self.paths]
            if None in cols:  # before its channels were in force, or taken away behind irpd's back
                if self.started and self.gap is None:
                    self.drop(lo, last, "rows without the recording's channels (the trace was reconfigured)")
                self.last = last
                continue
            self.started = True
            s0 = -(-lo // n) * n
            if s0 <= last:
                k0 = s0 - part.first_seq
                t = part.t_ns[k0::n]
                columns = [part.columns[i][k0::n] for i in cols]
                self.write(s0, t, columns, irpd_pid)
            self.last = last

    def write(self, s0: int, t: list[int], columns: list, irpd_pid: int | None) -> None:
        n = self.decimation
        opened = self.out is None
        if opened:
            self.open_part(irpd_pid)
        offset = self.out.clock_offset_ns
        if self.duration_ns is not None:
            first = self.meta.get("first_unix_ns")
            if first is None:
                first = self.meta["first_unix_ns"] = t[0] + offset
            keep = bisect.bisect_left(t, first + self.duration_ns - offset)  # due times increase
            if keep < len(t):
                t, columns = t[:keep], [c[:keep] for c in columns]
                self.done = ("stopped", "duration", f"its duration ({self.duration_ns / 1e9:g} s) is recorded")
        if not len(t):
            return
        seqs = range(s0, s0 + n * len(t), n)
        if self.gap is not None:
            self.record_gap(seqs[0], t[0])
            opened = True
        self.out.add_rows(seqs, t, columns)
        p = self.part
        if p["first_seq"] is None:
            p["first_seq"], p["first_unix_ns"] = seqs[0], t[0] + offset
        p["last_seq"], p["last_unix_ns"], p["rows"] = seqs[-1], t[-1] + offset, p["rows"] + len(t)
        self.meta.setdefault("first_unix_ns", p["first_unix_ns"])
        self.meta["rows"] = self.meta.get("rows", 0) + len(t)
        self.meta["last_unix_ns"] = p["last_unix_ns"]
        if self.max_bytes is not None and self.size() >= self.max_bytes:
            self.done = ("stopped", "size", f"its size limit ({self.max_bytes} bytes) is reached")
        if opened:
            self.save()  # the new part and the gap before it, at once

    def drop(self, lo: int, hi: int, why: str) -> None:
        count = multiples(lo, hi, self.decimation)
        if not count:
            return
        self.meta["drops"] = self.meta.get("drops", 0) + count
        if self.part is not None:
            self.part["drops"] += count
        self.add_note("drop", f"{count} rows dropped: {why}", first_seq=lo, last_seq=hi, count=count)

    def record_gap(self, first_seq: int, t_ns: int) -> None:
        """The gap before the first rows of a new part: the last seq written before it, this first
        one, and how many rows it misses (counted in one irpd run only: seq restarts with irpd)."""
        gap = {
            "part": len(self.meta["parts"]) - 1,
            "last_seq": self.gap["last_seq"],
            "first_seq": first_seq,
            "missing": None,
            "reason": self.gap["reason"],
        }
        if self.gap.get("same_run") and gap["last_seq"] is not None:
            gap["missing"] = multiples(gap["last_seq"] + 1, first_seq - 1, self.decimation)
        self.meta.setdefault("gaps", []).append(gap)
        text = f"gap: {self.gap['reason']}; last row before it {gap['last_seq']}, first after it {first_seq}"
        fields = {k: v for k, v in gap.items() if k in ("last_seq", "first_seq") and v is not None}
        self.out.note(
            "gap", text, t_ns=t_ns, **fields, **({"count": gap["missing"]} if gap["missing"] is not None else {})
        )
        self.gap = None

    def add_note(self, kind: str, text: str, **fields) -> None:
        if self.out is not None:
            self.out.note(kind, text, **fields)
        else:
            self.pending.append({"kind": kind, "text": text, **fields})

    # ---- parts ----------------------------------------------------------------------------------
    def open_part(self, irpd_pid: int | None) -> None:
        path = self.entry.new_part()
        self.out = McapOut(
            path,
            self.variables,
            title=self.name,
            basic_period_ns=self.basic_period_ns,
            decimation=self.decimation,
            joints=self.joints,
            joint_every=self.joint_every,
            metadata={"recording": self.name, "part": path.name, "irpd_pid": str(irpd_pid or "")},
        )
        self.part = {
            "file": path.name,
            "irpd_pid": irpd_pid,
            "opened": now(),
            "closed": None,
            "first_seq": None,
            "last_seq": None,
            "rows": 0,
            "drops": 0,
            "first_unix_ns": None,
            "last_unix_ns": None,
            "recovered": None,
        }
        self.meta["parts"].append(self.part)
        for note in self.pending:
            self.out.note(**note)
        self.pending.clear()

    def close_part(self, note: tuple[str, str] | None = None) -> None:
        """Closes the current part with its summary (and a last note); OSError when it cannot."""
        if self.out is None:
            return
        out, self.out = self.out, None
        try:
            if note:
                out.note(note[0], note[1])
            self.part["size"] = out.close({"recording": self.name, "drops": str(self.part["drops"])})
            self.part["closed"] = now()
        except OSError:
            out.abandon()
            raise
        finally:
            self.part = None

    def written_pid(self) -> int | None:
        """The irpd run (pid) of the last row written."""
        written = [p for p in self.meta["parts"] if p["last_seq"] is not None]
        return written[-1]["irpd_pid"] if written else None

    def new_run(self, irpd_pid: int | None, reason: str, same_run: bool) -> None:
        """The rows go on after a gap: irpd restarted (seq starts again), or the agent did (same
        run: the rows the rings still hold after the last one written are taken)."""
        written = [p["last_seq"] for p in self.meta["parts"] if p["last_seq"] is not None]
        self.gap = {"last_seq": written[-1] if written else None, "reason": reason, "same_run": same_run}
        self.irpd_pid = irpd_pid
        if same_run:
            self.last, self.started = (written[-1] if written else self.last), True
        else:
            self.last, self.started = 0, False

    def abandon_part(self) -> None:
        if self.out is not None:
            self.out.abandon()
            self.out, self.part = None, None

    def flush(self) -> None:
        if self.out is not None:
            self.out.flush()
        if time.monotonic() - self.last_save >= 10:
            self.save()

    def size(self) -> int:
        closed = sum(p.get("size") or 0 for p in self.meta["parts"] if p is not self.part)
        return closed + (self.out.size if self.out is not None else 0)

    def save(self) -> None:
        if self.part is not None and self.out is not None:
            self.part["size"] = self.out.size
        self.entry.save()
        self.last_save = time.monotonic()

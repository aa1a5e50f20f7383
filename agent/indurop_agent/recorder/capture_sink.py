"""capture_sink.py -- where a capture's shots go: the CaptureSink protocol (open a shot, rows in,
notes in, close) and what reads them back (ShotStore), and MemorySink, both in memory (tests).
The agent's are MCAP files in the recordings folder (capture_files.py).

A shot's header (what open() is given):

    {"capture", "name", "by", "shot", "channels": [{"path", "type"}], "basic_period_ns",
     "trigger", "pre", "post", "trigger_seq", "cause", "trigger_time_ns"}

and its summary (close()): {"shot", "trigger_seq", "first_seq", "last_seq", "pre_rows",
"post_rows", "rows", "drops", "cause", "trigger_time_ns", "notes"}.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np


class ShotWriter(Protocol):
    def rows(self, seq: np.ndarray, t_ns: np.ndarray, values: np.ndarray) -> None:
        """Rows in seq order: values has one row per channel of the header."""

    def note(self, text: str) -> None: ...

    def close(self, summary: dict) -> None:
        """The shot is complete; after this it is listed and read back."""

    def abort(self) -> None:
        """Writing failed (a full disk): what was written of this shot goes; nothing else is touched."""


class CaptureSink(Protocol):
    def open(self, header: dict) -> ShotWriter:
        """A new shot; OSError when it cannot be written (no room, its name taken)."""


@dataclass
class ShotData:
    header: dict
    summary: dict
    notes: list[str]
    seq: np.ndarray
    t_ns: np.ndarray
    values: np.ndarray  # one row per channel of the header

    @property
    def paths(self) -> list[str]:
        return [c["path"] for c in self.header["channels"]]


class ShotStore(Protocol):
    def summaries(self, capture_id: str) -> list[dict]:
        """The closed shots' summaries (with "shot"), oldest first."""

    def read(self, capture_id: str, shot: int) -> ShotData | None: ...

    def delete(self, capture_id: str, shot: int | None = None) -> None:
        """One shot, or (None) every shot of the capture."""


# ---- in memory -------------------------------------------------------------------------------------
@dataclass
class _MemoryShot:
    sink: MemorySink
    header: dict
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def rows(self, seq, t_ns, values) -> None:
        self.parts.append((np.array(seq), np.array(t_ns), np.array(values)))

    def note(self, text: str) -> None:
        self.notes.append(text)

    def abort(self) -> None:
        self.parts.clear()

    def close(self, summary: dict) -> None:
        channels = len(self.header["channels"])
        seq = np.concatenate([p[0] for p in self.parts]) if self.parts else np.zeros(0, np.int64)
        t = np.concatenate([p[1] for p in self.parts]) if self.parts else np.zeros(0, np.int64)
        v = np.concatenate([p[2] for p in self.parts], axis=1) if self.parts else np.zeros((channels, 0))
        data = ShotData(self.header, {**summary, "shot": self.header["shot"]}, self.notes, seq, t, v)
        with self.sink.lock:
            self.sink.shots.setdefault(self.header["capture"], {})[self.header["shot"]] = data


class MemorySink:
    """Shots kept in memory (tests)."""

    def __init__(self):
        self.shots: dict[str, dict[int, ShotData]] = {}
        self.lock = threading.Lock()

    def open(self, header: dict) -> ShotWriter:
        return _MemoryShot(self, header)

    def summaries(self, capture_id: str) -> list[dict]:
        with self.lock:
            return [d.summary for _, d in sorted(self.shots.get(capture_id, {}).items())]

    def read(self, capture_id: str, shot: int) -> ShotData | None:
        with self.lock:
            return self.shots.get(capture_id, {}).get(shot)

    def delete(self, capture_id: str, shot: int | None = None) -> None:
        with self.lock:
            if shot is None:
                self.shots.pop(capture_id, None)
            else:
                self.shots.get(capture_id, {}).pop(shot, None)


class Shots(CaptureSink, ShotStore, Protocol):
    """What the capture engine writes shots to and reads them back from."""

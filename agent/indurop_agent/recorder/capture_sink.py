"""capture_sink.py -- where a capture's shots go: the CaptureSink protocol (open a shot, rows in,
notes in, close) and what reads them back (ShotStore), with two implementations: in memory (the
tests) and JSON lines under the data folder (the agent, until the MCAP writer of the recordings
takes their place: an adapter of these two protocols).

A shot's JSON-lines file, `<folder>/<capture id>/shot-<n>.jsonl`, is written as
`shot-<n>.jsonl.part` and renamed when closed, so that a crash leaves no half shot listed:

    {"header": {"capture", "name", "shot", "channels": [{"path", "type"}], "basic_period_ns",
                "trigger", "pre", "post", "trigger_seq", "cause", "trigger_time_ns"}}
    [seq, t_ns, value, value, ...]          one line per row, in seq order; NaN as null
    {"note": "..."}                         anywhere
    {"summary": {"pre_rows", "post_rows", "rows", "drops", ...}}    last
"""

from __future__ import annotations

import json
import os
import re
import shutil
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import numpy as np

ID_PATTERN = re.compile(r"^[a-z0-9-]{1,40}$")
SHOT_FILE = re.compile(r"^shot-(\d{1,9})\.jsonl$")


class ShotWriter(Protocol):
    def rows(self, seq: np.ndarray, t_ns: np.ndarray, values: np.ndarray) -> None:
        """Rows in seq order: values has one row per channel of the header."""

    def note(self, text: str) -> None: ...

    def close(self, summary: dict) -> None:
        """The shot is complete; after this it is listed and read back."""

    def abort(self) -> None:
        """Writing failed (a full disk): what was written of this shot goes; nothing else is touched."""


class CaptureSink(Protocol):
    def open(self, header: dict) -> ShotWriter: ...


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


# ---- JSON lines ------------------------------------------------------------------------------------
def _json_rows(seq: np.ndarray, t_ns: np.ndarray, values: np.ndarray) -> str:
    """One line per row, NaN and infinities as null (JSON has neither)."""
    cells = np.where(np.isfinite(values), values, np.nan).T.tolist()
    lines = []
    for s, t, row in zip(seq.tolist(), t_ns.tolist(), cells):
        lines.append(json.dumps([s, t, *(None if v != v else v for v in row)]))
    return "\n".join(lines) + "\n" if lines else ""


class _FileShot:
    def __init__(self, path: Path, header: dict, closed):
        self.path, self.part, self.closed = path, path.with_name(path.name + ".part"), closed
        self.file = open(self.part, "w", encoding="utf-8")  # noqa: SIM115 -- closed by close()
        self.file.write(json.dumps({"header": header}) + "\n")

    def rows(self, seq, t_ns, values) -> None:
        self.file.write(_json_rows(np.asarray(seq), np.asarray(t_ns), np.asarray(values)))

    def note(self, text: str) -> None:
        self.file.write(json.dumps({"note": text}) + "\n")

    def close(self, summary: dict) -> None:
        self.file.write(json.dumps({"summary": summary}) + "\n")
        self.file.flush()
        os.fsync(self.file.fileno())
        self.file.close()
        os.replace(self.part, self.path)
        self.closed()

    def abort(self) -> None:
        try:
            self.file.close()
        except OSError:
            pass  # the data it could not flush is what is being thrown away
        self.part.unlink(missing_ok=True)


class JsonLinesSink:
    """Shots as JSON-lines files under `folder` (<data-dir>/captures), one folder per capture."""

    def __init__(self, folder: Path):
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self._summaries: dict[str, list[dict]] = {}  # each capture's, read once from its files
        self._changes = 0  # shots closed or deleted: a list read meanwhile is not cached
        self._lock = threading.Lock()
        for part in self.folder.glob("*/*.part"):  # a shot a crash left half written
            part.unlink(missing_ok=True)

    def _dir(self, capture_id: str) -> Path:
        if not ID_PATTERN.match(capture_id):
            raise ValueError(f"{capture_id!r} is not a capture id")
        return self.folder / capture_id

    def open(self, header: dict) -> ShotWriter:
        folder = self._dir(header["capture"])
        folder.mkdir(exist_ok=True)
        return _FileShot(folder / f"shot-{int(header['shot'])}.jsonl", header, lambda: self._forget(header["capture"]))

    def _forget(self, capture_id: str) -> None:
        with self._lock:
            self._summaries.pop(capture_id, None)
            self._changes += 1

    def _files(self, capture_id: str) -> list[tuple[int, Path]]:
        folder = self._dir(capture_id)
        if not folder.is_dir():
            return []
        found = [(int(m.group(1)), p) for p in folder.iterdir() if (m := SHOT_FILE.match(p.name))]
        return sorted(found)

    def summaries(self, capture_id: str) -> list[dict]:
        with self._lock:
            cached, changes = self._summaries.get(capture_id), self._changes
        if cached is not None:
            return list(cached)
        out = []
        for n, path in self._files(capture_id):
            summary = _last_line(path).get("summary")
            if summary is not None:
                out.append({**summary, "shot": n})
        with self._lock:
            if changes == self._changes:
                self._summaries[capture_id] = out
        return list(out)

    def read(self, capture_id: str, shot: int) -> ShotData | None:
        path = self._dir(capture_id) / f"shot-{int(shot)}.jsonl"
        if not path.is_file():
            return None
        header, summary, notes, rows = {}, {}, [], []
        with open(path, encoding="utf-8") as f:
            for line in f:
                item = json.loads(line)
                if isinstance(item, list):
                    rows.append(item)
                elif "header" in item:
                    header = item["header"]
                elif "note" in item:
                    notes.append(item["note"])
                elif "summary" in item:
                    summary = item["summary"]
        channels = len(header.get("channels", []))
        seq = np.array([r[0] for r in rows], dtype=np.int64)
        t = np.array([r[1] for r in rows], dtype=np.int64)
        values = np.array([r[2:] for r in rows], dtype=float).T if rows else np.zeros((channels, 0))
        return ShotData(header, {**summary, "shot": shot}, notes, seq, t, values.reshape(channels, len(rows)))

    def delete(self, capture_id: str, shot: int | None = None) -> None:
        if shot is None:
            shutil.rmtree(self._dir(capture_id), ignore_errors=True)
        else:
            (self._dir(capture_id) / f"shot-{int(shot)}.jsonl").unlink(missing_ok=True)
        self._forget(capture_id)


def _last_line(path: Path) -> dict:
    """The last line of a shot file (its summary), read from the end."""
    with open(path, "rb") as f:
        f.seek(0, os.SEEK_END)
        size = f.tell()
        f.seek(max(0, size - 65536))
        tail = f.read().rstrip(b"\n").rsplit(b"\n", 1)[-1]
    try:
        item = json.loads(tail)
    except ValueError:
        return {}
    return item if isinstance(item, dict) else {}

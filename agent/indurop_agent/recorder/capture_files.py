"""capture_files.py -- a capture's shots as MCAP files in the recordings folder (docs/recorder.md
"Where shots go"): each shot is an entry of kind `capture` of the recorder's Store, named
`<capture id>.shot-<n>`, written by McapOut.  So GET /recordings lists shots beside recordings, and
they are downloaded, exported, deleted and evicted by the quota like them.

    shots = CaptureFiles(store)          # the agent's Store (<data-dir>/recordings)
    writer = shots.open(header)          # CaptureSink: the engine's writer thread writes a shot
    shots.summaries("a1b2")              # ShotStore: the shots kept, oldest first
    shots.read("a1b2", 3)                # rows back, through mcap_read

An entry's entry.json holds what the recordings' listing shows and, besides, `capture` (the shot's
header: capture id, name, trigger, pre, post, trigger_seq, cause ...) and `summary` (pre_rows,
post_rows, rows, drops, notes ...).  The MCAP file holds the same header as metadata
(`indurop.capture`), the trigger as a note on /indurop/notes with its seq (at its row's time, just
before that row), and the summary.
"""

from __future__ import annotations

import json
import re
import shutil
import threading

import numpy as np

from . import mcap_read
from .capture_sink import ShotData, ShotWriter
from .mcap_out import McapOut, Variable
from .store import Entry, Store, StoreError, now
from .trigger_text import describe_trigger

SHOT_NAME = re.compile(r"^([a-z0-9-]{1,40})\.shot-(\d{1,9})$")


def shot_name(capture_id: str, shot: int) -> str:
    return f"{capture_id}.shot-{int(shot)}"


class _McapShot:
    """One shot being written: an entry marked as being written (never evicted) and its MCAP file."""

    def __init__(self, files: CaptureFiles, header: dict):
        self.files, self.header = files, header
        self.store = files.store
        channels = header["channels"]
        variables = [Variable(c["path"], c.get("type") or "double", "", c.get("iec_type")) for c in channels]
        self.entry: Entry = self.store.create(
            shot_name(header["capture"], header["shot"]),
            "capture",
            {
                "state": "recording",
                "created_by": header.get("by"),
                "variables": [v.__dict__ for v in variables],
                "decimation": 1,
                "basic_period_ns": header["basic_period_ns"],
                "parts": [],
                "gaps": [],
                "rows": 0,
                "drops": 0,
                "capture": header,
            },
        )
        self.store.writing(self.entry.name)
        try:
            self.out = McapOut(
                self.entry.new_part(),
                variables,
                title=self.entry.name,
                basic_period_ns=header["basic_period_ns"],
                metadata={"capture": header["capture"], "shot": str(header["shot"])},
            )
            self.out.add_metadata("indurop.capture", {k: json.dumps(v) for k, v in header.items()})
        except BaseException:
            self.abort()
            raise
        self.notes: list[str] = []
        self.triggered = False  # the trigger's note given to the file

    def rows(self, seq, t_ns, values) -> None:
        seq, t_ns = np.asarray(seq).tolist(), np.asarray(t_ns).tolist()
        if not self.triggered and seq:
            # the trigger row's due time (rows are one basic period apart): McapOut writes the
            # note just before that row, so that log_time never goes backwards in the file
            h = self.header
            self.trigger_note(t_ns[0] + (int(h["trigger_seq"]) - seq[0]) * int(h["basic_period_ns"]))
        self.out.add_rows(seq, t_ns, list(np.asarray(values, dtype=np.float64)))

    def trigger_note(self, t_ns: int | None) -> None:
        h = self.header
        said = describe_trigger(h["trigger"]) if isinstance(h.get("trigger"), dict) else ""
        text = f"{h['cause']}: {said}" if said and said != h["cause"] else str(h["cause"])
        self.out.note("trigger", text, seq=int(h["trigger_seq"]), t_ns=t_ns)
        self.triggered = True

    def note(self, text: str) -> None:
        self.notes.append(text)
        self.out.note("info", text)

    def close(self, summary: dict) -> None:
        h, out = self.header, self.out
        if not self.triggered:  # a shot without rows
            self.trigger_note(None)
        size = out.close({k: json.dumps(v) for k, v in summary.items()})
        first_unix = out.first_t_ns + out.clock_offset_ns if out.first_t_ns is not None else None
        last_unix = out.last_t_ns + out.clock_offset_ns if out.last_t_ns is not None else None
        self.entry.meta.update(
            state="stopped",
            reason="captured",
            cause="captured",
            ended=now(),
            rows=out.rows,
            drops=int(summary.get("drops", 0)),
            first_unix_ns=first_unix,
            last_unix_ns=last_unix,
            summary=summary,
            parts=[
                {
                    "file": out.path.name,
                    "rows": out.rows,
                    "drops": int(summary.get("drops", 0)),
                    "first_seq": out.first_seq,
                    "last_seq": out.last_seq,
                    "first_unix_ns": first_unix,
                    "last_unix_ns": last_unix,
                    "size": size,
                    "closed": True,
                }
            ],
        )
        self.entry.save()
        self.store.done_writing(self.entry.name)
        self.files.changed(h["capture"])

    def abort(self) -> None:
        out = getattr(self, "out", None)
        if out is not None:
            out.abandon()
        self.store.done_writing(self.entry.name)
        shutil.rmtree(self.entry.folder, ignore_errors=True)
        self.files.changed(self.header["capture"])


class CaptureFiles:
    """CaptureSink and ShotStore over the recordings' Store."""

    def __init__(self, store: Store):
        self.store = store
        self._lock = threading.Lock()
        self._cache: dict[str, list[tuple[str, dict]]] = {}  # capture id -> [(entry name, summary)]
        self._changes = 0
        self.cleared = self._clear_cut_short()

    def _clear_cut_short(self) -> list[str]:
        """Deletes the shots the agent died writing (state still `recording`): their rows were in
        memory, the file holds at most a part of them, so no half shot is ever listed."""
        gone = []
        for folder in self.store.root.iterdir():
            if not SHOT_NAME.match(folder.name) or folder.name in self.store.busy():
                continue
            try:
                entry = self.store.get(folder.name)
            except StoreError:
                continue
            if entry.meta.get("kind") == "capture" and entry.meta.get("state") == "recording":
                shutil.rmtree(entry.folder, ignore_errors=True)
                gone.append(entry.name)
        return gone

    def open(self, header: dict) -> ShotWriter:
        try:
            return _McapShot(self, header)
        except StoreError as e:
            raise OSError(e.message) from None

    def changed(self, capture_id: str) -> None:
        with self._lock:
            self._cache.pop(capture_id, None)
            self._changes += 1

    def _shots(self, capture_id: str) -> list[tuple[str, dict]]:
        """The capture's closed shots (entry name, summary with "shot"), oldest first: read from the
        entries once, then checked by their folders (the quota or DELETE /recordings may remove one)."""
        with self._lock:
            cached, changes = self._cache.get(capture_id), self._changes
        if cached is not None and all((self.store.root / name).is_dir() for name, _ in cached):
            return cached
        found = []
        for folder in self.store.root.iterdir():
            m = SHOT_NAME.match(folder.name)
            if not m or m.group(1) != capture_id:
                continue
            try:
                entry = self.store.get(folder.name)
            except StoreError:
                continue
            if entry.meta.get("kind") == "capture" and entry.meta.get("state") == "stopped":
                found.append((int(m.group(2)), folder.name, {**entry.meta.get("summary", {}), "shot": int(m.group(2))}))
        shots = [(name, summary) for _, name, summary in sorted(found)]
        with self._lock:
            if changes == self._changes:
                self._cache[capture_id] = shots
        return shots

    def summaries(self, capture_id: str) -> list[dict]:
        return [dict(summary) for _, summary in self._shots(capture_id)]

    def read(self, capture_id: str, shot: int) -> ShotData | None:
        try:
            entry = self.store.get(shot_name(capture_id, shot))
        except StoreError:
            return None
        if entry.meta.get("kind") != "capture" or entry.meta.get("state") != "stopped":
            return None
        header = entry.meta.get("capture", {})
        channels = len(header.get("channels", []))
        seq, t_ns, columns = [], [], [[] for _ in range(channels)]
        for _, rows in mcap_read.iter_rows(entry.parts()):
            seq += rows.seq
            t_ns += rows.t_ns
            for column, values in zip(columns, rows.columns):
                column += values
        values = np.array(columns, dtype=np.float64).reshape(channels, len(seq))  # None (not finite) -> NaN
        summary = {**entry.meta.get("summary", {}), "shot": int(shot)}
        notes = list(summary.get("notes", []))
        return ShotData(header, summary, notes, np.array(seq, np.int64), np.array(t_ns, np.int64), values)

    def delete(self, capture_id: str, shot: int | None = None) -> None:
        names = [shot_name(capture_id, shot)] if shot is not None else [n for n, _ in self._shots(capture_id)]
        for name in names:
            try:
                self.store.delete(name)
            except StoreError as e:
                if e.status not in (404, 409):  # 409: a shot still being written stays, listed by /recordings
                    raise
        self.changed(capture_id)

"""capture_engine.py -- the agent's thread that runs the triggered captures (docs/recorder.md): it
asks irpd to trace every armed capture's channels (owner "capture"), reads the trace rings every
POLL_S, feeds each capture the rows that carry its channels, hands it the alarms, faults and swaps
it may trigger on, and writes the finished shots through the sink from a thread of their own.

    each poll (POLL_S, 20 ms), with any capture armed:
        every second: the rings replaced (irpd restarted) or our channels gone -> `trace` again
        the rings' new rows (from the oldest armed capture's cursor), part by part -> each capture
            whose channels the part carries, in blocks of BLOCK_ROWS
        the events queued by the alarm manager and the alarm watcher -> each armed capture
        each capture's tick: a pending event or a shot whose rows stopped coming
    captures to re-arm (after the agent restarted, or irpd came back): tried every second

The captures (their requests and whether they are armed) persist in <data-dir>/captures/captures.json,
so that a capture armed on "fault" is armed again when the agent restarts.
"""

from __future__ import annotations

import json
import os
import queue
import secrets
import threading
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..access.auth import now_iso
from ..events import AgentEvents
from ..irpd.client import IrpdClient, IrpdRefused, IrpdUnavailable
from ..irpd.trace import TraceError, TraceRing
from . import capture_limits as L
from .capture import ARMED, DONE, IDLE, Capture, Shot, capture_bytes, rows_of
from .capture_checks import CaptureError, channels_of, check_request
from .capture_sink import Shots
from .triggers import Event, alarm_events, irpd_events

CHECK_EVERY_S = 1.0


@dataclass
class Entry:
    id: str
    request: dict  # capture_models.CaptureRequest as JSON
    created: str
    by: str | None = None
    capture: Capture | None = None
    channels: list[str] | None = None
    types: dict | None = None  # path -> (type, iec_type), capture_checks.numeric_types

    def channel_list(self, paths: list[str]) -> list[dict]:
        """The channels as the API and the shots' files name them: path, type, IEC type."""
        types = self.types or {}
        return [dict(zip(("path", "type", "iec_type"), (p, *types.get(p, (None, None))))) for p in paths]

    cursor: int = 0  # the last seq of the rings this capture was given (or skipped)
    want_armed: bool = False  # armed, or to be armed again (agent restarted, irpd back)
    next_number: int = 1
    armed_at: str | None = None
    message: str | None = None


class CaptureEngine(threading.Thread):
    def __init__(
        self,
        irpd_socket: str,
        folder: Path,
        shots: Shots,
        events: AgentEvents | None = None,
        poll_s: float = L.POLL_S,
    ):
        super().__init__(name="captures", daemon=True)
        self.folder = Path(folder)  # captures.json
        self.folder.mkdir(parents=True, exist_ok=True)
        self.shots = shots  # capture_files.CaptureFiles: MCAP files in the recordings folder
        self.events = events or AgentEvents()
        self.client = IrpdClient(irpd_socket, timeout_s=2.0)
        self.poll_s = poll_s
        self.lock = threading.RLock()
        self.entries: dict[str, Entry] = {}
        self.ring: TraceRing | None = None
        self.union: list[str] = []
        self.types: dict[str, str] = {}
        self.capacity: int | None = None
        self.basic_period_ns: int | None = None
        self.queued: deque[Event] = deque(maxlen=1024)
        self.finished: queue.Queue = queue.Queue()  # shots for the writer thread
        self.writer = threading.Thread(target=self._write_shots, name="capture-writer", daemon=True)
        self._halt = threading.Event()  # not _stop: threading.Thread has a _stop() of its own
        self.next_check = self.next_rearm = 0.0
        self.last_error: str | None = None
        self.path = self.folder / "captures.json"
        self._load()

    # ---- life ------------------------------------------------------------------------------------
    def start(self) -> None:
        self.writer.start()
        super().start()

    def stop(self) -> None:
        self._halt.set()
        if self.is_alive():
            self.join(timeout=5)
        self.finished.put(None)
        if self.writer.is_alive():
            self.writer.join(timeout=30)
        self.client.close()
        if self.ring is not None:
            self.ring.close()

    def run(self) -> None:
        if not any(e.want_armed for e in self.entries.values()):
            self._withdraw()  # what a previous agent left traced as ours
        while not self._halt.wait(self.poll_s):
            try:
                self.poll_once()
                self.last_error = None
            except Exception as e:  # noqa: BLE001 -- the engine must outlive anything irpd does
                error = f"the capture engine: {type(e).__name__}: {e}"
                if error != self.last_error:
                    self.events.add("agent_error", error)
                self.last_error = error

    # ---- events in (called from the alarm manager's and the alarm watcher's threads) ----------------
    def on_alarms(self, message: dict) -> None:
        self.queued.extend(alarm_events(message))

    def on_irpd_events(self, events: list[dict]) -> None:
        self.queued.extend(irpd_events(events))

    # ---- the poll --------------------------------------------------------------------------------
    def armed(self) -> list[Entry]:
        return [e for e in self.entries.values() if e.capture is not None and e.capture.armed]

    def poll_once(self) -> None:
        now = time.monotonic()
        with self.lock:
            if now >= self.next_rearm:
                self.next_rearm = now + CHECK_EVERY_S
                self._rearm_waiting()
            armed = self.armed()
            if not armed:
                self.queued.clear()
                return
            if now >= self.next_check:
                self.next_check = now + CHECK_EVERY_S
                self._check_rings()
                armed = self.armed()
            if self.ring is not None and armed:
                read = self.ring.read_since(min(e.cursor for e in armed))
                for part in read.parts:
                    self._feed(part, armed)
                for e in armed:
                    e.cursor = max(e.cursor, read.next)
            offset = time.time_ns() - time.monotonic_ns()  # CLOCK_REALTIME - CLOCK_MONOTONIC, now
            while self.queued:
                event = self.queued.popleft()
                for e in armed:
                    e.capture.on_event(event, event.time_ns - offset)
            for e in armed:
                e.capture.tick()
            if any(not e.capture.armed for e in armed):
                for e in armed:
                    e.want_armed = e.capture.armed
                self._narrow()
                self._save()

    def _feed(self, part, armed: list[Entry]) -> None:
        index = {p: i for i, p in enumerate(part.config.paths)}
        first, n = part.first_seq, part.count
        t_ns = np.frombuffer(part.t_ns, dtype=np.int64)
        columns: dict[int, np.ndarray] = {}
        for e in armed:
            if not e.capture.armed or any(c not in index for c in e.channels):
                continue  # sampled without its channels: rows it does not get
            lo = max(0, e.cursor + 1 - first)
            if lo >= n:
                continue
            for c in e.channels:
                if index[c] not in columns:
                    columns[index[c]] = np.frombuffer(part.columns[index[c]], dtype=np.float64)
            seq = np.arange(first + lo, first + n, dtype=np.int64)
            values = np.stack([columns[index[c]][lo:] for c in e.channels])
            for k in range(0, len(seq), L.BLOCK_ROWS):
                e.capture.feed(
                    seq[k : k + L.BLOCK_ROWS], t_ns[lo + k : lo + k + L.BLOCK_ROWS], values[:, k : k + L.BLOCK_ROWS]
                )
            e.cursor = first + n - 1

    # ---- irpd's trace: the union of the armed captures' channels, as the owner "capture" ------------
    def _wanted(self, extra: Entry | None = None) -> list[str]:
        want = [c for e in self.armed() for c in e.channels]
        if extra is not None:
            want += extra.channels
        kept = [p for p in self.union if p in want]
        return kept + [p for p in dict.fromkeys(want) if p not in kept]

    def _configure(self, union: list[str]) -> bool:
        """Asks irpd to trace `union` as ours; opens the rings it names.  True when they are new
        rings (irpd restarted: every armed capture starts again)."""
        answer = self.client.request("trace", channels=union, owner=L.TRACE_OWNER) or {}
        if not isinstance(answer.get("shm"), str):
            raise TraceError(f"irpd's answer to trace names no shared memory: {answer!r}")
        self.union = list(union)
        self.types.update({c["path"]: c["type"] for c in answer.get("channels", [])})
        self.capacity, self.basic_period_ns = answer.get("capacity"), answer.get("basic_period_ns")
        if self.ring is not None and self.ring.name == answer["shm"] and not self.ring.replaced():
            return False
        fresh = self.ring is not None
        if self.ring is not None:
            self.ring.close()
        self.ring = TraceRing(answer["shm"])
        return fresh

    def _withdraw(self) -> None:
        try:
            self.client.request("trace", channels=[], owner=L.TRACE_OWNER)
            self.union = []
        except (IrpdUnavailable, IrpdRefused):
            pass

    def _narrow(self) -> None:
        """Traces only what the captures still armed need (nothing: withdraws ours)."""
        wanted = self._wanted()
        if wanted == self.union:
            return
        try:
            if wanted:
                self._configure(wanted)
            else:
                self._withdraw()
        except (IrpdUnavailable, IrpdRefused, TraceError):
            pass  # irpd gone: nothing to narrow

    def _check_rings(self) -> None:
        """irpd restarted (new rings), or our channels are no longer in force: ask again."""
        try:
            config = self.ring.in_force() if self.ring is not None and not self.ring.replaced() else None
        except TraceError:
            return
        if config is not None and set(self.union) <= set(config.paths):
            return
        try:
            restarted = self._configure(self._wanted())
        except IrpdUnavailable as e:
            for entry in self.armed():
                entry.message = f"irpd does not answer: {e}"
            return
        except IrpdRefused as e:  # a new set without some of the variables
            self._drop_refused(str(e))
            return
        for entry in self.armed():
            if not restarted:
                entry.message = None
                continue
            entry.cursor = 0
            if self.basic_period_ns != entry.capture.basic_period_ns:
                self._disarm(entry, f"irpd restarted with another basic period ({self.basic_period_ns} ns)")
                entry.want_armed = True  # armed again, its lengths in rows anew
            else:
                entry.capture.restart("irpd restarted: the rings began again")
                entry.message = f"irpd restarted at {now_iso()}: armed again in its new rings"
        if restarted:
            self.events.add("captures", "irpd restarted: the armed captures go on in its new trace rings")

    def _drop_refused(self, why: str) -> None:
        """irpd refused the union: the captures naming a path it names are disarmed, and the others
        asked for again."""
        for entry in self.armed():
            if any(f"'{c}'" in why for c in entry.channels):
                self._disarm(entry, f"irpd refused its channels: {why}")
        try:
            self._configure(self._wanted())
        except (IrpdUnavailable, IrpdRefused, TraceError) as e:
            for entry in self.armed():
                self._disarm(entry, f"irpd refused the captures' channels: {e}")
        self._save()

    # ---- arming ------------------------------------------------------------------------------------
    def _check(self, entry: Entry) -> None:
        """Raises CaptureError naming what to fix when the capture cannot be armed as asked."""
        taken = sum(
            capture_bytes(
                len(e.channels), e.capture.pre, e.capture.post, e.capture.event_trigger, e.capture.basic_period_ns
            )
            for e in self.armed()
            if e is not entry
        )
        entry.channels, entry.types = check_request(entry.request, self._ask, taken)

    def _ask(self, cmd: str, **arguments) -> dict:
        try:
            return self.client.request(cmd, **arguments) or {}
        except IrpdUnavailable as e:
            raise CaptureError(503, f"irpd does not answer: {e}") from e
        except IrpdRefused as e:
            raise CaptureError(409, f"irpd refused {cmd}: {e}") from e

    def _arm(self, entry: Entry) -> None:
        """Checks the capture, has its channels traced and arms it (call with the lock held)."""
        if len(self.armed()) >= L.MAX_ARMED:
            raise CaptureError(409, f"{L.MAX_ARMED} captures are armed, the most at once: disarm one first")
        self._check(entry)
        union = self._wanted(entry)
        if len(union) > L.MAX_CHANNELS:
            raise CaptureError(
                409,
                f"the armed captures and this one would trace {len(union)} channels; at most {L.MAX_CHANNELS} "
                "can be traced: disarm a capture, or capture fewer variables",
            )
        try:
            restarted = self._configure(union)
        except IrpdUnavailable as e:
            raise CaptureError(503, f"irpd does not answer: {e}") from e
        except IrpdRefused as e:
            raise CaptureError(409, f"irpd refused to trace the capture's channels: {e}") from e
        except TraceError as e:
            raise CaptureError(503, str(e)) from e
        if restarted:
            for other in self.armed():
                other.cursor = 0
                other.capture.restart("irpd restarted: the rings began again")
        capture = Capture(entry.id, entry.request, entry.channels, self.basic_period_ns, self._shot_done)
        capture.next_number = entry.next_number
        capture.arm(self.ring.head())
        entry.capture, entry.cursor, entry.want_armed = capture, 0, True
        entry.armed_at, entry.message = now_iso(), None

    def _disarm(self, entry: Entry, why: str) -> None:
        if entry.capture is not None and entry.capture.armed:
            entry.capture.disarm(why)
        entry.want_armed, entry.message = False, why if why != "disarmed" else None

    def _rearm_waiting(self) -> None:
        for entry in self.entries.values():
            if entry.want_armed and (entry.capture is None or not entry.capture.armed):
                try:
                    self._arm(entry)
                    self.events.add("captures", f"capture {entry.id} ({entry.request.get('name') or '-'}) armed again")
                    self._save()
                except CaptureError as e:
                    message = f"not armed again: {e}"
                    if e.status != 503:  # irpd down: try again; refused: it stays idle, saying why
                        entry.want_armed = False
                    if message != entry.message or not entry.want_armed:
                        entry.message = message
                        self._save()

    # ---- the API's calls ----------------------------------------------------------------------------
    def create(self, request: dict, who: str | None) -> dict:
        with self.lock:
            if len(self.entries) >= L.MAX_CAPTURES:
                raise CaptureError(
                    409, f"{L.MAX_CAPTURES} captures are kept, the most: delete one (DELETE /captures/ID) first"
                )
            entry = Entry(secrets.token_hex(5), request, now_iso(), who)
            self._arm(entry)
            self.entries[entry.id] = entry
            self._save()
            return self.public(entry)

    def get(self, capture_id: str) -> Entry:
        entry = self.entries.get(capture_id)
        if entry is None:
            raise CaptureError(404, f"no capture {capture_id!r}; GET /captures lists them")
        return entry

    def rearm(self, capture_id: str, who: str | None) -> dict:
        with self.lock:
            entry = self.get(capture_id)
            if entry.capture is not None and entry.capture.armed:
                raise CaptureError(409, f"capture {capture_id} is {entry.capture.state} already")
            self._arm(entry)
            entry.by = who
            self._save()
            return self.public(entry)

    def disarm(self, capture_id: str) -> dict:
        with self.lock:
            entry = self.get(capture_id)
            if not entry.want_armed and (entry.capture is None or not entry.capture.armed):
                raise CaptureError(409, f"capture {capture_id} is not armed")
            self._disarm(entry, "disarmed")
            self._narrow()
            self._save()
            return self.public(entry)

    def trigger(self, capture_id: str) -> dict:
        with self.lock:
            entry = self.get(capture_id)
            state = entry.capture.state if entry.capture is not None else IDLE
            if state != ARMED:
                raise CaptureError(409, f"capture {capture_id} is {state}: only an armed capture can be triggered")
            event = Event("manual", time.time_ns(), "an operator's trigger (now)", capture=capture_id)
            entry.capture.on_event(event, time.monotonic_ns(), force=True)
            return self.public(entry)

    def delete(self, capture_id: str) -> None:
        with self.lock:
            entry = self.get(capture_id)
            self._disarm(entry, "deleted")
            del self.entries[capture_id]
            self._narrow()
            self._save()
        self.shots.delete(capture_id)

    def list(self) -> list[dict]:
        with self.lock:
            return [self.public(e) for e in sorted(self.entries.values(), key=lambda e: e.created)]

    def public(self, entry: Entry) -> dict:
        c = entry.capture
        basic = c.basic_period_ns if c is not None else self.basic_period_ns
        return {
            "id": entry.id,
            "name": entry.request.get("name", ""),
            "state": c.state if c is not None else IDLE,
            "request": entry.request,
            "channels": entry.channel_list(entry.channels or channels_of(entry.request)),
            "pre_rows": c.pre if c is not None else (rows_of(entry.request["pre"], basic) if basic else 0),
            "post_rows": c.post if c is not None else (rows_of(entry.request["post"], basic) if basic else 0),
            "basic_period_ns": basic,
            "pre_filled": c.pre_filled() if c is not None and c.armed else 0,
            "shots_taken": c.shots_taken if c is not None else 0,
            "lost_rows": c.lost_rows if c is not None else 0,
            "created": entry.created,
            "armed_at": entry.armed_at,
            "by": entry.by,
            "message": entry.message,
            "shots": self.shots.summaries(entry.id),
        }

    def limits(self) -> dict:
        ring_rows = self.capacity
        if ring_rows is None:
            try:
                ring_rows = int(self.client.request("trace", timeout=1.0)["capacity"])
            except (IrpdUnavailable, IrpdRefused, KeyError, TypeError):
                ring_rows = None
        return L.as_dict(ring_rows)

    # ---- shots out -----------------------------------------------------------------------------------
    def _shot_done(self, capture: Capture, shot: Shot) -> None:
        """A capture finished a shot (engine thread, lock held): it goes to the writer."""
        entry = self.entries.get(capture.id)
        if entry is None:
            return
        entry.next_number = capture.next_number
        header = {
            "capture": entry.id,
            "name": entry.request.get("name", ""),
            "by": entry.by,
            "shot": shot.number,
            "channels": entry.channel_list(entry.channels),
            "basic_period_ns": capture.basic_period_ns,
            "trigger": entry.request["trigger"],
            "pre": capture.pre,
            "post": capture.post,
            "trigger_seq": shot.trigger_seq,
            "cause": shot.cause,
            "trigger_time_ns": shot.trigger_time_ns,
        }
        self.finished.put((header, shot))
        if capture.state == DONE:
            entry.want_armed = False
        self._save()

    def _write_shots(self) -> None:
        while True:
            item = self.finished.get()
            if item is None:
                return
            header, shot = item
            try:
                self._write(header, shot)
            except Exception as e:  # noqa: BLE001 -- a full disk must not stop the captures
                self.events.add("agent_error", f"capture {header['capture']}: shot {header['shot']} not saved: {e}")
                with self.lock:
                    entry = self.entries.get(header["capture"])
                    if entry is not None:
                        entry.message = f"shot {header['shot']} not saved: {e}"
            finally:
                self.finished.task_done()

    def _write(self, header: dict, shot: Shot) -> None:
        with self.lock:
            if header["capture"] not in self.entries:
                return  # deleted meanwhile
        seq, t_ns, values = shot.arrays()
        writer = self.shots.open(header)
        try:
            step = L.BLOCK_ROWS * 8
            for k in range(0, len(seq), step):
                writer.rows(seq[k : k + step], t_ns[k : k + step], values[:, k : k + step])
            for note in shot.notes:
                writer.note(note)
            writer.close(shot.summary())
        except BaseException:
            writer.abort()
            raise
        kept = self.shots.summaries(header["capture"])
        for old in kept[: max(0, len(kept) - L.MAX_SHOTS_KEPT)]:
            self.shots.delete(header["capture"], old["shot"])

    def flush(self, timeout_s: float = 30.0) -> None:
        """Waits until every finished shot is written (tests, shutdown)."""
        deadline = time.monotonic() + timeout_s
        while self.finished.unfinished_tasks and time.monotonic() < deadline:
            time.sleep(0.01)

    # ---- persistence -----------------------------------------------------------------------------
    def _save(self) -> None:
        rows = [
            {
                "id": e.id,
                "request": e.request,
                "created": e.created,
                "by": e.by,
                "want_armed": e.want_armed,
                "next_number": e.capture.next_number if e.capture is not None else e.next_number,
                "armed_at": e.armed_at,
                "message": e.message,
            }
            for e in self.entries.values()
        ]
        tmp = self.path.with_name(self.path.name + ".tmp")
        tmp.write_text(json.dumps({"captures": rows}, indent=1))
        os.replace(tmp, self.path)

    def _load(self) -> None:
        try:
            saved = json.loads(self.path.read_text()).get("captures", [])
        except FileNotFoundError:
            return
        except (OSError, ValueError) as e:
            aside = self.path.with_name(f"captures.json.unreadable-{int(time.time())}")
            os.replace(self.path, aside)
            self.events.add("agent_error", f"the captures' file did not read ({e}): moved aside to {aside}")
            return
        for row in saved:
            entry = Entry(row["id"], row["request"], row["created"], row.get("by"))
            entry.want_armed, entry.next_number = bool(row.get("want_armed")), int(row.get("next_number", 1))
            entry.armed_at, entry.message = row.get("armed_at"), row.get("message")
            entry.channels = channels_of(entry.request)
            self.entries[entry.id] = entry

"""manager.py -- the recorder: the agent's thread that writes every row of the trace rings the
running recordings ask for into their MCAP files, independent of any browser (docs/recorder.md).

    every poll (poll_s, 50 ms):   the rows since the cursor (trace.py), fed to every recording
                                  (recording.py); those whose duration or size is reached end
    every flush (flush_s, 1 s):   each recording's open chunk to disk, fsynced: a crash loses at most that
    every check (check_s, 1 s):   irpd restarted (the rings replaced)? ask `trace` again, new parts;
                                  the quota (oldest entries evicted), the free disk space;
                                  the union of channels narrowed after recordings ended

It asks irpd to trace, as the owner "recorder", the union of the running recordings' variables
(irpd traces the union of every owner's, at most 64 channels in all), on an irpd connection of its
own.  The API's calls (start, stop, ...) come from other threads: `lock` guards the recordings and
the rings; `config_lock` one `trace` request at a time (taken before `lock`, never after).
At start it resumes the recordings that were running when the agent stopped (entry.json's state),
completing a part a crash left without its footer, in a new part after a recorded gap.
"""

from __future__ import annotations

import copy
import math
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from ..events import AgentEvents
from ..irpd.client import IrpdClient, IrpdRefused, IrpdUnavailable
from ..irpd.trace import MAX_CHANNELS, TraceError, TraceRing
from ..irpd.variables import Segment, VariableError, number_problem
from ..viewer.mapping import ROBOT_JSON, MappingError, parse_config
from . import mcap_read
from .capture_files import SHOT_NAME
from .mcap_out import JOINT_FILE_SUFFIX, Joint, Variable
from .recording import Recording
from .store import Store, StoreError, check_name, now

OWNER = "recorder"
MAX_DECIMATION = 1_000_000
JOINT_STATES_MAX_HZ = 1000  # /joint_states at most this often (the samples channel has every row)


class RecorderError(StoreError):
    """A refusal of the API's calls, with its HTTP status (400, 404, 409, 503, 507)."""


@dataclass(frozen=True)
class Wanted:
    """A start request, checked for shape by the API's model."""

    name: str
    variables: list[tuple[str, str]]  # (path, unit)
    decimation: int = 1
    duration_s: float | None = None
    max_bytes: int | None = None


class Recorder(threading.Thread):
    def __init__(
        self,
        store: Store,
        socket_path: str,
        events: AgentEvents,
        poll_s: float = 0.05,
        flush_s: float = 1.0,
        check_s: float = 1.0,
        owner: str = OWNER,
    ):
        super().__init__(name="recorder", daemon=True)
        self.owner = owner  # the trace owner irpd knows it by (one per agent)
        self.store, self.events = store, events
        self.poll_s, self.flush_s, self.check_s = poll_s, flush_s, check_s
        self.irpd = IrpdClient(socket_path, timeout_s=2.0)
        self.lock = threading.RLock()
        self.config_lock = threading.Lock()
        self.recordings: dict[str, Recording] = {}
        self.unsaved: dict[str, Recording] = {}  # ended, but entry.json could not be written (disk full)
        self.ring: TraceRing | None = None
        self.cursor = 0
        self.irpd_pid: int | None = None
        self.union: list[str] = []  # what irpd was last asked to trace for the recorder
        self._stop_event = threading.Event()

    # ---- the API's calls -------------------------------------------------------------------------
    def begin(self, wanted: Wanted, who: str | None) -> dict:
        """Starts a recording; its entry's meta.  RecorderError says what to fix."""
        name = check_name(wanted.name)
        if SHOT_NAME.fullmatch(name):
            raise RecorderError(
                400, f"'{name}' has the form of a capture's shot (<capture id>.shot-<n>); pick another name"
            )
        try:
            self.store.get(name)
        except StoreError as e:
            if e.status != 404:
                raise
        else:
            raise RecorderError(409, f"there is a recording or capture named '{name}' already; pick another name")
        paths = [p for p, _ in wanted.variables]
        if len(set(paths)) != len(paths):
            twice = next(p for p in paths if paths.count(p) > 1)
            raise RecorderError(400, f"variable '{twice}' is listed twice")
        if len(paths) > MAX_CHANNELS:
            raise RecorderError(400, f"{len(paths)} variables; a recording holds at most {MAX_CHANNELS}")
        if not 1 <= wanted.decimation <= MAX_DECIMATION:
            raise RecorderError(
                400, f"decimation must be 1 to {MAX_DECIMATION} (1: every row), not {wanted.decimation}"
            )
        if wanted.max_bytes is not None and wanted.max_bytes > self.store.quota_bytes:
            raise RecorderError(
                400,
                f"stop.max_bytes ({wanted.max_bytes}) is over the recordings' quota ({self.store.quota_bytes} bytes, "
                "the agent's recordings_quota_bytes): ask for less, or raise the quota",
            )
        free = self.store.disk_free()
        if free < self.store.min_free_bytes:
            raise RecorderError(507, self.disk_full_text(free))
        status = self.ask("status")
        variables, joints, basic = self.check_variables(wanted.variables, status)
        joint_every = max(1, math.ceil(1e9 / JOINT_STATES_MAX_HZ / (basic * wanted.decimation))) if basic else 1
        with self.config_lock:
            with self.lock:
                union = self.union_with(paths)
            answer, pid = self.connect(union)  # refused: irpd's message names every owner's count
            meta = {
                "state": "recording",
                "cause": None,
                "reason": None,
                "created_by": who,
                "variables": [v.__dict__ for v in variables],
                "decimation": wanted.decimation,
                "stop": {"duration_s": wanted.duration_s, "max_bytes": wanted.max_bytes},
                "joints": [j.__dict__ for j in joints],
                "joint_every": joint_every,
                "basic_period_ns": basic,
                "set": status.get("set"),
                "parts": [],
                "gaps": [],
                "rows": 0,
                "drops": 0,
            }
            try:
                entry = self.store.create(name, "recording", meta)
            except StoreError:
                self.trace(self.union_with(), quiet=True)
                raise
            self.store.writing(name)
            with self.lock:
                rec = self.recording(entry)
                rec.irpd_pid = pid
                rec.last = int(answer.get("head") or 0)  # from the rows after this answer on
                self.cursor = min(self.cursor, rec.last) if self.recordings else rec.last
                self.recordings[name] = rec
                started = copy.deepcopy(entry.meta)
        self.events.add("recording", f"recording '{name}' started: {len(paths)} variables")
        return started

    def end(self, name: str, who: str | None) -> dict:
        """Stops a running recording (its file closed, complete); its meta.  The stop's moment is
        the rings' head when the request is handled: the rings are read once more up to it, so
        the file holds every row up to that one (the thread last read them up to 50 ms before)."""
        entry = self.store.get(name)
        with self.lock:
            rec = self.recordings.get(name)
            if rec is None:
                raise RecorderError(409, f"'{name}' is not recording (it is {entry.meta.get('state')})")
            self.poll()  # may end it by its own stop (duration, size, a write failed) first
            if rec.name in self.recordings:
                self.finish(rec, "stopped", "manual", f"stopped by {who or 'the appliance'}")
        self.narrow()
        return rec.meta

    def delete(self, name: str) -> None:
        self.store.delete(name)

    def live(self, name: str) -> dict | None:
        """The meta of a running recording as the thread holds it (with the open part's size), or of
        one that ended but whose entry.json could not be written yet (a full disk)."""
        with self.lock:
            rec = self.recordings.get(name) or self.unsaved.get(name)
            if rec is None:
                return None
            if rec.part is not None and rec.out is not None:
                rec.part["size"] = rec.out.size
            return copy.deepcopy(rec.meta)

    def owners(self) -> dict | None:
        """Every owner's traced channels, as irpd says ({owner: [paths]}); None without irpd."""
        try:
            answer = self.irpd.request("trace")
        except (IrpdUnavailable, IrpdRefused):
            return None
        return answer.get("owners") if isinstance(answer, dict) else None

    # ---- checks ----------------------------------------------------------------------------------
    def ask(self, cmd: str, **arguments):
        try:
            return self.irpd.request(cmd, **arguments)
        except IrpdUnavailable as e:
            raise RecorderError(503, str(e)) from e
        except IrpdRefused as e:
            raise RecorderError(409, f"irpd refused '{cmd}': {e}") from e

    def check_variables(self, wanted: list[tuple[str, str]], status: dict) -> tuple[list[Variable], list[Joint], int]:
        """The variables as the running layout has them (scalar leaves), the joints of the set's
        robot.json among them, and the basic period; RecorderError 400 naming a path that is not."""
        name = (status.get("shared_memory") or {}).get("variables")
        if not name:
            raise RecorderError(409, "the running set has no shared variables (no layout): nothing can be recorded")
        try:
            seg = Segment(name)
        except VariableError as e:
            raise RecorderError(503, str(e)) from e
        try:
            variables = []
            for i, (path, unit) in enumerate(wanted):
                problem = number_problem(path, seg.leaves, seg.scalars, traced=True, unknown=seg.unknown)
                if problem:
                    raise RecorderError(400, f"variables[{i}]: {problem}")
                leaf = seg.leaves[path]
                variables.append(Variable(path, leaf["type"], unit, leaf.get("iec_type")))
        finally:
            seg.close()
        joints = []
        robot = Path(status.get("set") or "").parent / ROBOT_JSON
        if status.get("set") and robot.is_file():
            try:
                config = parse_config(robot.read_bytes())
                recorded = {v.path for v in variables}
                joints = [
                    Joint(j.joint, j.variable, j.scale, j.offset) for j in config.joints if j.variable in recorded
                ]
            except (MappingError, OSError):
                joints = []  # the robot view says what is wrong with it; the rows are recorded all the same
        return variables, joints, int(status.get("basic_period_ns") or 0)

    def disk_full_text(self, free: int) -> str:
        return (
            f"the disk of {self.store.root} has {free >> 20} MiB free, under the {self.store.min_free_bytes >> 20} MiB "
            "the recorder keeps free (recordings_min_free_bytes): delete recordings or make room"
        )

    # ---- irpd ------------------------------------------------------------------------------------
    def union_with(self, extra: list[str] = ()) -> list[str]:
        """The recordings' channels (and `extra`), those asked for already first, in their order."""
        want = [p for rec in self.recordings.values() for p in rec.paths] + list(extra)
        kept = [p for p in self.union if p in want]
        return kept + [p for p in dict.fromkeys(want) if p not in kept]

    def trace(self, union: list[str], quiet: bool = False) -> dict | None:
        """Asks irpd to trace `union` for the recorder (with config_lock held).  quiet: failures
        are left for the next check (irpd gone forgets our channels by itself)."""
        try:
            answer = self.irpd.request("trace", channels=union, owner=self.owner)
        except IrpdUnavailable as e:
            if quiet:
                return None
            raise RecorderError(503, str(e)) from e
        except IrpdRefused as e:
            if quiet:
                return None
            raise RecorderError(409, f"irpd refused to trace the recording's variables: {e}") from e
        if not isinstance(answer, dict) or not isinstance(answer.get("shm"), str):
            raise RecorderError(503, f"irpd's answer to trace names no shared memory: {answer!r:.200}")
        self.union = list(union)
        return answer

    def connect(self, union: list[str]) -> tuple[dict, int]:
        """Asks irpd to trace `union` (with config_lock held) and maps the rings it names.  The
        recordings of another irpd run (irpd restarted; or they were resumed at the agent's start)
        close their part and go on after a gap: in the same run from the last row written (the
        rings may still hold what followed it), else from the first row of this run."""
        try:
            status = self.irpd.request("status")
        except IrpdUnavailable as e:
            raise RecorderError(503, str(e)) from e
        answer = self.trace(union)
        pid = int(status.get("pid") or 0)
        with self.lock:
            replaced = self.ring is None or self.ring.name != answer["shm"] or self.ring.replaced()
            if replaced:
                if self.ring is not None:
                    self.ring.close()
                try:
                    self.ring = TraceRing(answer["shm"])
                except TraceError as e:
                    self.ring = None
                    raise RecorderError(503, str(e)) from e
                self.cursor = self.ring.head()
            previous, self.irpd_pid = self.irpd_pid, pid
            cursors = []
            for rec in self.recordings.values():
                if rec.irpd_pid == pid and not rec.resuming:
                    continue
                same = rec.written_pid() == pid
                if rec.resuming:
                    why = "the agent was stopped" + ("" if same else " and irpd restarted meanwhile")
                else:
                    why = f"irpd restarted (pid {previous} -> {pid}); seq starts again"
                    self.close_part(rec, ("gap", f"{why}: the rows go on in the next part"))
                rec.new_run(pid, why, same_run=same)
                rec.resuming = False
                cursors.append(rec.last)
            if cursors:
                self.cursor = min(cursors if replaced else [*cursors, self.cursor])
        return answer, pid

    def narrow(self) -> None:
        """Asks irpd to trace only what the running recordings need (nothing: the request withdrawn)."""
        with self.config_lock:
            with self.lock:
                union = self.union_with()
            if union != self.union:
                self.trace(union, quiet=True)

    def variables_gone(self, message: str) -> None:
        """irpd refused the union after a restart: the recordings whose variables the new layout
        lacks end (cause "variables"); the others are asked for again at the next check."""
        try:
            status = self.irpd.request("status")
            name = (status.get("shared_memory") or {}).get("variables")
            seg = Segment(name) if name else None
        except (IrpdUnavailable, IrpdRefused, VariableError):
            return
        with self.lock:
            for rec in list(self.recordings.values()):
                problems = [
                    p for p in rec.paths if seg is None or number_problem(p, seg.leaves, seg.scalars, traced=True)
                ]
                if problems:
                    why = f"irpd's running set no longer has '{problems[0]}' as a scalar: {message}"
                    self.finish(rec, "stopped", "variables", why)
        if seg is not None:
            seg.close()

    # ---- the thread ------------------------------------------------------------------------------
    def stop(self) -> None:
        """Closes every part (complete files) and ends the thread; the recordings stay "recording"
        in entry.json and resume when the agent starts again.  irpd keeps tracing their channels
        meanwhile, so that rows the rings still hold then are not lost."""
        self._stop_event.set()
        if self.is_alive():
            self.join(10)
        with self.lock:
            for rec in self.recordings.values():
                try:
                    self.close_part(
                        rec, ("info", "the agent stopped; the recording resumes in a new part when it starts")
                    )
                    rec.save()
                except OSError:
                    pass
            self.recordings.clear()
        self.irpd.close()

    def run(self) -> None:
        self.resume()
        next_flush = next_check = time.monotonic()
        while not self._stop_event.wait(self.poll_s):
            with self.lock:
                self.poll()
            now_s = time.monotonic()
            if now_s >= next_flush:
                next_flush = now_s + self.flush_s
                with self.lock:
                    for rec in list(self.recordings.values()):
                        self.guard(rec, rec.flush)
            if now_s >= next_check:
                next_check = now_s + self.check_s
                self.check()

    def poll(self) -> None:
        if self.ring is None or not self.recordings:
            return
        try:
            read = self.ring.read_since(self.cursor)
        except TraceError:
            return
        self.cursor = read.next
        for rec in list(self.recordings.values()):  # the union is narrowed at the next check
            if rec.resuming:
                continue  # until connect() says from which row on
            self.guard(rec, lambda rec=rec: rec.feed(read, self.irpd_pid))
            if rec.done and rec.name in self.recordings:
                self.finish(rec, *rec.done)

    def check(self) -> None:
        with self.lock:
            names = list(self.recordings)
            lost = names and (self.ring is None or self.ring.replaced())
        if names:
            with self.lock:
                union, ring = self.union_with(), self.ring
            try:
                config = ring.in_force() if ring is not None and not lost else None
            except TraceError:
                config = None
            if lost or config is None or not set(union) <= set(config.paths):
                with self.config_lock:  # irpd restarted, or someone reconfigured the trace: ask again
                    try:
                        self.connect(union)
                    except RecorderError as e:
                        if e.status == 409:
                            self.variables_gone(e.message)
        with self.lock:
            for name, rec in list(self.unsaved.items()):
                try:
                    rec.save()
                    del self.unsaved[name]
                except OSError:
                    pass
        self.store.keep_reserve()
        for name in self.store.evict():
            self.events.add(
                "recording",
                f"'{name}' deleted to keep the recordings under their quota ({self.store.quota_bytes} bytes)",
            )
        with self.lock:
            if self.recordings and self.store.used() > self.store.quota_bytes:
                why = (
                    f"the recordings being written fill the quota ({self.store.quota_bytes} bytes, recordings_quota_bytes) "
                    "with nothing older left to delete: raise the quota or stop recordings"
                )
                for rec in list(self.recordings.values()):
                    self.finish(rec, "stopped", "quota", why)
            free = self.store.disk_free() if self.recordings else None
            if free is not None and free < self.store.min_free_bytes:
                for rec in list(self.recordings.values()):
                    self.finish(rec, "stopped", "disk_full", self.disk_full_text(free))
        self.narrow()

    # ---- recordings --------------------------------------------------------------------------------
    def recording(self, entry) -> Recording:
        m = entry.meta
        stop = m.get("stop") or {}
        return Recording(
            entry,
            [Variable(**v) for v in m["variables"]],
            m["decimation"],
            None if stop.get("duration_s") is None else int(stop["duration_s"] * 1e9),
            stop.get("max_bytes"),
            [Joint(**j) for j in m.get("joints", [])],
            m.get("joint_every", 1),
            m.get("basic_period_ns", 0),
        )

    def guard(self, rec: Recording, action) -> None:
        """Runs a write of `rec`; a write that fails (a full disk) ends it as failed, its file left
        as flushed last (readable; completed at the next start)."""
        try:
            action()
        except OSError as e:
            rec.abandon_part()
            cause = "disk_full" if e.errno == 28 else "error"
            self.finish(rec, "failed", cause, f"writing {rec.name}'s file failed: {e}")

    def close_part(self, rec: Recording, note: tuple[str, str] | None = None) -> None:
        try:
            rec.close_part(note)
        except OSError as e:
            rec.meta["reason"] = f"its last part could not be closed: {e}"

    def finish(self, rec: Recording, state: str, cause: str, reason: str) -> None:
        """Ends a recording (with lock held): its part closed, its state saved."""
        self.close_part(rec, ("stop", reason) if state == "stopped" else None)
        rec.meta.update(state=state, cause=cause, reason=reason, ended=now())
        try:
            rec.save()
        except OSError:
            self.store.release_reserve()  # the room kept for this
            try:
                rec.save()
            except OSError:
                self.unsaved[rec.name] = rec  # shown from memory; saved when there is room
        self.recordings.pop(rec.name, None)
        self.store.done_writing(rec.name)
        self.events.add("recording", f"recording '{rec.name}' {state}: {reason}")

    @staticmethod
    def gaps_from_notes(entry, index: int, found: mcap_read.Scan) -> None:
        """A gap the file noted that entry.json lacks (a crash came before it was saved)."""
        gaps = entry.meta.setdefault("gaps", [])
        for note in found.notes:
            if note.get("kind") == "gap" and not any(g["part"] == index for g in gaps):
                missing = note.get("count")
                reason = note.get("text", "").removeprefix("gap: ").split(";")[0]
                gaps.append(
                    {
                        "part": index,
                        "last_seq": note.get("last_seq"),
                        "first_seq": note.get("first_seq"),
                        "missing": missing,
                        "reason": reason,
                    }
                )
        gaps.sort(key=lambda g: g["part"])

    def resume(self) -> None:
        """The recordings entry.json says were running: their last part completed if a crash left
        it open, then recording again in a new part (the gap recorded with its first rows)."""
        found = []
        for entry in self.store.entries():
            if entry.meta.get("kind") != "recording" or entry.meta.get("state") != "recording":
                continue
            self.store.writing(entry.name)
            self.reconcile(entry)
            found.append(entry)
        with self.lock:
            for entry in found:
                rec = self.recording(entry)
                rec.irpd_pid, rec.resuming = rec.written_pid(), True
                self.recordings[entry.name] = rec  # connected by the first check

    def reconcile(self, entry) -> None:
        """entry.json's parts in step with the files: a part not closed is completed (its rows
        counted from the file), a file entry.json does not list yet is added."""
        listed = {p["file"]: p for p in entry.meta.get("parts", [])}
        entry.meta.setdefault("parts", [])
        for path in entry.parts():
            part = listed.get(path.name)
            if part is not None and part.get("closed"):
                continue
            found = mcap_read.recover(path)
            joints = path.with_name(path.name.removesuffix(".mcap") + JOINT_FILE_SUFFIX)
            if joints.exists():
                mcap_read.recover(joints)
            if part is None:
                pid = found.metadata.get("indurop.part", {}).get("irpd_pid")
                part = {"file": path.name, "irpd_pid": int(pid) if pid else None, "opened": None, "drops": 0}
                entry.meta["parts"].append(part)
            part.update(
                closed=now() if found.complete else None,
                first_seq=found.first_seq,
                last_seq=found.last_seq,
                rows=found.rows,
                first_unix_ns=found.first_unix_ns,
                last_unix_ns=found.last_unix_ns,
                size=path.stat().st_size + (joints.stat().st_size if joints.exists() else 0),
                recovered=found.error,
            )
            part["drops"] = sum(n.get("count", 0) for n in found.notes if n.get("kind") == "drop")
            self.gaps_from_notes(entry, entry.meta["parts"].index(part), found)
        entry.meta["rows"] = sum(p.get("rows") or 0 for p in entry.meta["parts"])
        entry.meta["drops"] = sum(p.get("drops") or 0 for p in entry.meta["parts"])
        try:
            entry.save()
        except OSError:
            pass

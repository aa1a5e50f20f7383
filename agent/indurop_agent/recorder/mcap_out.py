"""mcap_out.py -- one MCAP file of recorded rows, written with the `mcap` library (docs/recorder.md,
"The file").  The recorder and the triggered captures both write through it.

    out = McapOut(path, [Variable("SIG.sample", "uint32_t"), Variable("SIG.wave[0]", "double", "V")],
                  title="run-7", basic_period_ns=1_000_000)
    out.add_rows(range(101, 104), t_ns=[...], columns=[[1, 2, 3], [0.0, 0.5, 1.0]])  # seq, due time, values
    out.note("drop", "rows overwritten before they were read", first_seq=104, last_seq=110, count=7)
    out.flush()   # the open chunk to disk (and fsync): a crash loses nothing written before it
    out.close({"rows": "3"})  # the summary section and footer

What it holds:
- `/indurop/samples`: one JSON message per row (orjson), `{"seq", "t_ns", <field>: value, ...}`; a
  field per variable (`field_names`: the path with every character but [A-Za-z0-9_] made `_`, so
  that Foxglove's and PlotJuggler's message paths can name it), a JSON Schema naming each field's
  variable path, type and unit (and a Structured Text variable's IEC type beside the C++ one:
  "Main.t.ET (TIME (int64_t))", `x-indurop-iec-type`), and the same list in the channel's metadata
  (`indurop.variables`, with `iec_type` on such a variable).
  Values are the ring's doubles, `null` where not finite.  log_time = the row's due time on the
  wall clock (t_ns + clock_offset_ns), sequence = seq mod 2^32 (the full seq is in the message).
- `/indurop/notes`: JSON messages for what is not a row: drops, gaps, triggers, why it stopped.
  A note takes its place in time among the rows, so that log_time never goes backwards in the
  file (readers that require order take it): one with a time of its own (a gap's first row, a
  trigger's row) is written before the first row due at or after it, one without takes the time
  of the row written last (before any row: the first row's, before it).
- metadata records: `indurop.part` at the start (what the caller gives), `indurop.summary` at close.

With `joints`, a second file beside it, `<name>.joint_states.mcap` (`joint_file`), in the MCAP
`ros2` profile: `/joint_states`, sensor_msgs/msg/JointState in ROS 2 CDR, encoded by
mcap-ros2-support from the ros2msg definition rosbag2 stores (ros2_msgdefs.py, generated from
protocol/ros2), position = value x scale + offset, at most one message per `joint_every` rows.  It
is a file of its own because ROS 2 readers (rosbags, rosbag2) take only files of that profile, all
CDR; Foxglove opens both together.

Chunks (zstd) are closed at `chunk_bytes` and at every flush(); a file whose writer died holds every
chunk flushed before (mcap_read.recover makes it whole again).
"""

from __future__ import annotations

import os
import re
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import orjson
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import CompressionType, Writer
from mcap_ros2._dynamic import serialize_dynamic  # the encoder mcap_ros2.writer.Writer uses, for a file of our own

from ..irpd.variables import type_text
from .ros2_msgdefs import MSGDEFS

SAMPLES_TOPIC = "/indurop/samples"
NOTES_TOPIC = "/indurop/notes"
JOINT_STATES_TOPIC = "/joint_states"
SAMPLES_SCHEMA = "indurop.Samples"
NOTES_SCHEMA = "indurop.Note"
JOINT_STATE = "sensor_msgs/msg/JointState"
JOINT_FILE_SUFFIX = ".joint_states.mcap"  # part-0001.mcap -> part-0001.joint_states.mcap
CHUNK_BYTES = 4 << 20  # uncompressed bytes of a chunk before it is compressed and written
RESERVED = ("seq", "t_ns")  # the fields every row has; no variable's field takes these names
LIBRARY = "indurop-recorder"
NOTE_KINDS = ("drop", "gap", "trigger", "stop", "info")
NOTES_JSON_SCHEMA = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": NOTES_SCHEMA,
    "description": "what happened to the rows: rows dropped, a gap between two parts, a trigger, a stop",
    "type": "object",
    "properties": {
        "kind": {"type": "string", "enum": list(NOTE_KINDS)},
        "text": {"type": "string"},
        "seq": {"type": "integer", "description": "the row it is about (a trigger's)"},
        "first_seq": {"type": "integer", "description": "the first row it is about"},
        "last_seq": {"type": "integer", "description": "the last row it is about"},
        "count": {"type": "integer", "description": "rows it is about (dropped rows: those the file would hold)"},
    },
    "required": ["kind", "text"],
}


@dataclass(frozen=True)
class Variable:
    """A recorded variable: its path in the shared-variable layout, the layout's type, a unit, and a
    Structured Text variable's IEC type (layout.json's iec_type; None for a .glb variable)."""

    path: str
    type: str
    unit: str = ""
    iec_type: str | None = None


@dataclass(frozen=True)
class Joint:
    """A joint of the JointState channel: its name and the recorded variable that drives it."""

    name: str
    variable: str
    scale: float = 1.0
    offset: float = 0.0


def field_names(paths: Sequence[str]) -> list[str]:
    """The JSON field of each path: [A-Za-z0-9_] kept, runs of anything else one `_`, none at the
    ends (`SIG.wave[0]` -> `SIG_wave_0`); a name taken already (by `seq`, `t_ns` or an earlier
    path) gets `_2`, `_3`, ... so that every field is unique."""
    taken, out = set(RESERVED), []
    for path in paths:
        base = re.sub(r"[^A-Za-z0-9_]+", "_", path).strip("_") or "v"
        name, n = base, 1
        while name in taken:
            n += 1
            name = f"{base}_{n}"
        taken.add(name)
        out.append(name)
    return out


def samples_schema(title: str, variables: Sequence[Variable], fields: Sequence[str]) -> dict:
    """The JSON Schema of the rows: every variable's field with its path, type and unit."""
    properties = {
        "seq": {
            "type": "integer",
            "description": "the trace row's sequence number: irpd's basic periods since it started",
        },
        "t_ns": {"type": "integer", "description": "the row's due time, CLOCK_MONOTONIC ns"},
    }
    for v, f in zip(variables, fields):
        unit = f", {v.unit}" if v.unit else ""
        properties[f] = {
            "type": "number",
            "title": v.path,
            "description": f"{v.path} ({type_text(v.type, v.iec_type)}{unit}); null when not finite",
            "x-indurop-path": v.path,
            "x-indurop-type": v.type,
            "x-indurop-unit": v.unit,
        } | ({"x-indurop-iec-type": v.iec_type} if v.iec_type else {})
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": SAMPLES_SCHEMA,
        "description": f"rows of {title}: one per recorded basic period",
        "type": "object",
        "properties": properties,
        "required": list(properties),
    }


class McapOut:
    """One MCAP file being written.  Not thread-safe: one writer thread per file.  OSError (a full
    disk) leaves the file as it was after its last complete write: call abandon(), not close()."""

    def __init__(
        self,
        path: Path,
        variables: Sequence[Variable],
        *,
        title: str,
        basic_period_ns: int,
        decimation: int = 1,
        clock_offset_ns: int | None = None,
        joints: Sequence[Joint] = (),
        joint_every: int = 1,
        metadata: dict[str, str] | None = None,
        chunk_bytes: int = CHUNK_BYTES,
        compression: CompressionType = CompressionType.ZSTD,
    ):
        if not variables:
            raise ValueError("a recording file needs at least one variable")
        self.path = Path(path)
        self.variables = list(variables)
        self.fields = field_names([v.path for v in self.variables])
        self.clock_offset_ns = time.time_ns() - time.monotonic_ns() if clock_offset_ns is None else clock_offset_ns
        self.rows = 0
        self.first_seq: int | None = None
        self.last_seq: int | None = None
        self.first_t_ns: int | None = None
        self.last_t_ns: int | None = None
        self.closed = False
        self._last_log_time: int | None = None  # of the newest message written (rows and notes)
        self._held: list[tuple[int | None, bytes]] = []  # notes waiting for their place: (log_time, data)
        index = {v.path: i for i, v in enumerate(self.variables)}
        missing = [j.variable for j in joints if j.variable not in index]
        if missing:
            raise ValueError(f"joint variable {missing[0]!r} is not among the recorded variables")
        self.joints = list(joints)
        self.joint_columns = [index[j.variable] for j in self.joints]
        self.joint_every = max(1, joint_every)
        self.joint_messages = 0
        self._joint_phase = 0
        # rows are written as a template filled with orjson's numbers (see add_rows)
        head = b'{"seq":%s,"t_ns":%s'
        self._template = head + b"".join(b"," + orjson.dumps(f) + b":%s" for f in self.fields) + b"}"
        self.joint_file: Path | None = None
        self._joint_out = self._joint_writer = None
        self._file = open(self.path, "xb")  # never over an existing file
        try:
            self._writer = Writer(self._file, chunk_size=chunk_bytes, compression=compression)
            self._writer.start(profile="", library=LIBRARY)
            described = [
                {"field": f, "path": v.path, "type": v.type, "unit": v.unit}
                | ({"iec_type": v.iec_type} if v.iec_type else {})
                for v, f in zip(variables, self.fields)
            ]
            schema = self._writer.register_schema(
                SAMPLES_SCHEMA, SchemaEncoding.JSONSchema, orjson.dumps(samples_schema(title, variables, self.fields))
            )
            self._samples = self._writer.register_channel(
                SAMPLES_TOPIC,
                MessageEncoding.JSON,
                schema,
                {
                    "indurop.title": title,
                    "indurop.variables": orjson.dumps(described).decode(),
                    "indurop.decimation": str(decimation),
                    "indurop.basic_period_ns": str(basic_period_ns),
                    "indurop.clock_offset_ns": str(self.clock_offset_ns),
                },
            )
            notes = self._writer.register_schema(
                NOTES_SCHEMA, SchemaEncoding.JSONSchema, orjson.dumps(NOTES_JSON_SCHEMA)
            )
            self._notes = self._writer.register_channel(NOTES_TOPIC, MessageEncoding.JSON, notes)
            part = {"title": title, "basic_period_ns": str(basic_period_ns), "decimation": str(decimation)}
            part["clock_offset_ns"] = str(self.clock_offset_ns)
            self._writer.add_metadata("indurop.part", {**part, **(metadata or {})})
            self._writer.flush()
            if self.joints:
                self._open_joint_file(compression, {**part, **(metadata or {})})
        except BaseException:
            self._file.close()
            if self._joint_out is not None:
                self._joint_out.close()
            raise

    def _open_joint_file(self, compression: CompressionType, part: dict[str, str]) -> None:
        self.joint_file = self.path.with_name(self.path.name.removesuffix(".mcap") + JOINT_FILE_SUFFIX)
        self._joint_out = open(self.joint_file, "xb")
        self._joint_writer = Writer(self._joint_out, chunk_size=CHUNK_BYTES, compression=compression)
        self._joint_writer.start(profile="ros2", library=LIBRARY)
        definition = MSGDEFS[JOINT_STATE]
        self._encode_joints = serialize_dynamic(JOINT_STATE, definition)[JOINT_STATE]
        schema = self._joint_writer.register_schema(JOINT_STATE, SchemaEncoding.ROS2, definition.encode())
        self._joint_channel = self._joint_writer.register_channel(
            JOINT_STATES_TOPIC,
            MessageEncoding.CDR,
            schema,
            {"indurop.joints": orjson.dumps([j.__dict__ for j in self.joints]).decode()},
        )
        self._joint_writer.add_metadata("indurop.part", part)
        self._joint_writer.flush()

    # ---- rows -------------------------------------------------------------------------------------
    def add_rows(self, seqs: Sequence[int], t_ns: Sequence[int], columns: Sequence[Sequence[float]]) -> int:
        """Writes rows: seqs[k] and t_ns[k] (the due time, CLOCK_MONOTONIC ns) with columns[c][k],
        the value of variables[c].  Rows must come in increasing seq.  Returns the rows written."""
        n = len(seqs)
        if n == 0:
            return 0
        if len(columns) != len(self.variables) or len(t_ns) != n or any(len(c) != n for c in columns):
            raise ValueError(f"add_rows wants {len(self.variables)} columns of {n} values and {n} times")
        seqs = [int(s) for s in seqs]
        times = [int(t) for t in t_ns]
        if self.last_seq is not None and seqs[0] <= self.last_seq:
            raise ValueError(f"row {seqs[0]} comes after row {self.last_seq}: rows are written in increasing seq")
        block = np.column_stack([np.asarray(c, dtype=np.float64) for c in columns])
        # orjson writes the block as [[v,v,...],[v,...]] (shortest round-trip numbers, null for NaN
        # and infinities); each row's numbers then fill the template of field names.
        text = orjson.dumps(block, option=orjson.OPT_SERIALIZE_NUMPY)
        rows = text[2:-2].split(b"],[")
        template, add, channel, offset = self._template, self._writer.add_message, self._samples, self.clock_offset_ns
        held = self._held
        if held and held[0][0] is None:  # noted before any row: at the first row's time, before it
            first = times[0] + offset
            held[:] = sorted([(first if t is None else t, d) for t, d in held], key=lambda h: h[0])
        for k in range(n):
            log_time = times[k] + offset
            if held and held[0][0] <= log_time:
                self._write_held(log_time)
            data = template % (b"%d" % seqs[k], b"%d" % times[k], *rows[k].split(b","))
            add(channel, log_time, data, log_time, seqs[k] & 0xFFFFFFFF)
        self._last_log_time = times[-1] + offset
        if self._joint_writer is not None:
            self._add_joints(seqs, times, block)
        if self.first_seq is None:
            self.first_seq, self.first_t_ns = seqs[0], times[0]
        self.last_seq, self.last_t_ns = seqs[-1], times[-1]
        self.rows += n
        return n

    def _add_joints(self, seqs: list[int], times: list[int], block: np.ndarray) -> None:
        names = [j.name for j in self.joints]
        scale = np.array([j.scale for j in self.joints])
        offset = np.array([j.offset for j in self.joints])
        positions = block[:, self.joint_columns] * scale + offset
        k0 = (-self._joint_phase) % self.joint_every
        self._joint_phase = (self._joint_phase + len(seqs)) % self.joint_every
        for k in range(k0, len(seqs), self.joint_every):
            log_time = times[k] + self.clock_offset_ns
            message = {
                "header": {
                    "stamp": {"sec": log_time // 1_000_000_000, "nanosec": log_time % 1_000_000_000},
                    "frame_id": "",
                },
                "name": names,
                "position": positions[k].tolist(),
                "velocity": [],
                "effort": [],
            }
            self._joint_writer.add_message(
                self._joint_channel, log_time, self._encode_joints(message), log_time, seqs[k] & 0xFFFFFFFF
            )
            self.joint_messages += 1

    def note(self, kind: str, text: str, *, t_ns: int | None = None, **fields) -> None:
        """A note on /indurop/notes: `kind` one of NOTE_KINDS, `text` in words, and any of seq,
        first_seq, last_seq, count (integers) or other JSON fields.  Its time: the due time t_ns
        given (CLOCK_MONOTONIC), written before the first row due at or after it (held until
        then, or until close); else its place among the rows, the time of the last row written
        (before any row: the first row's).  ValueError for a time before what is written."""
        if kind not in NOTE_KINDS:
            raise ValueError(f"note kind {kind!r} is not one of {', '.join(NOTE_KINDS)}")
        data = orjson.dumps({"kind": kind, "text": text, **fields})
        last = self._last_log_time
        log_time = last if t_ns is None else t_ns + self.clock_offset_ns
        if last is not None and log_time < last:
            raise ValueError(
                f"a {kind} note at log_time {log_time} comes after messages up to {last}: "
                "notes are written in time order"
            )
        if log_time is not None and log_time == last:
            self._writer.add_message(self._notes, log_time, data, log_time, 0)
        else:  # a time still to come, or no row yet
            self._held.append((log_time, data))
            self._held.sort(key=lambda h: -1 if h[0] is None else h[0])  # stable: those without a time first

    def _write_held(self, upto: int | None) -> None:
        """The held notes due at or before `upto` (None: all of them), in time order."""
        while self._held and (upto is None or self._held[0][0] <= upto):
            log_time, data = self._held.pop(0)
            self._writer.add_message(self._notes, log_time, data, log_time, 0)
            self._last_log_time = log_time

    def add_metadata(self, name: str, values: dict[str, str]) -> None:
        """A metadata record (string to string), e.g. a capture's trigger definition."""
        self._writer.add_metadata(name, values)

    # ---- the file -------------------------------------------------------------------------------
    @property
    def size(self) -> int:
        """Bytes on disk of both files (what flush() has written; the open chunk is not counted)."""
        return self._file.tell() + (self._joint_out.tell() if self._joint_out is not None else 0)

    def flush(self, sync: bool = True) -> None:
        """Closes the open chunks, writes them out, and with `sync` fsyncs the files."""
        for writer, f in self._files():
            writer.flush()
            if sync:
                os.fsync(f.fileno())

    def _files(self) -> list:
        files = [(self._writer, self._file)]
        if self._joint_writer is not None:
            files.append((self._joint_writer, self._joint_out))
        return files

    def close(self, summary: dict[str, str] | None = None) -> int:
        """The summary metadata, indexes and footer; returns the file's size."""
        if self.closed:
            return self.size
        if self._held and self._held[0][0] is None:  # notes of a file without a row: at its close
            closing = max([time.time_ns(), *(t for t, _ in self._held if t is not None)])
            self._held = sorted([(closing if t is None else t, d) for t, d in self._held], key=lambda h: h[0])
        self._write_held(None)
        done = {
            "rows": str(self.rows),
            "first_seq": str(self.first_seq or ""),
            "last_seq": str(self.last_seq or ""),
            "joint_states": str(self.joint_messages),
        }
        for writer, f in self._files():
            writer.add_metadata("indurop.summary", {**done, **(summary or {})})
            writer.finish()
            f.flush()
            os.fsync(f.fileno())
        size = self.size
        for _, f in self._files():
            f.close()
        self.closed = True
        return size

    def abandon(self) -> None:
        """Closes the file as it is, without a footer (after a write failed): what was flushed stays
        readable, mcap_read.recover() completes it later."""
        if not self.closed:
            self.closed = True
            for _, f in self._files():
                try:
                    f.close()
                except OSError:
                    pass  # the buffered tail could not be written either: the flushed chunks are what counts

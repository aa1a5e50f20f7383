"""mcap_read.py -- reading the recorder's MCAP files back (exports, resuming, the tests), and
completing a file a crash left without its footer (docs/recorder.md "Crashes").

Every file is read front to back with the mcap library's streaming reader (`StreamReader`), which
needs no summary or footer: so a file still being written, or one whose writer died, reads up to
its last complete record.  Chunks are written whole, so what is kept is every row of every chunk
that reached the disk (the recorder flushes one every second).
"""

from __future__ import annotations

import os
import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import orjson
from mcap.exceptions import McapError
from mcap.records import Attachment, Channel, DataEnd, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from .mcap_out import LIBRARY, NOTES_TOPIC, SAMPLES_TOPIC, Variable

# What a file cut short can raise while being read: a record or chunk cut off, bad magic.
READ_ERRORS = (McapError, EOFError, struct.error, ValueError, OSError, KeyError)


@dataclass
class Rows:
    """Consecutive rows of the samples channel: seq, due time, wall time (log_time), and a column
    per variable."""

    seq: list[int]
    t_ns: list[int]
    unix_ns: list[int]
    columns: list[list[float | None]]


@dataclass
class Scan:
    """What a part holds, read front to back."""

    variables: list[Variable] = field(default_factory=list)
    fields: list[str] = field(default_factory=list)
    rows: int = 0
    first_seq: int | None = None
    last_seq: int | None = None
    first_unix_ns: int | None = None
    last_unix_ns: int | None = None
    notes: list[dict] = field(default_factory=list)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    joint_states: int = 0
    complete: bool = False  # the footer was read
    error: str | None = None  # why reading stopped before the footer


def _records(path: Path, errors: list[str]) -> Iterator:
    """The records of a file in order, stopping quietly (and saying why in `errors`) where it is cut."""
    with open(path, "rb") as f:
        try:
            yield from StreamReader(f, validate_crcs=True).records
        except READ_ERRORS as e:
            errors.append(f"{type(e).__name__}: {e}" if str(e) else type(e).__name__)


def _variables(channel: Channel) -> tuple[list[Variable], list[str]]:
    described = orjson.loads(channel.metadata.get("indurop.variables", "[]"))
    variables = [Variable(d["path"], d["type"], d.get("unit", ""), d.get("iec_type")) for d in described]
    return variables, [d["field"] for d in described]


def scan(path: Path) -> Scan:
    """Counts a part's rows and collects its notes and metadata, without keeping the rows."""
    out, errors, channels = Scan(), [], {}
    for record in _records(path, errors):
        if isinstance(record, Channel):  # in the data section, then again in the summary
            channels[record.id] = record.topic
            if record.topic == SAMPLES_TOPIC and not out.variables:
                out.variables, out.fields = _variables(record)
        elif isinstance(record, Message):
            topic = channels.get(record.channel_id)
            if topic == SAMPLES_TOPIC:
                seq = orjson.loads(record.data)["seq"]
                if out.first_seq is None:
                    out.first_seq, out.first_unix_ns = seq, record.log_time
                out.last_seq, out.last_unix_ns = seq, record.log_time
                out.rows += 1
            elif topic == NOTES_TOPIC:
                out.notes.append(orjson.loads(record.data))
            else:
                out.joint_states += 1
        elif isinstance(record, Metadata):
            out.metadata[record.name] = dict(record.metadata)
        elif isinstance(record, Footer):
            out.complete = True
    out.error = errors[0] if errors else (None if out.complete else "no footer")
    return out


def iter_rows(paths: list[Path], block: int = 4096) -> Iterator[tuple[list[Variable], Rows]]:
    """The rows of the samples channel of each file in turn, in blocks of at most `block` rows, with
    the variables of the file they come from."""
    for path in paths:
        errors: list[str] = []
        samples, variables, fields = None, [], []
        rows = Rows([], [], [], [])
        for record in _records(path, errors):
            if isinstance(record, Channel) and record.topic == SAMPLES_TOPIC and samples is None:
                samples = record.id
                variables, fields = _variables(record)
                rows.columns = [[] for _ in fields]
            elif isinstance(record, Message) and record.channel_id == samples:
                m = orjson.loads(record.data)
                rows.seq.append(m["seq"])
                rows.t_ns.append(m["t_ns"])
                rows.unix_ns.append(record.log_time)
                for column, name in zip(rows.columns, fields):
                    column.append(m.get(name))
                if len(rows.seq) >= block:
                    yield variables, rows
                    rows = Rows([], [], [], [[] for _ in fields])
        if rows.seq:
            yield variables, rows


def recover(path: Path) -> Scan:
    """Rewrites a file without a footer (its writer died) into a complete one holding every record
    that could be read, and replaces it; returns the scan of what it holds.  A file that is complete
    already is left alone.  If the copy cannot be written (no room), the file stays as it is: the
    streaming reader still reads it, and the next start tries again."""
    found = scan(path)
    if found.complete:
        return found
    temporary = path.with_name(path.name + ".recovering")
    errors: list[str] = []
    try:
        with open(temporary, "wb") as f:
            writer = Writer(f, compression=CompressionType.ZSTD)
            writer.start(profile="", library=f"{LIBRARY} (recovered)")
            schemas: dict[int, int] = {}
            channels: dict[int, int] = {}
            for record in _records(path, errors):
                if isinstance(record, Schema) and record.id not in schemas:
                    schemas[record.id] = writer.register_schema(record.name, record.encoding, record.data)
                elif isinstance(record, Channel) and record.id not in channels:
                    channels[record.id] = writer.register_channel(
                        record.topic, record.message_encoding, schemas.get(record.schema_id, 0), dict(record.metadata)
                    )
                elif isinstance(record, Message) and record.channel_id in channels:
                    writer.add_message(
                        channels[record.channel_id], record.log_time, record.data, record.publish_time, record.sequence
                    )
                elif isinstance(record, Metadata):
                    writer.add_metadata(record.name, dict(record.metadata))
                elif isinstance(record, Attachment):
                    writer.add_attachment(
                        record.create_time, record.log_time, record.name, record.media_type, record.data
                    )
                elif isinstance(record, DataEnd):
                    break
            writer.add_metadata(
                "indurop.recovered",
                {"reason": found.error or "", "rows": str(found.rows), "last_seq": str(found.last_seq or "")},
            )
            writer.finish()
            f.flush()
            os.fsync(f.fileno())
        os.replace(temporary, path)
    except OSError:
        temporary.unlink(missing_ok=True)
        return found
    done = scan(path)
    done.error = found.error  # why it had to be recovered
    return done

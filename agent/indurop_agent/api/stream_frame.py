"""stream_frame.py -- the binary frame of WebSocket /api/v1/stream, encoded (the stream route) and
decoded (the Python client), after protocol/stream/frame.json (docs/trace-and-stream.md §4).

The header's format, fields and constants come from stream_frame_spec.py, which is generated from
that spec; the frames of protocol/stream/vectors.json, generated from it too, are decoded and
re-encoded by tests/python/agent/test_stream_frame.py.  The body is the due times (i64), then one
column of f64 per channel: a change of the spec's body stops the import here until this file
follows it.
"""

from __future__ import annotations

import struct
import sys
from array import array
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

from . import stream_frame_spec as spec

HEADER = struct.Struct(spec.HEADER_FORMAT)
HEADER_SIZE = spec.HEADER_SIZE
MAGIC, VERSION = spec.MAGIC, spec.VERSION
KIND_SAMPLES = spec.KINDS["samples"]
_BODY = (("t_ns", "q", "count", None), ("columns", "d", "count", "channels"))
if spec.BODY != _BODY or HEADER.size != HEADER_SIZE:
    raise ImportError(
        f"protocol/stream/frame.json lays the body out as {spec.BODY}; stream_frame.py codes "
        f"{_BODY}: update stream_frame.py (and webui/src/stream/frame.ts) to the spec"
    )
_KIND = struct.Struct("<" + spec.FORMATS["kind"])


class FrameError(ValueError):
    """A frame that is not a sample frame this side reads; the message says what is wrong with it."""


@dataclass
class Frame:
    """One decoded sample frame: sample i has sequence number first_seq + i x decimation."""

    first_seq: int
    t_ns: list[int]
    columns: list[list[float]]  # one list per channel, each len(t_ns) long
    dropped: int  # samples the server lost for this client since the stream began

    def samples(self) -> Iterator[tuple[int, int, list[float]]]:
        for i, t in enumerate(self.t_ns):
            yield self.first_seq + i, t, [column[i] for column in self.columns]


def _little(typecode: str, values) -> bytes:
    """Little-endian bytes of a column: an array of the right type as it is, anything else copied."""
    a = values if isinstance(values, array) and values.typecode == typecode else array(typecode, values)
    if sys.byteorder != "little":
        a = array(typecode, a)
        a.byteswap()
    return a.tobytes()


def size(count: int, channels: int) -> int:
    """Bytes of a sample frame of `count` samples of `channels` channels."""
    return HEADER_SIZE + 8 * count * (1 + channels)


def encode(first_seq: int, t_ns: Sequence[int], columns: Sequence[Sequence[float]], dropped: int = 0) -> bytes:
    """A sample frame; t_ns and each column may be lists or array('q') / array('d') (taken as they are)."""
    values = {
        "magic": MAGIC,
        "version": VERSION,
        "kind": KIND_SAMPLES,
        "first_seq": first_seq,
        "count": len(t_ns),
        "channels": len(columns),
        "dropped": dropped,
    }
    head = HEADER.pack(*(values[name] for name in spec.HEADER_FIELDS))
    return b"".join([head, _little("q", t_ns), *(_little("d", c) for c in columns)])


def kind(data) -> int | None:
    """The kind of a frame (None when it is too short to have one): a client skips kinds it does not know."""
    at = spec.OFFSETS["kind"]
    return _KIND.unpack_from(data, at)[0] if len(data) >= at + _KIND.size else None


def count(frame: bytes) -> int:
    """The number of samples a frame announces (the stream route counts what it sent)."""
    return HEADER.unpack_from(frame)[spec.HEADER_FIELDS.index("count")]


def _column(typecode: str, data: memoryview) -> list:
    values = array(typecode)
    values.frombytes(data)
    if sys.byteorder != "little":
        values.byteswap()
    return values.tolist()


def decode(data) -> Frame:
    """Decodes one sample frame (bytes, bytearray or memoryview); raises FrameError, a ValueError,
    naming what is wrong with it."""
    view = memoryview(data)
    if len(view) < HEADER_SIZE:
        raise FrameError(f"stream frame too short: {len(view)} bytes, the header alone is {HEADER_SIZE}")
    h = dict(zip(spec.HEADER_FIELDS, HEADER.unpack_from(view)))
    if h["magic"] != MAGIC:
        raise FrameError(f"not an indurop stream frame: magic {h['magic']!r}, expected {MAGIC!r}")
    if h["version"] != VERSION:
        raise FrameError(f"stream frame version {h['version']}; this client reads version {VERSION}")
    if h["kind"] != KIND_SAMPLES:
        raise FrameError(f"stream frame kind {h['kind']} is not a sample frame (kind {KIND_SAMPLES})")
    n, channels = h["count"], h["channels"]
    expected = size(n, channels)
    if len(view) != expected:
        raise FrameError(
            f"stream frame of {len(view)} bytes; its header ({n} samples x {channels} channels) announces {expected}"
        )
    at = HEADER_SIZE + 8 * n
    t_ns = _column("q", view[HEADER_SIZE:at])
    columns = [_column("d", view[at + 8 * n * c : at + 8 * n * (c + 1)]) for c in range(channels)]
    return Frame(h["first_seq"], t_ns, columns, h["dropped"])

"""export.py -- a recording's rows as CSV or Parquet, made while they are sent (docs/recorder.md,
"Export"): the parts are read front to back in blocks of rows (mcap_read.iter_rows), each block
turned into text or a Parquet row group and handed on, so that memory stays bounded whatever the
size of the recording.  Both carry the same rows as the MCAP files: seq, t_ns (the due time,
CLOCK_MONOTONIC), unix_ns (the MCAP log time: the due time on the wall clock) and a column per
variable, named by its path.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterator
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from .mcap_out import Variable
from .mcap_read import iter_rows

FORMATS = {"csv": "text/csv", "parquet": "application/vnd.apache.parquet"}
BLOCK_ROWS = 8192  # rows per CSV chunk and per Parquet row group


def csv_chunks(parts: list[Path], variables: list[Variable]) -> Iterator[bytes]:
    """The CSV text in chunks: a header (seq, t_ns, unix_ns, the paths), then a line per row; a
    value that is not finite is an empty cell."""
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(["seq", "t_ns", "unix_ns", *(v.path for v in variables)])
    for _, rows in iter_rows(parts, BLOCK_ROWS):
        cells = [["" if x is None else repr(x) for x in column] for column in rows.columns]
        writer.writerows(zip(rows.seq, rows.t_ns, rows.unix_ns, *cells))
        yield text.getvalue().encode()
        text.seek(0)
        text.truncate()
    yield text.getvalue().encode()


class _Sink:
    """A write-only file for pyarrow that keeps what it is given until taken."""

    def __init__(self):
        self.chunks: list[bytes] = []
        self.position = 0
        self.closed = False

    def write(self, data) -> int:
        data = bytes(data)
        self.chunks.append(data)
        self.position += len(data)
        return len(data)

    def tell(self) -> int:
        return self.position

    def flush(self) -> None:
        pass

    def close(self) -> None:
        self.closed = True

    def take(self) -> bytes:
        data = b"".join(self.chunks)
        self.chunks.clear()
        return data


def parquet_schema(variables: list[Variable], title: str) -> pa.Schema:
    fields = [
        pa.field("seq", pa.uint64(), nullable=False, metadata={"description": "the trace row's sequence number"}),
        pa.field("t_ns", pa.int64(), nullable=False, metadata={"description": "due time, CLOCK_MONOTONIC ns"}),
        pa.field("unix_ns", pa.int64(), nullable=False, metadata={"description": "due time on the wall clock, ns"}),
    ]
    for v in variables:
        fields.append(pa.field(v.path, pa.float64(), metadata={"type": v.type, "unit": v.unit}))
    return pa.schema(fields, metadata={"recording": title})


def parquet_chunks(parts: list[Path], variables: list[Variable], title: str) -> Iterator[bytes]:
    """The Parquet file in chunks: a row group per block of rows (zstd), the footer last."""
    schema = parquet_schema(variables, title)
    sink = _Sink()
    with pq.ParquetWriter(sink, schema, compression="zstd") as writer:
        for _, rows in iter_rows(parts, BLOCK_ROWS):
            arrays = [
                pa.array(rows.seq, pa.uint64()),
                pa.array(rows.t_ns, pa.int64()),
                pa.array(rows.unix_ns, pa.int64()),
                *(pa.array(column, pa.float64()) for column in rows.columns),
            ]
            writer.write_table(pa.Table.from_arrays(arrays, schema=schema))
            yield sink.take()
    yield sink.take()

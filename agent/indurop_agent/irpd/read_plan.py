"""read_plan.py -- many leaves of the shared-variable segment read in one pass (Segment.read_many): the
leaves asked, resolved once per layout, become two precompiled struct formats, one over the data they
lie in and one over the sequences of their variables' locks, so that a read of N values is three
`unpack_from` calls, not N locks checked and N values decoded one by one.

The seqlock rule is libindurop's, for every lock at once: every sequence read even, the values copied,
every sequence read again and equal; else the pass is made again, and after a few passes that met a
writer each lock is read on its own (Segment.values), as before.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

PASSES = 16  # whole passes tried before one lock at a time (a writer met in each)


@dataclass(frozen=True)
class Plan:
    leaves: list[dict]  # the leaves found, in the order asked
    errors: list[dict]  # [{path, message}] of the paths that name no leaf the agent decodes
    data: struct.Struct | None  # every distinct leaf, in offset order; None: one lock at a time
    data_at: int  # where `data` starts in the segment
    pick: tuple[int, ...]  # for each leaf asked, its place in what `data` unpacks
    seqs: struct.Struct | None  # the locks' sequences, in lock order
    seqs_at: int

    def read(self, mm) -> list | None:
        """The leaves' values from one pass in which no lock moved, or None after PASSES passes that
        met a writer."""
        if self.data is None:
            return None
        for _ in range(PASSES):
            before = self.seqs.unpack_from(mm, self.seqs_at)
            if any(map((1).__and__, before)):  # a writer is inside
                continue
            raw = self.data.unpack_from(mm, self.data_at)
            if self.seqs.unpack_from(mm, self.seqs_at) == before:
                return list(map(raw.__getitem__, self.pick))
        return None


def compile_plan(leaves: list[dict], formats: list[str], errors: list[dict], where: dict) -> Plan:
    """The plan of `leaves` (layout entries: offset, size, lock) decoded with `formats` ("<I", ...).
    `where`: the segment's data and locks offsets, lock_size, and the lock's seq field (format,
    offset)."""
    if not leaves:
        return Plan(leaves, errors, None, 0, (), None, 0)
    places = sorted({(leaf["offset"], fmt): leaf["size"] for leaf, fmt in zip(leaves, formats)}.items())
    data_fmt, end, index = ["<"], places[0][0][0], {}
    for (offset, fmt), size in places:
        if offset < end:  # two leaves over the same bytes: not a layout glbc makes; read them apart
            return Plan(leaves, errors, None, 0, (), None, 0)
        data_fmt.append(f"{offset - end}x{fmt[1:]}" if offset > end else fmt[1:])
        index[offset, fmt] = len(index)
        end = offset + size
    seq_fmt, seq_at = where["seq"]
    locks = sorted({leaf["lock"] for leaf in leaves})
    stride, first = where["lock_size"], locks[0]
    lock_fmt = ["<"] + [
        f"{(lock - prev) * stride - struct.calcsize(seq_fmt)}x{seq_fmt[1:]}" if i else seq_fmt[1:]
        for i, (prev, lock) in enumerate(zip([first, *locks], locks))
    ]
    return Plan(
        leaves,
        errors,
        struct.Struct("".join(data_fmt)),
        where["data"] + places[0][0][0],
        tuple(index[leaf["offset"], fmt] for leaf, fmt in zip(leaves, formats)),
        struct.Struct("".join(lock_fmt)),
        where["locks"] + first * stride + seq_at,
    )

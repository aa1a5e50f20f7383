"""memtrace.py -- where the agent's memory goes, for an operator chasing growth (docs/operations.md).

Python's own tracer does the work: start the agent with PYTHONTRACEMALLOC=<frames> (25 is a good
depth) and send it SIGUSR2; each signal writes a snapshot of every live Python allocation to
<data-dir>/memtrace/<pid>-<n>.snap (tracemalloc.Snapshot.dump).  Two snapshots compared
(`python3 -m indurop_agent.system.memtrace OLD NEW`) list the call sites whose memory grew.  Without the
environment variable nothing is installed and SIGUSR2 keeps its default action.

Memory that Python's allocator does not see (numpy buffers allocated by C code, glibc arenas,
thread stacks) is not in a snapshot: compare the snapshots' total with the RSS to tell the two apart.
"""

from __future__ import annotations

import argparse
import gc
import itertools
import os
import signal
import sys
import tracemalloc
from pathlib import Path

SIGNAL = signal.SIGUSR2


def install(data_dir: Path) -> Path | None:
    """Writes a snapshot on each SIGUSR2 when the tracer runs (PYTHONTRACEMALLOC); returns the folder
    the snapshots go to, or None when the tracer is off.  Call from the main thread."""
    if not tracemalloc.is_tracing():
        return None
    folder = data_dir / "memtrace"
    folder.mkdir(mode=0o700, exist_ok=True)
    counter = itertools.count(1)

    def dump(_signum, _frame) -> None:
        path = folder / f"{os.getpid()}-{next(counter)}.snap"
        partial = path.with_suffix(".part")  # a reader never sees half a snapshot
        gc.collect()  # live memory only: cyclic garbage waits for a full collection in a large heap
        tracemalloc.take_snapshot().dump(str(partial))
        partial.rename(path)
        print(
            f"indurop-agent: memory snapshot {path} ({tracemalloc.get_traced_memory()[0] // 1024} KiB traced)",
            flush=True,
        )

    signal.signal(SIGNAL, dump)
    return folder


def growth(old: Path, new: Path, top: int = 15) -> dict:
    """What grew between two snapshots: the traced totals and the `top` call sites by growth, each
    with its size difference, count difference and the innermost frames of its traceback."""
    a, b = tracemalloc.Snapshot.load(str(old)), tracemalloc.Snapshot.load(str(new))
    ignore = [
        tracemalloc.Filter(False, tracemalloc.__file__),
        tracemalloc.Filter(False, "<frozen importlib._bootstrap>"),
    ]
    a, b = a.filter_traces(ignore), b.filter_traces(ignore)
    diffs = b.compare_to(a, "traceback")
    return {
        "traced_kib": {
            "old": sum(s.size for s in a.statistics("filename")) // 1024,
            "new": sum(s.size for s in b.statistics("filename")) // 1024,
        },
        "top": [
            {
                "size_diff_kib": round(d.size_diff / 1024, 1),
                "count_diff": d.count_diff,
                "size_kib": round(d.size / 1024, 1),
                "where": [f"{f.filename}:{f.lineno}" for f in list(d.traceback)[-6:]],
            }
            for d in sorted(diffs, key=lambda d: d.size_diff, reverse=True)[:top]
        ],
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python3 -m indurop_agent.system.memtrace",
        description="What grew between two of the agent's memory snapshots (SIGUSR2).",
    )
    ap.add_argument("old", type=Path)
    ap.add_argument("new", type=Path)
    ap.add_argument("--top", type=int, default=15)
    a = ap.parse_args(argv)
    for p in (a.old, a.new):
        if not p.is_file():
            ap.error(f"{p}: no such snapshot (the agent writes them to <data-dir>/memtrace on SIGUSR2)")
    g = growth(a.old, a.new, a.top)
    print(f"traced by Python: {g['traced_kib']['old']} KiB -> {g['traced_kib']['new']} KiB")
    for d in g["top"]:
        print(f"{d['size_diff_kib']:+10.1f} KiB {d['count_diff']:+8d} blocks  (now {d['size_kib']} KiB)")
        for where in d["where"]:
            print(f"      {where}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

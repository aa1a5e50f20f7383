"""irpd_stats.py -- irpd's histograms: its stats block's layout (from `irpd --print-shm-layout`),
read live from shared memory (ShmObserver), and the histograms of irpd's shape that the benchmark
programs print (common/bench_hist.hpp); summarized as irpd summarizes them, and merged.
"""

from __future__ import annotations

import json
import math
import mmap
import os
import struct
import subprocess
import time
from pathlib import Path

from .common import BenchError

# Layout of the stats segment (docs/shared-memory.md): its offsets come from irpd itself
# (`irpd --print-shm-layout`): see load_stats_layout().
STATS = {}

# irpd's log-linear histogram (rtcore/src/stats/histogram.hpp), read back from its stats block
K_SUB_BITS, K_SUB, K_MAX_EXP = 5, 32, 36
K_BUCKETS = K_SUB + (K_MAX_EXP - K_SUB_BITS + 1) * K_SUB


def load_stats_layout(irpd: Path) -> None:
    """Takes the stats block's offsets and histogram shape from the irpd binary under test."""
    global K_SUB_BITS, K_SUB, K_MAX_EXP, K_BUCKETS
    stats = json.loads(
        subprocess.run([str(irpd), "--print-shm-layout"], check=True, capture_output=True, text=True).stdout
    )["segments"]["stats"]
    structs = stats["structs"]
    STATS.clear()
    STATS.update(
        magic=stats["magic"],
        version=stats["version"],
        record_size=structs["timing_record"]["size"],
        header=structs[stats["header"]]["fields"],
        record=structs["timing_record"]["fields"],
        histogram=structs["histogram"]["fields"],
    )
    constants = {k: c["value"] for k, c in stats["constants"].items()}
    K_SUB_BITS, K_MAX_EXP, K_BUCKETS = (
        constants["sub_bucket_bits"],
        constants["max_exponent"],
        constants["bucket_count"],
    )
    K_SUB = 1 << K_SUB_BITS


def header_offset(name: str) -> int:
    return STATS["header"][name]["offset"]


def bucket_low(i: int) -> int:
    if i < K_SUB:
        return i
    k, sub = divmod(i - K_SUB, K_SUB)
    e = k + K_SUB_BITS
    return (1 << e) | (sub << (e - K_SUB_BITS))


def bucket_width(i: int) -> int:
    return 1 if i < K_SUB else 1 << ((i - K_SUB) // K_SUB)


def summarize_irpd_hist(h: dict) -> dict:
    """irpd's own figures (stats/summary.cpp): nearest rank, the middle of the bucket, clamped."""
    total = sum(h["buckets"])
    out = {"count": total}
    if not total:
        return out
    out.update(min=h["min"], max=h["max"], mean=h["sum"] / total)
    for name, q in (("p50", 0.50), ("p99", 0.99), ("p999", 0.999)):
        rank = min(max(math.ceil(q * total), 1), total)
        seen = 0
        for i, c in enumerate(h["buckets"]):
            seen += c
            if seen >= rank:
                mid = bucket_low(i) + (bucket_width(i) - 1) / 2
                out[name] = min(max(mid, min(h["min"], h["max"])), h["max"])
                break
    return out


def merge_irpd_hists(hs: list[dict]) -> dict:
    return {
        "buckets": [sum(col) for col in zip(*(h["buckets"] for h in hs))],
        "sum": sum(h["sum"] for h in hs),
        "min": min(h["min"] for h in hs),
        "max": max(h["max"] for h in hs),
    }


class ShmObserver:
    """Reads irpd's cycle counter from its stats segment while it runs (from another CPU)."""

    def __init__(self, instance: str):
        self.path = Path("/dev/shm") / f"indurop.{instance}.stats"
        self.mm = None

    def attach(self, proc: subprocess.Popen, timeout_s: float = 30) -> bool:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline and proc.poll() is None:
            try:
                with open(self.path, "rb") as f:
                    if os.fstat(f.fileno()).st_size >= 128:
                        self.mm = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
                        if (
                            struct.unpack_from("<Q", self.mm, 0)[0] == STATS["magic"]
                            and struct.unpack_from("<I", self.mm, header_offset("version"))[0] == STATS["version"]
                        ):
                            return True
                        self.mm.close()
                        self.mm = None
            except OSError:
                pass
            time.sleep(0.002)
        return False

    def started(self) -> tuple[int, int]:
        return (
            struct.unpack_from("<q", self.mm, header_offset("started_ns"))[0],
            struct.unpack_from("<I", self.mm, header_offset("running"))[0],
        )

    def basic(self) -> int:
        return struct.unpack_from("<q", self.mm, header_offset("basic_ns"))[0]

    def cycles(self) -> int:
        return struct.unpack_from("<Q", self.mm, header_offset("cycles"))[0]

    def latency_hist(self, record: int = 0) -> dict:
        """The latency histogram of a record (0 = the main dispatcher).  The mapping outlives irpd's
        unlinking of the segment, so this reads the final figures after irpd has exited."""
        return self.record_hist(record, "latency")

    def record_hist(self, record: int, field: str) -> dict:
        """One histogram ("latency" or "exec") of a record: dispatchers first, then the modules."""
        header_size = struct.unpack_from("<I", self.mm, header_offset("header_size"))[0]
        record_size = struct.unpack_from("<I", self.mm, header_offset("record_size"))[0]
        if record_size != STATS["record_size"]:
            raise BenchError(f"irpd's stats records are {record_size} bytes, its layout says {STATS['record_size']}")
        base = header_size + record * record_size + STATS["record"][field]["offset"]
        h = STATS["histogram"]
        count, total, lo, hi = (
            struct.unpack_from("<Q", self.mm, base + h[f]["offset"])[0] for f in ("count", "sum", "min", "max")
        )
        buckets = list(struct.unpack_from(f"<{K_BUCKETS}Q", self.mm, base + h["buckets"]["offset"]))
        return {"count": count, "sum": total, "min": lo, "max": hi, "buckets": buckets}


def parse_bench_output(text: str, what: str) -> tuple[dict, dict]:
    """The histograms and counters a benchmark program printed (tests/bench/common/bench_hist.hpp):
    '@hist', '@buckets', '@info', '@end' lines, anywhere in a line (irpd prefixes "[name] ")."""
    hists: dict[str, dict] = {}
    info: dict[str, dict] = {}
    ended: set[str] = set()
    for line in text.splitlines():
        at = line.find("@")
        if at < 0:
            continue
        words = line[at:].split()
        if len(words) < 2 or words[0] not in ("@hist", "@buckets", "@info", "@end"):
            continue
        kind, label, rest = words[0], words[1], words[2:]
        if kind == "@hist":
            f = dict(w.split("=", 1) for w in rest)
            shape = (int(f["sub_bucket_bits"]), int(f["max_exponent"]), int(f["bucket_count"]))
            if shape != (K_SUB_BITS, K_MAX_EXP, K_BUCKETS):
                raise BenchError(
                    f"{what}: histogram '{label}' has shape {shape}, irpd's is "
                    f"{(K_SUB_BITS, K_MAX_EXP, K_BUCKETS)}: update tests/bench/common/bench_hist.hpp"
                )
            hists[label] = {
                "buckets": [0] * K_BUCKETS,
                "sum": int(f["sum"]),
                "min": int(f["min"]),
                "max": int(f["max"]),
                "count": int(f["count"]),
            }
        elif kind == "@buckets":
            for w in rest:
                i, c = w.split(":")
                hists[label]["buckets"][int(i)] += int(c)
        elif kind == "@info":
            info[label] = {
                k: (int(v) if v.lstrip("-").isdigit() else v) for k, v in (w.split("=", 1) for w in rest if "=" in w)
            }
        else:
            ended.add(label)
    for label, h in hists.items():
        if label not in ended or sum(h["buckets"]) != h["count"]:
            raise BenchError(
                f"{what}: histogram '{label}' arrived incomplete ({sum(h['buckets'])} of {h['count']} "
                "samples; was its output cut or rate-limited?)"
            )
    return hists, info


def bench_hist(hists: dict, label: str, what: str) -> dict:
    if label not in hists:
        raise BenchError(f"{what} printed no histogram '{label}'")
    return hists[label]

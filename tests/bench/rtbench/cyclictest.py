"""cyclictest.py -- the reference: cyclictest (Debian rt-tests) run on the benchmark's CPU with an
exact nanosecond histogram, its histogram file parsed, rounds merged, percentiles taken.
"""

from __future__ import annotations

import math
from pathlib import Path

from .common import BenchError, quote, run_checked

CT_HIST_NS = 1_000_000  # cyclictest caps its histogram at 1,000,000 entries: 1 ms in ns mode


def summary_from_counts(counts: dict[int, int], overflow: int, limit: int) -> dict:
    """Nearest-rank percentiles (rank = ceil(q * n), as irpd's summary) of an exact histogram.
    A percentile whose rank lies among the overflows is the limit, marked as a lower bound."""
    n = sum(counts.values()) + overflow
    out = {"count": n, "overflows": overflow, "lower_bound": []}
    if n == 0:
        return out
    keys = sorted(counts)
    out["min"] = keys[0] if keys else limit
    out["mean_in_range"] = sum(k * c for k, c in counts.items()) / max(1, n - overflow)
    for name, q in (("p50", 0.50), ("p99", 0.99), ("p999", 0.999)):
        rank = min(max(math.ceil(q * n), 1), n)
        seen, value = 0, None
        for k in keys:
            seen += counts[k]
            if seen >= rank:
                value = k
                break
        if value is None:
            value = limit
            out["lower_bound"].append(name)
        out[name] = value
    return out


def parse_cyclictest_hist(text: str) -> dict:
    """The raw figures of one cyclictest run: exact counts per ns, overflows, min, max, mean."""
    counts: dict[int, int] = {}
    meta: dict[str, str] = {}
    for line in text.splitlines():
        if line.startswith("#"):
            if ":" in line:
                key, _, value = line[1:].partition(":")
                meta[key.strip()] = value.strip()
            continue
        parts = line.split()
        if len(parts) >= 2 and parts[0].isdigit():
            c = int(parts[1])
            if c:
                counts[int(parts[0])] = c
    if "Max Latencies" not in meta:
        raise BenchError("cyclictest's histogram has no '# Max Latencies' line")
    overflows = int(meta.get("Histogram Overflows", "0").split()[0] or 0)
    n = sum(counts.values()) + overflows
    return {
        "counts": counts,
        "overflows": overflows,
        "count": n,
        "min": int(meta["Min Latencies"].split()[0]),
        "max": int(meta["Max Latencies"].split()[0]),
        "sum": int(meta["Avg Latencies"].split()[0]) * n,
    }  # cyclictest's own average (all samples)


def merge_cyclictest(raws: list[dict]) -> dict:
    counts: dict[int, int] = {}
    for r in raws:
        for v, c in r["counts"].items():
            counts[v] = counts.get(v, 0) + c
    return {
        "counts": counts,
        "overflows": sum(r["overflows"] for r in raws),
        "count": sum(r["count"] for r in raws),
        "min": min(r["min"] for r in raws),
        "max": max(r["max"] for r in raws),
        "sum": sum(r["sum"] for r in raws),
    }


def summarize_cyclictest(raw: dict, period_ns: int) -> dict:
    counts = raw["counts"]
    s = summary_from_counts(counts, raw["overflows"], CT_HIST_NS)
    s.update(min=raw["min"], max=raw["max"], mean=raw["sum"] / raw["count"] if raw["count"] else 0)
    # wake-ups a whole period or more late (the stalls): exact below 1 ms, plus every overflow
    s["late_ge_period"] = raw["overflows"] + sum(c for v, c in counts.items() if v >= period_ns)
    return s


def run_cyclictest(a, seconds: int, tag: str, work: Path, commands: list[str]) -> dict:
    hist = work / f"cyclictest-{tag}-hist.txt"
    cmd = [
        "cyclictest",
        "-m",
        "-p",
        str(a.rt_priority),
        "-i",
        str(a.period_ns // 1000),
        "-a",
        str(a.cpu),
        "-t",
        "1",
        "-D",
        str(seconds),
        "-q",
        "-N",
        "-h",
        str(CT_HIST_NS),
        f"--histfile={hist}",
    ]
    if not a.pm_qos:
        cmd.append("--default-system")
    commands.append(quote(cmd))
    run_checked(cmd, f"cyclictest ({tag}, {seconds} s)", seconds + 60)
    raw = parse_cyclictest_hist(hist.read_text())
    hist.unlink()  # 14 MB of mostly zeros; the parsed counts are kept
    return raw

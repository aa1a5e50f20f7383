"""shared_vars.py -- shared-variable access costs against plain memory (tests/bench/shared_vars.cpp):
the run and its section of the report.
"""

from __future__ import annotations

import json
from pathlib import Path

from .common import BenchError, log, quote, run_checked, verdict


def run_shared_vars(a, bench: Path, commands: list[str]) -> dict:
    """Shared-variable access costs, uncontended, pinned to the benchmark CPU (tests/bench/shared_vars.cpp)."""
    cmd = ["taskset", "-c", str(a.cpu), str(bench / "shared_vars"), str(bench / "shared" / "layout.json")]
    commands.append(quote(cmd))
    log(f"shared variables: {quote(cmd)}")
    p = run_checked(cmd, "shared_vars", 120)
    try:
        return json.loads(p.stdout)
    except json.JSONDecodeError as e:
        raise BenchError(f"shared_vars printed no JSON: {p.stdout[:500]}") from e


def render_shared(r: dict) -> str:
    target = r["scalar_read_ns"] <= 20 and r["scalar_write_ns"] <= 20
    rows = [
        ("scalar (uint64_t) read", "plain_scalar_read_ns", "scalar_read_ns"),
        ("scalar write", "plain_scalar_write_ns", "scalar_write_ns"),
        ("48-byte struct read (whole, consistent)", "plain_struct48_read_ns", "struct48_read_ns"),
        ("48-byte struct write (whole, locked)", "plain_struct48_write_ns", "struct48_write_ns"),
    ]
    out = [
        "## Shared variables: access cost, uncontended",
        "",
        "ns per access, best of 7 rounds of 2 000 000 (`tests/bench/shared_vars.cpp`, variables of "
        "`tests/bench/shared/bench.glb`, pinned to the benchmark CPU). Target: a scalar ≤ 20 ns: "
        f"{verdict(target)} ({r['scalar_read_ns']:.2f} ns read, {r['scalar_write_ns']:.2f} ns write).",
        "",
        "| access | plain memory | shared variable |",
        "| --- | ---: | ---: |",
    ]
    out += [f"| {name} | {r[p]:.2f} | {r[v]:.2f} |" for name, p, v in rows]
    out += [
        f"| one member of the struct, written (locked, keeps whole-struct readers consistent) | — | "
        f"{r['member_write_ns']:.2f} |",
        f"| `scalar += 1` (atomic read-modify-write, locked) | — | {r['scalar_add_ns']:.2f} |",
        "",
        "A scalar is one atomic load or store; a struct read is a seqlock copy (no lock); every locked "
        "write is a priority-inheritance mutex taken and released without a syscall when uncontended "
        "(docs/shared-variables.md).",
        "",
    ]
    return "\n".join(out)

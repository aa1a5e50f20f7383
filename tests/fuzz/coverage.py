#!/usr/bin/env python3
# coverage.py TARGET DIR... -- the edge coverage of one fuzz target over corpus folders, per source
# file of ours: runs build-fuzz/fuzz/TARGET once over every input (-runs=0 -print_coverage=1) and
# sums libFuzzer's "COVERED_FUNC: ... edges: covered/total" lines by file (functions never reached
# count as 0/their edges).  Files outside rtcore/ (libraries, the target itself) are left out.
# Usage: python3 tests/fuzz/coverage.py fuzz_control build-fuzz/corpus/fuzz_control tests/fuzz/corpus/fuzz_control
import collections
import os
import re
import subprocess
import sys

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
LINE = re.compile(r"^(COVERED|UNCOVERED)_FUNC: hits: (\d+) edges: (\d+)/(\d+) (.*) (\S+):\d+$")


def main() -> int:
    target, dirs = sys.argv[1], sys.argv[2:]
    exe = os.path.join(ROOT, "build-fuzz", "fuzz", target)
    run = subprocess.run([exe, "-runs=0", "-print_coverage=1", *dirs], capture_output=True, text=True, errors="replace")
    edges = collections.defaultdict(lambda: [0, 0])
    funcs = collections.defaultdict(lambda: [0, 0])
    for line in (run.stdout + run.stderr).splitlines():
        m = LINE.match(line)
        if not m:
            continue
        kind, _, covered, total, _, path = m.groups()
        path = os.path.relpath(os.path.normpath(path), ROOT)
        if not path.startswith("rtcore/"):
            continue
        edges[path][0] += int(covered) if kind == "COVERED" else 0
        edges[path][1] += int(total)
        funcs[path][0] += kind == "COVERED"
        funcs[path][1] += 1
    if not edges:
        print(run.stderr[-2000:], file=sys.stderr)
        return 1
    print(f"{'file':60} {'edges':>13} {'functions':>11}")
    for path in sorted(edges):
        c, t = edges[path]
        fc, ft = funcs[path]
        print(f"{path:60} {c:6}/{t:<6} {fc:5}/{ft:<5} {100 * c / t if t else 0:5.1f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""st_check_bench.py -- the Programs page's check latency (issue 30, item 7): a generated program of
about 1,000 lines (st_bench.generated) checked as the agent checks an edited file
(agent/indurop_agent/sets/st_check.py, in process, the standard library parsed once), each round a
changed text as typing gives; prints p50 and p99 in ms (target p99 <= 500 ms).  Nothing is asserted.

    .venv/bin/python tests/bench/st_check_bench.py [--lines 1000] [--rounds 100] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from indurop_agent.sets import st_check  # noqa: E402
from st_bench import STC, generated  # noqa: E402


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--lines", type=int, default=1000)
    p.add_argument("--rounds", type=int, default=100)
    p.add_argument("--json", help="also write the figures to this file")
    a = p.parse_args()
    stc = STC
    text = generated(a.lines)
    sources = st_check.SetSources({}, None)
    st_check.check(stc, sources, "big.st", text)  # the grammar and the library loaded once, as in the agent
    times = []
    for i in range(a.rounds):
        edited = text.replace("END_PROGRAM", f"a0 := a0 + {i};\nEND_PROGRAM", 1)  # a new text each time
        start = time.perf_counter()
        result = st_check.check(stc, sources, "big.st", edited)
        times.append((time.perf_counter() - start) * 1000)
        assert not result["errors"], result["errors"][:3]
    times.sort()
    out = {
        "lines": text.count("\n"),
        "rounds": a.rounds,
        "p50_ms": round(statistics.median(times), 1),
        "p99_ms": round(times[min(len(times) - 1, int(len(times) * 0.99))], 1),
        "max_ms": round(times[-1], 1),
        "load_avg": os.getloadavg(),
    }
    print(json.dumps(out))
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

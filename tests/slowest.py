"""slowest.py -- the N slowest tests of a run across suites, read from the JUnit XML files tests/run.sh
has each runner write (pytest --junitxml, ctest --output-junit, Vitest's and Playwright's junit
reporters):  python3 tests/slowest.py [-n 20] build/test-results/*.xml"""

from __future__ import annotations

import argparse
import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path


def cases(path: Path):
    """(seconds, suite file's stem, test name) of every <testcase> in one JUnit file."""
    for case in ET.parse(path).iter("testcase"):
        name = re.sub(r"@[^@\]]*$", "", case.get("name", "?"))  # pytest-xdist's "@<group>"
        where = case.get("classname") or case.get("file") or ""
        yield float(case.get("time") or 0), path.stem, f"{where}::{name}" if where else name


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-n", type=int, default=20, help="how many (default 20)")
    ap.add_argument("files", nargs="+", type=Path)
    a = ap.parse_args()
    found = []
    for f in a.files:
        try:
            found += cases(f)
        except (OSError, ET.ParseError) as e:
            print(f"slowest: {f}: not read ({e})", file=sys.stderr)
    print(f"the {a.n} slowest tests (of {len(found)}):")
    for seconds, suite, name in sorted(found, reverse=True)[: a.n]:
        print(f"{seconds:8.1f} s  {suite:10}  {name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

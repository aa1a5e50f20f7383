#!/usr/bin/env python3
# regenerate_golden.py -- rewrites tests/python/glb/golden/<case>/{generated.h,layout.json} from
# the fixtures with the current glbc.  Run it after a deliberate change of glbc's output, and
# read the diff before committing it:  python3 tests/python/glb/regenerate_golden.py
import shutil
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from glb_helpers import GOLDEN, GOLDEN_CASES, compile_case  # noqa: E402


def main() -> int:
    for case in GOLDEN_CASES:
        with tempfile.TemporaryDirectory(prefix="glbc-golden-") as tmp:
            out = compile_case(case, Path(tmp))
            target = GOLDEN / case
            target.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(out / "indurop" / "generated.h", target / "generated.h")
            shutil.copyfile(out / "layout.json", target / "layout.json")
            print(f"wrote {target.relative_to(GOLDEN.parents[3])}/{{generated.h,layout.json}}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

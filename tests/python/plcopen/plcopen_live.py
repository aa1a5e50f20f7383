# plcopen_live.py -- helpers for the PLCopen XML importer's tests: the shared real projects
# (../shared/plcopen, read in place, never copied into the project), a project derived from one at
# test time (a POU made a function block so that an ST harness can call it and count cycles), and
# st_live's Running (stc build + a real irpd) reused for both.

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from live_processes import ROOT, wait_until

sys.path.insert(0, str(ROOT / "tests" / "python" / "st"))
sys.path.insert(0, str(ROOT / "plcopen"))
sys.path.insert(0, str(ROOT / "st"))

from st_helpers import run_stc  # noqa: E402
from st_live import Running, build_errors, stc_build  # noqa: E402


def _git(*args: str) -> str:
    return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True).stdout.strip()


def _shared_folder() -> Path:
    """The shared PLCopen projects, read in place: $INDUROP_SHARED_PLCOPEN, else ../shared/plcopen beside
    the repository, beside its main checkout (a git worktree), or beside the checkout it was cloned
    from (a fresh clone of a local checkout, as the CI's)."""
    named = os.environ.get("INDUROP_SHARED_PLCOPEN")
    if named:
        return Path(named)
    here = ROOT.parent / "shared" / "plcopen"
    candidates = [here]
    common = _git("rev-parse", "--path-format=absolute", "--git-common-dir")
    if common:
        candidates.append(Path(common).parent.parent / "shared" / "plcopen")
    origin = _git("remote", "get-url", "origin")
    if origin.startswith("/") or origin.startswith("file://"):
        candidates.append(Path(origin.removeprefix("file://")).resolve().parent / "shared" / "plcopen")
    return next((c for c in candidates if c.is_dir()), here)


WHERE = "$INDUROP_SHARED_PLCOPEN, or ../shared/plcopen beside the repository or the checkout it was cloned from"


SHARED = _shared_folder()
NS = "http://www.plcopen.org/xml/tc6_0201"


def shared(name: str) -> Path:
    """The plc.xml of a shared project, in place; the test is skipped (saying why) if it is absent."""
    path = SHARED / name / "plc.xml"
    if not path.is_file():
        pytest.skip(f"the shared PLCopen projects are not at {SHARED} ({WHERE})")
    return path


def derived(
    name: str,
    out: Path,
    *,
    drop: tuple[str, ...] = (),
    as_fb: dict[str, tuple[str, ...]] | None = None,
    instance_type: str = "Harness",
) -> Path:
    """A copy of a shared project written to `out` (a test's tmp folder) with POUs `drop` removed, each
    POU of `as_fb` made a function block whose named variables are outputs (an ST harness reads them),
    and every pouInstance made an instance of `instance_type` (the harness, an ST program)."""
    from lxml import etree

    def q(tag: str) -> str:
        return f"{{{NS}}}{tag}"

    root = etree.parse(str(shared(name))).getroot()
    for pou in list(root.iter(q("pou"))):
        pou_name = pou.get("name")
        if pou_name in drop:
            pou.getparent().remove(pou)
            continue
        outputs = (as_fb or {}).get(pou_name)
        if outputs is None:
            continue
        pou.set("pouType", "functionBlock")
        iface = pou.find(q("interface"))
        section = etree.SubElement(iface, q("outputVars"))
        for var in list(iface.iter(q("variable"))):
            if var.get("name") in outputs:
                var.getparent().remove(var)
                var.attrib.pop("address", None)
                section.append(var)
    for inst in root.iter(q("pouInstance")):
        inst.set("typeName", instance_type)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_bytes(etree.tostring(root, xml_declaration=True, encoding="utf-8"))
    return out


def recorded(folder: Path, files: dict, counter: str, cycles: int, array: str) -> list:
    """Runs a drawn project with an ST harness that counts its cycles in `counter` (a path) and records
    into `array`; the array's values, in order, once the harness has run more than `cycles` cycles."""
    run = Running(folder, files)
    try:
        wait_until(lambda: run.value(counter) > cycles, 30)
        return list(run.values(array).values())
    finally:
        run.close()


__all__ = ["SHARED", "WHERE", "Running", "build_errors", "derived", "recorded", "run_stc", "shared", "stc_build"]

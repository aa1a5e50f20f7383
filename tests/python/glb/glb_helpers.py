# glb_helpers.py -- shared by glbc's tests and regenerate_golden.py: where things are, how to
# run glbc, the golden cases, and g++ helpers for the compile tests.

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]  # tests/python/glb -> the repository
GLBC = ROOT / "glb" / "glbc"
FIXTURES = HERE / "fixtures"
# The paper's figures that an example set ships are kept once, in that set; the tests use them
# under the paper's names (the golden outputs name their sources).
PAPER_FIGURES = ROOT / "config" / "sets" / "paper-figures"
IN_THE_SETS = {
    "fig3-knuRobot.glb": PAPER_FIGURES / "knuRobot.glb",
    "fig4-output.cpp": PAPER_FIGURES / "fig4_output.cpp",
    "fig5-modify.cpp": PAPER_FIGURES / "fig5_modify.cpp",
}
GOLDEN = HERE / "golden"
RTCORE_INCLUDE = ROOT / "rtcore" / "include"
REGENERATE = "python3 tests/python/glb/regenerate_golden.py"

# Golden cases: name -> fixture files, compiled as `glbc FILES -o out` inside a folder holding them.
GOLDEN_CASES: dict[str, list[str]] = {
    "fig3": ["fig3-knuRobot.glb"],
    "fig11": ["fig11-plcRobot.glb"],
    "fig3_fig11": ["fig3-knuRobot.glb", "fig11-plcRobot.glb"],
    "stress": ["stress.glb"],
}


def fixture(name: str) -> Path:
    """Where the fixture file `name` is: in an example set for the figures it ships, else here."""
    return IN_THE_SETS.get(name, FIXTURES / name)


def run_glbc(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(GLBC), *args], cwd=cwd, capture_output=True, text=True, timeout=120)


def compile_case(case: str, workdir: Path) -> Path:
    """Copies the case's fixtures into workdir, runs glbc there and returns the output folder."""
    files = GOLDEN_CASES[case]
    for name in files:
        shutil.copyfile(fixture(name), workdir / name)
    result = run_glbc([*files, "-o", "out"], workdir)
    if result.returncode != 0:
        raise AssertionError(f"glbc failed on {files}:\n{result.stderr}")
    return workdir / "out"


def load_layout(out: Path) -> dict:
    return json.loads((out / "layout.json").read_text(encoding="utf-8"))


def gxx() -> str | None:
    return shutil.which("g++")


# Does shared.h's ArrayRef size the element of a nested ArrayRef as a whole row?  (conftest.py)
_PROBE = """
#include <indurop/shared.h>
using Inner = irp::shared::ArrayRef<irp::shared::ScalarRef<unsigned char>, 5>;
static_assert(sizeof(irp::shared::ArrayRef<Inner, 2>::value_type) == 5, "nested ArrayRef element");
"""


def arrayref_nesting_works(compiler: str, include: Path, folder: Path) -> bool:
    probe = folder / "probe.cpp"
    probe.write_text(_PROBE)
    return (
        subprocess.run(
            [compiler, "-std=c++20", "-fsyntax-only", "-I", str(include), str(probe)], capture_output=True
        ).returncode
        == 0
    )

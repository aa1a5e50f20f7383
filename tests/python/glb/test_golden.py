# test_golden.py -- glbc's outputs for the paper's Figures 3 and 11 (alone and together) and the
# stress file, compared with the checked-in golden files.  A difference fails and names the
# command that regenerates them; read the diff before committing a regeneration.

from __future__ import annotations

import difflib

import pytest
from glb_helpers import FIXTURES, GOLDEN, GOLDEN_CASES, REGENERATE, compile_case, fixture

FIGURES = FIXTURES.parents[4] / "shared" / "reference" / "figures"


@pytest.mark.parametrize("case", list(GOLDEN_CASES))
@pytest.mark.parametrize("output", ["indurop/generated.h", "layout.json"])
def test_output_matches_golden(case, output, tmp_path):
    out = compile_case(case, tmp_path)
    got = (out / output).read_text(encoding="utf-8")
    golden = GOLDEN / case / output.split("/")[-1]
    want = golden.read_text(encoding="utf-8") if golden.exists() else ""
    if got != want:
        diff = "".join(
            difflib.unified_diff(want.splitlines(True), got.splitlines(True), str(golden), "glbc output", n=2)
        )
        pytest.fail(
            f"{golden} is stale; if glbc's new output is intended, run `{REGENERATE}` "
            f"and review the diff:\n{diff[:6000]}"
        )


@pytest.mark.parametrize("name", ["fig3-knuRobot.glb", "fig11-plcRobot.glb", "fig4-output.cpp", "fig5-modify.cpp"])
def test_fixtures_are_the_figures_as_printed(name):
    original = FIGURES / name
    if not original.exists():
        pytest.skip(f"{original} is not on this machine")
    assert fixture(name).read_bytes() == original.read_bytes()

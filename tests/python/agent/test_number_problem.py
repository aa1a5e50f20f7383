"""test_number_problem.py -- variables.number_problem, the one check of "a number of the running
layout" behind the robot view's joint map, the recorder and the captures: what it says for each way
a path can fail, and the trace rings' narrower kinds."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "agent"))
from indurop_agent.irpd.variables import number_problem  # noqa: E402

LEAVES = {
    p: {"path": p, "type": t, "size": n}
    for p, t, n in [
        ("C.s.x", "double", 8),
        ("C.a[0]", "short", 2),
        ("C.a[1]", "short", 2),
        ("C.a[2]", "short", 2),
        ("C.a[3]", "short", 2),
        ("C.name", "string", 16),
        ("C.letter", "char", 1),
        ("C.on", "bool", 1),
    ]
}
SCALARS = {
    "double": {"kind": "float"},
    "short": {"kind": "signed"},
    "string": {"kind": "char"},
    "char": {"kind": "char"},
    "bool": {"kind": "bool"},
}


@pytest.mark.parametrize("path", ["C.s.x", "C.a[0]", "C.on", "C.letter"])
def test_numbers_the_agent_reads_pass(path):
    assert number_problem(path, LEAVES, SCALARS) is None


@pytest.mark.parametrize(
    "path, words",
    [
        ("C.nope", ["no variable 'C.nope'", "GET /api/v1/variables"]),
        ("", ["no variable ''"]),
        ("C.s", ["'C.s' is a struct or an array, not a scalar", "1 members ('C.s.x')"]),
        ("C.a", ["'C.a' is a struct or an array", "4 members ('C.a[0]', 'C.a[1]', 'C.a[2]', ...)"]),
        ("C", ["'C' is a struct or an array", "8 members"]),
        ("C.name", ["'C.name' is a string, not a number the agent can read"]),
    ],
)
def test_what_is_not_a_number_is_said(path, words):
    problem = number_problem(path, LEAVES, SCALARS)
    assert problem is not None and all(w in problem for w in words), problem


def test_the_trace_rings_take_no_char_and_an_unknown_path_is_said_by_the_caller():
    assert (
        number_problem("C.letter", LEAVES, SCALARS, traced=True) == "'C.letter' is a char, not a number irpd can trace"
    )
    assert number_problem("C.on", LEAVES, SCALARS, traced=True) is None
    said = number_problem("C.sx", LEAVES, SCALARS, unknown=lambda p: f"no {p}; did you mean 'C.s.x'?")
    assert said == "no C.sx; did you mean 'C.s.x'?"

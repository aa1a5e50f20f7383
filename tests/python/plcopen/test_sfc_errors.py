# test_sfc_errors.py -- what `stc check` says about a bad SFC chart in a PLCopen XML file, as a user
# runs it: each error names the POU, SFC, the step or transition and its localId.  An unreachable step
# (item 6), a chart without an initial step, a jump to a step that does not exist, a transition below
# no step, a timed qualifier without a duration or with two, an undeclared name in a condition or a
# named action, an SFC as the body of an action.

from __future__ import annotations

import plcopen_xml as x
import sfc_xml as s
from test_plcopen_errors import check, one


def chart(*elements: str, acts: dict | None = None) -> bytes:
    iface = x.section("inputVars", x.var("go", "BOOL")) + x.section("localVars", x.var("lamp", "BOOL"))
    return x.project(s.pou("Chart", "functionBlock", iface, "".join(elements), acts))


LOOP = s.two_steps("Init", "A", {"st": "go"}, {"st": "NOT go"})


def test_an_unreachable_step_is_named(tmp_path):
    orphan = [s.step(6, "Orphan", None, 200, 100), s.transition(7, 6, 200, 150, st="go"), s.jump(8, "A", 7, 200, 200)]
    e = one(tmp_path, chart(*LOOP, *orphan))
    assert e["origin"] == "Chart (SFC) step 'Orphan', step localId 6"
    assert e["message"] == "step 'Orphan' is unreachable: no transition leads to it from 'Init'"


def test_a_step_behind_a_convergence_with_an_unreachable_branch(tmp_path):
    # Later needs A and Orphan active together; Orphan never is, so neither is Later
    more = [
        s.step(6, "Orphan", None, 200, 100),
        s.convergence("simultaneous", 7, [3, 6], 100, 300),
        s.transition(8, 7, 100, 350, st="go"),
        s.step(9, "Later", 8, 100, 400),
    ]
    errors = check(tmp_path, chart(*LOOP, *more))
    assert sorted(e["origin"] for e in errors) == [
        "Chart (SFC) step 'Later', step localId 9",
        "Chart (SFC) step 'Orphan', step localId 6",
    ]
    assert all("is unreachable" in e["message"] for e in errors)


def test_a_chart_without_an_initial_step(tmp_path):
    e = one(tmp_path, chart(s.step(1, "A"), s.transition(2, 1, 0, 50, st="go"), s.jump(3, "A", 2, 0, 100)))
    assert e["origin"] == "Chart (SFC)"
    assert "no initial step" in e["message"]


def test_a_jump_to_a_missing_step(tmp_path):
    e = one(tmp_path, chart(*LOOP[:4], s.jump(5, "Nowhere", 4, 0, 200)))
    assert e["origin"] == "Chart (SFC) jumpStep localId 5"
    assert e["message"] == "the jump to 'Nowhere': no step has that name"


def test_a_timed_qualifier_needs_one_duration(tmp_path):
    e = one(tmp_path, chart(*LOOP, s.actions(9, 3, 200, 100, ("D", "lamp"))))
    assert e["origin"] == "Chart (SFC) step 'A', action 1, actionBlock localId 9"
    assert e["message"] == "the qualifier D needs a duration, e.g. T#2s"
    two = [s.actions(9, 3, 200, 100, ("D", "lamp", "T#1s")), s.actions(10, 1, 200, 0, ("L", "lamp", "T#2s"))]
    e = one(tmp_path, chart(*LOOP, *two))
    assert "two durations (T#1s in step 'A', T#2s here)" in e["message"]


def test_an_undeclared_name_in_a_condition_names_the_transition(tmp_path):
    bad = [*LOOP[:3], s.transition(4, 3, 0, 150, st="NOT gone"), LOOP[4]]
    e = one(tmp_path, chart(*bad))
    assert e["origin"] == "Chart (SFC) transition A -> Init, transition localId 4"
    assert "'gone' is not declared" in e["message"]


def test_a_transition_below_no_step(tmp_path):
    e = one(tmp_path, chart(*LOOP, s.transition(6, None, 200, 50, st="go"), s.jump(7, "A", 6, 200, 100)))
    assert e["origin"] == "Chart (SFC) transition localId 6"
    assert e["message"] == "a transition that follows no step; connect it below a step"


def test_an_error_in_a_named_action_names_pou_and_action(tmp_path):
    e = one(tmp_path, chart(*LOOP, s.actions(6, 3, 200, 100, ("N", "Blink")), acts={"Blink": "lamp := NOT lamps;"}))
    assert e["origin"] == "Chart.Blink (ST)"
    assert "'lamps' is not declared" in e["message"]


def test_an_sfc_inside_an_action_is_refused(tmp_path):
    inner = "<SFC>" + "".join(s.two_steps("I1", "I2", {"st": "go"}, {"st": "go"})) + "</SFC>"
    e = one(tmp_path, chart(*LOOP, s.actions(6, 3, 200, 100, ("N", "Inner")), acts={"Inner": inner}))
    assert e["origin"] == "Chart.Inner (SFC)"
    assert e["message"] == "an SFC as the body of an action is not supported; draw its steps in the POU's chart"

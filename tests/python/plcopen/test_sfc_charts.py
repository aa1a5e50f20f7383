# test_sfc_charts.py -- the structure of an SFC chart run in a real irpd, cycle by cycle: a selection
# divergence whose transitions are both true (the leftmost wins, whatever the localIds), a simultaneous
# divergence (both branches active) and convergence (it waits for both), a selection convergence and
# jumps back; a named transition drawn in LD (a rising-edge contact) named by two transitions, its body
# run once a period; each step's activity is seen through an N action on a BOOL variable (or an
# array's element).

from __future__ import annotations

import plcopen_xml as x
import sfc_xml as s

STEPS = ("Init", "S1", "S2", "P1", "P2", "Q1")
# inputs a, b, c per cycle, and the steps active after it
SCHEDULE = [
    ((1, 1, 0), {"S1"}),  # both of the selection's transitions true: the left one (a) wins
    ((0, 0, 0), {"S1"}),
    ((0, 0, 1), {"P1", "P2"}),  # simultaneous divergence
    ((0, 0, 0), {"Q1", "P2"}),  # P1 -> Q1 on TRUE; P2 waits for c
    ((0, 0, 0), {"Q1", "P2"}),
    ((0, 0, 1), {"Init"}),  # simultaneous convergence of Q1 and P2, then a jump to Init
    ((0, 1, 0), {"S2"}),
    ((0, 0, 0), {"S2"}),
    ((1, 0, 1), {"Init"}),  # S2 -> selection convergence -> Init; a is read from Init next cycle
    ((0, 0, 0), {"Init"}),
]


def chart() -> bytes:
    body = [
        s.step(1, "Init", initial=True, x=200, y=0),
        s.divergence("selection", 2, 1, 100, 50),
        # the right-hand transition has the lower localId: position decides, not the number
        s.transition(4, 2, 100, 80, st="a"),
        s.transition(3, 2, 300, 80, st="b"),
        s.step(5, "S1", 4, 100, 120),
        s.step(6, "S2", 3, 300, 120),
        s.transition(7, 5, 100, 170, st="c"),
        s.divergence("simultaneous", 8, 7, 50, 200),
        s.step(9, "P1", 8, 50, 240),
        s.step(10, "P2", 8, 150, 240),
        s.transition(11, 9, 50, 290, st="TRUE"),
        s.step(12, "Q1", 11, 50, 330),
        s.convergence("simultaneous", 13, [12, 10], 50, 380),
        s.transition(14, 13, 100, 400, st="c"),
        s.transition(15, 6, 300, 400, st="c"),
        s.convergence("selection", 16, [14, 15], 100, 450),
        s.jump(17, "Init", 16, 100, 500),
    ]
    blocks = [
        s.actions(100 + i, lid, 500, 60 * i, ("N", f"x{name}"))
        for i, (lid, name) in enumerate([(1, "Init"), (5, "S1"), (6, "S2"), (9, "P1"), (10, "P2"), (12, "Q1")])
    ]
    iface = x.section("inputVars", *(x.var(v, "BOOL") for v in "abc")) + x.section(
        "outputVars", *(x.var(f"x{v}", "BOOL") for v in STEPS)
    )
    return x.project(s.pou("Chart", "functionBlock", iface, "".join(body + blocks)), instances=x.config("Harness"))


HARNESS = f"""
PROGRAM Harness
VAR
  ch : Chart; n : INT;
  sched : ARRAY[1..{len(SCHEDULE)}, 1..3] OF BOOL := [{", ".join("TRUE" if v else "FALSE" for row, _ in SCHEDULE for v in row)}];
  got : ARRAY[1..{len(SCHEDULE)}, 1..{len(STEPS)}] OF INT;
END_VAR
  n := n + 1;
  IF n <= {len(SCHEDULE)} THEN
    ch(a := sched[n, 1], b := sched[n, 2], c := sched[n, 3]);
    {" ".join(f"got[n, {i + 1}] := BOOL_TO_INT(ch.x{v});" for i, v in enumerate(STEPS))}
  END_IF;
END_PROGRAM
"""


def test_divergences_convergences_and_jumps(tmp_path):
    (got,) = s.run_recorded(tmp_path, chart(), HARNESS, len(SCHEDULE), "got")
    k = len(STEPS)
    active = [{v for v, on in zip(STEPS, got[i : i + k], strict=True) if on} for i in range(0, len(got), k)]
    assert active == [want for _, want in SCHEDULE]


EDGE_SCHEDULE = [(0, {"Init"}), (1, {"S1"}), (1, {"S1"}), (0, {"S1"}), (1, {"Init"}), (0, {"Init"}), (1, {"S1"})]


def test_a_named_ld_transition_named_twice_runs_once_a_period(tmp_path):
    ld = "".join([x.rail(1), x.contact(2, "b", 1, 100, 0, edge="rising"), x.coil(3, "Edge", 2, 300, 0)])
    body = [
        *s.two_steps("Init", "S1", {"named": "Edge"}, {"named": "Edge"}),
        s.actions(6, 1, 200, 0, ("N", "xInit")),
        s.actions(7, 3, 200, 100, ("N", "xs[2]")),  # a BOOL action that is an array's element
    ]
    array = '<array><dimension lower="1" upper="2"/><baseType><BOOL/></baseType></array>'
    iface = x.section("inputVars", x.var("b", "BOOL")) + x.section(
        "outputVars", x.var("xInit", "BOOL"), x.var("xs", array)
    )
    fb = s.pou("Chart", "functionBlock", iface, "".join(body), trans={"Edge": f"<LD>{ld}</LD>"})
    n = len(EDGE_SCHEDULE)
    harness = f"""
PROGRAM Harness
VAR
  ch : Chart; n : INT;
  b : ARRAY[1..{n}] OF BOOL := [{", ".join("TRUE" if v else "FALSE" for v, _ in EDGE_SCHEDULE)}];
  got : ARRAY[1..{n}, 1..2] OF INT;
END_VAR
  n := n + 1;
  IF n <= {n} THEN
    ch(b := b[n]);
    got[n, 1] := BOOL_TO_INT(ch.xInit); got[n, 2] := BOOL_TO_INT(ch.xs[2]);
  END_IF;
END_PROGRAM
"""
    (got,) = s.run_recorded(tmp_path, x.project(fb, instances=x.config("Harness")), harness, n, "got")
    active = [{v for v, on in zip(("Init", "S1"), got[i : i + 2], strict=True) if on} for i in range(0, len(got), 2)]
    assert active == [want for _, want in EDGE_SCHEDULE]

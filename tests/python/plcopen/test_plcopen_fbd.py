# test_plcopen_fbd.py -- FBD drawn in a function block and run in a real irpd by an ST harness: a
# connector and its continuation carry a value between networks, an accumulator feeds back through its
# variable (the previous cycle's value), executionOrderId decides over the position, and a negated
# output variable; a cycle that no variable breaks is refused naming its blocks.

from __future__ import annotations

import json

import plcopen_xml as x
from plcopen_live import recorded, run_stc

HARNESS = """
PROGRAM Harness
VAR F : Flow; n : INT; got : ARRAY[1..4, 1..4] OF INT; END_VAR
  n := n + 1;
  IF n <= 4 THEN
    F(x := n);
    got[n, 1] := F.y; got[n, 2] := F.acc; got[n, 3] := F.z; got[n, 4] := BOOL_TO_INT(F.notbig);
  END_IF;
END_PROGRAM
"""


def flow() -> str:
    return "".join(
        [
            # network: y := x + 10 through connector/continuation 'plus'
            x.in_var(1, "x", 0, 0),
            x.in_var(2, "10", 0, 20),
            x.block(3, "ADD", {"IN1": 1, "IN2": 2}, ["OUT"], 100, 0),
            x.connector(4, "plus", (3, "OUT"), 200, 0),
            x.continuation(5, "plus", 0, 100),
            x.out_var(6, "y", 5, 100, 100),
            # feedback through a variable: acc := acc + x
            x.in_var(7, "acc", 0, 200),
            x.in_var(8, "x", 0, 220),
            x.block(9, "ADD", {"IN1": 7, "IN2": 8}, ["OUT"], 100, 200),
            x.out_var(10, "acc", (9, "OUT"), 200, 200),
            # executionOrderId over position: z := w drawn above w := x, but ordered after it
            x.in_var(11, "w", 0, 300),
            x.out_var(12, "z", 11, 100, 300, order=2),
            x.in_var(13, "x", 0, 400),
            x.out_var(14, "w", 13, 100, 400, order=1),
            # a negated input: notbig := NOT (x > 2)
            x.in_var(15, "x", 0, 500),
            x.in_var(16, "2", 0, 520),
            x.block(17, "GT", {"IN1": 15, "IN2": 16}, ["OUT"], 100, 500),
            x.out_var(18, "notbig", (17, "OUT"), 200, 500, negated=True),
        ]
    )


def test_fbd_connectors_feedback_and_order(tmp_path):
    iface = (
        x.section("inputVars", x.var("x", "INT"))
        + x.section("outputVars", *(x.var(v, "INT") for v in ("y", "acc", "z")), x.var("notbig", "BOOL"))
        + x.section("localVars", x.var("w", "INT"))
    )
    body = flow()
    xml = tmp_path / "flow.xml"
    xml.write_bytes(x.project(x.pou("Flow", "functionBlock", iface, "FBD", body), instances=x.config("Harness")))
    got = recorded(tmp_path, {"flow.xml": xml, "harness.st": HARNESS}, "instance0.n", 4, "instance0.got")
    rows = [got[i : i + 4] for i in range(0, 16, 4)]
    # y = x + 10; acc = 1, 3, 6, 10; z = w of this cycle (w := x runs first); notbig = NOT (x > 2)
    assert rows == [[11, 1, 1, 1], [12, 3, 2, 1], [13, 6, 3, 0], [14, 10, 4, 0]]


def test_a_cycle_without_a_variable_is_refused_naming_its_blocks(tmp_path):
    body = x.blocks_in_a_cycle("y")
    iface = x.section("outputVars", x.var("y", "INT"))
    (tmp_path / "loop.xml").write_bytes(x.project(x.pou("Loop", "functionBlock", iface, "FBD", body)))
    r = run_stc(["check", "--json", "loop.xml"], tmp_path)
    assert r.returncode == 1, r.stderr
    (err,) = json.loads(r.stdout)
    assert err["origin"].startswith("Loop (FBD) network 1, block localId")
    assert "a cycle without a variable" in err["message"]
    assert "block localId 2 (ADD)" in err["message"] and "block localId 3 (MUL)" in err["message"]

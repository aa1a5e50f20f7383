# test_fbd_instance_loop.py -- a loop in FBD through function block instances (SR -> TON -> SR, as
# the traffic light of beremiz4uc_traffic_lights draws it in its SFC) is no "cycle without a variable":
# an instance's output is a variable, read as its last call left it.  Run in a real irpd: a one-cycle
# request sets the SR, the TON it starts resets it a little later, and it stays reset.

from __future__ import annotations

import plcopen_xml as x
from sfc_xml import run_recorded

CYCLES = 30
HARNESS = f"""
PROGRAM Harness
VAR P : Pulse; n : INT; got : ARRAY[1..{CYCLES}] OF INT; END_VAR
  n := n + 1;
  IF n <= {CYCLES} THEN
    P(go := n = 2);
    got[n] := BOOL_TO_INT(P.out);
  END_IF;
END_PROGRAM
"""


def pulse() -> bytes:
    body = [
        x.in_var(1, "go", 0, 0),
        x.block(2, "SR", {"S1": 1, "R": (3, "Q")}, ["Q1"], 100, 0, instance="SR0"),
        x.in_var(4, "T#50ms", 0, 100),
        x.block(3, "TON", {"IN": (2, "Q1"), "PT": 4}, ["Q", "ET"], 200, 100, instance="TON0"),
        x.out_var(5, "out", (2, "Q1"), 300, 0),
    ]
    iface = (
        x.section("inputVars", x.var("go", "BOOL"))
        + x.section("outputVars", x.var("out", "BOOL"))
        + x.section("localVars", x.var("SR0", "<derived name='SR'/>"), x.var("TON0", "<derived name='TON'/>"))
    )
    return x.project(x.pou("Pulse", "functionBlock", iface, "FBD", "".join(body)), instances=x.config("Harness"))


def test_a_loop_through_instances_reads_their_last_outputs(tmp_path):
    (got,) = run_recorded(tmp_path, pulse(), HARNESS, CYCLES, "got")
    on = [n for n, v in enumerate(got, 1) if v]
    assert on[0] == 2, got  # set by the request
    assert on == list(range(2, on[-1] + 1)), got  # on without a gap, then reset by the TON
    assert on[-1] < CYCLES - 2, got  # and it stays off

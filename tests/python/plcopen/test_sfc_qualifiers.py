# test_sfc_qualifiers.py -- every SFC action qualifier (N R S L D P P1 P0 SD DS SL) against IEC 61131-3's
# timing: a chart of ours drawn as PLCopen XML, run in a real irpd by an ST harness that drives its
# transitions on a schedule and records, every cycle, the actions' BOOL variables and the period's due
# time; the records are compared with a model of the standard's rules computed on those times.  The
# step with the timed actions is active once for longer than their duration, once for shorter.

from __future__ import annotations

import plcopen_xml as x
import sfc_xml as s

MS = 1_000_000
T = 100 * MS  # the duration of L, D, SD, DS, SL
CYCLES = 110
# cycles where the transitions fire: Init -> A (go1), A -> C (go2), C -> B (go3), B -> Init (go4)
GO = {"go1": (3, 65), "go2": (33, 68), "go3": (60, 100), "go4": (62, 102)}
VARS = ("vN", "vS", "vL", "vD", "vP", "vP1", "vP0", "vSD", "vDS", "vSL", "vPi", "vP0i", "lit")


def chart() -> bytes:
    body = [
        s.step(1, "Init", initial=True, x=100, y=0),
        s.transition(2, 1, 100, 50, st="go1"),
        s.step(3, "A", 2, 100, 100),
        s.transition(4, 3, 100, 150, st="go2 OR A.T >= T#1h"),  # a step's T in ST
        s.step(5, "C", 4, 100, 200),
        s.transition(6, 5, 100, 250, named="ToB"),
        s.step(7, "B", 6, 100, 300),
        s.transition(8, 7, 100, 350, st="go4"),
        s.jump(9, "Init", 8, 100, 400),
        s.actions(10, 1, 300, 0, ("P", "vPi"), ("P0", "vP0i")),
        s.actions(
            11,
            3,
            300,
            100,
            ("N", "vN"),
            ("S", "vS"),
            ("L", "vL", "T#100ms"),
            ("D", "vD", "T#100ms"),
            ("P", "vP"),
            ("P1", "vP1"),
            ("P0", "vP0"),
            ("SD", "vSD", "T#100ms"),
            ("DS", "vDS", "T#100ms"),
            ("SL", "vSL", "T#100ms"),
            ("N", "lit := 1;"),  # an inline action; 1 is a BOOL literal
        ),
        s.actions(12, 5, 300, 200, ("N", "Count")),
        s.actions(13, 7, 300, 300, ("R", "vS"), ("R", "vSD"), ("R", "vDS"), ("R", "vSL")),
    ]
    iface = x.section("inputVars", *(x.var(g, "BOOL") for g in GO)) + x.section(
        "outputVars", *(x.var(v, "BOOL") for v in VARS), x.var("cnt", "INT")
    )
    fb = s.pou("Chart", "functionBlock", iface, "".join(body), {"Count": "cnt := cnt + 1;"}, {"ToB": "ToB := go3;"})
    return x.project(fb, instances=x.config("Harness"))


HARNESS = f"""
PROGRAM Harness
VAR
  c : Chart; n : INT;
  got : ARRAY[1..{CYCLES}, 1..{len(VARS) + 1}] OF INT;
  now : ARRAY[1..{CYCLES}] OF LTIME;
END_VAR
  n := n + 1;
  IF n <= {CYCLES} THEN
    c({", ".join(f"{g} := n = {a} OR n = {b}" for g, (a, b) in GO.items())});
    {" ".join(f"got[n, {i + 1}] := BOOL_TO_INT(c.{v});" for i, v in enumerate(VARS))}
    got[n, {len(VARS) + 1}] := c.cnt;
    now[n] := __CYCLE_TIME_NS();
  END_IF;
END_PROGRAM
"""


def model(now: list[int]) -> list[dict]:
    """The variables after each cycle k (1-based) by the standard's ACTION_CONTROL, on the due times."""

    def between(k, spans):
        return any(a <= k < b for a, b in spans)

    (a1, a2), (off1, off2), (r1, r2) = GO["go1"], GO["go2"], GO["go3"]
    rows = []
    ds = False
    for k in range(1, CYCLES + 1):
        act = a1 if k < a2 else a2  # A's last activation, and the reset (step B) that ends what it stored
        reset = r1 if act == a1 else r2
        el = now[k - 1] - now[act - 1]
        active = between(k, [(a1, off1), (a2, off2)])
        stored = act <= k < reset
        if k == act:
            ds = False
        ds = stored and (ds or (active and el >= T))
        rows.append(
            {
                "vN": active,
                "vS": stored,
                "vL": active and el < T,
                "vD": active and el >= T,
                "vP": k in (a1, a2),
                "vP1": k in (a1, a2),
                "vP0": k in (off1, off2),
                "vSD": stored and el >= T,
                "vDS": ds,
                "vSL": stored and el < T,
                "vPi": k in GO["go4"],  # Init entered again; not in cycle 1, where it is initial
                "vP0i": k in (a1, a2),  # Init left
                "lit": k >= a1,
                "cnt": sum(1 for j in range(1, k + 1) if between(j, [(off1, r1), (off2, r2)])),
            }
        )
    return [{v: int(b) for v, b in row.items()} for row in rows]


def test_every_qualifier_follows_the_standard(tmp_path):
    got, now = s.run_recorded(tmp_path, chart(), HARNESS, CYCLES, "got", "now")
    k = len(VARS) + 1
    rows = [dict(zip((*VARS, "cnt"), got[i : i + k], strict=True)) for i in range(0, len(got), k)]
    want = model(now)
    for n, (row, w) in enumerate(zip(rows, want, strict=True), 1):
        assert row == w, f"cycle {n}: {row} != {w}"

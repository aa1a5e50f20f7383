# test_plcopen_il.py -- an IL body (il.py) run in a real irpd: loads, stores, set/reset, the boolean,
# arithmetic and comparison operators with their N forms, a conditional jump to labels, CAL of a
# function block and a conditional return, fed by an ST harness cycle by cycle and compared with
# what the same instructions mean.

from __future__ import annotations

import plcopen_xml as x
from plcopen_live import recorded

IL = """LD a
ANDN b
ST x1        (* a AND NOT b *)
LDN a
OR b
XOR a
STN x2       (* NOT ((NOT a OR b) XOR a) *)
LD b
S s1
LD a
R s1
LD n
MUL 3
SUB 1
DIV 2
MOD 5
ST k
LD n
GT 2
JMPCN small
LD 100
ST big
JMP done
small:
LD 0
ST big
done:
CAL r1(CLK := b, Q => rq)
LD a
RETC
LD n
ADD 1
ST last
"""
SCHEDULE = [(0, 0, 0), (1, 0, 1), (1, 1, 2), (0, 1, 3), (0, 0, 4), (1, 1, 7)]  # a, b, n
OUTS = ("x1", "x2", "s1", "k", "big", "rq", "last")
HARNESS = """
PROGRAM Harness
VAR O : Ops; i : INT;
  sched : ARRAY[1..{m}, 1..3] OF INT := [{sched}];
  got : ARRAY[1..{m}, 1..7] OF INT;
END_VAR
  i := i + 1;
  IF i <= {m} THEN
    O(a := sched[i, 1] = 1, b := sched[i, 2] = 1, n := sched[i, 3]);
    got[i, 1] := BOOL_TO_INT(O.x1); got[i, 2] := BOOL_TO_INT(O.x2); got[i, 3] := BOOL_TO_INT(O.s1);
    got[i, 4] := O.k; got[i, 5] := O.big; got[i, 6] := BOOL_TO_INT(O.rq); got[i, 7] := O.last;
  END_IF;
END_PROGRAM
"""


def model() -> list[list[int]]:
    o = dict.fromkeys(OUTS, 0)
    m = 0
    rows = []
    for a, b, n in SCHEDULE:
        o["x1"] = int(a and not b)
        o["x2"] = int(not ((not a or b) != a))
        if b:
            o["s1"] = 1
        if a:
            o["s1"] = 0
        o["k"] = int((n * 3 - 1) / 2) % 5
        o["big"] = 100 if n > 2 else 0
        o["rq"] = int(b and not m)
        m = b
        if not a:
            o["last"] = n + 1
        rows.append([o[k] for k in OUTS])
    return rows


def test_il_instructions_cycle_by_cycle(tmp_path):
    iface = (
        x.section("inputVars", x.var("a", "BOOL"), x.var("b", "BOOL"), x.var("n", "INT"))
        + x.section("outputVars", *(x.var(v, "BOOL") for v in ("x1", "x2", "s1", "rq")))
        + x.section("outputVars", *(x.var(v, "INT") for v in ("k", "big", "last")))
        + x.section("localVars", x.var("r1", '<derived name="R_TRIG"/>'))
    )
    body = f"<IL><xhtml:p><![CDATA[{IL}]]></xhtml:p></IL>"
    pou = f'<pou name="Ops" pouType="functionBlock"><interface>{iface}</interface><body>{body}</body></pou>'
    xml = tmp_path / "ops.xml"
    xml.write_bytes(x.project(pou, instances=x.config("Harness")))
    sched = ", ".join(str(v) for row in SCHEDULE for v in row)
    files = {"ops.xml": xml, "harness.st": HARNESS.format(m=len(SCHEDULE), sched=sched)}
    got = recorded(tmp_path, files, "instance0.i", len(SCHEDULE), "instance0.got")
    rows = [dict(zip(OUTS, got[i : i + 7], strict=True)) for i in range(0, len(got), 7)]
    assert rows == [dict(zip(OUTS, r, strict=True)) for r in model()]

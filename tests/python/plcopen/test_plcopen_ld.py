# test_plcopen_ld.py -- every LD element the importer takes, drawn in one function block and run in a
# real irpd by an ST harness that feeds it a schedule of inputs cycle by cycle and records its outputs:
# contacts (NO, NC, rising, falling), coils (plain, negated, set, reset, rising), a branch (two
# connections into one coil: OR), a jump over a rung to a label, ADD called with EN from a contact
# and its ENO to a coil, and a return; the records are compared with a model of the standard's rules.

from __future__ import annotations

import plcopen_xml as x
from plcopen_live import recorded

INPUTS = ("a", "b", "r", "stop")
OUTPUTS = ("p", "f", "s", "nc", "pc", "orab", "skipped", "cnt", "eno", "last")
SCHEDULE = [  # a, b, r, stop per cycle
    (0, 0, 0, 0),
    (1, 0, 0, 0),
    (1, 1, 0, 0),
    (0, 1, 1, 0),
    (0, 0, 1, 1),
    (1, 0, 0, 1),
    (1, 0, 1, 0),
    (0, 0, 0, 0),
]


def ladder() -> str:
    rows = [x.rail(1)]
    y = lambda k: 100 * k  # noqa: E731  one rung per row, top to bottom
    rows += [x.contact(11, "a", 1, 100, y(1), edge="rising"), x.coil(12, "p", 11, 400, y(1))]
    rows += [x.contact(21, "a", 1, 100, y(2), edge="falling"), x.coil(22, "f", 21, 400, y(2))]
    rows += [x.contact(31, "b", 1, 100, y(3)), x.coil(32, "s", 31, 400, y(3), storage="set")]
    rows += [x.contact(41, "r", 1, 100, y(4)), x.coil(42, "s", 41, 400, y(4), storage="reset")]
    rows += [x.contact(51, "a", 1, 100, y(5)), x.coil(52, "nc", 51, 400, y(5), negated=True)]
    rows += [x.contact(61, "a", 1, 100, y(6)), x.coil(62, "pc", 61, 400, y(6), edge="rising")]
    rows += [
        x.contact(71, "a", 1, 100, y(7)),
        x.contact(72, "b", 71, 200, y(7), negated=True),
        x.contact(73, "b", 1, 100, y(7) + 40),
        x.coil(74, "orab", [72, 73], 400, y(7)),
    ]
    rows += [x.contact(81, "b", 1, 100, y(8)), x.jump(82, "SKIP", 81, 400, y(8))]
    rows += [x.contact(91, "a", 1, 100, y(9)), x.coil(92, "skipped", 91, 400, y(9))]
    rows += [x.label(100, "SKIP", 0, y(10))]
    rows += [
        x.contact(111, "r", 1, 100, y(11)),
        x.in_var(112, "cnt", 100, y(11) + 20),
        x.in_var(113, "1", 100, y(11) + 40),
        x.block(114, "ADD", {"EN": 111, "IN1": 112, "IN2": 113}, ["ENO", "OUT"], 200, y(11)),
        x.out_var(115, "cnt", (114, "OUT"), 300, y(11) + 20),
        x.coil(116, "eno", (114, "ENO"), 400, y(11)),
    ]
    rows += [x.contact(121, "stop", 1, 100, y(12)), x.ret(122, 121, 400, y(12))]
    rows += [x.contact(131, "a", 1, 100, y(13)), x.coil(132, "last", 131, 400, y(13))]
    return "".join(rows)


def model() -> list[list[int]]:
    """The outputs after each cycle by IEC 61131-3's rules (R_TRIG/F_TRIG as in its standard library)."""
    o = dict.fromkeys(OUTPUTS, 0)
    m_p = m_pc = 0
    m_f = 0
    rows = []
    for a, b, r, stop in SCHEDULE:
        o["p"] = int(a and not m_p)
        m_p = a
        o["f"] = int(not a and not m_f)
        m_f = int(not a)
        if b:
            o["s"] = 1
        if r:
            o["s"] = 0
        o["nc"] = int(not a)
        o["pc"] = int(a and not m_pc)
        m_pc = a
        o["orab"] = int((a and not b) or b)
        if not b:
            o["skipped"] = a
        if r:
            o["cnt"] += 1
        o["eno"] = r
        if not stop:
            o["last"] = a
        rows.append([o[k] for k in OUTPUTS])
    return rows


HARNESS = """
PROGRAM Harness
VAR
  L : Ladder; n : INT;
  sched : ARRAY[1..{n}, 1..4] OF BOOL := [{sched}];
  got : ARRAY[1..{n}, 1..{k}] OF INT;
END_VAR
  n := n + 1;
  IF n <= {n} THEN
    L(a := sched[n, 1], b := sched[n, 2], r := sched[n, 3], stop := sched[n, 4]);
    {record}
  END_IF;
END_PROGRAM
"""


def test_ld_elements_cycle_by_cycle(tmp_path):
    ints = {"cnt"}
    iface = x.section("inputVars", *(x.var(v, "BOOL") for v in INPUTS)) + x.section(
        "outputVars", *(x.var(v, "INT" if v in ints else "BOOL") for v in OUTPUTS)
    )
    xml = tmp_path / "ladder.xml"
    xml.write_bytes(x.project(x.pou("Ladder", "functionBlock", iface, "LD", ladder()), instances=x.config("Harness")))
    record = " ".join(
        f"got[n, {i + 1}] := {'L.' + v if v in ints else f'BOOL_TO_INT(L.{v})'};" for i, v in enumerate(OUTPUTS)
    )
    sched = ", ".join("TRUE" if v else "FALSE" for row in SCHEDULE for v in row)
    harness = HARNESS.format(n=len(SCHEDULE), k=len(OUTPUTS), sched=sched, record=record)
    got = recorded(tmp_path, {"ladder.xml": xml, "harness.st": harness}, "instance0.n", len(SCHEDULE), "instance0.got")
    k = len(OUTPUTS)
    rows = [dict(zip(OUTPUTS, got[i : i + k], strict=True)) for i in range(0, len(got), k)]
    want = [dict(zip(OUTPUTS, row, strict=True)) for row in model()]
    assert rows == want

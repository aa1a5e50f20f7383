# test_conformance_statements.py -- ST executed in a real irpd (stc build, then the module's periods):
# integer wrap, REAL->INT rounding, TIME arithmetic, string bounds, CASE with lists and ranges, FOR
# with a negative BY, EXIT and CONTINUE in nested loops, WHILE/REPEAT, functions with VAR_IN_OUT and
# outputs, FB instances, enums, arrays, structs, bit access, a derived type's initial value.  One
# program runs once (a `done` flag), so every value is the result of exactly one pass.

from __future__ import annotations

import pytest
from st_live import ran_once

PROGRAM = """
TYPE Color : (Red, Green := 5, Blue); END_TYPE
TYPE Point : STRUCT x : REAL := 1.5; y : INT := 7; END_STRUCT; END_TYPE
(* a derived type's own initial value, and what takes it: aliases, elements, fields, locals *)
TYPE Five : INT := 5; END_TYPE
TYPE AlsoFive : Five; END_TYPE
TYPE Flag : BOOL := TRUE; END_TYPE
TYPE Pair : STRUCT a : Five; b : INT; c : ARRAY[1..3] OF Five; END_STRUCT; END_TYPE

FUNCTION_BLOCK Holder
VAR_OUTPUT out : Five; END_VAR
VAR inner : Five; END_VAR
  out := inner + 1;
END_FUNCTION_BLOCK

FUNCTION Local : INT
VAR v : Five; END_VAR
  v := v + 1;
  Local := v;
END_FUNCTION

FUNCTION Unset : Five  (* its result is never assigned: the type's initial value *)
VAR_INPUT unused : BOOL; END_VAR
END_FUNCTION

FUNCTION Twice : DINT
VAR_INPUT v : DINT; END_VAR
VAR_IN_OUT calls : INT; END_VAR
  calls := calls + 1;
  Twice := v * 2;
END_FUNCTION

FUNCTION Midpoint : Point
VAR_INPUT a : Point; b : Point; END_VAR
  Midpoint.x := (a.x + b.x) / 2.0;
  Midpoint.y := (a.y + b.y) / 2;
END_FUNCTION

FUNCTION Split : BOOL
VAR_INPUT v : INT; END_VAR
VAR_OUTPUT hi : INT; lo : INT; END_VAR
  hi := v / 10;
  lo := v MOD 10;
  Split := lo > 4;
END_FUNCTION

FUNCTION_BLOCK Bump
VAR_IN_OUT target : INT; END_VAR
VAR_INPUT amount : INT; END_VAR
VAR_OUTPUT big : BOOL; END_VAR
  target := target + amount;
  big := target > 100;
END_FUNCTION_BLOCK

FUNCTION_BLOCK Acc
VAR_INPUT add : INT; END_VAR
VAR_OUTPUT total : INT; END_VAR
VAR n : INT := 100; END_VAR
  n := n + add;
  total := n;
END_FUNCTION_BLOCK

PROGRAM Conf
VAR
  done : BOOL;
  wrapInt : INT := 32767;
  wrapUsint : USINT := 255;
  wrapMul : DINT; big : DINT := 65536;
  negMin : INT := -32768;
  round1 : INT; round2 : INT; round3 : INT; round4 : INT; trunc1 : DINT;
  t : TIME := T#1s200ms;
  tSum : TIME; tMs : DINT; tDiv : TIME; tMul : TIME;
  s : STRING[5];
  sLen : INT; sFind : INT; sMid : STRING[10]; sCat : STRING[20];
  caseA : INT; caseB : INT; caseC : INT;
  i : INT; j : INT;
  forDown : DINT; forCount : INT; forEnd : INT; toMax : INT; toMaxRuns : INT;
  nested : INT; cont : INT;
  whileN : INT; repeatN : INT;
  calls : INT; fnResult : DINT;
  acc : Acc; accOut : INT;
  col : Color := Blue; wasBlue : BOOL;
  arr : ARRAY[1..3, 0..1] OF INT;
  arrSum : INT;
  p : Point; q : Point := (x := 3.5, y := 2); m : Point;
  w : WORD := 16#00F0; bit4 : BOOL; bit0 : BOOL;
  shifted : BYTE;
  r : REAL;
  hi : INT; lo : INT; roundUp : BOOL;
  bump : Bump; bumped : INT := 95; notBig : BOOL := TRUE;
  edges : ARRAY[1..2] OF R_TRIG; rises : INT;
  ctu1 : CTU; ctuQ : BOOL;
  ins : STRING[20]; del : STRING[20]; rep : STRING[20]; lft : STRING[5]; rgt : STRING[5];
  modNeg : INT; divNeg : INT; shrInt : WORD; rolByte : BYTE;
  lreal1 : LREAL; sq : LREAL;
  dt1 : DT := DT#2024-01-02-12:00:00; tod1 : TOD; d1 : DATE;
  todAdd : TOD := TOD#23:00:00;
  mx : INT; lim : INT; selv : INT;
  five : Five; alsoFive : AlsoFive; ownFive : Five := 9; flag : Flag;
  fives : ARRAY[0..2] OF Five; grid : ARRAY[0..1, 0..1] OF Five;
  pair : Pair; pairs : ARRAY[1..2] OF Pair; holder : Holder;
  fromLocal1 : INT; fromLocal2 : INT; fromTemp : INT; fromResult : INT;
END_VAR
VAR_TEMP k : INT; tempFive : Five; END_VAR
  IF done THEN RETURN; END_IF;
  done := TRUE;
  wrapInt := wrapInt + 1;
  wrapUsint := wrapUsint + 1;
  wrapMul := big * big + 3;
  negMin := -negMin;
  round1 := REAL_TO_INT(1.5); round2 := REAL_TO_INT(2.5); round3 := REAL_TO_INT(-1.5); round4 := LREAL_TO_INT(3.7);
  trunc1 := TRUNC(-2.7);
  tSum := t + T#800ms;
  tMs := TIME_TO_DINT(tSum);
  tDiv := t / 4;
  tMul := t * 2;
  s := 'abcdefgh';
  sLen := LEN(s);
  sFind := FIND(s, 'cd');
  sMid := MID('hello world', 5, 7);
  sCat := CONCAT(s, '-', 'xy');
  FOR k := 1 TO 3 DO
    CASE k * 4 OF
      4: caseA := caseA + 1;
      8, 9, 10: caseB := caseB + 10;
      11..20: caseC := caseC + 100;
    ELSE
      caseA := -1;
    END_CASE;
  END_FOR;
  FOR i := 10 TO 1 BY -3 DO
    forDown := forDown * 100 + i;
    forCount := forCount + 1;
  END_FOR;
  forEnd := i;
  FOR toMax := 32760 TO 32767 DO toMaxRuns := toMaxRuns + 1; END_FOR;
  FOR i := 1 TO 5 DO
    FOR j := 1 TO 5 DO
      IF j = 3 THEN EXIT; END_IF;
      nested := nested + 1;
    END_FOR;
    IF i = 4 THEN EXIT; END_IF;
    IF i = 2 THEN CONTINUE; END_IF;
    cont := cont + 1;
  END_FOR;
  WHILE whileN < 7 DO whileN := whileN + 2; END_WHILE;
  REPEAT repeatN := repeatN + 1; UNTIL repeatN >= 3 END_REPEAT;
  fnResult := Twice(21, calls) + Twice(v := 1, calls := calls);
  acc(add := 5);
  acc(add := 6, total => accOut);
  wasBlue := col = Blue;
  IF col = Blue THEN col := Red; END_IF;
  arr[3, 1] := 9; arr[1, 0] := 1;
  FOR i := 1 TO 3 DO FOR j := 0 TO 1 DO arrSum := arrSum + arr[i, j]; END_FOR; END_FOR;
  p.y := p.y * 2;
  m := Midpoint(p, q);
  bit4 := w.4; bit0 := w.0;
  w.0 := TRUE;
  shifted := SHL(BYTE#16#81, 1);
  r := INT_TO_REAL(7) / 2.0;
  mx := MAX(INT#3, 9, 4);
  lim := LIMIT(INT#0, 150, 100);
  selv := SEL(TRUE, INT#1, 2);
  roundUp := Split(v := 47, hi => hi, lo => lo);
  bump(bumped, 10);
  bump(target := bumped, amount := 0, NOT big => notBig);
  FOR k := 1 TO 3 DO
    edges[1](CLK := k >= 2);
    IF edges[1].Q THEN rises := rises + 1; END_IF;
    ctu1(CU := k <> 2, PV := 2, Q => ctuQ);
  END_FOR;
  ins := INSERT('abef', 'cd', 2);
  del := DELETE('abcdef', 2, 3);
  rep := REPLACE('abcdef', 'XY', 3, 2);
  lft := LEFT('abcdef', 2); rgt := RIGHT('abcdef', 2);
  modNeg := -7 MOD 2; divNeg := -7 / 2;
  shrInt := SHR(WORD#16#8000, 15); rolByte := ROL(BYTE#16#81, 9);
  lreal1 := 2.0 ** 10; sq := SQRT(16.0);
  tod1 := DT_TO_TOD(dt1); d1 := DT_TO_DATE(dt1);
  todAdd := todAdd + T#2h;
  holder();
  fromLocal1 := Local(); fromLocal2 := Local();
  fromTemp := tempFive;
  fromResult := Unset(FALSE);
END_PROGRAM
"""

EXPECTED = {
    "wrapInt": -32768,
    "wrapUsint": 0,
    "wrapMul": 3,
    "negMin": -32768,
    "round1": 2,
    "round2": 2,
    "round3": -2,
    "round4": 4,
    "trunc1": -2,
    "tSum": 2_000_000_000,
    "tMs": 2000,
    "tDiv": 300_000_000,
    "tMul": 2_400_000_000,
    "sLen": 5,
    "sFind": 3,
    "caseA": 1,
    "caseB": 10,
    "caseC": 100,
    "forDown": 10070401,
    "forCount": 4,
    "forEnd": -2,
    "toMaxRuns": 8,  # ends at the type's maximum (the step does not overflow into an endless loop)
    "toMax": -32768,  # end + step, wrapped as the addition wraps
    "nested": 8,
    "cont": 2,
    "whileN": 8,
    "repeatN": 3,
    "calls": 2,
    "fnResult": 44,
    "accOut": 111,
    "wasBlue": 1,
    "col": 0,
    "arrSum": 10,
    "p.x": 1.5,
    "p.y": 14,
    "m.x": 2.5,  # a FUNCTION returning a STRUCT
    "m.y": 8,
    "bit4": 1,
    "bit0": 0,
    "w": 0xF1,
    "shifted": 2,
    "r": 3.5,
    "mx": 9,
    "lim": 100,
    "selv": 2,
    "roundUp": 1,
    "hi": 4,
    "lo": 7,
    "bumped": 105,
    "notBig": 0,
    "rises": 1,
    "ctu1.CV": 2,
    "ctuQ": 1,
    "modNeg": -1,
    "divNeg": -3,
    "shrInt": 1,
    "rolByte": 3,
    "lreal1": 1024.0,
    "sq": 4.0,
    "tod1": 12 * 3600 * 10**9,
    "d1": 1704153600 * 10**9,
    "todAdd": 3600 * 10**9,
    # TYPE Five : INT := 5: a declaration of it without its own initial value starts at 5
    "five": 5,
    "alsoFive": 5,
    "ownFive": 9,
    "flag": 1,
    "fives[0]": 5,
    "fives[2]": 5,
    "grid[0][0]": 5,
    "grid[1][1]": 5,
    "pair.a": 5,
    "pair.b": 0,
    "pair.c[0]": 5,
    "pair.c[2]": 5,
    "pairs[1].a": 5,
    "pairs[1].c[1]": 5,
    "pairs[1].b": 0,
    "holder.inner": 5,
    "holder.out": 6,
    "fromLocal1": 6,  # a FUNCTION's local starts at 5 in every call
    "fromLocal2": 6,
    "fromTemp": 5,
    "fromResult": 5,  # a FUNCTION's result of type Five
}


@pytest.fixture(scope="module")
def conf(tmp_path_factory):
    with ran_once(tmp_path_factory.mktemp("conf"), {"conf.st": PROGRAM}, "Conf.done") as run:
        yield run


@pytest.mark.parametrize("name", list(EXPECTED))
def test_the_value_after_one_pass(conf, name):
    assert conf.value(f"Conf.{name}") == EXPECTED[name]


def test_strings_are_cut_at_their_length(conf):
    assert conf.string("Conf.s") == "abcde"  # STRING[5] := 'abcdefgh'
    assert conf.string("Conf.sMid") == "world"  # MID(s, L := 5, P := 7)
    assert conf.string("Conf.sCat") == "abcde-xy"
    assert conf.string("Conf.ins") == "abcdef" and conf.string("Conf.del") == "abef"  # DELETE(s, L := 2, P := 3)
    assert conf.string("Conf.rep") == "aXYef" and conf.string("Conf.lft") == "ab" and conf.string("Conf.rgt") == "ef"


def test_the_layout_names_the_iec_types(conf):
    layout = conf.segment.layout
    iec = {v["path"]: v.get("iec_type") for v in layout["variables"]}
    assert iec["Conf.t"] == "TIME" and iec["Conf.col"] == "Color" and iec["Conf.s"] == "STRING[5]"
    assert iec["Conf.acc"] == "Acc" and iec["Conf.p"] == "Point"
    leaves = {leaf["path"]: leaf.get("iec_type") for leaf in layout["leaves"]}
    assert leaves["Conf.acc.total"] == "INT" and leaves["Conf.arr[2][1]"] == "INT"

# test_conformance_calls.py -- ST executed in a real irpd: FUNCTIONs called as statements (their
# result dropped, their VAR_IN_OUT and VAR_OUTPUT side effects kept) and untyped literals typed by
# their context in MAX / MIN / LIMIT / SEL / MUX / ABS (into SINT, INT, DINT, UINT, REAL); an FB's
# output read in another case than declared.  One
# program runs once (a `done` flag), so every value is the result of exactly one pass.

from __future__ import annotations

import pytest
from st_live import ran_once

PROGRAM = """
FUNCTION Accum : INT
VAR_INPUT add : INT; big : DINT; END_VAR
VAR_IN_OUT total : INT; END_VAR
VAR_OUTPUT twice : DINT; END_VAR
  total := total + add;
  twice := big * 2;
  Accum := total;
END_FUNCTION

FUNCTION Touch  (* no result at all *)
VAR_IN_OUT n : INT; END_VAR
  n := n + 1;
END_FUNCTION

FUNCTION_BLOCK Counter  (* its output read in another case: ST is case-insensitive *)
VAR_OUTPUT Out : INT; END_VAR
  Out := Out + 1;
END_FUNCTION_BLOCK

PROGRAM Calls
VAR
  cnt : Counter; counted : INT;
  done : BOOL;
  total : INT := 1; out : DINT; touched : INT; k : INT := 1; s : SINT := 3;
  si1 : SINT; si2 : SINT; si3 : SINT;
  i1 : INT; i2 : INT; i3 : INT; i4 : INT;
  di1 : DINT; di2 : DINT;
  ui1 : UINT; ui2 : UINT;
  r1 : REAL; r2 : REAL; r3 : REAL; r4 : REAL;
END_VAR
  IF done THEN RETURN; END_IF;
  done := TRUE;
  cnt();
  counted := cnt.OUT + cnt.out;
  (* calls as statements: the result is dropped, the side effects happen *)
  Accum(1, 2, total);
  Accum(add := s, big := 70000, total := total, twice => out);
  Touch(touched);
  Touch(n := touched);
  MUX(0, k, 1);
  MAX(1, 2);
  LIMIT(0, k, 10);
  SEL(TRUE, s, 1);
  ABS(-3);
  (* untyped literals take the type of the target or of the other operands *)
  si1 := MAX(-100, 100);
  si2 := MIN(-100, 100);
  si3 := LIMIT(0, s, 2);
  i1 := MAX(1, 2);
  i2 := LIMIT(-1000, 32000, 30000);
  i3 := MAX(k, 300);
  i4 := ABS(-32767);
  di1 := SEL(TRUE, 1, 70000);
  di2 := MUX(2, 10, 20, 70000);
  ui1 := MAX(65535, 1);
  ui2 := LIMIT(10, 5, 60000);
  r1 := MAX(1.5, 2);
  r2 := LIMIT(0.5, 3, 2.5);
  r3 := MUX(1, 1.25, 2.75);
  r4 := MIN(0.25, 1) + SEL(FALSE, 1, 2);
END_PROGRAM
"""

EXPECTED = {
    "counted": 2,
    "total": 5,  # 1 + 1, then + s (3)
    "out": 140000,
    "touched": 2,
    "si1": 100,
    "si2": -100,
    "si3": 2,
    "i1": 2,
    "i2": 30000,
    "i3": 300,
    "i4": 32767,
    "di1": 70000,
    "di2": 70000,
    "ui1": 65535,
    "ui2": 10,
    "r1": 2.0,
    "r2": 2.5,
    "r3": 2.75,
    "r4": 1.25,
}


@pytest.fixture(scope="module")
def calls(tmp_path_factory):
    with ran_once(tmp_path_factory.mktemp("calls"), {"calls.st": PROGRAM}, "Calls.done") as run:
        yield run


@pytest.mark.parametrize("name", list(EXPECTED))
def test_the_value_after_one_pass(calls, name):
    assert calls.value(f"Calls.{name}") == EXPECTED[name]

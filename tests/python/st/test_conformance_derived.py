# test_conformance_derived.py -- a derived type's own initial value (TYPE X : INT := 5; END_TYPE),
# executed in a real irpd: variables, aliases of X, array elements, struct and FB fields, a
# FUNCTION's locals and VAR_TEMPs of type X start at 5 unless they have an initial value of their own.

from __future__ import annotations

import pytest
from st_live import ran_once

PROGRAM = """
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

PROGRAM Derived
VAR
  done : BOOL;
  x : Five;
  y : AlsoFive;
  own : Five := 9;
  flag : Flag;
  arr : ARRAY[0..2] OF Five;
  grid : ARRAY[0..1, 0..1] OF Five;
  p : Pair;
  pairs : ARRAY[1..2] OF Pair;
  h : Holder;
  fromFunction1 : INT;
  fromFunction2 : INT;
  fromTemp : INT;
END_VAR
VAR_TEMP t : Five; END_VAR
  IF NOT done THEN
    h();
    fromFunction1 := Local();
    fromFunction2 := Local();
    fromTemp := t;
    done := TRUE;
  END_IF;
END_PROGRAM
"""

EXPECTED = {
    "x": 5,
    "y": 5,
    "own": 9,
    "flag": True,
    "arr[0]": 5,
    "arr[2]": 5,
    "grid[0][0]": 5,
    "grid[1][1]": 5,
    "p.a": 5,
    "p.b": 0,
    "p.c[0]": 5,
    "p.c[2]": 5,
    "pairs[1].a": 5,
    "pairs[1].c[1]": 5,
    "pairs[1].b": 0,
    "h.inner": 5,
    "h.out": 6,
    "fromFunction1": 6,
    "fromFunction2": 6,
    "fromTemp": 5,
}


@pytest.fixture(scope="module")
def derived(tmp_path_factory):
    with ran_once(tmp_path_factory.mktemp("derived"), {"derived.st": PROGRAM}, "Derived.done") as run:
        yield run


@pytest.mark.parametrize("name", list(EXPECTED))
def test_a_derived_types_initial_value(derived, name):
    assert derived.value(f"Derived.{name}") == EXPECTED[name]

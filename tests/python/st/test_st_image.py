# test_st_image.py -- the generated run() in a real irpd: its process image (kept from one run to the
# next, read again when another writer changed a variable; a variable the code only reads never
# written back) and a long body split into C++ functions of bounded size (a RETURN in any part ends
# the POU's call).  The values are written from outside with irpd's `write`, as the Variables page does.

from __future__ import annotations

from live_processes import wait_until
from st_live import Running, periods

GLB = "namespace IO;\nstruct {\n  int32_t mode;\n  double x;\n} axis;\nint32_t limit;\n"

IMAGE = """
TYPE Pair : STRUCT n : DINT; m : DINT; END_STRUCT; END_TYPE

PROGRAM Main
VAR pair : Pair; mirror : DINT; x : LREAL; seenLimit : DINT; t : TON := (PT := T#1h); END_VAR
  pair.n := pair.n + 1;          (* the program writes pair every period ... *)
  IF pair.n > 5 THEN             (* ... and reads pair.m only in this branch *)
    mirror := pair.m;
  END_IF;
  IF IO.axis.mode = 1 THEN       (* a .glb struct the program only reads, its field in one branch *)
    x := IO.axis.x;
  END_IF;
  seenLimit := IO.limit;
  t(IN := TRUE);
END_PROGRAM
"""


def test_what_another_writer_changes_is_read_by_the_next_run_and_kept(tmp_path):
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "io.glb").write_text(GLB)
    run = Running(tmp_path, {"main.st": IMAGE}, "--glb", "io.glb")
    try:
        wait_until(lambda: run.value("Main.pair.n") > 10)
        # a field of a variable the program writes every period, read only in a branch
        run.client.request("write", path="Main.pair.m", value=42)
        run.wait_value("Main.mirror", 42)
        assert run.value("Main.pair.m") == 42, "the program's write-back of pair kept the other writer's m"
        n = run.value("Main.pair.n")
        wait_until(lambda: run.value("Main.pair.n") > n + 3)  # and it goes on writing n
        # a .glb struct the program only reads: seen when its field is read, never written back
        run.client.request("write", path="IO.axis.x", value=2.5)
        run.client.request("write", path="IO.axis.mode", value=1)
        run.wait_value("Main.x", 2.5)
        run.client.request("write", path="IO.axis.x", value=-1.0)
        run.wait_value("Main.x", -1.0)
        run.client.request("write", path="IO.limit", value=7)
        run.wait_value("Main.seenLimit", 7)
        # an FB instance the program keeps: written from outside, the next run works on that value
        run.client.request("write", path="Main.t.PT", value=1_000_000)  # 1 ms: Q at the next run
        run.wait_value("Main.t.Q", True)
    finally:
        run.close()


def _long(stop: str, tail: str) -> str:
    """Statements enough for three parts of the split body around `stop`, then `tail`."""
    return "\n".join(["  a := a + 1;"] * 300 + [stop] + ["  b := b + 1;"] * 300 + [tail])


SPLIT = f"""
FUNCTION Early : DINT
VAR_INPUT cut : BOOL; END_VAR
VAR a, b : DINT; END_VAR
{_long("  IF cut THEN Early := a; RETURN; END_IF;", "  Early := a + b;")}
END_FUNCTION

FUNCTION_BLOCK Counter
VAR_INPUT cut : BOOL; END_VAR
VAR_OUTPUT a, b : DINT; END_VAR
{_long("  IF cut THEN RETURN; END_IF;", "")}
END_FUNCTION_BLOCK

PROGRAM Main
VAR cut : BOOL; a, b, cutShort, whole : DINT; c : Counter; END_VAR
{_long("  cutShort := Early(cut); whole := Early(FALSE); c(cut := cut);  IF cut THEN RETURN; END_IF;", "")}
END_PROGRAM
"""


def test_a_return_in_a_part_of_a_long_body_ends_the_pous_call(tmp_path):
    run = Running(tmp_path, {"main.st": SPLIT})
    try:
        cpp = (tmp_path / "set" / "Main.cpp").read_text()
        assert all(f in cpp for f in ("programBody2_", "fbBody2_", "Early2_")), "the bodies were not split"
        wait_until(lambda: run.value("Main.b") >= 600)
        assert run.value("Main.cutShort") == 600 and run.value("Main.whole") == 600
        assert run.value("Main.c.b") == run.value("Main.c.a")
        run.client.request("write", path="Main.cut", value=True)
        wait_until(lambda: run.value("Main.cutShort") == 300)  # the FUNCTION returned from its second part
        a, b, ca, cb = (run.value(p) for p in ("Main.a", "Main.b", "Main.c.a", "Main.c.b"))
        periods(5)
        assert run.value("Main.a") > a and run.value("Main.b") == b, "the PROGRAM's part 3 ran after RETURN"
        assert run.value("Main.c.a") > ca and run.value("Main.c.b") == cb, "the FB's part 3 ran after RETURN"
        assert run.value("Main.whole") == 600
    finally:
        run.close()

# test_conformance_shared.py -- ST programs and the set's other shared variables in a real irpd: an AT
# binding and a qualified access to the set's .glb variables (written from outside with `write`), a
# VAR_GLOBAL of the CONFIGURATION that two programs share through VAR_EXTERNAL, a .glb struct field,
# and a subrange assignment out of range as a fault naming the place.

from __future__ import annotations

from live_processes import wait_until
from st_live import Running

GLB = "namespace IO;\nint16_t start;\nint32_t speed;\nstruct {\n  double x;\n  int32_t count;\n} axis;\n"

ST = """
TYPE Percent : INT (0..100); END_TYPE

PROGRAM Producer
VAR_EXTERNAL level : DINT; END_VAR
VAR go AT %IO.start : INT; n : DINT; END_VAR
  n := n + 1;
  level := n;
  IO.speed := go * 3;
  IO.axis.count := IO.axis.count + 1;
END_PROGRAM

PROGRAM Consumer
VAR_EXTERNAL level : DINT; END_VAR
VAR seen : DINT; x : LREAL; pct : Percent := 50; step : INT; END_VAR
  seen := level;
  x := IO.axis.x;
  step := step + 10;
  pct := step;
END_PROGRAM

CONFIGURATION Plant
  VAR_GLOBAL level : DINT; END_VAR
  RESOURCE Cpu ON PLC
    TASK Fast (INTERVAL := T#10ms, PRIORITY := 1);
    TASK Slow (INTERVAL := T#20ms, PRIORITY := 2);
    PROGRAM Prod WITH Fast : Producer;
    PROGRAM Cons WITH Slow : Consumer;
  END_RESOURCE
END_CONFIGURATION
"""


def test_programs_share_globals_and_the_sets_glb_variables(tmp_path):
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "io.glb").write_text(GLB)
    run = Running(tmp_path, {"plant.st": ST}, "--glb", "io.glb")
    try:
        run.client.request("write", path="IO.start", value=7)
        run.client.request("write", path="IO.axis.x", value=2.5)
        wait_until(lambda: run.value("IO.speed") == 21)
        wait_until(lambda: run.value("Cons.x") == 2.5)
        wait_until(lambda: run.value("Cons.seen") > 5)
        assert run.value("Plant.level") >= run.value("Cons.seen")
        assert run.value("IO.axis.count") >= run.value("Prod.n") - 1
        fault = wait_until(lambda: [e["message"] for e in run.events("fault") if e["module"] == "Cons"], 30)[0]
        assert "plant.st:19:3: value 110 is outside the subrange 0..100 (PROGRAM Consumer)" in fault, fault
        assert run.value("Cons.pct") == 100
    finally:
        run.close()

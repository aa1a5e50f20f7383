# test_conformance_retain.py -- RETAIN in ST across an irpd restart (a real irpd with a state folder):
# the RETAIN variable goes on from the value irpd restored, a plain one starts again at its initial
# value, and an FB instance declared RETAIN keeps its fields.  The program's FB instances share one
# lock (its lock group) and its variables are packed (docs/glbc.md): RETAIN is still per variable, the
# retained CTU beside a plain one that starts again.

from __future__ import annotations

from live_processes import wait_until
from st_live import Running

ST = """
PROGRAM Keep
VAR RETAIN kept : DINT := 1000; ctr : CTU; END_VAR
VAR plain : DINT := 5; other : CTU; END_VAR
  kept := kept + 1;
  plain := plain + 1;
  ctr(CU := NOT ctr.CU, PV := 30000);
  other(CU := NOT other.CU, PV := 30000);
END_PROGRAM
"""


def test_retain_values_survive_a_restart_and_plain_ones_start_again(tmp_path):
    state = tmp_path / "state"
    state.mkdir()
    run = Running(tmp_path, {"keep.st": ST}, irpd=("--state-dir", str(state), "--retain-interval", "50"))
    try:
        wait_until(lambda: run.value("Keep.kept") > 1030)
        assert run.value("Keep.plain") > 30
        run.close()  # irpd writes the retained values at its stop
        kept = run.segment_values_at_close
        run.start()
        assert run.value("Keep.kept") >= kept["Keep.kept"]  # restored, then counting on
        assert run.value("Keep.ctr.CV") >= kept["Keep.ctr.CV"] > 0
        assert run.value("Keep.plain") < kept["Keep.plain"]  # its initial value again
        assert run.value("Keep.other.CV") < kept["Keep.other.CV"]  # the plain FB of the same group too
        layout = {v["path"]: v for v in run.segment.layout["variables"]}
        assert layout["Keep.ctr"]["lock"] == layout["Keep.other"]["lock"]  # one lock group
        assert layout["Keep.ctr"].get("retain") == "retain" and "retain" not in layout["Keep.other"]
    finally:
        run.close()

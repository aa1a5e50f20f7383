"""restart_bench.py -- what a managed restart costs: N restarts (default 20) of irpd onto the plc-robot
cell (its drive simulator on Modbus TCP, libiodispat, the robot and the PLC at 10 ms), alternating
between two copies of the set so that each restart is onto another set id.  irpd measures each
downtime itself, from the end of the old set's last period to the start of the new set's first
(status.last_restart.downtime_ns); the bench reports p50, p99 and max, and irpd's own expected
downtime next to them.  Results go to docs/benchmark-online.md.

    .venv/bin/python tests/bench/restart_bench.py [--restarts 20] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import shutil
import signal
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))
from live_processes import ROOT, copy_cell, start_irpd  # noqa: E402

sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.irpd.client import IrpdClient, IrpdRefused, IrpdUnavailable  # noqa: E402


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(q * (len(ordered) - 1))))]


def wait_for_restart(control: IrpdClient, requested: int, pid: int, limit_s: float = 30.0) -> dict:
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        try:
            status = control.request("status", timeout=2.0) or {}
        except (IrpdUnavailable, IrpdRefused):
            status = {}
        last = status.get("last_restart") or {}
        if status and status.get("pid") != pid:
            raise RuntimeError(f"irpd came back as another process ({status.get('pid')})")
        if last.get("requested_ns") == requested:
            return last
        time.sleep(0.02)
    raise RuntimeError("irpd did not come back from its restart")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--restarts", type=int, default=20)
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="restart-bench-") as tmp:
        folder = Path(tmp)
        xml, port = copy_cell(folder / "a")
        other = folder / "b"
        shutil.copytree(folder / "a", other)  # the same cell (same drive simulator port), another set id
        sets = [(xml, "cell-a"), (other / xml.name, "cell-b")]
        sock = folder / "irpd.sock"
        irpd = start_irpd(sock, xml, f"restart-bench-{port}")
        control = IrpdClient(str(sock), timeout_s=30)
        downtimes, expected, failed = [], [], []
        try:
            time.sleep(1.0)
            for k in range(a.restarts):
                config, set_id = sets[(k + 1) % 2]
                asked = control.request("restart", config=str(config), set_id=set_id)
                expected.append(asked["expected_downtime_ns"] / 1e6)
                last = wait_for_restart(control, asked["requested_ns"], asked["pid"])
                if last.get("fell_back"):
                    failed.append(last.get("error"))
                    continue
                downtimes.append(last["downtime_ns"] / 1e6)
                time.sleep(0.5)  # the cell runs a little between restarts
        finally:
            control.close()
            irpd.send_signal(signal.SIGTERM)
            irpd.wait(timeout=20)
    result = {
        "restarts": a.restarts,
        "fell_back": len(failed),
        "errors": failed[:3],
        "downtime_ms": {
            "p50": round(percentile(downtimes, 0.5), 1),
            "p99": round(percentile(downtimes, 0.99), 1),
            "max": round(max(downtimes), 1),
            "min": round(min(downtimes), 1),
        },
        "expected_downtime_ms": {"p50": round(percentile(expected, 0.5), 1), "max": round(max(expected), 1)},
    }
    print(json.dumps(result, indent=1))
    if a.json:
        a.json.write_text(json.dumps(result, indent=1) + "\n")
    return 0 if not failed else 1


if __name__ == "__main__":
    sys.exit(main())

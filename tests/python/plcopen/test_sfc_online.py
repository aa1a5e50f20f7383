# test_sfc_online.py -- an SFC program changed online in a real irpd (built against the running layout
# and loaded with `load`): the active step stays active and its T goes on growing, the chart's
# variables keep their values, the changed action runs from the next period, and a step added by the
# change is laid out, inactive.

from __future__ import annotations

import plcopen_xml as x
import sfc_xml as s
from live_processes import wait_until
from plcopen_live import Running


def chart(action: str, later: bool) -> bytes:
    body = [
        s.step(1, "Init", initial=True),
        s.transition(2, 1, 0, 50, st="TRUE"),
        s.step(3, "Count", 2, 0, 100),
        s.transition(4, 3, 0, 150, st="stop"),
        s.actions(5, 3, 200, 100, ("N", action)),
    ]
    if later:
        body += [s.step(6, "Later", 4, 0, 200), s.transition(7, 6, 0, 250, st="TRUE"), s.jump(8, "Init", 7, 0, 300)]
    else:
        body += [s.jump(6, "Init", 4, 0, 200)]
    iface = x.section("localVars", x.var("cnt", "DINT"), x.var("stop", "BOOL"))
    return x.project(s.pou("Seq", "program", iface, "".join(body)), instances=x.config("Seq"))


def test_a_chart_changed_online_keeps_its_active_step(tmp_path):
    v1 = tmp_path / "v1" / "seq.xml"
    v2 = tmp_path / "v2" / "seq.xml"
    for path, data in ((v1, chart("cnt := cnt + 1;", False)), (v2, chart("cnt := cnt + 1000;", True))):
        path.parent.mkdir()
        path.write_bytes(data)
    run = Running(tmp_path, {"seq.xml": v1})
    try:
        wait_until(lambda: run.value("instance0.cnt") > 20)
        t_before = run.value("instance0.Count.T")
        report = run.load({"seq.xml": v2}, "set2")
        assert any(v.startswith("instance0.Later") for v in report["variables"]["added"]), report
        n = run.value("instance0.cnt")
        assert n > 20  # kept
        wait_until(lambda: run.value("instance0.cnt") > n + 3000)  # the changed action counts by 1000
        assert run.value("instance0.cnt") % 1000 == n % 1000
        assert run.value("instance0.Count.X") == 1 and run.value("instance0.Init.X") == 0
        assert run.value("instance0.Later.X") == 0
        assert run.value("instance0.Count.T") > t_before  # still timing from its activation
    finally:
        run.close()

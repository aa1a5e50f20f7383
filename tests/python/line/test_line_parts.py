"""test_line_parts.py -- the line's pieces (docs/dds.md "The line") without live controllers: a
controller's state from what it announced, the view file as the agent reads it (off, stale,
unreadable, current), the jitter window, the alarms' order, the settings, irpctl's table, and two
announcers in one process on a domain of their own: one sees the other, and a disposed one leaves."""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.cli.line import line_text  # noqa: E402
from indurop_agent.dds.line import JitterWindow, Line, active_alarms, p99, set_name  # noqa: E402
from indurop_agent.dds.line_view import LineAlarm, LineEntry, LineFile, read_view, state_of, write_view  # noqa: E402
from indurop_agent.dds.settings import BridgeSettings, parse_args  # noqa: E402


def entry(**kw) -> LineEntry:
    base = dict(
        name="a",
        agent_url="http://10.0.0.1:8080/",
        version="0.1.0",
        set_name="signals/module.xml",
        set_id="",
        layout_hash="",
        health="running",
        health_detail="",
        basic_period_ns=1_000_000,
        jitter_p99_ns=12_000,
        alarms_active=0,
        alarms=[],
        uptime_ns=5_000_000_000,
        period_s=1.0,
        lease_s=3.0,
        alive=True,
        last_seen=time.time(),
    )
    return LineEntry(**{**base, **kw})


def alarm(severity: str, source="main", id=8) -> LineAlarm:
    return LineAlarm(source=source, id=id, severity=severity, text=f"{severity} thing")


def test_a_controller_s_state_follows_its_health_alarms_and_liveliness():
    assert state_of(entry()) == ("ok", [])
    state, why = state_of(entry(alarms_active=2, alarms=[alarm("high"), alarm("low")]))
    assert state == "warning" and "2 alarm(s) active, the highest high" in why[0]
    assert state_of(entry(health="stopped"))[0] == "warning"
    state, why = state_of(entry(alarms_active=1, alarms=[alarm("critical")]))
    assert state == "fault" and "critical alarm main/8" in why[0]
    state, why = state_of(entry(health="fault", health_detail="main overran"))
    assert state == "fault" and why == ["faulted: main overran"]
    assert state_of(entry(health="irpd_unreachable"))[0] == "fault"
    state, why = state_of(entry(alive=False, lost_reason="its liveliness lease (3 s) ran out", health="fault"))
    assert state == "lost" and "lease" in why[0]
    state, why = state_of(entry(duplicate=True))
    assert state == "warning" and "more than one controller" in why[0]


def view_file(tmp_path: Path, written: float, controllers: list[LineEntry], **kw) -> Path:
    path = tmp_path / "line.json"
    fields = dict(format=1, written=written, period_s=1.0, name="a", domain_id=7, interface="lo")
    write_view(path, LineFile(**{**fields, **kw}, controllers=controllers))
    return path


def test_the_agent_s_view_says_when_the_bridge_is_off_stale_or_unreadable(tmp_path):
    off = read_view(tmp_path / "absent.json")
    assert off.bridge == "off" and "not running" in off.message and off.controllers == []
    now = time.time()
    path = view_file(tmp_path, now - 60, [entry()])
    stale = read_view(path, now)
    assert stale.bridge == "stale" and "60 s ago" in stale.message and stale.controllers == []
    path.write_text("{not json")
    assert read_view(path).bridge == "unreadable"
    path.write_text(json.dumps({"format": 1, "controllers": "x"}))
    bad = read_view(path)
    assert bad.bridge == "unreadable" and "another version" in bad.message
    path = view_file(tmp_path, now, [entry()], format=2)
    assert read_view(path, now).bridge == "unreadable"


def test_a_current_view_is_sorted_with_states_and_this_controller_marked(tmp_path):
    now = time.time()
    lost = entry(name="c", alive=False, last_seen=now - 10, lost_since=now - 7, lost_reason="lease ran out")
    path = view_file(tmp_path, now - 0.5, [entry(name="b", last_seen=now - 2), lost, entry(name="a", last_seen=now)])
    assert oct(path.stat().st_mode & 0o777) == "0o640"
    view = read_view(path, now)
    assert view.bridge == "ok" and view.message == "" and view.this == "a" and view.domain_id == 7
    assert [(c.name, c.state, c.this) for c in view.controllers] == [
        ("a", "ok", True),
        ("b", "ok", False),
        ("c", "lost", False),
    ]
    assert view.controllers[1].age_s == pytest.approx(2, abs=0.01)
    text = line_text(view.model_dump(), now)
    assert text.splitlines()[0] == "domain 7 on lo, as a (*) sees it"
    assert "a *" in text and "lost, last" in text and "c: lease ran out" in text
    assert "12 µs" in text and "http://10.0.0.1:8080/" in text
    assert line_text(read_view(tmp_path / "absent.json").model_dump()).startswith(
        "no line: the DDS bridge is not running"
    )


def test_the_jitter_window_is_the_difference_of_cumulative_histograms():
    assert p99({}) is None
    assert p99({(0, 1000): 99, (1000, 1000): 1}) == 1000
    assert p99({(0, 1000): 98, (5000, 1000): 2}) == 6000
    w = JitterWindow(window_s=10)
    assert w.add(0.0, 1, [[0, 1000, 1000], [90_000, 10_000, 50]]) == 100_000  # since irpd started
    # 10 s later, only fast wake-ups were added: the window forgets the early slow ones
    assert w.add(5.0, 1, [[0, 1000, 2000], [90_000, 10_000, 50]]) == 1000
    assert w.add(11.0, 1, [[0, 1000, 3000], [90_000, 10_000, 50]]) == 1000
    assert w.add(12.0, 2, [[4000, 1000, 10]]) == 5000  # another irpd (pid): its own histograms
    assert w.add(13.0, 2, [[4000, 1000, 10]]) is None  # nothing dispatched in between


def test_active_alarms_come_most_severe_first():
    answer = {
        "sources": [
            {"module": "io", "declared": [{"id": 1, "severity": "low", "text": "low"}], "active": [1]},
            {
                "module": "main",
                "declared": [
                    {"id": 8, "severity": "critical", "text": "x" * 500},
                    {"id": 9, "severity": "high", "text": "h"},
                ],
                "active": [9, 8],
            },
            {"module": "quiet", "declared": [{"id": 2, "severity": "high", "text": "h"}], "active": []},
        ]
    }
    got = active_alarms(answer)
    assert [(a.source, a.id, a.severity) for a in got] == [
        ("main", 8, "critical"),
        ("main", 9, "high"),
        ("io", 1, "low"),
    ]
    assert len(got[0].text) == 200


def test_the_set_s_name_and_the_line_settings():
    assert set_name("/var/lib/indurop/sets/0123456789abcdef/files/module.xml") == "0123456789abcdef/module.xml"
    assert set_name("/x/config/sets/plc-robot/module-1ms.xml") == "plc-robot/module-1ms.xml"
    s = parse_args(["--name", "cell-1", "--agent-url", "https://cell1:8443/", "--line-lease-s", "4", "--line-file", ""])
    assert (s.name, s.agent_url, s.line_lease_s, s.line_file) == ("cell-1", "https://cell1:8443/", 4.0, "")
    assert BridgeSettings().line_file == "/run/indurop-dds/line.json"


@pytest.mark.parametrize(
    "argv, words",
    [
        (["--agent-url", "javascript:alert(1)"], "agent_url"),
        (["--name", "two words"], "name 'two words'"),
        (["--line-lease-s", "1"], "at least twice line_period_s"),
        (["--line-period-s", "0"], "line_period_s 0"),
    ],
)
def test_bad_line_settings_are_refused_naming_the_setting(argv, words, capsys):
    with pytest.raises(SystemExit):
        parse_args(argv)
    assert words in capsys.readouterr().err


def test_two_announcers_see_each_other_and_a_disposed_one_leaves(tmp_path):
    from cyclonedds.domain import Domain, DomainParticipant
    from indurop_agent.dds.settings import cyclone_config

    domain = 20 + os.getpid() % 30  # the line tests use 20..99 (docs/dds.md)
    Domain(domain, cyclone_config(BridgeSettings(domain_id=domain)))
    lines = {}
    for name in ("a", "b"):
        settings = BridgeSettings(
            domain_id=domain,
            name=name,
            irpd_socket=str(tmp_path / "none.sock"),
            line_file=str(tmp_path / f"{name}.json"),
        )
        lines[name] = Line(DomainParticipant(domain), settings, irpd=None)

    def names(line: Line) -> list[str]:
        return sorted(line.entries)

    deadline = time.monotonic() + 30
    while names(lines["a"]) != ["a", "b"] or names(lines["b"]) != ["a", "b"]:
        assert time.monotonic() < deadline, (names(lines["a"]), names(lines["b"]))
        for line in lines.values():
            line.next = 0
            line.step(time.monotonic(), {})
        time.sleep(0.1)
    b = lines["a"].entries["b"]
    assert b.health == "irpd_unreachable" and "none.sock" in b.health_detail and b.alive
    assert read_view(tmp_path / "a.json").controllers[1].state == "fault"
    lines["b"].close()
    assert not (tmp_path / "b.json").exists()
    while "b" in lines["a"].entries:
        assert time.monotonic() < deadline, lines["a"].entries["b"]
        lines["a"].next = 0
        lines["a"].step(time.monotonic(), {})
        time.sleep(0.1)


def test_hostile_announcements_are_bounded_and_counted(tmp_path):
    """Any participant on the domain may announce anything: names that are none, more names than
    the line lists, texts of any length."""
    from cyclonedds.domain import Domain, DomainParticipant
    from cyclonedds.pub import DataWriter
    from cyclonedds.topic import Topic
    from indurop_agent.dds.indurop_types import LineAlarm as Alarm
    from indurop_agent.dds.indurop_types import LineController as Controller
    from indurop_agent.dds.line import MAX_CONTROLLERS, TEXT_MAX, TOPIC, writer_qos
    from indurop_agent.dds.settings import cyclone_config

    domain = 50 + os.getpid() % 25
    Domain(domain, cyclone_config(BridgeSettings(domain_id=domain)))
    settings = BridgeSettings(domain_id=domain, name="a", line_file=str(tmp_path / "a.json"))
    line = Line(DomainParticipant(domain), settings, irpd=None)
    dp = DomainParticipant(domain)
    w = DataWriter(dp, Topic(dp, TOPIC, Controller), writer_qos(3))
    deadline = time.monotonic() + 30
    while not w.get_publication_matched_status().current_count:
        assert time.monotonic() < deadline, "the line's reader did not match"
        time.sleep(0.05)
    w.write(Controller(name="", health="running"))
    w.write(Controller(name="x\n<script>", health="running"))
    long_alarms = [Alarm(source="m", id=i, severity="high", text="t" * 5000) for i in range(50)]
    w.write(Controller(name="big", health="weird", agent_url="u" * 10_000, alarms=long_alarms, lease_ms=3000))
    for i in range(MAX_CONTROLLERS + 20):
        w.write(Controller(name=f"n{i:04d}", health="running", lease_ms=3000, period_ms=1000))
    while line.ignored < 2 + 20 + 1 or "a" not in line.entries:  # 2 bad names, 21 over the limit
        assert time.monotonic() < deadline, (line.ignored, len(line.entries))
        line.next = 0
        line.step(time.monotonic(), {})
        time.sleep(0.05)
    assert len(line.entries) in (MAX_CONTROLLERS, MAX_CONTROLLERS + 1)  # this controller is always listed
    big = line.entries["big"]
    assert len(big.agent_url) == TEXT_MAX and len(big.alarms) == 5 and all(len(a.text) == TEXT_MAX for a in big.alarms)
    assert big.health == "fault" and "unknown health" in big.health_detail
    view = read_view(tmp_path / "a.json")
    assert view.bridge == "ok" and view.ignored >= 23 and len(view.controllers) == len(line.entries)

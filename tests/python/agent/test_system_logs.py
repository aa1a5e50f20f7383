"""test_system_logs.py -- the System page's logs: files as packaging/demo.sh writes them (stamped
lines) read through GET /system/logs/{log} with lines, search and since; followed live through
/follow from a real agent; the journal read through a stand-in journalctl (its arguments, its JSON,
the follow's process ended when the client goes); no source is a 404 that says how to get one;
bounds and roles.  docs/administration.md, "Logs"."""

from __future__ import annotations

import asyncio
import json
import os
import stat
import time
from datetime import UTC, datetime

import httpx
import pytest
from agent_helpers import API, free_port, start_agent, stop
from indurop_agent.system import logs

LINES = [
    "2026-01-31T08:00:00Z irpd: started set a",
    "2026-01-31T08:00:01Z module cntr1: Overrun 1",
    "  a continuation without a stamp",
    "2026-01-31T09:30:00Z irpd: swap to set b",
    "2026-01-31T09:30:05Z module cntr1: overrun 2",
]


@pytest.fixture
def no_journal(monkeypatch, tmp_path):
    monkeypatch.setattr(logs, "JOURNALD", tmp_path / "no-journald")


@pytest.fixture
def agent_with_logs(make_agent, tmp_path, no_journal):
    irpd_log = tmp_path / "irpd.log"
    irpd_log.write_text("\n".join(LINES) + "\n")
    agent = make_agent(irpd_log=irpd_log, agent_log=tmp_path / "agent.log")  # the agent's log not written yet
    return agent


def read(agent, log: str, role: str = "admin", **params):
    return agent.client.get(f"{API}/system/logs/{log}", params=params, headers=agent.h(role))


def test_a_log_file_is_read_oldest_first_with_its_times(agent_with_logs):
    r = read(agent_with_logs, "irpd")
    assert r.status_code == 200, r.text
    page = r.json()
    assert page["log"] == "irpd" and page["source"].startswith("file ") and page["truncated"] is False
    assert [x["message"] for x in page["lines"]] == [
        line.split(" ", 1)[1] if line[0] == "2" else line for line in LINES
    ]
    assert page["lines"][0]["time"] == "2026-01-31T08:00:00Z"
    assert page["lines"][2]["time"] == "2026-01-31T08:00:01Z"  # an unstamped line takes the time before it


def test_lines_search_and_since_narrow_the_read(agent_with_logs):
    assert [x["message"] for x in read(agent_with_logs, "irpd", lines=2).json()["lines"]] == [
        "irpd: swap to set b",
        "module cntr1: overrun 2",
    ]
    found = read(agent_with_logs, "irpd", grep="OVERRUN").json()["lines"]  # any case
    assert [x["message"] for x in found] == ["module cntr1: Overrun 1", "module cntr1: overrun 2"]
    late = read(agent_with_logs, "irpd", since="2026-01-31T09:00:00").json()["lines"]  # UTC without a zone
    assert [x["message"] for x in late] == ["irpd: swap to set b", "module cntr1: overrun 2"]
    both = read(agent_with_logs, "irpd", since="2026-01-31T10:00:00+01:00", grep="swap").json()["lines"]
    assert [x["message"] for x in both] == ["irpd: swap to set b"]
    assert read(agent_with_logs, "irpd", grep="[a-z]+(").json()["lines"] == []  # a plain string, not a pattern


def test_a_log_not_written_yet_is_empty(agent_with_logs):
    r = read(agent_with_logs, "agent")
    assert r.status_code == 200 and r.json()["lines"] == []


def test_a_long_line_is_cut_and_says_so(make_agent, tmp_path, no_journal):
    log = tmp_path / "irpd.log"
    log.write_text("x" * 20000 + "\n")
    agent = make_agent(irpd_log=log)
    message = read(agent, "irpd").json()["lines"][0]["message"]
    assert message.startswith("x" * logs.MAX_MESSAGE_CHARS) and "more characters" in message


def test_without_a_source_the_answer_says_how_to_get_one(make_agent, no_journal):
    r = read(make_agent(), "irpd")
    assert r.status_code == 404 and "--irpd-log" in r.json()["detail"] and "demo.sh" in r.json()["detail"]


def test_bounds_and_names_are_checked(agent_with_logs):
    for params in ({"lines": 0}, {"lines": logs.MAX_LINES + 1}, {"grep": "x" * 201}, {"since": "yesterday"}):
        assert read(agent_with_logs, "irpd", **params).status_code == 422, params
    assert read(agent_with_logs, "../etc/passwd").status_code in (404, 422)
    assert read(agent_with_logs, "kernel").status_code == 422


def test_logs_are_admin_only(agent_with_logs):
    for role in ("viewer", "operator"):
        assert read(agent_with_logs, "irpd", role=role).status_code == 403
        r = agent_with_logs.client.get(f"{API}/system/logs/irpd/follow", headers=agent_with_logs.h(role))
        assert r.status_code == 403


# ---- following a file, from a real agent -----------------------------------------------------------
def test_a_followed_log_sends_the_last_lines_then_each_new_one(tmp_path):
    log = tmp_path / "irpd.log"
    log.write_text("\n".join(LINES) + "\n")
    port, data = free_port(), tmp_path / "data"
    agent = start_agent(port, data, tmp_path / "no-irpd.sock", "--irpd-log", str(log))
    try:
        token = (data / "admin-token").read_text().strip()
        url = f"http://127.0.0.1:{port}{API}/system/logs/irpd/follow"
        got = []
        with httpx.stream(
            "GET", url, params={"lines": 2, "grep": "set"}, headers={"Authorization": f"Bearer {token}"}, timeout=20
        ) as r:
            assert r.status_code == 200 and r.headers["content-type"].startswith("application/x-ndjson")
            lines = r.iter_lines()
            got += [json.loads(next(lines)) for _ in range(2)]
            with open(log, "a") as f:  # written while followed: a match, a line that does not match, a match
                f.write("2026-01-31T10:00:00Z irpd: set c\nnothing here\n2026-01-31T10:00:01Z irpd: set d")
                f.flush()
                time.sleep(0.7)
                f.write(" (finished)\n")
            got += [json.loads(next(lines)) for _ in range(2)]
        assert [x["message"] for x in got] == [
            "irpd: started set a",
            "irpd: swap to set b",
            "irpd: set c",
            "irpd: set d (finished)",
        ]
        assert got[2]["time"] == "2026-01-31T10:00:00Z"
        # the follow ended with the client: the agent still answers, and follows again
        with httpx.stream("GET", url, headers={"Authorization": f"Bearer {token}"}, timeout=20) as r:
            assert r.status_code == 200
    finally:
        stop(agent)


# ---- the journal, through a stand-in journalctl ----------------------------------------------------
FAKE_JOURNALCTL = """#!/bin/sh
printf '%s\\n' "$@" > "{args}"
echo $$ > "{pid}"
printf '%s\\n' '{{"__REALTIME_TIMESTAMP": "1769846400000000", "MESSAGE": "irpd started", "_PID": "42", "PRIORITY": "6"}}'
printf '%s\\n' '{{"__REALTIME_TIMESTAMP": "1769846401500000", "MESSAGE": [104, 105, 255], "PRIORITY": "3"}}'
printf '%s\\n' 'not json'
case " $* " in *" --follow "*) exec sleep 60 ;; esac
"""


@pytest.fixture
def journalctl(tmp_path):
    script = tmp_path / "journalctl"
    args, pid = tmp_path / "args", tmp_path / "pid"
    script.write_text(FAKE_JOURNALCTL.format(args=args, pid=pid))
    script.chmod(script.stat().st_mode | stat.S_IXUSR)
    return script, args, pid


def test_the_journal_is_read_as_json_with_the_units_since_and_search(journalctl):
    script, args, _ = journalctl
    source = logs.JournalLog("irpd", "irpd.service", str(script))
    since = datetime(2026, 1, 31, 8, 0, tzinfo=UTC)
    lines, truncated = source.read(logs.LogQuery(lines=50, grep="a.b", since=None))
    sent = args.read_text().splitlines()
    assert "--output=json" in sent and "--unit=irpd.service" in sent and "--lines=50" in sent
    assert "--grep=a\\.b" in sent and "--case-sensitive=false" in sent  # the text escaped: no pattern
    assert lines == []  # journalctl's own --grep is checked again here: nothing holds "a.b"
    lines, truncated = source.read(logs.LogQuery(lines=50, since=since))
    assert f"--since=@{since.timestamp():.6f}" in args.read_text().splitlines()
    assert [x["message"] for x in lines] == ["irpd started", "hi\ufffd"]
    assert lines[0] == {
        "log": "irpd",
        "time": "2026-01-31T08:00:00.000000Z",
        "message": "irpd started",
        "pid": 42,
        "priority": 6,
    }
    assert lines[1]["time"] == "2026-01-31T08:00:01.500000Z" and lines[1]["priority"] == 3


def test_a_followed_journal_ends_its_journalctl_when_the_reader_stops(journalctl):
    script, args, pid = journalctl
    source = logs.JournalLog("agent", "indurop-agent.service", str(script))

    async def first_two():
        stream = source.follow(logs.LogQuery(lines=10))
        got = [await anext(stream), await anext(stream)]
        await stream.aclose()
        return got

    got = asyncio.run(first_two())
    assert [x["message"] for x in got] == ["irpd started", "hi\ufffd"]
    assert "--follow" in args.read_text().splitlines()
    child = int(pid.read_text())
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline:
        try:
            os.kill(child, 0)
        except ProcessLookupError:
            break
        time.sleep(0.05)
    else:
        pytest.fail(f"journalctl (pid {child}) still runs after the reader stopped")

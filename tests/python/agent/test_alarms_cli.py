"""test_alarms_cli.py -- `irpctl alarms`, `ack`, `shelve` and `unshelve` against the agent's real
routes (an in-process agent, irpctl's client on its transport): what they print, what they send,
and usage errors that exit 2 naming what to fix."""

from __future__ import annotations

import json
import time
from types import SimpleNamespace

import pytest
from indurop_agent.cli import alarms as cli_alarms
from indurop_agent.cli import client as client_module
from indurop_agent.cli import irpctl as cli


@pytest.fixture
def irpctl(agent, capsys, monkeypatch):
    """irpctl's main() against `agent`, with the token of a role: run(role, *argv) -> (code, out, err)."""
    for name in ("INDUROP_URL", "INDUROP_TOKEN", "INDUROP_TOKEN_FILE"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(
        cli,
        "Client",
        lambda url, token=None, **kw: client_module.Client(url, token, transport=agent.client._transport, **kw),
    )

    def run(role: str, *argv: str) -> tuple[int, str, str]:
        capsys.readouterr()
        code = cli.main(["--url", "http://testserver", "--token", agent.tokens[role], *argv])
        out, err = capsys.readouterr()
        return code, out, err

    agent.manager = agent.client.app.state.alarms
    agent.manager.declare(
        [
            {
                "module": "PLC",
                "declared": [{"id": 8, "severity": "high", "text": "drive communication lost", "origin": "module.xml"}],
            }
        ]
    )
    return run


def test_alarms_lists_what_needs_attention_with_the_counts(agent, irpctl):
    code, out, _ = irpctl("viewer", "alarms")
    assert code == 0 and out.startswith("no alarms (0 active, 0 unacknowledged, 0 shelved)")
    agent.manager.raise_alarm("PLC", "8", time.time_ns(), detail="comm lost: Invalid data", value=22)
    agent.manager.raise_alarm("ROBOT", "3", time.time_ns(), severity="low")
    code, out, _ = irpctl("viewer", "alarms")
    lines = out.splitlines()
    assert code == 0 and lines[0].split() == ["KEY", "STATE", "SEVERITY", "RAISED", "(UTC)", "TEXT"]
    assert lines[1].startswith("PLC/8") and "ACTIVE, unack" in lines[1] and "high" in lines[1]
    assert "drive communication lost -- comm lost: Invalid data" in lines[1]
    assert "2 active, 2 unacknowledged, 0 shelved" in lines
    code, out, _ = irpctl("viewer", "alarms", "--module", "ROBOT")
    assert "PLC/8" not in out and "ROBOT/3" in out
    code, out, _ = irpctl("viewer", "--json", "alarms")
    assert code == 0 and json.loads(out)["counts"]["active"] == 2


def test_ack_and_shelve_need_an_operator_and_say_what_they_did(agent, irpctl):
    agent.manager.raise_alarm("PLC", "8", time.time_ns())
    code, _, err = irpctl("viewer", "ack", "PLC/8")
    assert code == 1 and "needs the operator role" in err
    code, out, _ = irpctl("operator", "ack", "PLC/8")
    assert (code, out) == (0, "PLC/8: active_acknowledged\n")
    code, _, err = irpctl("operator", "ack", "PLC/8")
    assert code == 1 and "acknowledged already" in err
    code, _, err = irpctl("operator", "ack", "NOPE/1")
    assert code == 1 and "404" in err
    agent.manager.raise_alarm("ROBOT", "3", time.time_ns())
    code, out, _ = irpctl("operator", "ack", "--all")
    assert (code, out) == (0, "acknowledged 1: ROBOT/3\n")
    code, out, _ = irpctl("operator", "shelve", "ROBOT/3", "--minutes", "15", "--reason", "robot in manual mode")
    assert code == 0 and out.startswith("ROBOT/3: shelved until ") and "(robot in manual mode)" in out
    code, out, _ = irpctl("operator", "alarms")
    assert "shelved until" in out and "1 active, 0 unacknowledged, 1 shelved" in out.splitlines()
    code, out, _ = irpctl("operator", "unshelve", "ROBOT/3")
    assert (code, out) == (0, "ROBOT/3: active_acknowledged\n")
    assert [e["action"] for e in agent.audit()] == [
        "refused",  # the viewer's ack: a role refusal
        "alarm_ack",
        "alarm_ack",
        "alarm_ack",
        "alarm_ack_all",
        "alarm_shelve",
        "alarm_unshelve",
    ]


def test_the_history_prints_oldest_first_and_filters(agent, irpctl):
    t = time.time_ns()
    agent.manager.raise_alarm("PLC", "8", t - 7200 * 1_000_000_000, detail="old")
    agent.manager.clear_alarm("PLC", "8", t - 7100 * 1_000_000_000)
    agent.manager.raise_alarm("PLC", "8", t, detail="new")
    code, out, _ = irpctl("operator", "ack", "PLC/8")
    code, out, _ = irpctl("viewer", "alarms", "--history")
    lines = out.splitlines()
    assert code == 0 and lines[0].split()[:4] == ["SEQ", "TIME", "(UTC)", "KEY"]
    assert [line.split()[4] for line in lines[1:]] == ["raise", "clear", "raise", "acknowledge"]
    assert "by test-operator (operator)" in lines[-1]
    code, out, _ = irpctl("viewer", "alarms", "--history", "--since", "1h")
    assert [line.split()[4] for line in out.splitlines()[1:]] == ["raise", "acknowledge"]
    code, out, _ = irpctl("viewer", "alarms", "--history", "--state", "cleared_unacknowledged", "--json")
    assert [x["event"] for x in json.loads(out)["transitions"]] == ["clear"]


def test_follow_prints_the_transitions_as_they_come(agent, irpctl, monkeypatch):
    sleeps = []

    def sleep(s):
        sleeps.append(s)
        if len(sleeps) == 1:
            agent.manager.raise_alarm("PLC", "8", time.time_ns(), detail="comm lost")
        else:
            raise KeyboardInterrupt

    monkeypatch.setattr(cli_alarms, "time", SimpleNamespace(sleep=sleep))  # irpctl's sleeps only, no other thread's
    code, out, _ = irpctl("viewer", "--json", "alarms", "--follow", "--interval", "0.5")
    assert code == 0 and sleeps == [0.5, 0.5]
    followed = [json.loads(line) for line in out.splitlines()[-1:]]
    assert followed[0]["key"] == "PLC/8" and followed[0]["event"] == "raise"


@pytest.mark.parametrize(
    "argv, message",
    [
        (["ack"], "give an alarm KEY (irpctl alarms lists them) or --all"),
        (["ack", "PLC/8", "--all"], "give an alarm KEY (irpctl alarms lists them) or --all, not both"),
        (["ack", "PLC/8", "--module", "PLC"], "--module goes with --all"),
        (["shelve", "PLC/8", "--reason", "x"], "required: --minutes"),
        (["shelve", "PLC/8", "--minutes", "10"], "required: --reason"),
        (["shelve", "PLC/8", "--minutes", "0", "--reason", "x"], "give more than 0 minutes"),
        (["shelve", "PLC/8", "--minutes", "ten", "--reason", "x"], "'ten' is not a number of minutes"),
        (["shelve", "PLC/8", "--minutes", "10", "--reason", "  "], "--reason must say why"),
        (["alarms", "--since", "yesterday"], "'yesterday' is not a time"),
        (["alarms", "--since", "1h"], "--since go with --history"),
        (["alarms", "--severity", "urgent"], "invalid choice: 'urgent'"),
    ],
)
def test_usage_errors_exit_2_and_name_what_to_fix(irpctl, argv, message):
    code, _, err = irpctl("operator", *argv)
    assert code == 2 and message in err, err

"""test_protocol_limits.py -- the agent's request bodies hold irpd's ranges (protocol/control.json,
through the generated indurop_agent/irpd/protocol.py), tried at each edge: a value inside reaches irpd
(absent here: 503), one outside is refused by the agent (422) naming the field.  What irpd alone
decides (a module named twice, one the set lacks) is not checked here at all."""

from __future__ import annotations

import json

import pytest
from agent_helpers import API
from indurop_agent.irpd import protocol


def patch(agent, body: dict, name: str = "cntr1"):
    return agent.client.patch(f"{API}/modules/{name}", json=body, headers=agent.h("operator"))


def changes(agent, entries: list[dict]):
    return agent.client.post(
        f"{API}/modules/changes", json={"changes": entries, "dry_run": True}, headers=agent.h("operator")
    )


def refused_naming(r, field: str) -> bool:
    return r.status_code == 422 and field in json.dumps(r.json()["detail"])


def test_the_limits_are_the_ones_irpd_and_module_xml_hold():
    assert (protocol.PRIORITY_MIN, protocol.PRIORITY_MAX) == (0, 1_000_000)
    assert protocol.MAX_CHANGES == 1024


@pytest.mark.parametrize(
    "priority, passes",
    [
        (protocol.PRIORITY_MIN - 1, False),
        (protocol.PRIORITY_MIN, True),
        (protocol.PRIORITY_MAX, True),
        (protocol.PRIORITY_MAX + 1, False),
    ],
)
def test_priority_at_its_edges(agent, priority, passes):
    for r in (patch(agent, {"priority": priority}), changes(agent, [{"name": "cntr1", "priority": priority}])):
        if passes:
            assert r.status_code == 503, r.text  # past the agent: irpd is not there
        else:
            assert refused_naming(r, "priority"), r.text


def test_a_change_list_holds_up_to_max_changes(agent):
    entries = [{"name": f"m{i}", "enabled": False} for i in range(protocol.MAX_CHANGES + 1)]
    assert changes(agent, entries[:-1]).status_code == 503
    assert refused_naming(changes(agent, entries), "changes")


def test_period_and_module_name_at_their_edges(agent):
    assert refused_naming(patch(agent, {"period_ns": 0}), "period_ns")
    assert patch(agent, {"period_ns": 1}).status_code == 503
    longest = "n" * protocol.MAX_NAME_LENGTH
    assert changes(agent, [{"name": longest, "enabled": True}]).status_code == 503
    assert refused_naming(changes(agent, [{"name": longest + "n", "enabled": True}]), "name")


def test_what_only_irpd_knows_is_left_to_irpd(agent):
    """A module named twice is irpd's refusal (409 with its message when irpd runs), not the agent's."""
    r = changes(agent, [{"name": "cntr1", "priority": 1}, {"name": "cntr1", "period_ns": 1_000_000}])
    assert r.status_code == 503, r.text

"""test_live_answers.py -- a real irpd's answers hold the shapes protocol/control.json gives each
command's result (JSON Schema), and its refusals carry error codes the spec lists for that
command.  irpd runs the paper's Figure 1 set on an instance of its own."""

from __future__ import annotations

import importlib.util
import os
import time

import pytest
from indurop_agent.irpd.client import IrpdClient, IrpdRefused
from jsonschema import Draft202012Validator
from live_processes import FIG1, IRPD, ROOT, start_irpd, stop, wait_dispatching
from referencing import Registry, Resource
from referencing.jsonschema import DRAFT202012

_spec = importlib.util.spec_from_file_location("protocol_generate", ROOT / "protocol" / "generate.py")
generate = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(generate)

SPEC = generate.load()
COMMANDS = {c["name"]: c for c in SPEC["commands"]}
REGISTRY = Registry().with_resource("urn:indurop:control", Resource.from_contents(SPEC, DRAFT202012))

pytestmark = pytest.mark.skipif(
    not IRPD.exists() or not FIG1.exists(), reason=f"irpd and the paper-fig1 set are not built ({IRPD}): a full build"
)


def result_validator(name: str) -> Draft202012Validator:
    index = [c["name"] for c in SPEC["commands"]].index(name)
    return Draft202012Validator({"$ref": f"urn:indurop:control#/commands/{index}/result/schema"}, registry=REGISTRY)


@pytest.fixture(scope="module")
def irpd(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("irpd")
    instance = f"protocol-test-{os.getpid()}"
    process = start_irpd(tmp / "irpd.sock", FIG1, instance, "--state-dir", str(tmp / "state"))
    client = IrpdClient(str(tmp / "irpd.sock"), timeout_s=30)
    wait_dispatching(client)
    yield client
    client.close()
    stop(process)  # removes its segments if irpd had to be killed


def answer_of(irpd, command: str, /, **arguments):
    result = irpd.request(command, timeout=60, **arguments)
    errors = sorted(result_validator(command).iter_errors(result), key=lambda e: list(e.path))
    assert not errors, f"{command}: " + "; ".join(f"{'/'.join(map(str, e.path))}: {e.message}" for e in errors[:5])
    return result


def test_every_answer_has_the_shape_the_spec_gives(irpd):
    """Each command once (restart aside: it replaces the process), in an order that leaves the set
    as it was; every answer is validated against its command's result schema."""
    answered = set()
    for name, arguments in [
        ("status", {}),
        ("schedule", {}),
        ("modules", {}),
        ("stats", {}),
        ("alarms", {}),
        ("histograms", {}),
        ("histograms", {"name": "cntr1"}),
        ("events", {"since": 0, "limit": 10}),
        ("check", {"config": str(FIG1)}),
        ("trace", {}),
        ("write", {"path": "joint[1].y", "value": 1.5}),
        ("force", {"path": "joint[1].x", "value": 2.5, "by": "protocol-test"}),
        ("forces", {}),
        ("change", {"changes": [{"module": "cntr1", "priority": 9}], "dry_run": True}),
        ("set_priority", {"module": "cntr1", "priority": 9}),
        ("set_priority", {"module": "cntr1", "priority": 3}),
        ("disable", {"module": "cntr2"}),
        ("enable", {"module": "cntr2"}),
        ("set_period", {"module": "cntr2", "period_ns": 100_000}),
        ("load", {"config": str(FIG1), "set_id": "protocol-test"}),
        ("unforce", {"path": "joint[1].x", "restore": True}),
        ("clear_crash", {}),
    ]:
        answer_of(irpd, name, **arguments)
        answered.add(name)
    assert answered == set(COMMANDS) - {"restart"}
    kinds = {k["kind"] for k in SPEC["event_kinds"]}
    events = answer_of(irpd, "events")["events"]
    assert events and all(e["kind"] in kinds for e in events), [e["kind"] for e in events]


@pytest.mark.parametrize(
    "name, arguments, code",
    [
        ("histograms", {"name": "nope"}, "not_found"),
        ("set_priority", {"module": "nope", "priority": 1}, "not_found"),
        ("set_priority", {"module": "cntr1", "priority": -1}, "refused"),
        ("set_priority", {"module": "cntr1", "priority": 1_000_001}, "refused"),
        ("change", {"changes": [{"module": "cntr1", "enabled": True}] * 1025}, "refused"),
        ("load", {}, "refused"),
        ("write", {"path": "joint[1].y", "value": "x"}, "refused"),
        ("force", {"path": "joint[1]", "value": 1, "by": "protocol-test"}, "refused"),
        ("force", {"path": "joint[1].y", "value": 1}, "refused"),
        ("unforce", {"path": "joint[1].y"}, "not_found"),
        ("restart", {"config": "/nonexistent/module.xml"}, "refused"),
    ],
)
def test_refusals_carry_a_code_the_spec_lists_for_the_command(irpd, name, arguments, code):
    with pytest.raises(IrpdRefused) as refused:
        irpd.request(name, timeout=60, **arguments)
    assert refused.value.code == code, str(refused.value)
    assert code in COMMANDS[name]["errors"]
    error = refused.value.error  # the whole error object irpd sent
    shape = Draft202012Validator({"$ref": "urn:indurop:control#/shapes/error"}, registry=REGISTRY)
    assert not list(shape.iter_errors(error)), error


def test_a_refusal_and_a_check_give_the_place_as_fields(irpd, tmp_path):
    """A set with a bad <period>: `load`'s refusal and `check`'s problems both name the file, line,
    column, module and field as fields, the same as the message says in words."""
    text = FIG1.read_text()
    line = text.splitlines().index("    <period>500000</period>") + 1
    bad = tmp_path / "module.xml"
    bad.write_text(text.replace("<period>500000</period>", "<period>0</period>", 1))
    where = {"file": str(bad), "line": line, "column": 5, "module": "cntr1", "field": "period"}
    with pytest.raises(IrpdRefused) as refused:
        irpd.request("load", timeout=60, config=str(bad))
    assert {k: refused.value.error.get(k) for k in where} == where, refused.value.error
    assert refused.value.error["message"].startswith(f"{bad}:{line}: module 'cntr1': <period>")
    checked = answer_of(irpd, "check", config=str(bad))
    assert checked["valid"] is False
    assert checked["problems"][0]["message"] == checked["errors"][0]
    assert {k: checked["problems"][0].get(k) for k in where} == where, checked["problems"]


def test_an_argument_refusal_names_the_argument_as_its_field(irpd):
    with pytest.raises(IrpdRefused) as refused:
        irpd.request("set_priority", timeout=60, module="cntr1", priority=-1)
    assert refused.value.error.get("field") == "priority", refused.value.error

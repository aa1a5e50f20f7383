"""test_generated.py -- protocol/control.json is the control protocol's one description: each file
generated from it fails here when it is stale, naming the command that regenerates it; the
generator refuses what it cannot turn into code; the spec's shapes are valid JSON Schema and say
what irpd and the agent accept at the edges of each range."""

from __future__ import annotations

import copy
import importlib.util
import json
import re
from pathlib import Path

import pytest
from jsonschema import Draft202012Validator
from referencing import Registry, Resource
from referencing.jsonschema import DRAFT202012

ROOT = Path(__file__).resolve().parents[3]
_spec = importlib.util.spec_from_file_location("protocol_generate", ROOT / "protocol" / "generate.py")
generate = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(generate)

SPEC = generate.load()
OUTPUTS = generate.outputs(SPEC)


@pytest.mark.parametrize("path", sorted(OUTPUTS))
def test_the_generated_file_is_fresh(path):
    assert (ROOT / path).read_text() == OUTPUTS[path], (
        f"{path} is stale (protocol/control.json changed): run `{generate.COMMAND}`"
    )


def test_a_changed_spec_makes_every_output_stale(tmp_path):
    """The check compares with what the spec makes now: a new limit shows in every file."""
    (tmp_path / "protocol").mkdir()
    raw = json.loads((ROOT / "protocol" / "control.json").read_text())
    raw["limits"]["max_changes"]["value"] = 512
    (tmp_path / "protocol" / "control.json").write_text(json.dumps(raw))
    for path in OUTPUTS:
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / path).write_text((ROOT / path).read_text())
    assert sorted(generate.stale(tmp_path)) == sorted(OUTPUTS)


def broken(mutate) -> str:
    """The generator's refusal of the spec changed by `mutate`."""
    raw = json.loads((ROOT / "protocol" / "control.json").read_text())
    mutate(raw)
    path = Path(f"/tmp/indurop-protocol-test-{id(mutate)}.json")
    path.write_text(json.dumps(raw))
    try:
        with pytest.raises(generate.SpecError) as e:
            generate.outputs(generate.load(path))
        return str(e.value)
    finally:
        path.unlink()


def command(raw: dict, name: str) -> dict:
    return next(c for c in raw["commands"] if c["name"] == name)


@pytest.mark.parametrize(
    "mutate, says",
    [
        (
            lambda s: command(s, "set_priority")["arguments"]["properties"].__setitem__("x", {"type": "object"}),
            "#/commands/set_priority/arguments/properties/x: an argument is a value or a list",
        ),
        (
            lambda s: command(s, "events")["arguments"]["properties"]["limit"].__setitem__("type", "number"),
            "#/commands/events/arguments/properties/limit: type 'number' is none of",
        ),
        (lambda s: s["types"]["priority"].__setitem__("maximum", {"$limit": "nope"}), "no limit 'nope'"),
        (lambda s: command(s, "load")["errors"].append("exploded"), "'exploded' is not in #/errors"),
        (lambda s: s["types"]["module"].__setitem__("pattern", "^[a-z]+$"), "pattern: no language checks that"),
        (lambda s: command(s, "load")["arguments"]["required"].append("speed"), "speed not among the properties"),
        (lambda s: s["types"]["change_entry"].pop("unevaluatedProperties"), "takes no other members"),
        (lambda s: s["commands"].append(copy.deepcopy(command(s, "status"))), "a command is described twice"),
        (
            lambda s: s["shapes"]["left_out"]["items"].pop("title"),
            "#/shapes/left_out/items: an object in an answer has a \"title\"",
        ),
        (
            lambda s: s["shapes"]["crash_record"]["properties"]["time"].__setitem__("format", "date-time"),
            "#/shapes/crash_record/properties/time: format: the answer models do not say that",
        ),
        (
            lambda s: s["shapes"]["schedule"]["properties"]["slots"]["items"].__setitem__("title", "Schedule"),
            "a second model named Schedule",
        ),
    ],
)
def test_the_generator_refuses_what_it_cannot_generate(mutate, says):
    assert says in broken(mutate)


def test_the_docs_markers_must_be_there(tmp_path):
    text = (ROOT / generate.DOCS).read_text()
    without = re.sub(r"<!-- generated: limits .*?<!-- end generated: limits -->", "", text, flags=re.S)
    with pytest.raises(generate.SpecError, match="has no block <!-- generated: limits"):
        generate.docs(SPEC, without)


# ---- the spec's shapes as JSON Schema ------------------------------------------------------------

REGISTRY = Registry().with_resource("urn:indurop:control", Resource.from_contents(SPEC, DRAFT202012))


def validator(pointer: str) -> Draft202012Validator:
    return Draft202012Validator({"$ref": f"urn:indurop:control#{pointer}"}, registry=REGISTRY)


def pointer_of(name: str, part: str) -> str:
    index = [c["name"] for c in SPEC["commands"]].index(name)
    return f"/commands/{index}/{part}"


@pytest.mark.parametrize("name", [c["name"] for c in SPEC["commands"]])
def test_each_command_is_valid_json_schema(name):
    c = next(c for c in SPEC["commands"] if c["name"] == name)
    Draft202012Validator.check_schema(c["arguments"])
    Draft202012Validator.check_schema(c["result"]["schema"])
    assert c["result"]["description"] and c["errors"]


def valid(name: str, request: dict) -> bool:
    return validator(pointer_of(name, "arguments")).is_valid(request)


def test_the_spec_at_the_edges_of_its_ranges():
    low, high = SPEC["limits"]["priority_min"]["value"], SPEC["limits"]["priority_max"]["value"]
    assert (low, high) == (0, 1_000_000), "module.xml's range, the one every language holds"
    assert valid("set_priority", {"module": "m", "priority": low})
    assert valid("set_priority", {"module": "m", "priority": high})
    assert not valid("set_priority", {"module": "m", "priority": low - 1})
    assert not valid("set_priority", {"module": "m", "priority": high + 1})
    most = SPEC["limits"]["max_changes"]["value"]
    entry = {"module": "m", "enabled": True}
    assert valid("change", {"changes": [entry] * most})
    assert not valid("change", {"changes": [entry] * (most + 1)})
    assert not valid("change", {"changes": []})
    assert not valid("change", {"changes": [{"module": "m"}]}), "an entry changes at least one value"
    assert not valid("change", {"changes": [{"module": "m", "period": 5}]}), "no other members"
    assert valid("set_period", {"module": "m", "period_ns": 1})
    assert not valid("set_period", {"module": "m", "period_ns": 0})
    name = "n" * SPEC["limits"]["max_name_length"]["value"]
    assert valid("enable", {"module": name})
    assert not valid("enable", {"module": name + "n"})


def test_every_event_kind_irpd_logs_is_described():
    """The event kinds irpd adds (events.add("kind", ...) in rtcore) are the spec's, and each of the
    spec's is added somewhere."""
    added = set()
    for source in (ROOT / "rtcore" / "src").rglob("*.cpp"):
        added |= set(re.findall(r'\b(?:events|log_|log|events_)(?:\.|->)add\("([a-z_]+)"', source.read_text()))
    described = {k["kind"] for k in SPEC["event_kinds"]}
    assert added and added == described, (
        f"irpd adds {sorted(added - described)} undescribed; described but never added: {sorted(described - added)}"
    )


def test_no_error_code_is_written_out_by_hand():
    """The codes come from the generated files, never a literal where an error is made or its code
    compared: irpd's sources and the agent's."""
    codes = [e["code"] for e in SPEC["errors"]]
    literal = re.compile(r'"(' + "|".join(codes) + r')"')
    found = []
    for folder, pattern in ((ROOT / "rtcore" / "src", "*.[ch]pp"), (ROOT / "agent" / "indurop_agent", "*.py")):
        for source in folder.rglob(pattern):
            rel = source.relative_to(ROOT).as_posix()
            if rel in OUTPUTS or rel.startswith("agent/indurop_agent/api/routes/stream.py"):
                continue  # generated; the stream's own errors are its (docs/trace-and-stream.md)
            for number, line in enumerate(source.read_text().splitlines(), 1):
                in_code_context = any(word in line for word in ("code", "Error{", "failure(", "Refused("))
                if literal.search(line) and in_code_context and not line.lstrip().startswith(("//", "#")):
                    found.append(f"{rel}:{number}: {line.strip()}")
    assert not found, "error codes written out instead of taken from the generated files:\n" + "\n".join(found)


# ---- the agent's models of irpd's answers ------------------------------------------------------


def test_a_member_added_to_a_shape_makes_the_agents_models_stale_until_regenerated(tmp_path):
    """The models of irpd's answers are generated from the spec's shapes: a member irpd starts to
    send, once described, fails the check until the agent's protocol.py is regenerated, and then
    the agent's model has it."""
    (tmp_path / "protocol").mkdir()
    raw = json.loads((ROOT / "protocol" / "control.json").read_text())
    raw["shapes"]["swap_report"]["properties"]["drift_ns"] = {"type": "integer", "description": "how far it drifted"}
    raw["shapes"]["swap_report"]["required"].append("drift_ns")
    (tmp_path / "protocol" / "control.json").write_text(json.dumps(raw))
    for path in OUTPUTS:
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / path).write_text((ROOT / path).read_text())
    assert generate.stale(tmp_path) == [generate.PYTHON]
    regenerated = generate.outputs(generate.load(tmp_path / "protocol" / "control.json"), tmp_path)
    for path, text in regenerated.items():
        (tmp_path / path).write_text(text)
    assert generate.stale(tmp_path) == []
    assert '    drift_ns: int = Field(description="how far it drifted")\n' in regenerated[generate.PYTHON]


def test_the_api_answers_with_the_generated_models():
    """Where the agent passes irpd's answer on, its API's model is the generated one, or one made
    from it that adds or reshapes what the agent does (sets' activation reports, histograms'
    buckets); the spec's members are all there."""
    from indurop_agent.api import models
    from indurop_agent.irpd import protocol

    for generated, served, agent_only in [
        (protocol.SwapReport, models.SwapReport, {"mode", "downtime_ns"}),
        (protocol.Histograms, models.Histograms, set()),
        (protocol.HistogramRecord, models.HistogramRecord, set()),
        (protocol.VariableWritten, models.VariableValue, {"layout_hash", "forced"}),
    ]:
        assert set(served.model_fields) - agent_only == set(generated.model_fields), served.__name__
    assert issubclass(models.Histograms, protocol.Histograms) and issubclass(models.RestartNeed, protocol.IrpdShape)

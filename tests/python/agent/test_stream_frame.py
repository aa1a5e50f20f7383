"""test_stream_frame.py -- the stream frame is specified once (protocol/stream/frame.json): the files
generated from it are current, a changed field makes them stale, and the Python codec
(indurop_agent.api.stream_frame, used by the stream route and the client) decodes every frame of the
spec's vectors (protocol/stream/vectors.json, decoded by webui/tests/unit/frame.test.ts too) and
encodes them byte for byte."""

from __future__ import annotations

import importlib.util
import json
import math
import subprocess
import sys
from array import array

import pytest
from agent_helpers import ROOT
from indurop_agent.api import stream_frame
from indurop_agent.cli import client

GENERATE = ROOT / "protocol" / "stream" / "generate.py"
REGENERATE = "python3 protocol/stream/generate.py"
VECTORS = json.loads((ROOT / "protocol" / "stream" / "vectors.json").read_text())
# What each refusal of the vectors is called in the decoder's message.
REASONS = {
    "short": "too short",
    "magic": "not an indurop stream frame",
    "version": "this client reads version",
    "kind": "is not a sample frame",
    "length": "announces",
}


def generator():
    spec = importlib.util.spec_from_file_location("stream_frame_generate", GENERATE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_files_generated_from_the_spec_are_current():
    r = subprocess.run([sys.executable, str(GENERATE), "--check"], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, f"{r.stderr.strip()}\n(run `{REGENERATE}` and review the diff)"


@pytest.mark.parametrize(
    "change, stale",
    [
        ("a field's type", {"python", "typescript", "doc"}),  # the same bytes: the vectors stay
        ("a new field", {"python", "typescript", "vectors", "doc"}),
        ("the version", {"python", "typescript", "vectors", "doc"}),
    ],
)
def test_a_changed_spec_leaves_the_generated_files_stale(tmp_path, change, stale):
    gen = generator()
    changed = json.loads(gen.SPEC.read_text())
    if change == "a field's type":
        next(f for f in changed["header"] if f["name"] == "dropped")["type"] = "i64"
    elif change == "a new field":
        changed["header"].append({"name": "flags", "type": "u64", "meaning": "zero"})
    else:
        changed["version"] += 1
    path = tmp_path / "frame.json"
    path.write_text(json.dumps(changed))
    before, after = gen.load(gen.SPEC), gen.load(path)
    render = {
        "python": gen.python_module,
        "typescript": gen.typescript_module,
        "vectors": gen.vectors,
        "doc": gen.doc_table,
    }
    assert {name for name, f in render.items() if f(after) != f(before)} == stale


def test_a_spec_the_decoders_cannot_view_as_typed_arrays_is_refused(tmp_path):
    gen = generator()
    spec = json.loads(gen.SPEC.read_text())
    spec["header"].append({"name": "flags", "type": "u32", "meaning": "zero"})  # a 36-byte header
    path = tmp_path / "frame.json"
    path.write_text(json.dumps(spec))
    with pytest.raises(gen.SpecError, match="multiple of 8"):
        gen.load(path)


@pytest.mark.parametrize("vector", VECTORS["decode"], ids=lambda v: v["name"])
def test_every_vector_decodes_to_its_frame_and_encodes_back(vector):
    raw, want = bytes.fromhex(vector["hex"]), vector["frame"]
    f = stream_frame.decode(raw)
    assert (f.first_seq, len(f.t_ns), len(f.columns), f.dropped) == (
        want["first_seq"],
        want["count"],
        want["channels"],
        want["dropped"],
    )
    assert f.t_ns == want["t_ns"]
    assert f.columns == want["columns"]
    # -0.0 == 0.0: compare the signs too
    assert [[math.copysign(1, y) for y in c] for c in f.columns] == [
        [math.copysign(1, y) for y in c] for c in want["columns"]
    ]
    assert stream_frame.encode(want["first_seq"], want["t_ns"], want["columns"], want["dropped"]) == raw
    assert client.decode_frame(raw) == f  # the client decodes with the same codec


@pytest.mark.parametrize("vector", VECTORS["refuse"], ids=lambda v: v["name"])
def test_every_bad_vector_is_refused_naming_what_is_wrong(vector):
    with pytest.raises(stream_frame.FrameError, match=REASONS[vector["error"]]):
        stream_frame.decode(bytes.fromhex(vector["hex"]))


def test_the_stream_routes_arrays_encode_as_the_lists_do():
    t, columns = [5, -6, 2**62], [[0.25, 0.5, 0.75], [1.0, -1.0, 1e-300]]
    as_arrays = stream_frame.encode(9, array("q", t), [array("d", c) for c in columns], 3)
    assert as_arrays == stream_frame.encode(9, t, columns, 3)
    assert stream_frame.count(as_arrays) == 3
    assert stream_frame.size(3, 2) == len(as_arrays)
    assert stream_frame.kind(as_arrays) == stream_frame.KIND_SAMPLES
    assert stream_frame.kind(as_arrays[:3]) is None

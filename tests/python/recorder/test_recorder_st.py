"""test_recorder_st.py -- recordings and triggered captures of a Structured Text set's variables
(docs/recorder.md "The file"): stc builds a PROGRAM into a set, a real irpd and agent run it, and the
MCAP files name each variable's IEC type beside its C++ one, in the samples channel's metadata and
in its JSON Schema (read back with the mcap library); a capture's channels name it in the API too."""

from __future__ import annotations

import os
import sys

import orjson
import pytest
from indurop_agent.recorder import mcap_read
from indurop_agent.recorder.manager import Wanted
from indurop_agent.recorder.store import Store
from mcap.reader import make_reader
from recorder_helpers import IRPD, ROOT, SAMPLES, recorder_of, start_cell, stop, wait_done, wait_until

sys.path.insert(0, str(ROOT / "tests" / "python" / "st"))
from st_live import stc_build  # noqa: E402

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")

ST = """
PROGRAM Main
VAR count : DINT; elapsed : TIME; level : LREAL := 0.5; END_VAR
  count := count + 1;
  elapsed := elapsed + T#10ms;
END_PROGRAM
"""


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("recorder-st")
    built = stc_build(tmp, {"main.st": ST})
    assert built.returncode == 0, built.stdout + built.stderr
    irpd, agent, api, sock = start_cell(tmp, tmp / "set" / "module.xml", f"recorder-st-{os.getpid()}")
    yield api, sock
    stop(agent)
    stop(irpd)


def samples_channel(part):
    """The samples channel of an MCAP file and its JSON Schema's properties."""
    with open(part, "rb") as f:
        summary = make_reader(f).get_summary()
    (channel,) = [c for c in summary.channels.values() if c.topic == SAMPLES]
    return channel, orjson.loads(summary.schemas[channel.schema_id].data)["properties"]


def test_a_recording_of_st_variables_names_their_iec_types_beside_the_cpp_ones(cell, tmp_path):
    _, sock = cell
    store = Store(tmp_path / "recordings", quota_bytes=1 << 30)
    rec = recorder_of(store, sock)
    try:
        wanted = [("Main.count", ""), ("Main.elapsed", "ns"), ("Main.level", "")]
        rec.begin(Wanted("st", wanted, duration_s=0.5), "test")
        done = wait_done(store, "st")
    finally:
        rec.stop()
    assert done["state"] == "stopped" and done["rows"] > 0, done
    (part,) = store.get("st").parts()
    channel, schema = samples_channel(part)
    described = {d["path"]: d for d in orjson.loads(channel.metadata["indurop.variables"])}
    assert {p: (d["type"], d["iec_type"]) for p, d in described.items()} == {
        "Main.count": ("int32_t", "DINT"),
        "Main.elapsed": ("int64_t", "TIME"),
        "Main.level": ("double", "LREAL"),
    }
    assert schema["Main_elapsed"]["x-indurop-iec-type"] == "TIME"
    assert schema["Main_elapsed"]["description"].startswith("Main.elapsed (TIME (int64_t), ns)")
    # the recorder's own reader (exports, the API) gets them back from the file
    assert [v.iec_type for v in mcap_read.scan(part).variables] == ["DINT", "TIME", "LREAL"]


def test_the_api_lists_a_recordings_st_variables_with_their_iec_types(cell):
    api, _ = cell
    r = api.start("st-api", ["Main.count", "Main.level"], stop={"duration_s": 0.3})
    assert r.status_code in (200, 201), r.text
    listed = api.wait_state("st-api", "stopped")["variables"]
    assert [(v["path"], v["type"], v["iec_type"]) for v in listed] == [
        ("Main.count", "int32_t", "DINT"),
        ("Main.level", "double", "LREAL"),
    ]


def test_a_capture_of_st_variables_names_their_iec_types_in_the_api_and_its_shot(cell):
    api, _ = cell
    request = {
        "name": "st",
        "variables": ["Main.count", "Main.elapsed"],
        "trigger": {"kind": "manual"},
        "pre": {"rows": 10},
        "post": {"rows": 5},
    }
    armed = api.call("POST", "/captures", json=request)
    assert armed.status_code in (200, 201), armed.text
    capture_id = armed.json()["id"]
    channels = [(c["path"], c["type"], c["iec_type"]) for c in armed.json()["channels"]]
    assert channels == [("Main.count", "int32_t", "DINT"), ("Main.elapsed", "int64_t", "TIME")]

    def filled():
        """the capture's pre-trigger rows taken"""
        return api.call("GET", f"/captures/{capture_id}", "viewer").json()["pre_filled"] == 10

    wait_until(filled, 30, 0.1)
    assert api.call("POST", f"/captures/{capture_id}/trigger").status_code == 200

    def shot():
        """the shot saved"""
        return api.call("GET", f"/captures/{capture_id}", "viewer").json()["shots"]

    wait_until(shot, 30, 0.1)
    rows = api.call("GET", f"/captures/{capture_id}/shots/1", "viewer").json()
    assert [c["iec_type"] for c in rows["channels"]] == ["DINT", "TIME"]
    (part,) = (api.data / "recordings" / f"{capture_id}.shot-1").glob("*.mcap")
    channel, schema = samples_channel(part)
    described = orjson.loads(channel.metadata["indurop.variables"])
    assert [(d["path"], d["iec_type"]) for d in described] == [("Main.count", "DINT"), ("Main.elapsed", "TIME")]
    assert schema["Main_count"]["x-indurop-iec-type"] == "DINT"

"""test_node_opcua.py -- indurop-opcua checked with node-opcua's client (tests/opcua-client/client.mjs),
an OPC UA stack written apart from the server's asyncua, against a real irpd, agent and server on
127.0.0.1: node-opcua's certificate refused until an admin trusts it through the agent's API (no
restart); the tree it browses is GET /variables' leaves with their types, and every leaf reads what
GET /variables reads; an operator's write changes the variable, a viewer's is BadUserAccessDenied;
an anonymous session is refused; Aes128_Sha256_RsaOaep with Sign as well as Basic256Sha256 with
SignAndEncrypt; thousands of monitored items get BadTooManyMonitoredItems past the session's limit
and the agent and irpd go on; the nodes rebuilt after an online change (a model change event) while
a subscription on an unchanged variable goes on; a 1 kHz counter monitored at 10 ms, every
tenth value; and an active alarm sent again by ConditionRefresh, with its ConditionId.  What is asserted is the state reached and the values, never how fast."""

from __future__ import annotations

import hashlib
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest
from cryptography import x509
from cryptography.hazmat.primitives.serialization import Encoding

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import ALARMING, BUILD, ROOT, SIGNALS, copy_cell, signals_with_an_alarm, wait_until
from opcua_helpers import PASSWORDS, Controller, compare_held_leaves

sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.access.auth import now_iso

CLIENT = ROOT / "tests" / "opcua-client"
CELL = BUILD / "sets" / "plc-robot"
GROWN = BUILD / "tests" / "cpp" / "online" / "plc-robot-grown"
LIMIT_S = 120
NODE_TYPES = {  # the cell's C types as node-opcua names OPC UA's built-in types
    "short": "Int16",
    "unsigned short": "UInt16",
    "uint16_t": "UInt16",
    "int8_t": "SByte",
    "int32_t": "Int32",
    "uint32_t": "UInt32",
    "double": "Double",
}

pytestmark = [
    pytest.mark.skipif(not (CELL / "Robot.so").exists(), reason=f"the plc-robot cell is not built ({CELL})"),
    pytest.mark.skipif(
        not (CLIENT / "node_modules" / "node-opcua-client").is_dir(),
        reason="node-opcua is not installed: bash packaging/npm-ci.sh tests/opcua-client (tests/run.sh does it)",
    ),
]


class NodeClient:
    """client.mjs as a child process: one JSON command a line in, one answer a line out."""

    def __init__(self, pki: Path):
        self.pki, self.log = pki, pki.parent / f"{pki.name}.log"
        self.p = subprocess.Popen(
            ["node", str(CLIENT / "client.mjs"), str(pki)],
            cwd=CLIENT,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self.log.open("w"),
            text=True,
        )

    def __call__(self, op: str, **args) -> dict:
        self.p.stdin.write(json.dumps({"op": op, **args}) + "\n")
        self.p.stdin.flush()
        line = self.p.stdout.readline()
        assert line, f"client.mjs ended (exit {self.p.poll()}) on {op}: {self.log.read_text()[-3000:]}"
        return json.loads(line)

    def connect(self, cell: Controller, id: str, user: str | None = "oper", policy: str = "Basic256Sha256",
                mode: str = "SignAndEncrypt", **more) -> dict:  # fmt: skip
        return self(
            "connect", id=id, url=cell.url, policy=policy, mode=mode, user=user,
            password=PASSWORDS.get(user or ""), server_cert=str(cell.data / "opcua" / "server-cert.der"), **more,
        )  # fmt: skip

    def certificate(self) -> bytes:
        """node-opcua's own application certificate, DER."""
        pem = (self.pki / "own" / "certs" / "client_certificate.pem").read_bytes()
        return x509.load_pem_x509_certificate(pem).public_bytes(Encoding.DER)

    def close(self) -> None:
        try:
            self("quit")
        except (AssertionError, BrokenPipeError, ValueError):
            pass
        try:
            self.p.wait(10)
        except subprocess.TimeoutExpired:
            self.p.kill()
            self.p.wait()


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("node-opcua")
    config, _ = copy_cell(tmp / "plc-robot")
    c = Controller(tmp, config, "node-opcua")
    c.folder, c.xml = tmp / "plc-robot", config
    c.node = NodeClient(tmp / "node-pki")
    yield c
    c.node.close()
    c.close()


def ns2(path: str) -> str:
    return f"ns=2;s={path}"


def admin_change(cell, verb: str, thumbprint: str, headers: dict | None = None) -> httpx.Response:
    return httpx.post(f"{cell.api}/opcua/certificates/{thumbprint}/{verb}", headers=headers or cell.admin, timeout=30)


def test_node_opcuas_certificate_is_refused_until_an_admin_trusts_it_through_the_agent(cell):
    refused = cell.node.connect(cell, "a")
    assert refused.get("error") == "BadCertificateUntrusted", refused
    der = cell.node.certificate()
    sha1 = hashlib.sha1(der).hexdigest()
    wait_until(lambda: any(c["sha1"] == sha1 for c in cell.rest("/opcua")["rejected"]), LIMIT_S, 0.1)
    viewer = httpx.post(
        f"{cell.api}/tokens", json={"name": "node-viewer", "role": "viewer"}, headers=cell.admin, timeout=30
    )
    r = admin_change(cell, "trust", sha1, {"Authorization": f"Bearer {viewer.json()['token']}"})
    assert r.status_code == 403
    assert cell.node.connect(cell, "a").get("error") == "BadCertificateUntrusted"  # still refused
    r = admin_change(cell, "trust", sha1)
    assert r.status_code == 200 and r.json()["certificate"]["folder"] == "trusted", r.text
    assert cell.node.connect(cell, "a") == {"ok": True}  # the same server process: no restart
    state = cell.rest("/opcua")
    assert state["server"] == "ok" and state["security"]["warnings"] == []
    assert [c["sha1"] for c in state["trusted"] if c["sha1"] == sha1] == [sha1]
    audit = [e for e in cell.audit() if e["action"] == "opcua_trust" and e["result"] == "ok"]
    assert audit[-1]["target"] == hashlib.sha256(der).hexdigest()


def test_the_tree_node_opcua_browses_is_get_variables_with_its_types(cell):
    listed = cell.rest("/variables")
    browsed = cell.node("browse", id="a", root=ns2("PLC_ROBOT"))["variables"]
    found = {}
    for v in browsed:
        path = v["nodeId"].removeprefix("ns=2;s=")
        if v["valueRank"] == 1:
            (length,) = v["arrayDimensions"]
            found.update({f"{path}[{i}]": v["dataType"] for i in range(length)})
        else:
            assert v["valueRank"] == -1, v
            found[path] = v["dataType"]
    assert sorted(found) == sorted(v["path"] for v in listed["variables"])
    for v in listed["variables"]:
        assert found[v["path"]] == NODE_TYPES[v["type"]], v


def test_every_leaf_node_opcua_reads_is_what_get_variables_reads(cell):
    nodes = [v["nodeId"] for v in cell.node("browse", id="a", root=ns2("PLC_ROBOT"))["variables"]]
    before = {v["path"]: v["value"] for v in cell.rest("/variables/PLC_ROBOT")["values"]}
    values = cell.node("read", id="a", nodes=nodes)["values"]
    after = {v["path"]: v["value"] for v in cell.rest("/variables/PLC_ROBOT")["values"]}
    leaves = []
    for node, read in zip(nodes, values):
        assert read["status"] == "Good", (node, read)
        path, value = node.removeprefix("ns=2;s="), read["value"]
        leaves += [(f"{path}[{i}]", v) for i, v in enumerate(value)] if isinstance(value, list) else [(path, value)]
    compare_held_leaves(leaves, before, after)


def test_an_operators_write_changes_the_variable_and_a_viewers_is_refused(cell):
    assert cell.node.connect(cell, "view", user="view") == {"ok": True}
    override = ns2("PLC_ROBOT.PLC_IN.Override")
    assert cell.node("write", id="a", node=override, type="Double", value=0.75) == {"status": "Good"}
    assert cell.rest("/variables/PLC_ROBOT.PLC_IN.Override")["value"] == 0.75
    assert cell.node("write", id="view", node=override, type="Double", value=0.25) == {"status": "BadUserAccessDenied"}
    assert cell.rest("/variables/PLC_ROBOT.PLC_IN.Override")["value"] == 0.75
    cell.node("disconnect", id="view")
    writes = [e for e in cell.audit() if e["action"] == "write_variable" and e["target"] == "PLC_ROBOT.PLC_IN.Override"]
    assert [(e["who"]["name"], e["opcua_status"]) for e in writes[-2:]] == [
        ("oper", "Good"),
        ("view", "BadUserAccessDenied"),
    ]


def test_an_anonymous_session_is_refused(cell):
    answer = cell.node.connect(cell, "anon", user=None)  # no endpoint offers anonymous tokens: node-opcua stops
    assert "ANONYMOUS user token policy" in answer.get("error", ""), answer
    answer = cell.node.connect(cell, "anon", user=None, force_anonymous=True)  # sent anyway: the server refuses
    assert answer.get("error") == "BadIdentityTokenRejected", answer


def test_a_session_over_security_none_is_refused(cell):
    """node-opcua told to use None whether or not an endpoint offers it: no session, nothing read."""
    answer = cell.node.connect(cell, "none", policy="None", mode="None")  # no endpoint offers None: it stops
    assert "must exist" in answer.get("error", ""), answer
    answer = cell.node.connect(cell, "none", policy="None", mode="None", force_none=True)  # asked anyway
    assert answer.get("error") == "BadSecurityPolicyRejected", answer


def test_aes128_sha256_rsaoaep_with_sign_reads_and_writes(cell):
    assert cell.node.connect(cell, "aes", policy="Aes128_Sha256_RsaOaep", mode="Sign") == {"ok": True}
    read = cell.node("read", id="aes", nodes=[ns2("PLC_ROBOT.PLC_IN.Override")])["values"][0]
    assert read == {"value": cell.rest("/variables/PLC_ROBOT.PLC_IN.Override")["value"], "status": "Good"}
    assert cell.node("write", id="aes", node=ns2("PLC_ROBOT.PLC_IN.Override"), type="Double", value=0.5) == {
        "status": "Good"
    }
    assert cell.rest("/variables/PLC_ROBOT.PLC_IN.Override")["value"] == 0.5
    cell.node("disconnect", id="aes")


def test_thousands_of_monitored_items_from_one_client_are_bounded_and_the_rest_goes_on(cell):
    assert cell.node.connect(cell, "many", user="view") == {"ok": True}
    per_session = cell.settings["max_monitored_items_per_session"]
    per_call = cell.settings["max_monitored_items_per_call"]
    statuses = cell.node("many_items", id="many", node=ns2("PLC_ROBOT.IO_STATUS.cycles"), count=3000, per_call=per_call)
    assert statuses["statuses"] == {"Good": per_session, "BadTooManyMonitoredItems": 3000 - per_session}
    over = cell.node("many_items", id="many", node=ns2("PLC_ROBOT.IO_STATUS.cycles"), count=per_call + 1,
                     per_call=per_call + 1)  # fmt: skip
    assert over["statuses"] == {"BadTooManyOperations": per_call + 1}  # one call over the call's limit
    cell.node("disconnect", id="many")
    assert httpx.get(f"{cell.api}/health", timeout=10).status_code == 200
    assert cell.control.request("status")["running"]
    assert cell.node("read", id="a", nodes=[ns2("PLC_ROBOT.IO_STATUS.cycles")])["values"][0]["status"] == "Good"


@pytest.mark.skipif(not (GROWN / "grown_main.so").exists(), reason=f"the grown cell is not built ({GROWN})")
def test_nodes_are_rebuilt_after_an_online_change_while_a_subscription_goes_on(cell, tmp_path):
    grown = tmp_path / "grown"
    shutil.copytree(cell.folder, grown)
    shutil.copy(GROWN / "grown_main.so", grown / "main.so")
    shutil.copy(GROWN / "grown_Robot.so", grown / "Robot.so")
    shutil.copy(GROWN / "layout.json", grown / "layout.json")
    node = cell.node
    cycles = node("subscribe", id="a", node=ns2("PLC_ROBOT.IO_STATUS.cycles"), sampling=10, publishing=100)
    changes = node("events", id="a", fields=["EventType", "Changes"])
    assert cycles["status"] == "Good" and changes["status"] == "Good", (cycles, changes)
    seen = lambda: node("notifications", id="a", item=cycles["item"])["values"]  # noqa: E731
    wait_until(lambda: len(seen()) >= 5, LIMIT_S, 0.1)
    assert node("read", id="a", nodes=[ns2("PLC_ROBOT.OperatorNote")])["values"][0]["status"] == "BadNodeIdUnknown"
    report = cell.control.request("load", config=str(grown / cell.xml.name), set_id="grown", timeout=60)
    assert report["variables"]["added"] == ["PLC_ROBOT.OperatorNote"]
    events = lambda: node("notifications", id="a", item=changes["item"])["events"]  # noqa: E731
    wait_until(events, LIMIT_S, 0.1)
    added = [c["affected"] for e in events() for c in e["Changes"] or [] if c["verb"] & 1]
    assert "ns=2;s=PLC_ROBOT.OperatorNote" in added
    browsed = {v["nodeId"] for v in node("browse", id="a", root=ns2("PLC_ROBOT"))["variables"]}
    assert "ns=2;s=PLC_ROBOT.OperatorNote" in browsed
    assert node("read", id="a", nodes=[ns2("PLC_ROBOT.OperatorNote")])["values"][0] == {"value": 0, "status": "Good"}
    count = len(seen())
    wait_until(lambda: len(seen()) >= count + 20, LIMIT_S, 0.1)
    values = [v["value"] for v in seen()]
    assert values == sorted(values) and all(v["status"] == "Good" for v in seen())  # one subscription throughout


@pytest.mark.skipif(not (SIGNALS / "module.xml").exists(), reason=f"the signals set is not built ({SIGNALS})")
def test_a_1_khz_counter_monitored_at_10_ms_gets_every_tenth_value(tmp_path):
    shutil.copytree(SIGNALS, tmp_path / "signals")
    c = Controller(tmp_path, tmp_path / "signals" / "module.xml", "node-opcua-signals")
    node = NodeClient(tmp_path / "node-pki")
    try:
        assert node.connect(c, "s", user="view").get("error") == "BadCertificateUntrusted"
        sha1 = hashlib.sha1(node.certificate()).hexdigest()
        wait_until(lambda: any(x["sha1"] == sha1 for x in c.rest("/opcua")["rejected"]), LIMIT_S, 0.1)
        assert admin_change(c, "trust", sha1).status_code == 200
        assert node.connect(c, "s", user="view") == {"ok": True}
        # An item's values come from the segment until irpd traces its variable for the server; once
        # it does (status.json says so), a new item's values after its first come from the rings alone.
        node("subscribe", id="s", node=ns2("SIG.sample"), sampling=1000, publishing=100)
        since = now_iso()
        wait_until(
            lambda: (
                c.server_status().get("updated", "") > since and c.server_status()["sampling"]["from_trace_rings"] == 1
            ),
            LIMIT_S,
            0.1,
        )
        item = node("subscribe", id="s", node=ns2("SIG.sample"), sampling=10, publishing=100, queue=1000)
        assert item["status"] == "Good" and item["revised"] == 10, item
        seen = lambda: node("notifications", id="s", item=item["item"])["values"]  # noqa: E731
        wait_until(lambda: len(seen()) >= 200, LIMIT_S, 0.2)
        values = seen()
    finally:
        node.close()
        c.close()
    counts = [v["value"] for v in values[1:]]  # the first is the value when the item was made
    assert all(b - a == 10 for a, b in zip(counts, counts[1:])), counts[:50]  # every tenth row, none lost
    stamps = [v["source"] for v in values[1:]]
    assert all(b - a == 10 for a, b in zip(stamps, stamps[1:])), stamps[:50]  # the rows' due times, 10 ms apart


@pytest.mark.skipif(not ALARMING.exists(), reason=f"the alarming test module is not built ({ALARMING})")
def test_an_active_alarm_comes_again_with_its_condition_id_on_condition_refresh(tmp_path):
    xml = signals_with_an_alarm(tmp_path / "signals")
    c = Controller(tmp_path, xml, "node-opcua-alarm")
    node = NodeClient(tmp_path / "node-pki")
    jam = tmp_path / "signals" / "jam"
    try:
        node.connect(c, "s", user="view")  # refused (untrusted), and its certificate kept as rejected
        sha1 = hashlib.sha1(node.certificate()).hexdigest()
        wait_until(lambda: any(x["sha1"] == sha1 for x in c.rest("/opcua")["rejected"]), LIMIT_S, 0.1)
        assert admin_change(c, "trust", sha1).status_code == 200
        assert node.connect(c, "s", user="view") == {"ok": True}
        jam.touch()
        active = lambda: node("read", id="s", nodes=[ns2("@Controller.Alarms.ActiveCount")])["values"][0]  # noqa: E731
        wait_until(lambda: active()["value"] == 1, LIMIT_S, 0.1)
        wait_until(lambda: c.fresh_status()["alarm_events"] == 1, LIMIT_S, 0.1)  # the raise's event went out
        fields = ["EventType", "ConditionName", "ActiveState", "Severity", "ConditionId"]
        alarms = node("events", id="s", fields=fields)
        assert alarms["status"] == "Good", alarms
        events = lambda: node("notifications", id="s", item=alarms["item"])["events"]  # noqa: E731
        time.sleep(1)  # subscribed after the alarm was raised: it does not come by itself
        assert not [e for e in events() if e["ConditionName"] == "conveyor/5"], events()
        assert node("condition_refresh", id="s") == {"status": "Good"}
        wait_until(lambda: any(e["EventType"] == "ns=0;i=2788" for e in events()), LIMIT_S, 0.1)
        refreshed = events()
        assert c.fresh_status()["condition_refreshes"] == 1
    finally:
        jam.unlink(missing_ok=True)
        node.close()
        c.close()
    kinds = [e["EventType"] for e in refreshed]
    start, end = kinds.index("ns=0;i=2787"), kinds.index("ns=0;i=2788")  # RefreshStart, RefreshEnd
    between = [e for e in refreshed[start + 1 : end] if e["ConditionName"] == "conveyor/5"]
    assert len(between) == 1, refreshed
    assert between[0]["ActiveState"] == "Active" and between[0]["Severity"] == 750
    assert between[0]["ConditionId"] == "ns=2;s=@Controller.Alarms.conveyor/5"

"""test_sets_api.py -- the agent's API where irpd is not needed, or is absent on purpose: storing
and listing sets, who may do what, the audit log, the agent's events, tokens, the brute-force
lockout, the body limit, the validation of PATCH and PUT bodies, and the TLS options.
(With a real irpd v2: test_sets_irpd.py.)"""

from __future__ import annotations

import json
import stat
import subprocess
import sys
import time

import httpx
import pytest
from agent_helpers import API, ROOT, files_body, post_set, small_set
from indurop_agent import config
from indurop_agent.access.security import Lockout
from live_processes import free_port


def upload(agent, elves, **extra) -> dict:
    r = post_set(agent, *files_body({**small_set(elves), **extra}))
    assert r.status_code == 201, r.text
    return r.json()


# ---- sets ---------------------------------------------------------------------------------------
def test_an_upload_is_stored_unchecked_when_irpd_is_unreachable(agent, elves):
    s = upload(agent, elves)
    assert s["validation"] == {
        "valid": None,
        "errors": [],
        "problems": [],
        "warnings": ["not checked: irpd unreachable"],
        "schedule": None,
        "online": None,
        "restart": None,
        "variables": None,
        "modules": None,
    }
    assert s["by"]["name"] == "admin" and s["by"]["role"] == "admin" and len(s["by"]["id"]) == 12
    assert s["active"] is False
    assert {f["path"]: f["kind"] for f in s["files"]} == {
        "module.xml": "module_xml",
        "lib/ctl.so": "thread_module",
        "proc.exe": "executable",
        "layout.json": "layout",
        "README.md": "text",
    }
    manifest = json.loads((agent.data / "sets" / s["id"] / "manifest.json").read_text())
    assert manifest["validation"] == s["validation"] and manifest["files"] == s["files"]
    assert (agent.data / "sets" / s["id"] / "files" / "module.xml").read_bytes() == small_set(elves)["module.xml"]
    assert list((agent.data / "tmp").iterdir()) == []


def test_a_validation_stored_before_converted_variables_existed_is_still_read(agent, elves):
    s = upload(agent, elves)
    path = agent.data / "sets" / s["id"] / "manifest.json"
    manifest = json.loads(path.read_text())
    old = {"layout": "ab" * 32, "added": ["a.x"], "removed": [], "moved": [{"path": "a.y", "from": 0, "to": 64}]}
    manifest["validation"] |= {"valid": True, "online": True, "variables": old | {"replaced": []}}
    path.write_text(json.dumps(manifest))
    r = agent.client.get(f"{API}/sets/{s['id']}", headers=agent.h())
    assert r.status_code == 200, r.text
    variables = r.json()["validation"]["variables"]
    assert [m["path"] for m in variables["moved"]] == ["a.y"] and variables["converted"] is None


def test_the_same_set_twice_has_the_same_id(agent, elves):
    first, second = upload(agent, elves), upload(agent, elves)
    assert first["id"] == second["id"] and first["created"] == second["created"]
    assert len(agent.client.get(f"{API}/sets", headers=agent.h()).json()) == 1
    assert upload(agent, elves, **{"notes.txt": b"changed"})["id"] != first["id"]


def test_sets_are_listed_newest_first_and_read_by_id(agent, elves):
    a = upload(agent, elves)
    time.sleep(0.01)
    b = upload(agent, elves, **{"notes.txt": b"b"})
    listing = agent.client.get(f"{API}/sets", headers=agent.h("viewer")).json()
    assert [s["id"] for s in listing] == [b["id"], a["id"]]
    assert listing[0] == {
        "id": b["id"],
        "created": b["created"],
        "by": b["by"],
        "files": 6,
        "valid": None,
        "active": False,
    }
    assert agent.client.get(f"{API}/sets/{a['id']}", headers=agent.h("viewer")).json() == a


@pytest.mark.parametrize("bad", ["0123456789abcdef", "ZZZ", "0123456789ABCDEF", "0123456789abcdef0"])
def test_an_unknown_set_is_404(agent, bad):
    r = agent.client.get(f"{API}/sets/{bad}", headers=agent.h())
    assert r.status_code == 404 and "GET /api/v1/sets lists them" in r.json()["detail"]
    r = agent.client.post(f"{API}/sets/{bad}/activate", headers=agent.h("operator"))
    assert r.status_code == 404


def test_a_traversal_set_id_reaches_nothing(agent, elves):
    upload(agent, elves)
    for bad in ("..", "..%2f..%2fetc", "%2e%2e", "..%2ftokens.json"):
        assert agent.client.get(f"{API}/sets/{bad}", headers=agent.h()).status_code == 404
        assert agent.client.post(f"{API}/sets/{bad}/activate", headers=agent.h()).status_code == 404


def test_no_active_set_yet(agent):
    r = agent.client.get(f"{API}/sets/active", headers=agent.h("viewer"))
    assert r.status_code == 404 and "no set has been activated" in r.json()["detail"]
    r = agent.client.post(f"{API}/sets/rollback", headers=agent.h("operator"))
    assert r.status_code == 409 and "nothing to roll back to" in r.json()["detail"]


def test_activation_without_irpd_is_503_and_changes_nothing(agent, elves):
    s = upload(agent, elves)
    r = agent.client.post(f"{API}/sets/{s['id']}/activate", headers=agent.h("operator"))
    assert r.status_code == 503 and "not reachable" in r.json()["detail"]
    assert not (agent.data / "history.jsonl").exists() and not (agent.data / "active.json").exists()
    assert not (agent.data / "active").exists()
    assert agent.client.get(f"{API}/sets/{s['id']}", headers=agent.h()).json()["active"] is False
    line = agent.audit()[-1]
    assert (line["action"], line["target"], line["result"], line["status"]) == ("activate", s["id"], "error", 503)


# ---- roles --------------------------------------------------------------------------------------
ROUTES = [
    ("POST", "/sets", "admin"),
    ("GET", "/sets", "viewer"),
    ("GET", "/sets/active", "viewer"),
    ("GET", "/sets/0123456789abcdef", "viewer"),
    ("POST", "/sets/0123456789abcdef/activate", "operator"),
    ("POST", "/sets/rollback", "operator"),
    ("GET", "/modules/cntr1", "viewer"),
    ("PATCH", "/modules/cntr1", "operator"),
    ("PUT", "/variables/joint[1].y", "operator"),
    ("GET", "/events", "viewer"),
    ("GET", "/audit", "admin"),
    ("GET", "/tokens", "admin"),
    ("DELETE", "/tokens/0123456789ab", "admin"),
]
BODIES = {"PATCH": {"period_ns": 1000000}, "PUT": {"value": 1.0}}


@pytest.mark.parametrize("method, path, needed", ROUTES)
def test_every_new_route_needs_its_role(agent, method, path, needed):
    roles = ["viewer", "operator", "admin"]
    body = BODIES.get(method)
    assert agent.client.request(method, f"{API}{path}", json=body).status_code == 401
    for role in roles:
        r = agent.client.request(method, f"{API}{path}", json=body, headers=agent.h(role))
        if roles.index(role) < roles.index(needed):
            assert r.status_code == 403 and f"needs the {needed} role" in r.json()["detail"], (role, r.text)
        else:
            assert r.status_code not in (401, 403), (role, r.status_code, r.text)


# ---- audit --------------------------------------------------------------------------------------
def test_mutations_are_audited_with_who_where_what_and_hashes(agent, elves):
    s = upload(agent, elves, **{"notes/{0}%s%n.txt": b"free text"})
    created = agent.client.post(f"{API}/tokens", json={"name": "hmi", "role": "viewer"}, headers=agent.h()).json()
    lines = agent.audit()
    up, tok = lines[-2], lines[-1]
    assert up["action"] == "upload" and up["result"] == "ok" and up["target"] == s["id"] and up["new"] is True
    assert up["client"] == "testclient" and up["who"] == s["by"]
    assert up["files"] == {f["path"]: f["sha256"] for f in s["files"]}
    assert "notes/{0}%s%n.txt" in up["files"]  # free text kept as data, verbatim
    assert tok["action"] == "token_create" and tok["target"] == "hmi" and tok["token_id"] == created["id"]
    assert created["token"] not in (agent.data / "audit.jsonl").read_text()
    assert stat.S_IMODE((agent.data / "audit.jsonl").stat().st_mode) == 0o600
    assert all(line["time"].endswith("Z") for line in lines)


def test_the_audit_log_is_served_newest_last(agent, elves):
    for name in ("a", "b", "c"):
        agent.client.post(f"{API}/tokens", json={"name": name, "role": "viewer"}, headers=agent.h())
    log = agent.client.get(f"{API}/audit?limit=2", headers=agent.h()).json()
    assert [e["target"] for e in log] == ["b", "c"]
    assert agent.client.get(f"{API}/audit?limit=0", headers=agent.h()).status_code == 422


# ---- tokens -------------------------------------------------------------------------------------
def test_tokens_are_listed_without_secrets_and_revoked_by_id(agent):
    new = agent.client.post(f"{API}/tokens", json={"name": "hmi", "role": "operator"}, headers=agent.h()).json()
    listing = agent.client.get(f"{API}/tokens", headers=agent.h()).json()
    listed = next(t for t in listing if t["id"] == new["id"])
    assert (listed["name"], listed["role"]) == ("hmi", "operator") and listed["created"].endswith("Z")
    assert new["token"] not in json.dumps(listing)
    hmi = {"Authorization": f"Bearer {new['token']}"}
    assert agent.client.get(f"{API}/sets", headers=hmi).status_code == 200
    assert agent.client.delete(f"{API}/tokens/{new['id']}", headers=agent.h()).status_code == 204
    assert agent.client.get(f"{API}/sets", headers=hmi).status_code == 401
    assert agent.client.delete(f"{API}/tokens/{new['id']}", headers=agent.h()).status_code == 404
    line = [e for e in agent.audit() if e["action"] != "refused"][-2]  # the revoked token's 401 is audited between
    assert (line["action"], line["target"], line["name"], line["result"]) == ("token_revoke", new["id"], "hmi", "ok")


def test_a_minted_token_never_reads_as_a_command_line_option():
    """token_urlsafe starts with "-" one time in 32; irpctl --token would take it for an option."""
    from indurop_agent.access.auth import TOKEN_PREFIX, TokenStore

    tokens = [TokenStore._mint() for _ in range(200)]
    assert all(t.startswith(TOKEN_PREFIX) and len(t) > 40 for t in tokens)
    assert len(set(tokens)) == len(tokens)


def test_the_last_admin_token_cannot_be_revoked(agent):
    listing = agent.client.get(f"{API}/tokens", headers=agent.h()).json()
    admin_id = next(t["id"] for t in listing if t["role"] == "admin")
    r = agent.client.delete(f"{API}/tokens/{admin_id}", headers=agent.h())
    assert r.status_code == 409 and "last admin token" in r.json()["detail"]
    assert agent.client.get(f"{API}/tokens", headers=agent.h()).status_code == 200


# ---- events -------------------------------------------------------------------------------------
def test_events_have_the_agents_own_when_irpd_is_absent(agent, elves):
    s = upload(agent, elves)
    agent.client.post(f"{API}/tokens", json={"name": "hmi", "role": "viewer"}, headers=agent.h())
    page = agent.client.get(f"{API}/events", headers=agent.h("viewer")).json()
    assert page["irpd"].startswith("unavailable")
    assert [(e["source"], e["kind"]) for e in page["events"]] == [("agent", "upload"), ("agent", "token_create")]
    assert s["id"] in page["events"][0]["message"]
    assert [e["seq"] for e in page["events"]] == [1, 2] and page["agent_next"] == 3
    later = agent.client.get(f"{API}/events?agent_since={page['agent_next']}", headers=agent.h()).json()
    assert later["events"] == [] and later["agent_next"] == 3


# ---- lockout ------------------------------------------------------------------------------------
def test_unknown_tokens_lock_the_address_out_with_429(make_agent):
    agent = make_agent(lockout_attempts=3, lockout_window_s=60)
    bad = {"Authorization": "Bearer guessed"}
    assert [agent.client.get(f"{API}/sets", headers=bad).status_code for _ in range(2)] == [401, 401]
    r = agent.client.get(f"{API}/sets", headers=bad)
    assert r.status_code == 429 and r.headers["Retry-After"] == "60"
    r = agent.client.get(f"{API}/sets", headers=agent.h())  # even a good token, from that address
    assert r.status_code == 429 and 0 < int(r.headers["Retry-After"]) <= 60
    assert agent.client.get(f"{API}/health").status_code == 200  # no token, no lock
    line = agent.audit()[-1]
    assert line["action"] == "lockout" and line["client"] == "testclient"


def test_the_lockout_counts_per_address_within_the_window_and_expires():
    now = [1000.0]
    lock = Lockout(attempts=3, window_s=60, clock=lambda: now[0])
    assert not lock.failed("a") and not lock.failed("a") and not lock.failed("b")
    now[0] += 61  # the first two fall out of the window
    assert not lock.failed("a") and not lock.failed("a")
    assert lock.failed("a") and lock.retry_after("a") == 60 and lock.retry_after("b") == 0
    now[0] += 30
    assert lock.retry_after("a") == 30
    now[0] += 30
    assert lock.retry_after("a") == 0


# ---- body limit ---------------------------------------------------------------------------------
def test_a_large_body_is_refused_with_413_except_for_uploads(make_agent, elves):
    agent = make_agent(max_body_bytes=1024)
    big = {"name": "x" * 2000, "role": "viewer"}
    r = agent.client.post(f"{API}/tokens", json=big, headers=agent.h())
    assert r.status_code == 413 and "larger than 1024 bytes" in r.json()["detail"]

    def chunks():  # no Content-Length: counted as it streams
        yield b'{"name": "'
        for _ in range(10):
            yield b"x" * 200
        yield b'", "role": "viewer"}'

    r = agent.client.post(f"{API}/tokens", content=chunks(), headers={**agent.h(), "Content-Type": "application/json"})
    assert r.status_code == 413
    assert post_set(agent, *files_body(small_set(elves))).status_code == 201  # far over 1024 bytes


# ---- PATCH and PUT bodies -----------------------------------------------------------------------
@pytest.mark.parametrize(
    "body, field",
    [
        ({}, "at least one"),
        ({"period_ns": 0}, "period_ns"),
        ({"period_ns": "100"}, "period_ns"),
        ({"priority": -1}, "priority"),
        ({"enabled": "yes"}, "enabled"),
        ({"speed": 2}, "speed"),
    ],
)
def test_a_bad_module_patch_is_422_naming_the_field(agent, body, field):
    r = agent.client.patch(f"{API}/modules/cntr1", json=body, headers=agent.h("operator"))
    assert r.status_code == 422 and field in json.dumps(r.json()["detail"])


@pytest.mark.parametrize(
    "raw", ['{"value": "1"}', '{"value": null}', '{"value": NaN}', '{"value": Infinity}', '{"v": 1}', '{"value": [1]}']
)
def test_a_bad_variable_write_is_422(agent, raw):
    r = agent.client.put(
        f"{API}/variables/joint[1].y", content=raw, headers={**agent.h("operator"), "Content-Type": "application/json"}
    )
    assert r.status_code == 422, r.text


def test_writes_and_patches_without_irpd_are_503_and_audited(agent):
    r = agent.client.put(f"{API}/variables/joint[1].y", json={"value": True}, headers=agent.h("operator"))
    assert r.status_code == 503
    r = agent.client.patch(f"{API}/modules/cntr1", json={"enabled": False}, headers=agent.h("operator"))
    assert r.status_code == 503
    write, patch = agent.audit()[-2:]
    assert (write["action"], write["target"], write["value"], write["status"]) == (
        "write_variable",
        "joint[1].y",
        True,
        503,
    )
    assert (patch["action"], patch["changes"], patch["who"]["role"]) == ("patch_module", {"enabled": False}, "operator")


# ---- settings and TLS ---------------------------------------------------------------------------
def test_tls_takes_both_files_or_neither(tmp_path, capsys):
    cert, key = tmp_path / "c.pem", tmp_path / "k.pem"
    cert.write_text("c")
    key.write_text("k")
    with pytest.raises(SystemExit):
        config.parse(["--tls-cert", str(cert)])
    assert "--tls-cert needs --tls-key too" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        config.parse(["--tls-key", str(key)])
    assert "--tls-key needs --tls-cert too" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        config.parse(["--tls-cert", str(cert), "--tls-key", str(tmp_path / "missing.pem")])
    err = capsys.readouterr().err
    assert "tls_key" in err and "cannot be read" in err
    s = config.parse(["--tls-cert", str(cert), "--tls-key", str(key)])
    assert (s.tls_cert, s.tls_key, s.host) == (cert, key, "127.0.0.1")


def test_the_config_file_sets_limits_and_tls_and_refuses_unknown_keys(tmp_path, capsys):
    cert, key = tmp_path / "c.pem", tmp_path / "k.pem"
    cert.write_text("c")
    key.write_text("k")
    f = tmp_path / "agent.json"
    f.write_text(
        json.dumps(
            {
                "max_file_bytes": 1000,
                "max_upload_bytes": 5000,
                "max_files": 3,
                "tls_cert": str(cert),
                "tls_key": str(key),
                "lockout_attempts": 5,
            }
        )
    )
    s = config.parse(["--config", str(f)])
    assert (s.max_file_bytes, s.max_upload_bytes, s.max_files, s.lockout_attempts) == (1000, 5000, 3, 5)
    assert s.tls_cert == cert and s.tls_key == key
    for bad, words in [
        ({"max_files": "many"}, "'max_files' must be an integer"),
        ({"colour": 1}, "unknown keys colour"),
        ({"max_file_bytes": 0}, "max_file_bytes must be greater than 0"),
        ({"max_file_bytes": 10, "max_upload_bytes": 5}, "larger than max_upload_bytes"),
    ]:
        f.write_text(json.dumps(bad))
        with pytest.raises(SystemExit):
            config.parse(["--config", str(f)])
        assert words in capsys.readouterr().err


def test_the_agent_serves_https_with_tls_options(tmp_path):
    cert, key = tmp_path / "cert.pem", tmp_path / "key.pem"
    made = subprocess.run(
        [
            "openssl",
            "req",
            "-x509",
            "-newkey",
            "rsa:2048",
            "-nodes",
            "-days",
            "1",
            "-subj",
            "/CN=127.0.0.1",
            "-addext",
            "subjectAltName=IP:127.0.0.1",
            "-keyout",
            str(key),
            "-out",
            str(cert),
        ],
        capture_output=True,
        text=True,
    )
    assert made.returncode == 0, made.stderr
    port = free_port()
    p = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "indurop_agent",
            "--port",
            str(port),
            "--data-dir",
            str(tmp_path / "d"),
            "--irpd-socket",
            str(tmp_path / "none.sock"),
            "--tls-cert",
            str(cert),
            "--tls-key",
            str(key),
        ],
        cwd=ROOT / "agent",
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        deadline = time.monotonic() + 20
        while True:
            try:
                r = httpx.get(f"https://127.0.0.1:{port}{API}/health", verify=str(cert), timeout=1)
                break
            except httpx.HTTPError:
                assert p.poll() is None, p.stdout.read()
                assert time.monotonic() < deadline, "the agent did not come up with TLS"
                time.sleep(0.1)
        assert r.status_code == 200 and r.json()["agent"] == "ok"
        with pytest.raises(httpx.HTTPError):
            httpx.get(f"http://127.0.0.1:{port}{API}/health", timeout=2)  # plain HTTP is not served
    finally:
        p.terminate()  # by pid
        p.wait(10)


def test_a_sets_dds_json_is_checked_at_upload_and_stored_as_the_bridge_file(agent, elves):
    """docs/dds.md: dds.json's refusals name the file and the line; a good one is kind "bridge"."""
    bad = b'{"publish": [\n  {"topic": "9x", "type": "std_msgs/msg/Bool", "variable": "v"}]}'
    r = post_set(agent, *files_body({**small_set(elves), "dds.json": bad}))
    assert r.status_code == 400, r.text
    body = r.json()
    assert body["file"] == "dds.json" and body["line"] == 2, body
    assert "publish[0].topic" in body["detail"]
    two = b'{"subscribe": [{"topic": "a", "type": "std_msgs/msg/Bool", "variable": "v"},\n {"topic": "b", "type": "std_msgs/msg/Bool", "variable": "v"}]}'
    r = post_set(agent, *files_body({**small_set(elves), "dds.json": two}))
    assert r.status_code == 400 and "v would have two writers" in r.json()["detail"], r.text
    good = b'{"joint_states": {"rate_hz": 50}}'
    s = upload(agent, elves, **{"dds.json": good})
    assert {f["path"]: f["kind"] for f in s["files"]}["dds.json"] == "bridge"


def test_a_dds_json_with_a_bad_declared_type_or_mapping_is_refused_and_not_stored(agent, elves):
    """docs/dds.md "Declared message types": refused at upload naming the type or the mapping and
    the field; the set is not stored, so it never reaches irpd."""
    before = len(agent.client.get(f"{API}/sets", headers=agent.h()).json())
    types = '"types": {"cell_msgs/msg/Status": "float64 speed\\nfloat64[2] pair"}'
    publish = '"publish": [\n {"topic": "s", "type": "cell_msgs/msg/Status", "fields": {FIELDS}}]'
    for fields, words in (
        ('"speed": "P.S"', "field pair (float64[2]) is not mapped"),
        ('"speed": "P.S", "pair": ["P.A"]', "field pair (float64[2]) maps 1 variable; it has 2 elements"),
    ):
        text = "{" + types + ",\n" + publish.replace("FIELDS", fields) + "}"
        r = post_set(agent, *files_body({**small_set(elves), "dds.json": text.encode()}))
        assert r.status_code == 400, r.text
        body = r.json()
        assert body["file"] == "dds.json" and body["line"] == 3, body
        assert f"publish s (cell_msgs/msg/Status): {words}" in body["detail"]
    bad = b'{"types": {"cell_msgs/msg/Status": "float64[x] speed"}}'
    r = post_set(agent, *files_body({**small_set(elves), "dds.json": bad}))
    assert r.status_code == 400 and "types: cell_msgs/msg/Status: line 1 of its definition" in r.json()["detail"], (
        r.text
    )
    assert len(agent.client.get(f"{API}/sets", headers=agent.h()).json()) == before

"""test_scopes.py -- trace configurations kept with a set (GET/PUT/DELETE /sets/{id}/scopes/{name})
on in-process agents (no irpd): saved, listed, read and deleted with the roles the API says and
an audit line per change; names that could be paths, bodies that are not a capture request and
unknown sets refused with nothing written; at most MAX_CONFIGS per set; a prune removes them with
their set, and a backup carries them into another data folder; irpctl scope saves, lists, gets
and removes them.  docs/recorder.md "Trace configurations", docs/irpctl.md."""

from __future__ import annotations

import json
import stat

import httpx
import pytest
from agent_helpers import API, files_body, free_port, post_set, small_set, start_agent, stop
from indurop_agent.api.scope_models import MAX_CONFIGS
from indurop_agent.cli import irpctl as cli
from test_system_backup import backup, members, quiet_restarts, repack, restarted, restore, snapshot, with_manifest

WHO = {"id": None, "name": "test", "role": "admin"}
CONFIG = {
    "capture": {
        "name": "square rising",
        "variables": ["SIG.wave[4]", "SIG.wave[0]"],
        "trigger": {
            "kind": "condition",
            "combine": "or",
            "conditions": [
                {"kind": "edge", "variable": "SIG.wave[4]", "direction": "rising", "threshold": 0},
                {"kind": "window", "variable": "SIG.sample", "where": "outside", "low": -1, "high": 1, "hold_rows": 3},
            ],
        },
        "pre": {"rows": 200},
        "post": {"seconds": 0.1},
        "repeat": 0,
    },
    "plotted": ["SIG.wave[4]"],
    "mode": "xy",
    "xy": ["SIG.wave[0]", "SIG.wave[4]"],
}


def upload(agent, elves, note: bytes = b"# a set\n") -> str:
    files = small_set(elves)
    files["README.md"] = note
    r = post_set(agent, *files_body(files))
    assert r.status_code == 201, r.text
    return r.json()["id"]


def scopes(agent, set_id: str, name: str | None = None, method: str = "GET", role: str = "operator", body=None):
    path = f"{API}/sets/{set_id}/scopes" + (f"/{name}" if name is not None else "")
    return agent.client.request(method, path, json=body, headers=agent.h(role))


def folder(agent, set_id: str):
    return agent.data / "sets" / set_id / "scopes"


def test_a_configuration_is_saved_listed_read_replaced_and_deleted_with_an_audit_line_each(agent, elves):
    set_id = upload(agent, elves)
    assert scopes(agent, set_id, role="viewer").json()["scopes"] == []

    r = scopes(agent, set_id, "square", "PUT", body=CONFIG)
    assert r.status_code == 200, r.text
    saved = r.json()
    assert saved["name"] == "square" and saved["set_id"] == set_id and saved["error"] is None
    assert saved["by"]["name"] == "test-operator" and saved["saved"].endswith("Z")
    # what was asked comes back (defaults filled in: the capture request's own model)
    assert saved["config"]["capture"]["trigger"]["conditions"][0] == CONFIG["capture"]["trigger"]["conditions"][0]
    assert saved["config"]["capture"]["post"] == {"rows": None, "seconds": 0.1}
    assert saved["config"]["mode"] == "xy" and saved["config"]["xy"] == CONFIG["xy"]
    path = folder(agent, set_id) / "square.json"
    assert path.is_file() and stat.S_IMODE(path.stat().st_mode) == 0o644
    assert json.loads(path.read_text())["config"] == saved["config"]

    listed = scopes(agent, set_id, role="viewer").json()
    assert listed["max_configs"] == MAX_CONFIGS and [s["name"] for s in listed["scopes"]] == ["square"]
    assert listed["scopes"][0]["config"] == saved["config"] and listed["scopes"][0]["size"] == path.stat().st_size
    assert scopes(agent, set_id, "square", role="viewer").json()["config"] == saved["config"]

    changed = {**CONFIG, "mode": "time", "xy": None}
    r = scopes(agent, set_id, "square", "PUT", body=changed)
    assert r.status_code == 200 and r.json()["config"]["mode"] == "time" and r.json()["config"]["xy"] is None
    assert [s["name"] for s in scopes(agent, set_id).json()["scopes"]] == ["square"]

    assert scopes(agent, set_id, "square", "DELETE").status_code == 204
    assert not path.exists()
    r = scopes(agent, set_id, "square", role="viewer")
    assert r.status_code == 404 and "no trace configuration 'square'" in r.json()["detail"]
    assert scopes(agent, set_id, "square", "DELETE").status_code == 404

    lines = [(e["action"], e["target"], e["result"], e.get("new")) for e in agent.audit() if "scope" in e["action"]]
    assert lines == [
        ("scope_save", "square", "ok", True),
        ("scope_save", "square", "ok", False),
        ("scope_delete", "square", "ok", None),
        ("scope_delete", "square", "error", None),
    ]
    assert all(e["set_id"] == set_id for e in agent.audit() if "scope" in e["action"])


def test_roles_viewers_read_operators_change(agent, elves):
    set_id = upload(agent, elves)
    assert scopes(agent, set_id, "x", "PUT", "viewer", CONFIG).status_code == 403
    assert scopes(agent, set_id, "x", "PUT", "operator", CONFIG).status_code == 200
    assert scopes(agent, set_id, "x", "GET", "viewer").status_code == 200
    r = scopes(agent, set_id, "x", "DELETE", "viewer")
    assert r.status_code == 403 and "needs the operator role" in r.json()["detail"]
    assert agent.client.get(f"{API}/sets/{set_id}/scopes").status_code == 401
    assert scopes(agent, set_id, "x", "DELETE", "admin").status_code == 204


@pytest.mark.parametrize(
    "name",
    ["%2E%2E%2Fx", "..%2Fx", "a%2Fb", "a/b", ".hidden", "-x", "a%20b", "x" * 65, "%00", "a%5Cb", "%C3%A9"],
)
def test_names_that_could_be_paths_are_400_and_nothing_is_written(agent, elves, name):
    set_id = upload(agent, elves)
    before = agent.stored()
    r = scopes(agent, set_id, name, "PUT", body=CONFIG)
    assert r.status_code == 400, (name, r.status_code, r.text)
    assert "is not allowed: use 1 to 64 letters, digits" in r.json()["detail"]
    assert scopes(agent, set_id, name).status_code == 400
    assert scopes(agent, set_id, name, "DELETE").status_code == 400
    assert agent.stored() == before and not folder(agent, set_id).exists()
    assert not any((agent.data / "sets").rglob("x"))


@pytest.mark.parametrize(
    "body, says",
    [
        ({**CONFIG, "extra": 1}, "extra"),
        ({**CONFIG, "capture": {**CONFIG["capture"], "pre": {"rows": 1, "seconds": 1}}}, "one of the two"),
        ({**CONFIG, "capture": {**CONFIG["capture"], "variables": []}}, "at least 1"),
        (
            {
                **CONFIG,
                "capture": {
                    **CONFIG["capture"],
                    "trigger": {"kind": "condition", "conditions": [{"kind": "edge", "variable": "a"}] * 5},
                },
            },
            "at most 4",
        ),
        ({**CONFIG, "capture": {**CONFIG["capture"], "trigger": {"kind": "sometime"}}}, "sometime"),
        ({**CONFIG, "mode": "polar"}, "'time' or 'xy'"),  # what is allowed; the value sent is never echoed
        ({"plotted": ["a"]}, "capture"),
        ([], "dict"),
    ],
)
def test_a_body_that_is_not_a_configuration_is_422_with_pydantics_message(agent, elves, body, says):
    set_id = upload(agent, elves)
    before = agent.stored()
    r = scopes(agent, set_id, "bad", "PUT", body=body)
    assert r.status_code == 422, r.text
    assert says in json.dumps(r.json()["detail"])
    assert agent.stored() == before


def test_an_unknown_set_is_404_and_gets_no_folder(agent, elves):
    upload(agent, elves)
    before = agent.stored()
    for set_id in ("0123456789abcdef", "../../etc", "x" * 16, "0123456789ABCDEF"):
        for method in ("GET", "PUT", "DELETE"):
            r = scopes(agent, set_id, "square", method, body=CONFIG if method == "PUT" else None)
            assert r.status_code == 404, (set_id, method, r.text)
        r = scopes(agent, set_id)
        assert r.status_code in (404,), r.text
    assert "no set" in scopes(agent, "0123456789abcdef").json()["detail"]
    assert agent.stored() == before


def test_a_set_holds_at_most_max_configs_and_a_damaged_file_is_listed_with_why(agent, elves):
    set_id = upload(agent, elves)
    for i in range(MAX_CONFIGS):
        assert scopes(agent, set_id, f"c{i}", "PUT", body=CONFIG).status_code == 200
    r = scopes(agent, set_id, "one-more", "PUT", body=CONFIG)
    assert r.status_code == 409 and f"holds {MAX_CONFIGS} trace configurations" in r.json()["detail"]
    assert not (folder(agent, set_id) / "one-more.json").exists()
    assert scopes(agent, set_id, "c0", "PUT", body=CONFIG).status_code == 200  # replacing one is not one more
    assert scopes(agent, set_id, "c1", "DELETE").status_code == 204
    assert scopes(agent, set_id, "one-more", "PUT", body=CONFIG).status_code == 200

    (folder(agent, set_id) / "c2.json").write_text('{"name": "c2", "config": {"capture": {}}}')
    (folder(agent, set_id) / "c3.json").write_bytes(b"\xff not json")
    (folder(agent, set_id) / "c4.json").write_bytes(b" " * (256 << 10) + b"{}")
    listed = {s["name"]: s for s in scopes(agent, set_id, role="viewer").json()["scopes"]}
    assert listed["c2"]["config"] is None and "capture.variables" in listed["c2"]["error"]
    assert "not JSON" in listed["c3"]["error"] and "at most" in listed["c4"]["error"]
    assert listed["c5"]["error"] is None
    assert scopes(agent, set_id, "c2").status_code == 422
    assert scopes(agent, set_id, "c4").status_code == 413


def test_a_prune_removes_the_configurations_with_their_set(agent, elves):
    old, active = upload(agent, elves, b"# old\n"), upload(agent, elves, b"# active\n")
    agent.client.app.state.store.record_activation(active, "activate", WHO, {"generation": 1})
    for set_id in (old, active):
        assert scopes(agent, set_id, "kept", "PUT", body=CONFIG).status_code == 200
    r = agent.client.post(f"{API}/sets/prune", json={"keep_last": 0, "dry_run": False}, headers=agent.h())
    assert r.status_code == 200 and [s["id"] for s in r.json()["deleted"]] == [old]
    assert not (agent.data / "sets" / old).exists() and scopes(agent, old, "kept").status_code == 404
    assert scopes(agent, active, "kept").status_code == 200


def test_a_backup_carries_the_configurations_and_a_restore_brings_them_back(make_agent, elves):
    source, target = make_agent(), make_agent()
    set_id = upload(source, elves)
    source.client.app.state.store.record_activation(set_id, "activate", WHO, {"generation": 1})
    assert scopes(source, set_id, "square", "PUT", body=CONFIG).status_code == 200
    assert scopes(source, set_id, "other", "PUT", body={**CONFIG, "mode": "time"}).status_code == 200
    archive = backup(source)
    held = members(archive)
    name = f"data/sets/{set_id}/scopes/square.json"
    assert held[name] == (folder(source, set_id) / "square.json").read_bytes()
    assert f"data/sets/{set_id}/scopes/other.json" in held

    quiet_restarts(target)
    plan = restore(target, archive, dry_run=True).json()
    assert {f["path"]: f["action"] for f in plan["files"]}[f"sets/{set_id}/scopes/square.json"] == "add"
    assert restore(target, archive, dry_run=False).status_code == 200
    client = restarted(target)
    h = {"Authorization": f"Bearer {source.tokens['viewer']}"}  # the backup's tokens
    listed = client.get(f"{API}/sets/{set_id}/scopes", headers=h).json()["scopes"]
    assert [s["name"] for s in listed] == ["other", "square"]
    assert (folder(target, set_id) / "square.json").read_bytes() == (
        folder(source, set_id) / "square.json"
    ).read_bytes()


def test_a_backup_with_a_bad_configuration_or_one_of_a_set_it_lacks_is_refused(make_agent, elves):
    source, target = make_agent(), make_agent()
    set_id = upload(source, elves)
    assert scopes(source, set_id, "square", "PUT", body=CONFIG).status_code == 200
    held = {k: v for k, v in members(backup(source)).items() if k != "manifest.json"}
    before = snapshot(target.data)
    cases = [
        ({**held, f"data/sets/{set_id}/scopes/square.json": b'{"name": "square", "config": {"mode": "xy"}}'}, "square"),
        ({**held, f"data/sets/{'f' * 16}/scopes/x.json": held[f"data/sets/{set_id}/scopes/square.json"]}, "lacks"),
        ({**held, f"data/sets/{set_id}/scopes/..x.json": b"{}"}, "not a file a backup holds"),
    ]
    for files, says in cases:
        r = restore(target, repack(with_manifest(files)), dry_run=True)
        assert r.status_code == 400 and says in r.json()["detail"], r.text
    assert snapshot(target.data) == before


# ---- irpctl scope -----------------------------------------------------------------------------------
@pytest.fixture
def irpctl(tmp_path, capsys, monkeypatch, elves):
    """irpctl against a real agent (no irpd) holding one stored set, none active: (run, set id)."""
    for name in ("INDUROP_URL", "INDUROP_TOKEN", "INDUROP_TOKEN_FILE"):
        monkeypatch.delenv(name, raising=False)
    port, data = free_port(), tmp_path / "data"
    agent = start_agent(port, data, tmp_path / "no-irpd.sock")
    url, token_file = f"http://127.0.0.1:{port}", str(data / "admin-token")
    body, ctype = files_body(small_set(elves))
    token = (data / "admin-token").read_text().strip()
    r = httpx.post(
        f"{url}{API}/sets", content=body, headers={"Authorization": f"Bearer {token}", "Content-Type": ctype}
    )
    assert r.status_code == 201, r.text

    def run(*argv: str) -> tuple[int, str, str]:
        capsys.readouterr()
        code = cli.main(["--url", url, "--token-file", token_file, *argv])
        out, err = capsys.readouterr()
        return code, out, err

    yield run, r.json()["id"]
    stop(agent)


def test_irpctl_scope_saves_lists_gets_and_removes_a_configuration(irpctl, tmp_path):
    run, set_id = irpctl
    code, _, err = run("scope", "list")  # no set active through the agent
    assert code == 1 and "give --set ID" in err
    request = tmp_path / "capture.json"
    request.write_text(json.dumps(CONFIG["capture"]))  # a bare capture request, as `capture arm` sends
    code, out, err = run("scope", "save", "square", str(request), "--set", set_id)
    assert code == 0, err
    assert out.strip() == f"saved square with set {set_id}"
    code, out, err = run("scope", "list", "--set", set_id)
    assert code == 0, err
    assert "1 of at most 100" in out and "square" in out and "SIG.wave[4] rising 0 or SIG.sample outside" in out
    written = tmp_path / "square.json"
    code, out, err = run("scope", "get", "square", "--set", set_id, "-o", str(written))
    assert code == 0 and f"wrote {written}" in out
    config = json.loads(written.read_text())
    assert config["capture"]["pre"] == {"rows": 200, "seconds": None} and config["mode"] == "time"
    config["mode"] = "xy"  # what get wrote is what save takes
    written.write_text(json.dumps(config))
    assert run("scope", "save", "square", str(written), "--set", set_id)[0] == 0
    code, out, _ = run("--json", "scope", "get", "square", "--set", set_id)
    assert json.loads(out)["config"]["mode"] == "xy"
    code, _, err = run("scope", "save", "../x", str(written), "--set", set_id)
    assert code == 1 and "is not allowed" in err
    bad = tmp_path / "bad.json"
    bad.write_text('{"capture": {"variables": []}}')
    code, _, err = run("scope", "save", "bad", str(bad), "--set", set_id)
    assert code == 1 and "422" in err
    code, out, err = run("scope", "rm", "square", "--set", set_id)
    assert code == 0 and f"deleted square of set {set_id}" in out
    code, _, err = run("scope", "rm", "square", "--set", set_id)
    assert code == 1 and "no trace configuration 'square'" in err


def test_links_made_by_hand_in_a_set_folder_are_not_followed(agent, elves, tmp_path):
    set_id, elsewhere = upload(agent, elves), tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "x.json").write_text(json.dumps({"name": "x", "config": CONFIG}))
    folder(agent, set_id).symlink_to(elsewhere)
    r = scopes(agent, set_id, "y", "PUT", body=CONFIG)
    assert r.status_code == 409 and "is not a folder the agent made" in r.json()["detail"]
    assert scopes(agent, set_id, role="viewer").json()["scopes"] == []
    assert sorted(p.name for p in elsewhere.iterdir()) == ["x.json"]
    folder(agent, set_id).unlink()
    folder(agent, set_id).mkdir()
    (folder(agent, set_id) / "x.json").symlink_to(elsewhere / "x.json")
    assert scopes(agent, set_id, role="viewer").json()["scopes"] == []
    assert scopes(agent, set_id, "x", role="viewer").status_code == 404

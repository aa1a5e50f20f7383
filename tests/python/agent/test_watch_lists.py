"""test_watch_lists.py -- watch lists kept with a set (GET/PUT/DELETE /sets/{id}/watches/{name}) on
in-process agents (no irpd), as the trace configurations are (sets/kept.py): a prune removes them with
their set, a backup carries them into another data folder beside the trace configurations, and a
backup holding a list that is not one is refused naming it.  docs/programming.md "Watch lists",
docs/set-store.md "Kept with a set".  The live routes: test_monitor_api.py."""

from __future__ import annotations

from agent_helpers import API
from test_scopes import CONFIG, WHO, scopes, upload
from test_system_backup import backup, members, quiet_restarts, repack, restarted, restore, snapshot, with_manifest

WATCH = {"paths": ["PLC_ROBOT.I0", "main.ResetRobot.Execute"]}


def watches(agent, set_id: str, name: str | None = None, method: str = "GET", role: str = "operator", body=None):
    path = f"{API}/sets/{set_id}/watches" + (f"/{name}" if name is not None else "")
    return agent.client.request(method, path, json=body, headers=agent.h(role))


def test_a_prune_removes_the_watch_lists_with_their_set(agent, elves):
    old, active = upload(agent, elves, b"# old\n"), upload(agent, elves, b"# active\n")
    agent.client.app.state.store.record_activation(active, "activate", WHO, {"generation": 1})
    for set_id in (old, active):
        assert watches(agent, set_id, "cell", "PUT", body=WATCH).status_code == 200
    r = agent.client.post(f"{API}/sets/prune", json={"keep_last": 0, "dry_run": False}, headers=agent.h())
    assert r.status_code == 200 and [s["id"] for s in r.json()["deleted"]] == [old]
    assert watches(agent, old, "cell").status_code == 404
    assert watches(agent, active, "cell", role="viewer").json()["config"] == WATCH


def test_a_backup_carries_the_watch_lists_and_a_restore_brings_them_back(make_agent, elves):
    source, target = make_agent(), make_agent()
    set_id = upload(source, elves)
    source.client.app.state.store.record_activation(set_id, "activate", WHO, {"generation": 1})
    assert watches(source, set_id, "cell", "PUT", body=WATCH).status_code == 200
    assert scopes(source, set_id, "square", "PUT", body=CONFIG).status_code == 200
    archive = backup(source)
    name = f"data/sets/{set_id}/watches/cell.json"
    assert members(archive)[name] == (source.data / "sets" / set_id / "watches" / "cell.json").read_bytes()

    quiet_restarts(target)
    plan = restore(target, archive, dry_run=True).json()
    files = {f["path"]: f for f in plan["files"]}
    assert files[f"sets/{set_id}/watches/cell.json"]["action"] == "add"
    assert "watch list" in files[f"sets/{set_id}/watches/cell.json"]["what"]
    assert restore(target, archive, dry_run=False).status_code == 200
    client = restarted(target)
    h = {"Authorization": f"Bearer {source.tokens['viewer']}"}  # the backup's tokens
    assert client.get(f"{API}/sets/{set_id}/watches/cell", headers=h).json()["config"] == WATCH
    assert [s["name"] for s in client.get(f"{API}/sets/{set_id}/scopes", headers=h).json()["scopes"]] == ["square"]


def test_a_backup_with_a_list_that_is_not_one_is_refused(make_agent, elves):
    source, target = make_agent(), make_agent()
    set_id = upload(source, elves)
    assert watches(source, set_id, "cell", "PUT", body=WATCH).status_code == 200
    held = {k: v for k, v in members(backup(source)).items() if k != "manifest.json"}
    before = snapshot(target.data)
    bad = {**held, f"data/sets/{set_id}/watches/cell.json": b'{"name": "cell", "config": {"paths": "PLC_ROBOT.I0"}}'}
    r = restore(target, repack(with_manifest(bad)), dry_run=True)
    assert r.status_code == 400 and "is not a watch list" in r.json()["detail"], r.text
    assert snapshot(target.data) == before

"""test_system_prune.py -- POST /sets/prune on an in-process agent (no irpd): the dry run deletes
nothing and says what would go; a prune keeps the active set, the rollback target, the newest N
and every blob they use (its tree stays loadable), deletes the rest and the blobs only they used,
is audited and admin only.  docs/set-store.md, "Pruning"."""

from __future__ import annotations

import time

from agent_helpers import API, files_body, post_set, small_set

WHO = {"id": None, "name": "test", "role": "admin"}


def upload(agent, elves, note: bytes, extra: bytes | None = None) -> str:
    files = small_set(elves)
    files["README.md"] = note
    if extra is not None:
        files["notes.txt"] = extra  # a file only this set has
    r = post_set(agent, *files_body(files))
    assert r.status_code == 201, r.text
    time.sleep(0.002)  # distinct creation times: "the newest" is well defined
    return r.json()["id"]


def prune(agent, keep_last: int, dry_run: bool, role: str = "admin"):
    return agent.client.post(
        f"{API}/sets/prune", json={"keep_last": keep_last, "dry_run": dry_run}, headers=agent.h(role)
    )


def listed(agent) -> list[str]:
    return sorted(s["id"] for s in agent.client.get(f"{API}/sets", headers=agent.h()).json())


def test_a_prune_keeps_the_active_set_and_every_blob_it_uses(make_agent, elves):
    agent = make_agent()
    store = agent.client.app.state.store
    oldest = upload(agent, elves, b"# 1\n", extra=b"only in the oldest set\n")
    middle = upload(agent, elves, b"# 2\n", extra=b"only in the middle set\n")
    earlier = upload(agent, elves, b"# 3\n")
    active = upload(agent, elves, b"# 4\n", extra=b"only in the active set\n")
    newest = upload(agent, elves, b"# 5\n")
    store.record_activation(oldest, "activate", WHO, {"generation": 1})
    store.record_activation(earlier, "activate", WHO, {"generation": 2})
    store.record_activation(active, "activate", WHO, {"generation": 3})
    # the oldest upload, active before the active one: the rollback target, kept however old
    store.record_activation(oldest, "activate", WHO, {"generation": 4})
    store.record_activation(active, "activate", WHO, {"generation": 5})
    assert store.active_id() == active and store.rollback_target() == oldest

    before = agent.stored()
    dry = prune(agent, 1, dry_run=True)
    assert dry.status_code == 200, dry.text
    report = dry.json()
    assert report["dry_run"] is True
    assert sorted(s["id"] for s in report["deleted"]) == sorted([middle, earlier])
    assert sorted(report["kept"]) == sorted([newest, active, oldest])
    # the blobs only the deleted sets use: their READMEs and the middle one's notes
    assert len(report["blobs"]) == 3
    assert report["bytes"] == len(b"# 2\n") + len(b"# 3\n") + len(b"only in the middle set\n")
    assert agent.stored() == before  # a dry run deletes nothing

    done = prune(agent, 1, dry_run=False)
    assert done.status_code == 200, done.text
    assert done.json()["deleted"] == report["deleted"] and done.json()["blobs"] == report["blobs"]
    assert listed(agent) == sorted([newest, active, oldest])
    for set_id in (newest, active, oldest):  # every kept set's tree is whole, its blobs there
        manifest = store.manifest(set_id)
        for f in manifest["files"]:
            assert (store.blobs / f["sha256"]).is_file(), f
            assert (store.files_dir(set_id) / f["path"]).is_file(), f
    assert (agent.data / "active" / "notes.txt").read_bytes() == b"only in the active set\n"
    assert not (store.sets / middle).exists() and not (store.sets / earlier).exists()
    assert not list(store.sets.glob(".partial-*"))
    entry = agent.audit()[-1]
    assert entry["action"] == "sets_prune" and entry["result"] == "ok" and entry["keep_last"] == 1
    assert sorted(entry["deleted"]) == sorted([middle, earlier]) and entry["blobs"] == 3

    again = prune(agent, 1, dry_run=False).json()  # nothing left to delete
    assert again["deleted"] == [] and again["blobs"] == []


def test_keep_zero_keeps_the_active_set_only_with_its_rollback_target(make_agent, elves):
    agent = make_agent()
    store = agent.client.app.state.store
    a, b, c = (upload(agent, elves, f"# {n}\n".encode()) for n in range(3))
    store.record_activation(a, "activate", WHO, None)
    store.record_activation(b, "activate", WHO, None)
    assert prune(agent, 0, dry_run=False).status_code == 200
    assert listed(agent) == sorted([a, b])
    assert c not in listed(agent)


def test_a_store_without_an_active_set_keeps_the_newest_n(make_agent, elves):
    agent = make_agent()
    ids = [upload(agent, elves, f"# {n}\n".encode()) for n in range(4)]
    assert prune(agent, 2, dry_run=False).status_code == 200
    assert listed(agent) == sorted(ids[2:])


def test_prune_checks_its_body_and_is_admin_only(make_agent, elves):
    agent = make_agent()
    upload(agent, elves, b"# x\n")
    for body in ({"keep_last": -1}, {"keep_last": "2"}, {"dry_run": True}, {"keep_last": 1, "extra": 1}):
        r = agent.client.post(f"{API}/sets/prune", json=body, headers=agent.h())
        assert r.status_code == 422, (body, r.text)
    for role in ("viewer", "operator"):
        r = prune(agent, 0, dry_run=True, role=role)
        assert r.status_code == 403 and "admin" in r.json()["detail"]
    assert len(listed(agent)) == 1

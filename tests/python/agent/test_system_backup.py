"""test_system_backup.py -- GET /system/backup and POST /system/restore on in-process agents (no
irpd): a backup restored into an empty data folder brings back the same sets, active set, tokens
and users (who sign in with the same password); the dry run changes nothing and says what would change; secrets only when asked;
an altered archive is refused, and so is every hostile one (traversal, absolute names, links,
devices, FIFOs, too many members, size bombs, ...), each with a 4xx naming what is wrong and the
data folder untouched.  docs/administration.md, "Backup and restore"."""

from __future__ import annotations

import gzip
import hashlib
import io
import json
import tarfile

import pytest
from agent_helpers import API, files_body, post_set, small_set
from fastapi.testclient import TestClient
from indurop_agent.api.app import create_app
from indurop_agent.config import Settings
from indurop_agent.sets.archives import LimitedReader
from indurop_agent.system import restore as restoring
from indurop_agent.system.restart import AgentRestarter

# the people seeded() adds through the API, with their passwords
PEOPLE = {"ana": ("admin", "correct horse battery"), "olaf": ("operator", "staple gun 42 meters")}


def quiet_restarts(agent) -> list[str]:
    """The agent's own restart replaced by a recorder (it would end this test process)."""
    asked = []
    agent.client.app.state.agent_restart = AgentRestarter("test", terminate=lambda: asked.append("exit"), delay_s=0)
    return asked


def seeded(agent, elves) -> dict:
    """Two sets (the first one active), two users and an audit line: what a backup must carry."""
    ids = []
    for note in (b"# one\n", b"# two\n"):
        files = small_set(elves)
        files["README.md"] = note
        r = post_set(agent, *files_body(files))
        assert r.status_code == 201, r.text
        ids.append(r.json()["id"])
    state = agent.client.app.state
    state.store.record_activation(ids[0], "activate", {"id": None, "name": "test", "role": "admin"}, {"generation": 1})
    for name, (role, password) in PEOPLE.items():
        r = agent.client.post(
            f"{API}/users", json={"name": name, "role": role, "password": password}, headers=agent.h()
        )
        assert r.status_code == 201, r.text
    return {"ids": ids, "active": ids[0]}


def sign_in(client: TestClient, name: str, password: str) -> int:
    return client.post(f"{API}/session", json={"name": name, "password": password}).status_code


def backup(agent, **params) -> bytes:
    r = agent.client.get(f"{API}/system/backup", params=params, headers=agent.h())
    assert r.status_code == 200, r.text
    assert r.headers["content-type"] == "application/gzip"
    assert "indurop-backup-" in r.headers["content-disposition"]
    return r.content


def restore(agent, body: bytes, dry_run: bool, role: str = "admin", content_type: str = "application/gzip"):
    return agent.client.post(
        f"{API}/system/restore",
        params={"dry_run": str(dry_run).lower()},
        content=body,
        headers={**agent.h(role), "Content-Type": content_type},
    )


def members(archive: bytes) -> dict[str, bytes]:
    with tarfile.open(fileobj=io.BytesIO(archive), mode="r:gz") as tar:
        return {m.name: tar.extractfile(m).read() for m in tar if m.isfile()}


def repack(files: list[tuple[str, bytes] | tarfile.TarInfo]) -> bytes:
    """A .tar.gz of (name, content) files and ready-made TarInfo entries, in this order."""
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz", format=tarfile.PAX_FORMAT) as tar:
        for f in files:
            if isinstance(f, tarfile.TarInfo):
                tar.addfile(f, io.BytesIO(b"\0" * f.size) if f.isfile() else None)
            else:
                info = tarfile.TarInfo(f[0])
                info.size = len(f[1])
                tar.addfile(info, io.BytesIO(f[1]))
    return buf.getvalue()


def with_manifest(files: dict[str, bytes], extra_manifest: list[dict] | None = None) -> list[tuple[str, bytes]]:
    """The files with a manifest.json that lists them truthfully (plus `extra_manifest` entries)."""
    listed = [{"path": n, "size": len(c), "sha256": hashlib.sha256(c).hexdigest()} for n, c in files.items()]
    manifest = {"format": "indurop-backup", "version": 1, "files": listed + (extra_manifest or [])}
    return [("manifest.json", json.dumps(manifest).encode()), *files.items()]


def snapshot(folder) -> dict[str, bytes]:
    """Every regular file under the data folder but the audit log (refusals are audited), by path."""
    return {
        str(p.relative_to(folder)): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and not p.is_symlink() and p.name != "audit.jsonl" and "tmp" not in p.relative_to(folder).parts
    }


def restarted(agent) -> TestClient:
    """A new agent on the same data folder: what the restart after a restore starts."""
    settings = Settings(data_dir=agent.data, irpd_socket=str(agent.data.parent / "no-irpd.sock"))
    return TestClient(create_app(settings, restore=False))


# ---- a backup and its restore ----------------------------------------------------------------------
def test_a_backup_restored_into_an_empty_data_folder_brings_back_sets_active_set_tokens_and_users(make_agent, elves):
    source, target = make_agent(), make_agent()
    seed = seeded(source, elves)
    archive = backup(source, with_secrets="true")
    asked = quiet_restarts(target)

    review = restore(target, archive, dry_run=True)
    assert review.status_code == 200, review.text
    plan = review.json()
    assert plan["dry_run"] is True and plan["restarting"] is False
    assert sorted(plan["sets"]["added"]) == sorted(seed["ids"]) and plan["sets"]["kept"] == []
    assert plan["active_set"] == {"now": None, "after": seed["active"]}
    assert plan["users"] == {"now": None, "after": len(PEOPLE)}
    assert {f["path"]: f["action"] for f in plan["files"]}["tokens.json"] == "replace"
    assert not (target.data / "restore-pending").exists() and asked == []

    done = restore(target, archive, dry_run=False)
    assert done.status_code == 200, done.text
    assert done.json()["restarting"] is True and target.client.app.state.agent_restart.requested
    assert (target.data / "restore-pending").is_dir()

    client = restarted(target)  # the agent after its restart
    h = {"Authorization": f"Bearer {source.tokens['admin']}"}  # the source's token works here now
    listed = client.get(f"{API}/sets", headers=h)
    assert listed.status_code == 200, listed.text
    assert sorted(s["id"] for s in listed.json()) == sorted(seed["ids"])
    active = client.get(f"{API}/sets/active", headers=h).json()
    assert active["id"] == seed["active"]
    assert client.get(f"{API}/audit", headers=h).json()[-1]["action"] == "restore_applied"
    assert client.get(f"{API}/sets", headers=target.h()).status_code == 401  # the target's own tokens are gone
    assert (target.data / "users.json").read_bytes() == (source.data / "users.json").read_bytes()
    for name, (role, password) in PEOPLE.items():  # the people sign in here with their passwords
        assert sign_in(client, name, password) == 200
        assert client.get(f"{API}/session").json()["role"] == role
        assert sign_in(client, name, password + "!") == 401
    assert (target.data / "active").resolve() == (target.data / "sets" / seed["active"] / "files").resolve()
    assert (target.data / "active" / "module.xml").read_bytes() == small_set(elves)["module.xml"]
    for set_id in seed["ids"]:  # the trees, made again from the blobs
        assert (target.data / "sets" / set_id / "files" / "lib" / "ctl.so").read_bytes() == elves.module
    assert not (target.data / "restore-pending").exists()
    aside = list(target.data.glob("replaced-*"))
    assert len(aside) == 1 and (aside[0] / "tokens.json").is_file()  # the replaced files are kept


def test_a_backup_without_secrets_leaves_out_the_password_hashes_and_the_tls_key(make_agent, elves):
    agent = make_agent()
    seeded(agent, elves)
    (agent.data / "tls").mkdir()
    (agent.data / "tls" / "cert.pem").write_text("cert")
    (agent.data / "tls" / "key.pem").write_text("key")
    plain = members(backup(agent))
    manifest = json.loads(plain["manifest.json"])
    assert manifest["format"] == "indurop-backup" and manifest["with_secrets"] is False
    stored = json.loads((agent.data / "users.json").read_text())
    redacted = json.loads(plain["data/users.json"])
    assert set(redacted["users"]) == set(PEOPLE) and all(u["hash"] == "" for u in redacted["users"].values())
    for name, user in redacted["users"].items():  # everything else as stored
        assert {**user, "hash": stored["users"][name]["hash"]} == stored["users"][name]
    assert "data/tls/key.pem" not in plain and plain["data/tls/cert.pem"] == b"cert"
    assert "data/tokens.json" in plain and "data/admin-token" not in plain  # hashes only, never the clear token
    for f in manifest["files"]:  # every file listed with its size and SHA-256
        assert hashlib.sha256(plain[f["path"]]).hexdigest() == f["sha256"] and len(plain[f["path"]]) == f["size"]
    secret = members(backup(agent, with_secrets="true"))
    assert json.loads(secret["data/users.json"]) == stored and secret["data/tls/key.pem"] == b"key"
    actions = [e for e in agent.audit() if e["action"] == "backup"]
    assert [e["with_secrets"] for e in actions] == [False, True] and actions[0]["who"]["name"] == "admin"


def test_the_dry_run_of_a_backup_without_secrets_warns_that_users_need_new_passwords(make_agent, elves):
    source, target = make_agent(), make_agent()
    seeded(source, elves)
    plan = restore(target, backup(source), dry_run=True).json()
    assert any("without their password hashes" in w for w in plan["warnings"]), plan["warnings"]


def test_users_restored_without_secrets_sign_in_only_once_an_admin_sets_their_passwords(make_agent, elves):
    source, target = make_agent(), make_agent()
    seeded(source, elves)
    quiet_restarts(target)
    assert restore(target, backup(source), dry_run=False).status_code == 200
    client = restarted(target)
    role, password = PEOPLE["olaf"]
    assert sign_in(client, "olaf", password) == 401  # no hash came: no password matches, not even ""
    assert sign_in(client, "olaf", "") in (401, 422)
    h = {"Authorization": f"Bearer {source.tokens['admin']}"}
    r = client.put(f"{API}/users/olaf/password", json={"password": "a new one for him 7"}, headers=h)
    assert r.status_code == 204, r.text
    assert sign_in(client, "olaf", "a new one for him 7") == 200


def test_only_admins_back_up_and_restore(make_agent, elves):
    agent = make_agent()
    archive = backup(agent)
    for role in ("viewer", "operator"):
        r = agent.client.get(f"{API}/system/backup", headers=agent.h(role))
        assert r.status_code == 403 and "admin" in r.json()["detail"]
        assert restore(agent, archive, dry_run=True, role=role).status_code == 403


# ---- refused archives ------------------------------------------------------------------------------
def refused(agent, body: bytes, status: int, *words: str, content_type: str = "application/gzip") -> str:
    before = snapshot(agent.data)
    r = restore(agent, body, dry_run=False, content_type=content_type)
    assert r.status_code == status, r.text
    detail = r.json()["detail"]
    for w in words:
        assert w in detail, detail
    assert snapshot(agent.data) == before  # nothing changed
    assert not (agent.data / "restore-pending").exists()
    assert not list((agent.data / "tmp").iterdir())  # nothing left behind
    assert agent.audit()[-1]["action"] == "restore_backup" and agent.audit()[-1]["result"] == "error"
    return detail


@pytest.fixture
def pair(make_agent, elves):
    """(an agent with sets, its backup, an empty agent to restore into)."""
    source = make_agent()
    seeded(source, elves)
    return source, backup(source, with_secrets="true"), make_agent()


def test_a_tampered_archive_is_refused_naming_the_member(pair):
    _, archive, target = pair
    files = members(archive)
    blob = next(n for n in files if n.startswith("data/blobs/"))
    files[blob] = bytes([files[blob][0] ^ 1]) + files[blob][1:]  # one bit, same size
    refused(target, repack(list(files.items())), 400, json.dumps(blob), "SHA-256", "altered or damaged")


def test_a_set_manifest_altered_with_its_hash_is_refused_by_the_set_id(pair):
    _, archive, target = pair
    files = members(archive)
    name = next(n for n in files if n.startswith("data/sets/"))
    m = json.loads(files[name])
    m["files"][0]["path"] = "other.xml"
    files[name] = json.dumps(m).encode()
    del files["manifest.json"]
    refused(target, repack(with_manifest(files)), 400, "another set id")


def test_a_set_manifest_naming_a_path_outside_its_tree_is_refused(pair):
    _, archive, target = pair
    files = members(archive)
    name = next(n for n in files if n.startswith("data/sets/"))
    m = json.loads(files[name])
    m["files"][0]["path"] = "../../../../tmp/evil"
    files[name] = json.dumps(m).encode()
    del files["manifest.json"]
    refused(target, repack(with_manifest(files)), 400, "not safe to restore")


def test_a_member_missing_from_the_archive_is_refused(pair):
    _, archive, target = pair
    files = members(archive)
    gone = next(n for n in files if n.startswith("data/blobs/"))
    manifest = files.pop("manifest.json")
    del files[gone]
    refused(target, repack([("manifest.json", manifest), *files.items()]), 400, "lacks 1 file", json.dumps(gone))


def test_a_member_not_in_the_manifest_is_refused(pair):
    _, archive, target = pair
    files = members(archive)
    refused(target, repack([*files.items(), ("data/tokens.json.extra", b"{}")]), 400, "not in the archive's manifest")


@pytest.mark.parametrize(
    "name, words",
    [
        ("data/../../../../tmp/indurop-evil", ["climbs out", "'..'"]),
        ("/etc/indurop-evil", ["absolute"]),
        ("data\\..\\evil", ["backslash"]),
        ("data/evil\x1b[31m", ["control character"]),
        ("data//tokens.json", ["empty or '.'"]),
    ],
)
def test_a_member_with_an_unsafe_name_is_refused(pair, name, words):
    _, archive, target = pair
    files = members(archive)
    refused(target, repack([*files.items(), (name, b"x")]), 400, *words)
    assert not list(target.data.parent.glob("**/indurop-evil"))


def link(name: str, kind: bytes, target: str = "") -> tarfile.TarInfo:
    info = tarfile.TarInfo(name)
    info.type, info.linkname = kind, target
    return info


@pytest.mark.parametrize(
    "entry, words",
    [
        (link("data/tokens.json", tarfile.SYMTYPE, "/etc/shadow"), ["symbolic link", "/etc/shadow"]),
        (link("data/history.jsonl", tarfile.LNKTYPE, "/etc/passwd"), ["hard link"]),
        (link("data/audit.jsonl", tarfile.CHRTYPE), ["device"]),
        (link("data/audit.jsonl", tarfile.BLKTYPE), ["device"]),
        (link("data/audit.jsonl", tarfile.FIFOTYPE), ["FIFO"]),
    ],
    ids=["symlink", "hardlink", "char-device", "block-device", "fifo"],
)
def test_links_devices_and_fifos_are_refused(pair, entry, words):
    _, archive, target = pair
    files = members(archive)
    manifest = files.pop("manifest.json")
    refused(target, repack([("manifest.json", manifest), entry, *files.items()]), 400, json.dumps(entry.name), *words)


def test_an_archive_with_too_many_members_is_refused(make_agent, pair):
    source, archive, _ = pair
    small = make_agent(max_backup_members=5)
    files = members(archive)
    assert len(files) > 6
    refused(small, archive, 413, "max_backup_members")


def test_a_size_bomb_stops_at_the_limit(make_agent):
    target = make_agent(max_backup_bytes=1 << 20)
    bomb = {"data/audit.jsonl": b"\0" * (8 << 20)}  # 8 MiB of zeros: about 8 kB compressed
    body = repack(with_manifest(bomb))
    assert len(body) < 100_000
    refused(target, body, 413, "max_backup_bytes")


def test_a_member_larger_than_its_manifest_says_is_refused_before_it_is_read(pair):
    _, archive, target = pair
    files = members(archive)
    manifest = json.loads(files.pop("manifest.json"))
    victim = next(f for f in manifest["files"] if f["path"] == "data/tokens.json")
    victim["size"] = 2
    refused(target, repack([("manifest.json", json.dumps(manifest).encode()), *files.items()]), 400, "manifest says 2")


def test_the_decompressed_stream_is_cut_at_its_limit():
    reader = LimitedReader(io.BytesIO(b"\0" * 5000), 4096, restoring.RestoreError, "max_backup_bytes")
    assert len(reader.read(4000)) == 4000
    with pytest.raises(restoring.RestoreError) as e:
        reader.read(4000)
    assert e.value.status == 413 and "max_backup_bytes" in e.value.message


def test_a_huge_pax_header_is_refused(pair):
    _, archive, target = pair
    files = members(archive)
    manifest = files.pop("manifest.json")
    info = tarfile.TarInfo("data/history.jsonl")
    info.pax_headers = {"comment": "x" * (256 << 10)}
    refused(target, repack([("manifest.json", manifest), info, *files.items()]), 400, "extended header")


@pytest.mark.parametrize(
    "body, status, words",
    [
        (b"", 400, ["empty"]),
        (b"this is not gzip", 400, ["not a readable .tar.gz"]),
        (gzip.compress(b"not a tar archive at all" * 100), 400, ["not a readable .tar.gz"]),
    ],
    ids=["empty", "not-gzip", "not-tar"],
)
def test_what_is_not_an_archive_is_refused(make_agent, body, status, words):
    refused(make_agent(), body, status, *words)


def test_an_archive_that_does_not_start_with_its_manifest_is_refused(pair):
    _, archive, target = pair
    files = members(archive)
    manifest = files.pop("manifest.json")
    refused(target, repack([*files.items(), ("manifest.json", manifest)]), 400, "not manifest.json")


def test_a_backup_of_a_newer_format_is_refused(make_agent):
    manifest = json.dumps({"format": "indurop-backup", "version": 99, "agent_version": "9.0", "files": []}).encode()
    refused(make_agent(), repack([("manifest.json", manifest)]), 400, "version 99", "upgrade")


def test_a_restore_sent_as_another_type_is_refused_with_415(pair):
    _, archive, target = pair
    refused(target, archive, 415, "application/gzip", content_type="text/plain")


def test_an_active_set_the_backup_does_not_hold_is_refused(pair):
    _, archive, target = pair
    files = members(archive)
    del files["manifest.json"]
    files["data/active.json"] = json.dumps({"set_id": "0123456789abcdef"}).encode()
    refused(target, repack(with_manifest(files)), 400, "active.json")


def test_a_token_file_with_an_unknown_role_is_refused(pair):
    _, archive, target = pair
    files = members(archive)
    del files["manifest.json"]
    files["data/tokens.json"] = json.dumps({"a" * 64: {"name": "x", "role": "root"}}).encode()
    refused(target, repack(with_manifest(files)), 400, "tokens.json")


def test_a_users_file_that_is_not_one_is_refused(pair):
    _, archive, target = pair
    files = members(archive)
    del files["manifest.json"]
    files["data/users.json"] = json.dumps({"format": 1, "users": {"ana": {"role": "root"}}}).encode()
    refused(target, repack(with_manifest(files)), 400, "users.json", "'ana'")


CAPTURE = {
    "id": "c0ffee12",
    "request": {
        "name": "error rising",
        "variables": ["PLC_ROBOT.PLC_OUT.Error"],
        "trigger": {
            "kind": "condition",
            "conditions": [{"kind": "edge", "variable": "PLC_ROBOT.PLC_OUT.Error", "direction": "rising"}],
        },
        "pre": {"seconds": 1.0},
        "post": {"seconds": 0.5},
        "repeat": 0,
    },
    "created": "2026-11-26T20:00:00.000Z",
    "by": "olaf",
    "want_armed": True,
    "next_number": 4,
}


def test_the_triggered_captures_are_in_a_backup_and_come_back_armed(make_agent, elves):
    source, target = make_agent(), make_agent()
    seeded(source, elves)
    (source.data / "captures" / "captures.json").write_text(json.dumps({"captures": [CAPTURE]}))
    archive = backup(source)
    assert json.loads(members(archive)["data/captures/captures.json"])["captures"][0]["id"] == CAPTURE["id"]
    quiet_restarts(target)
    assert restore(target, archive, dry_run=False).status_code == 200
    client = restarted(target)
    h = {"Authorization": f"Bearer {source.tokens['admin']}"}
    (listed,) = client.get(f"{API}/captures", headers=h).json()["captures"]
    assert listed["id"] == CAPTURE["id"] and listed["request"]["name"] == "error rising" and listed["by"] == "olaf"
    assert client.app.state.captures.entries[CAPTURE["id"]].want_armed  # armed again once irpd answers


def test_a_captures_file_that_is_not_one_is_refused(pair):
    _, archive, target = pair
    files = members(archive)
    del files["manifest.json"]
    files["data/captures/captures.json"] = json.dumps({"captures": [{"request": "x"}]}).encode()
    refused(target, repack(with_manifest(files)), 400, "captures/captures.json")

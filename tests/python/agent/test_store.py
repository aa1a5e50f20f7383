"""test_store.py -- the set store on disk (agent/indurop_agent/sets/store.py): content-addressed blobs,
content-derived ids, the read-only materialized tree, the activation history with its rollback
stack, active.json and the `active` link, and what a restart finds."""

from __future__ import annotations

import hashlib
import json
import os
import stat

import pytest
from indurop_agent.sets.store import SetStore, StagedFile, StoreError, set_id_of

WHO = {"id": "0123456789ab", "name": "tester", "role": "admin"}
UNCHECKED = {"valid": None, "errors": [], "warnings": ["not checked yet"], "schedule": None}


def staged(store: SetStore, files: dict[str, tuple[bytes, str]]) -> list[StagedFile]:
    """Writes files into a staging folder as an upload would: {path: (content, kind)}."""
    d = store.staging_dir()
    out = []
    for i, (path, (content, kind)) in enumerate(files.items()):
        src = d / f"f{i}"
        src.write_bytes(content)
        out.append(StagedFile(path, src, hashlib.sha256(content).hexdigest(), len(content), kind))
    return out


def a_set(xml: bytes = b"<root/>", so: bytes = b"\x7fELF-pretend") -> dict[str, tuple[bytes, str]]:
    return {
        "module.xml": (xml, "module_xml"),
        "lib/ctl.so": (so, "thread_module"),
        "proc.exe": (b"\x7fELF-exe", "executable"),
        "notes.txt": (b"hello", "text"),
    }


@pytest.fixture
def store(tmp_path) -> SetStore:
    return SetStore(tmp_path / "data")


def test_the_id_is_the_content_and_does_not_depend_on_order(store):
    files = staged(store, a_set())
    assert set_id_of(files) == set_id_of(list(reversed(files)))
    assert len(set_id_of(files)) == 16 and int(set_id_of(files), 16) >= 0
    other_content = staged(store, a_set(xml=b"<root> </root>"))
    assert set_id_of(other_content) != set_id_of(files)
    moved = [StagedFile("sub/" + f.path, f.source, f.sha256, f.size, f.kind) for f in files]
    assert set_id_of(moved) != set_id_of(files)


def test_commit_writes_manifest_blobs_and_a_read_only_tree(store):
    manifest, new = store.commit(staged(store, a_set()), WHO, UNCHECKED)
    assert new
    set_id = manifest["id"]
    on_disk = json.loads((store.sets / set_id / "manifest.json").read_text())
    assert on_disk == manifest
    assert on_disk["by"] == WHO and on_disk["validation"] == UNCHECKED and on_disk["created"].endswith("Z")
    assert [f["path"] for f in on_disk["files"]] == ["lib/ctl.so", "module.xml", "notes.txt", "proc.exe"]
    for f in on_disk["files"]:
        blob = store.blobs / f["sha256"]
        assert hashlib.sha256(blob.read_bytes()).hexdigest() == f["sha256"]
        assert not stat.S_IMODE(blob.stat().st_mode) & 0o222, f"blob of {f['path']} is writable"
    tree = store.files_dir(set_id)
    assert store.module_xml(set_id) == tree / "module.xml"
    assert (tree / "module.xml").read_bytes() == b"<root/>"
    # Hard links to the blob, except .so files (the loader would share one instance per inode).
    assert os.path.samestat((tree / "module.xml").stat(), (store.blobs / on_disk["files"][1]["sha256"]).stat())
    assert not os.path.samestat((tree / "lib/ctl.so").stat(), (store.blobs / on_disk["files"][0]["sha256"]).stat())
    for p in [tree, tree / "lib", *tree.rglob("*")]:
        assert not stat.S_IMODE(p.stat().st_mode) & 0o222, f"{p} is writable"
    assert stat.S_IMODE((tree / "proc.exe").stat().st_mode) & 0o111, "an executable lost its execute bit"


def test_the_same_files_again_give_the_stored_set(store):
    first, new1 = store.commit(staged(store, a_set()), WHO, UNCHECKED)
    second, new2 = store.commit(staged(store, a_set()), {"id": "x", "name": "other", "role": "admin"}, UNCHECKED)
    assert new1 and not new2
    assert second == first  # the first upload's manifest: who and when stay
    assert len(store.list()) == 1


def test_blobs_are_shared_between_sets(store):
    a, _ = store.commit(staged(store, a_set()), WHO, UNCHECKED)
    b, _ = store.commit(staged(store, a_set(xml=b"<root></root>")), WHO, UNCHECKED)
    assert a["id"] != b["id"]
    assert len(list(store.blobs.iterdir())) == 5  # 4 files each, 3 in common
    notes_a = store.files_dir(a["id"]) / "notes.txt"
    notes_b = store.files_dir(b["id"]) / "notes.txt"
    assert os.path.samestat(notes_a.stat(), notes_b.stat())
    assert [m["id"] for m in store.list()] == [b["id"], a["id"]]  # newest first


def test_save_validation_replaces_only_the_report(store):
    m, _ = store.commit(staged(store, a_set()), WHO, UNCHECKED)
    report = {"valid": False, "errors": ["module.xml:3: nope"], "warnings": [], "schedule": None}
    updated = store.save_validation(m["id"], report)
    assert updated == {**m, "validation": report} == store.manifest(m["id"])
    with pytest.raises(StoreError):
        store.save_validation("0" * 16, report)


@pytest.mark.parametrize("bad", ["../etc", "ABCDEF0123456789", "0123", "0123456789abcdef/../x", ""])
def test_a_malformed_id_is_no_set(store, bad):
    assert store.manifest(bad) is None


def commit_sets(store, n: int) -> list[str]:
    return [
        store.commit(staged(store, a_set(xml=f"<root>{i}</root>".encode())), WHO, UNCHECKED)[0]["id"] for i in range(n)
    ]


def test_activation_is_recorded_and_rollback_walks_back_the_stack(store):
    a, b, c = commit_sets(store, 3)
    assert store.active_id() is None and store.rollback_target() is None
    for s in (a, b, c):
        store.record_activation(s, "activate", WHO, {"generation": 1})
    assert store.active_id() == c and store.rollback_target() == b
    store.record_activation(b, "rollback", WHO, None)
    assert store.active_id() == b and store.rollback_target() == a
    store.record_activation(a, "rollback", WHO, None)
    assert store.active_id() == a and store.rollback_target() is None
    history = [json.loads(line) for line in store.history_path.read_text().splitlines()]
    assert [(h["action"], h["set_id"], h["previous"]) for h in history] == [
        ("activate", a, None),
        ("activate", b, a),
        ("activate", c, b),
        ("rollback", b, c),
        ("rollback", a, b),
    ]
    assert all(h["by"] == WHO for h in history)


def test_active_json_and_the_active_link_follow_the_active_set(store):
    a, b = commit_sets(store, 2)
    store.record_activation(a, "activate", WHO, None)
    store.record_activation(b, "activate", WHO, None)
    active = json.loads(store.active_path.read_text())
    assert active["set_id"] == b and active["rollback_to"] == a and active["config"] == str(store.module_xml(b))
    assert store.active_link.is_symlink() and not os.path.isabs(os.readlink(store.active_link))
    assert (store.active_link / "module.xml").read_bytes() == b"<root>1</root>"
    assert store.active_link.resolve() == store.files_dir(b)


def test_activating_the_active_set_again_does_not_grow_the_rollback_stack(store):
    a, b = commit_sets(store, 2)
    for s in (a, b, b):
        store.record_activation(s, "activate", WHO, None)
    store.record_activation(b, "restore", None, None)
    assert store.rollback_target() == a


def test_an_unknown_set_cannot_be_activated(store):
    with pytest.raises(StoreError) as e:
        store.record_activation("0123456789abcdef", "activate", WHO, None)
    assert e.value.status == 404
    assert not store.history_path.exists() and not store.active_path.exists()


def test_a_restart_finds_the_same_state_and_repairs_active_json_from_the_history(tmp_path):
    store = SetStore(tmp_path / "data")
    a, b = commit_sets(store, 2)
    store.record_activation(a, "activate", WHO, None)
    store.record_activation(b, "activate", WHO, None)
    store.active_path.unlink()  # as if the agent died between history and active.json
    store.active_link.unlink()
    again = SetStore(tmp_path / "data")
    assert again.active_id() == b and again.rollback_target() == a
    assert json.loads(again.active_path.read_text())["set_id"] == b
    assert again.active_link.resolve() == again.files_dir(b)
    assert [m["id"] for m in again.list()] == [b, a]


def test_a_restart_removes_half_done_uploads_and_sets(tmp_path):
    store = SetStore(tmp_path / "data")
    staging = store.staging_dir()
    (staging / "f1").write_bytes(b"partial")
    partial = store.sets / ".partial-0123456789abcdef-xyz" / "files"
    partial.mkdir(parents=True)
    os.chmod(partial, 0o555)
    SetStore(tmp_path / "data")
    assert list(store.tmp.iterdir()) == []
    assert list(store.sets.iterdir()) == []

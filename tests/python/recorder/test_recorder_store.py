"""test_recorder_store.py -- the recordings folder (docs/recorder.md "Files"): names that could be
paths are refused, a taken name is refused, the quota evicts whole entries oldest first and never
one being written, and delete refuses one being written."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.recorder.store import Store, StoreError, check_name  # noqa: E402


@pytest.mark.parametrize(
    "name",
    ["", "..", ".hidden", "../etc", "a/b", "a\\b", "/abs", "x" * 65, "naïve", "a b", "-x", "a\x00b", "_x", "a:b"],
)
def test_names_that_are_not_plain_are_refused_naming_the_rule(name):
    with pytest.raises(StoreError) as e:
        check_name(name)
    assert e.value.status == 400 and "letters, digits" in e.value.message


@pytest.mark.parametrize("name", ["run-7", "A", "cell1.night_2026-11-26", "9" * 64])
def test_plain_names_are_taken(name):
    assert check_name(name) == name


def fill(store: Store, name: str, size: int, ended: str) -> None:
    entry = store.create(name, "recording", {"state": "stopped", "ended": ended})
    (entry.folder / "part-0001.mcap").write_bytes(b"\0" * size)


def test_the_quota_evicts_the_oldest_entries_first_and_never_one_being_written(tmp_path):
    store = Store(tmp_path / "recordings", quota_bytes=10_000)
    fill(store, "c", 3000, "2026-01-03T00:00:00Z")
    fill(store, "a", 3000, "2026-01-01T00:00:00Z")
    fill(store, "b", 3000, "2026-01-02T00:00:00Z")
    assert store.evict() == []  # 9 000 bytes and three small entry.json: under 10 000
    store.writing("a")  # the oldest, being written (a capture re-armed, say)
    (store.get("a").folder / "part-0002.mcap").write_bytes(b"\0" * 3000)
    assert store.evict() == ["b"]  # a is older, but being written
    assert sorted(e.name for e in store.entries()) == ["a", "c"]
    with pytest.raises(StoreError) as e:
        store.delete("a")
    assert e.value.status == 409 and "being written" in e.value.message
    store.done_writing("a")
    assert store.evict(needed=6000) == ["a"]  # room for 6 000 more: a goes now, c stays (under the quota)
    assert [e.name for e in store.entries()] == ["c"]


def test_a_taken_name_and_a_missing_entry_are_refused(tmp_path):
    store = Store(tmp_path / "recordings", quota_bytes=1 << 20)
    store.create("run", "recording", {})
    with pytest.raises(StoreError) as e:
        store.create("run", "capture", {})
    assert e.value.status == 409 and "'run'" in e.value.message
    with pytest.raises(StoreError) as e:
        store.get("nothing")
    assert e.value.status == 404
    store.delete("run")
    assert store.entries() == []


def test_an_entry_json_a_crash_left_half_written_is_the_old_one(tmp_path):
    store = Store(tmp_path / "recordings", quota_bytes=1 << 20)
    entry = store.create("run", "recording", {"state": "recording"})
    (entry.folder / "entry.json.tmp").write_text('{"state": "stop')  # the new one, cut short
    again = Store(tmp_path / "recordings", quota_bytes=1 << 20)
    assert again.get("run").meta["state"] == "recording"
    assert not (entry.folder / "entry.json.tmp").exists()


def test_the_agent_refuses_a_quota_too_small_to_keep_recordings():
    from indurop_agent.config import Settings, check

    problems = check(Settings(recordings_quota_bytes=1 << 20))
    assert any("recordings_quota_bytes (1048576) is too small" in p and "16 MiB" in p for p in problems)
    assert not any("recordings" in p for p in check(Settings()))
    assert any(
        "recordings_min_free_bytes must be greater than 0" in p for p in check(Settings(recordings_min_free_bytes=0))
    )

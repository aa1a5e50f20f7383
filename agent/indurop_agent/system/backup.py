"""backup.py -- the backup archive of the data folder (docs/administration.md, "Backup and
restore"): what it holds (ITEMS, the one list of the data folder's files a backup takes, plus the
set store), and making one.  Reading one back is restore.py.

The archive is a .tar.gz:

    manifest.json                   first: format, version, agent version, created, host,
                                    with_secrets, every file's path, size and SHA-256, a summary
    data/<item path>                each of ITEMS the data folder has (secrets only when asked)
    data/sets/<id>/manifest.json    every stored set's manifest
    data/blobs/sha256/<hex>         every blob a set names (the sets' trees are made from them)
    data/sets/<id>/scopes/<n>.json  the trace configurations kept with a set (scope_configs.py)
    data/sets/<id>/watches/<n>.json the watch lists kept with a set (sets/watch_lists.py)
    data/opcua/pki/<folder>/<name>  the OPC UA server's trust list (opcua_backup.py)

The sets' trees (sets/<id>/files/) are not in it: they are hard links and copies of the blobs,
made again at restore.  Neither are the first admin token's clear text (admin-token), uploads in
progress (tmp/), logs, irpd's crash records (irpd/) nor what an earlier restore moved aside.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import shutil
import socket
import sqlite3
import tarfile
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from .. import __version__
from ..access.auth import now_iso
from ..access.users import parse_users, without_password_hashes
from ..recorder.scope_configs import ScopeConfigs
from ..sets.store import remove_tree
from ..sets.watch_lists import WatchLists
from . import opcua_backup

FORMAT = "indurop-backup"
FORMAT_VERSION = 1
MANIFEST = "manifest.json"
DATA = "data/"


def _users_redacted(raw: bytes) -> bytes:
    """users.json without its password hashes (users.without_password_hashes)."""
    return json.dumps(without_password_hashes(json.loads(raw)), indent=1).encode()


@dataclass(frozen=True)
class Item:
    """A file of the data folder that a backup holds."""

    path: str  # relative to the data folder
    what: str  # for people (the restore's review names it)
    sqlite: bool = False  # a live SQLite database: copied with SQLite's backup API
    secret: bool = False  # only in a backup taken with secrets
    redact: Callable[[bytes], bytes] | None = None  # what a backup without secrets holds of it
    mode: int = 0o600  # its mode when restored into a folder that lacks it
    drops: tuple[str, ...] = ()  # files that belong to the one it replaces: moved aside with it


# The data folder's files a backup takes, besides the set store (sets' manifests and blobs, always
# taken).  A new file of the data folder that belongs in backups is one more line here; restore.py
# checks each kind it knows (CHECKS there) and restores each the same way.
ITEMS: tuple[Item, ...] = (
    # admin-token: the clear text of a token of the tokens replaced
    Item("tokens.json", "the tokens: their hashes, names and roles", drops=("admin-token",)),
    Item("history.jsonl", "the activation history", mode=0o644),
    Item("active.json", "the active set", mode=0o644),
    Item("audit.jsonl", "the audit log"),
    Item("alarms.sqlite3", "the alarm history and states", sqlite=True),
    # sessions.json: the browser sessions of the users replaced (sessions are never in a backup)
    Item(
        "users.json",
        "the users (password hashes only with secrets)",
        redact=_users_redacted,
        drops=("sessions.json",),
    ),
    Item("captures/captures.json", "the triggered captures: what each asks for and whether it is armed"),
    Item("agent.json", "the agent's settings kept in the data folder (--config <data>/agent.json)"),
    Item("tls/cert.pem", "the TLS certificate", mode=0o644),
    Item("tls/key.pem", "the TLS private key", secret=True),
    # the OPC UA server's (opcua_backup.py: its trust list is taken beside ITEMS)
    Item("opcua/server-cert.der", "the OPC UA server's certificate", mode=0o640),
    Item("opcua/server-key.pem", "the OPC UA server's private key", secret=True),
)
ITEM_PATHS = {i.path: i for i in ITEMS}


def _sha256_of(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            digest.update(chunk)
    return digest.hexdigest()


def _snapshot_sqlite(source: Path, target: Path) -> None:
    """A consistent copy of a live database (WAL and all), as SQLite's own backup makes it."""
    src = sqlite3.connect(source, timeout=10)  # (read-only would need the WAL's -shm all the same)
    try:
        dst = sqlite3.connect(target)
        try:
            src.backup(dst)
        finally:
            dst.close()
    finally:
        src.close()


def _count_lines(path: Path) -> int:
    with open(path, "rb") as f:
        return sum(1 for line in f if line.strip())


def _users_count(path: Path) -> int | None:
    """How many users a users file lists, if it is one."""
    try:
        return len(parse_users(json.loads(path.read_bytes())))
    except (OSError, ValueError):
        return None


def summary_of(root: Path, set_ids: list[str]) -> dict:
    """What a data folder (or a staged restore laid out like one) holds, in numbers for people."""
    active = None
    try:
        active = json.loads((root / "active.json").read_text()).get("set_id")
    except (OSError, ValueError, AttributeError):
        pass
    tokens = None
    try:
        tokens = len(json.loads((root / "tokens.json").read_text()))
    except (OSError, ValueError, TypeError):
        pass
    audit = root / "audit.jsonl"
    return {
        "sets": sorted(set_ids),
        "active_set": active,
        "tokens": tokens,
        "users": _users_count(root / "users.json") if (root / "users.json").exists() else None,
        "audit_lines": _count_lines(audit) if audit.exists() else 0,
    }


def backup_name(created: str) -> str:
    """indurop-backup-<host>-<time>.tar.gz (the file name the download suggests)."""
    host = "".join(c if c.isalnum() or c in "-." else "-" for c in socket.gethostname())[:63] or "host"
    stamp = created.replace(":", "").replace("-", "").split(".")[0]
    return f"indurop-backup-{host}-{stamp}Z.tar.gz"


def create(data_dir: Path, store, activator, with_secrets: bool = False) -> tuple[Path, dict]:
    """Writes a backup of the data folder to a file in <data>/tmp: (its path, its manifest).  The
    caller removes the file.  The store's state is taken at one moment (no activation, upload or
    prune runs meanwhile); blobs are hard-linked into the snapshot, so a prune afterwards does
    not take them from under the archive."""
    staging = Path(tempfile.mkdtemp(prefix="backup-", dir=store.tmp))
    try:
        snap = staging / "data"
        files: list[tuple[str, Path]] = []  # (archive name, file)
        redacted: list[str] = []
        with activator.exclusive(), store.locked():
            for item in ITEMS:
                source = data_dir / item.path
                if not source.is_file() or (item.secret and not with_secrets):
                    continue
                target = snap / item.path
                target.parent.mkdir(parents=True, exist_ok=True)
                if item.sqlite:
                    _snapshot_sqlite(source, target)
                elif item.redact is not None and not with_secrets:
                    target.write_bytes(item.redact(source.read_bytes()))
                    redacted.append(item.path)
                else:
                    shutil.copyfile(source, target)
                files.append((DATA + item.path, target))
            for rel in opcua_backup.trust_files(data_dir):  # the OPC UA server's trust list
                target = snap / rel
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(data_dir / rel, target)
                files.append((DATA + rel, target))
            manifests = store.list()
            blobs = sorted({f["sha256"] for m in manifests for f in m["files"]})
            for m in manifests:
                target = snap / "sets" / m["id"] / "manifest.json"
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(store.sets / m["id"] / "manifest.json", target)
                files.append((f"{DATA}sets/{m['id']}/manifest.json", target))
                for kept in (ScopeConfigs(store), WatchLists(store)):
                    for source in kept.files(m["id"]):
                        rel = f"sets/{m['id']}/{kept.FOLDER}/{source.name}"
                        target = snap / rel
                        target.parent.mkdir(exist_ok=True)
                        shutil.copyfile(source, target)
                        files.append((DATA + rel, target))
            (snap / "blobs" / "sha256").mkdir(parents=True)
            for sha in blobs:
                target = snap / "blobs" / "sha256" / sha
                os.link(store.blobs / sha, target)
                files.append((f"{DATA}blobs/sha256/{sha}", target))
        created = now_iso()
        manifest = {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "agent_version": __version__,
            "created": created,
            "host": socket.gethostname(),
            "with_secrets": with_secrets,
            "redacted": redacted,
            "files": [{"path": name, "size": path.stat().st_size, "sha256": _sha256_of(path)} for name, path in files],
            "summary": summary_of(snap, [m["id"] for m in manifests]),
        }
        archive = staging / backup_name(created)
        with tarfile.open(archive, "w:gz", compresslevel=6, format=tarfile.PAX_FORMAT) as tar:
            body = json.dumps(manifest, indent=1).encode()
            tar.addfile(_member(MANIFEST, len(body)), io.BytesIO(body))
            for name, path in files:
                with open(path, "rb") as f:
                    tar.addfile(_member(name, path.stat().st_size), f)
        final = Path(tempfile.mkdtemp(prefix="backup-out-", dir=store.tmp)) / archive.name
        os.replace(archive, final)
        return final, manifest
    finally:
        remove_tree(staging)


def _member(name: str, size: int) -> tarfile.TarInfo:
    info = tarfile.TarInfo(name)
    info.size, info.mode, info.mtime = size, 0o600, int(time.time())
    return info

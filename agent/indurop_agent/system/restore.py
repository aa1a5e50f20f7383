"""restore.py -- a backup archive (backup.py) read back: unpacked and checked, reviewed (what it would
replace), staged, and applied when the agent starts again.

1. unpack(): the .tar.gz is read as a stream by tarfile with its "data" extraction filter and
   limits of our own, before anything is written: regular files and folders only (symbolic and hard
   links, devices, FIFOs, sparse files refused), no absolute name, no '..', no backslash or control
   character, manifest.json first, every other member listed in it once with its size, the
   members counted (max_backup_members), the manifest's total and the decompressed stream bounded
   (max_backup_bytes: a size bomb stops at the limit, not at the disk's end), each member's
   SHA-256 compared with the manifest's (an altered or damaged archive is refused, naming the
   member).  Only names of the kinds a backup holds are accepted (backup.ITEMS, sets' manifests,
   blobs, the sets' trace configurations and watch lists, the OPC UA trust list), each written to a path made here, in a staging folder
   in <data>/tmp.
2. check(): the content makes sense: every blob holds the content its name says, every set's
   manifest names safe paths and blobs of the archive and has the id its files give, every trace
   configuration and watch list is one (KEPT's parse) of a set the archive holds, the tokens, the active
   set, the alarm database, the settings, the TLS pair and the OPC UA server's certificates
   (opcua_backup.py) are what the agent and the OPC UA server can use.
3. plan(): what a restore would do here (the dry run's answer): sets added, the active set, the
   tokens and users before and after, each file added or replaced.
4. stage(): the checked staging folder becomes <data>/restore-pending (one rename), and the agent
   restarts.  apply_pending(), at the agent's start before anything opens the data folder, moves
   the files it replaces to <data>/replaced-<time>/ and the archive's into place, each by a
   rename, adds the sets and their trace configurations, and points the `active` link at the
   restored active set.  Each step can be run again, so a crash during it finishes at the next start.

Nothing in the data folder changes before step 4; a refusal at any step leaves it as it was.
"""

from __future__ import annotations

import errno
import gzip
import hashlib
import json
import os
import re
import shutil
import sqlite3
import tarfile
import tempfile
import zlib
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from .. import config
from ..access.auth import ROLES, now_iso
from ..access.users import parse_users
from ..recorder.scope_configs import ScopeConfigs
from ..recorder.store import NAME
from ..sets.archives import tar_stream, type_problem
from ..sets.kept import KeptError
from ..sets.store import SET_ID, SetStore, remove_tree, set_id_of
from ..sets.watch_lists import WatchLists
from . import opcua_backup
from .backup import DATA, FORMAT, FORMAT_VERSION, ITEM_PATHS, ITEMS, MANIFEST, summary_of
from .tls import CertificateError, check_pair

PENDING = "restore-pending"
MAX_MANIFEST_BYTES = 64 << 20
MAX_NAME_BYTES = 1024
HEX64 = re.compile(r"^[0-9a-f]{64}$")
SET_MANIFEST = re.compile(r"^sets/([0-9a-f]{16})/manifest\.json$")
BLOB = re.compile(r"^blobs/sha256/([0-9a-f]{64})$")
KEPT = {k.FOLDER: k for k in (ScopeConfigs, WatchLists)}  # the files kept beside a set (sets/kept.py)
SET_SCOPE = re.compile(rf"^sets/([0-9a-f]{{16}})/({'|'.join(KEPT)})/({NAME.pattern})\.json$")
KIND = re.compile(r"^[a-z_]{1,32}$")
ROOM_MARGIN = 64 << 20  # left free on the data folder's file system after unpacking


class RestoreError(Exception):
    """A refused archive: the HTTP status (400 bad, 413 too large, 507 no room) and what is wrong."""

    def __init__(self, status: int, message: str):
        super().__init__(message)
        self.status, self.message = status, message


@dataclass
class Limits:
    max_bytes: int
    max_members: int

    @classmethod
    def of(cls, settings) -> Limits:
        return cls(settings.max_backup_bytes, settings.max_backup_members)


# ---- 1. unpacking ----------------------------------------------------------------------------
def name_problem(name: str) -> str | None:
    """Why a member's name is unsafe, or None: the names a backup writes are plain relative paths."""
    if not name:
        return "has an empty name"
    if any(ord(c) < 0x20 or ord(c) == 0x7F for c in name):
        return "has a control character in its name"
    if "\\" in name:
        return "has a backslash in its name"
    if name.startswith("/"):
        return "has an absolute name"
    parts = name.split("/")
    if ".." in parts:
        return "climbs out of the archive with '..'"
    if len(name.encode("utf-8", "surrogateescape")) > MAX_NAME_BYTES:
        return f"has a name longer than {MAX_NAME_BYTES} bytes"
    if any(p in ("", ".") for p in parts):
        return "has an empty or '.' path component"
    return None


def kind_of(name: str) -> str | None:
    """What an archive name is ("item", "set", "blob"), or None for a name no backup holds."""
    if not name.startswith(DATA):
        return None
    rel = name[len(DATA) :]
    if rel in ITEM_PATHS:
        return "item"
    if SET_MANIFEST.match(rel):
        return "set"
    if SET_SCOPE.match(rel):
        return "scope"
    if BLOB.match(rel):
        return "blob"
    if opcua_backup.TRUST.match(rel):
        return "opcua_trust"
    return None


def _parse_manifest(raw: bytes, limits: Limits, room: int) -> dict:
    try:
        manifest = json.loads(raw)
    except ValueError as e:
        raise RestoreError(400, f"the archive's manifest.json is not JSON: {e}") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise RestoreError(400, f"manifest.json does not say format {FORMAT!r}: this is not an indurop backup")
    version = manifest.get("version")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise RestoreError(400, "manifest.json has no format version")
    if version > FORMAT_VERSION:
        raise RestoreError(
            400,
            f"the backup has format version {version}, made by a newer agent ({manifest.get('agent_version')}); "
            f"this agent reads version {FORMAT_VERSION}: upgrade it first",
        )
    files = manifest.get("files")
    if not isinstance(files, list):
        raise RestoreError(400, "manifest.json has no list of files")
    if len(files) > limits.max_members:
        raise RestoreError(
            413, f"the backup lists {len(files)} files; at most {limits.max_members} are accepted (max_backup_members)"
        )
    seen, total = set(), 0
    for f in files:
        ok = (
            isinstance(f, dict)
            and isinstance(f.get("path"), str)
            and isinstance(f.get("size"), int)
            and not isinstance(f.get("size"), bool)
            and f["size"] >= 0
            and isinstance(f.get("sha256"), str)
            and HEX64.match(f["sha256"])
        )
        if not ok:
            raise RestoreError(
                400, f"manifest.json lists a file without a path, size and SHA-256: {json.dumps(f)[:200]}"
            )
        if f["path"] in seen:
            raise RestoreError(400, f"manifest.json lists {json.dumps(f['path'])} twice")
        seen.add(f["path"])
        total += f["size"]
    if total > limits.max_bytes:
        raise RestoreError(
            413, f"the backup unpacks to {total} bytes; at most {limits.max_bytes} are accepted (max_backup_bytes)"
        )
    if total + ROOM_MARGIN > room:
        raise RestoreError(
            507,
            f"the backup unpacks to {total} bytes and the data folder's file system has {room} free; make room first",
        )
    return manifest


def unpack(archive: Path, staging: Path, limits: Limits) -> dict:
    """Unpacks and verifies a backup into `staging` (its members under staging/data/...); returns
    its manifest.  Raises RestoreError naming what is wrong; `staging` may then hold part of it."""
    # the stream holds the members' content plus their headers and padding (pax headers included)
    stream_limit = limits.max_bytes + 8192 * (limits.max_members + 8) + MAX_MANIFEST_BYTES
    manifest, expected, seen, members = None, {}, set(), 0
    try:
        with (
            open(archive, "rb") as raw,
            gzip.GzipFile(fileobj=raw, mode="rb") as gz,
            tar_stream(gz, stream_limit, RestoreError, "max_backup_bytes") as tar,
        ):
            for member in tar:
                members += 1
                if members > limits.max_members + 1:
                    raise RestoreError(
                        413,
                        f"the archive has more than {limits.max_members + 1} members (max_backup_members)",
                    )
                shown = json.dumps(member.name)
                problem = type_problem(member, "a backup") or name_problem(
                    member.name.rstrip("/") if member.isdir() else member.name
                )
                if problem:
                    raise RestoreError(400, f"archive member {shown} {problem}")
                if hasattr(tarfile, "data_filter"):  # Python's own checks, on top of ours
                    try:
                        tarfile.data_filter(member, str(staging))
                    except tarfile.FilterError as e:
                        raise RestoreError(400, f"archive member {shown}: {e}") from None
                if member.isdir():
                    continue
                if manifest is None:
                    if member.name != MANIFEST:
                        raise RestoreError(
                            400, f"the archive's first file is {shown}, not manifest.json: it is not an indurop backup"
                        )
                    if member.size > MAX_MANIFEST_BYTES:
                        raise RestoreError(413, f"manifest.json is {member.size} bytes; at most {MAX_MANIFEST_BYTES}")
                    room = shutil.disk_usage(staging).free
                    manifest = _parse_manifest(tar.extractfile(member).read(), limits, room)
                    expected = {f["path"]: f for f in manifest["files"]}
                    continue
                _unpack_member(tar, member, shown, expected, seen, staging)
    except RestoreError:
        raise
    except OSError as e:
        if e.errno == errno.ENOSPC:
            raise RestoreError(507, "the data folder's file system is full") from None
        if e.errno is not None:  # the staging folder, not the archive
            raise
        raise RestoreError(400, f"the archive is not a readable .tar.gz: {e}") from None
    except (tarfile.TarError, zlib.error, EOFError) as e:
        raise RestoreError(400, f"the archive is not a readable .tar.gz: {e}") from None
    if manifest is None:
        raise RestoreError(400, "the archive holds no manifest.json: it is not an indurop backup")
    missing = sorted(set(expected) - seen)
    if missing:
        raise RestoreError(
            400,
            f"the archive lacks {len(missing)} file(s) its manifest lists, e.g. {json.dumps(missing[0])}: "
            "it was cut short or altered",
        )
    return manifest


def _unpack_member(tar, member, shown: str, expected: dict, seen: set, staging: Path) -> None:
    entry = expected.get(member.name)
    if member.name in seen:
        raise RestoreError(400, f"archive member {shown} appears twice")
    if entry is None:
        raise RestoreError(400, f"archive member {shown} is not in the archive's manifest: the archive was altered")
    if kind_of(member.name) is None:
        raise RestoreError(400, f"archive member {shown} is not a file a backup holds")
    if member.size != entry["size"]:
        raise RestoreError(
            400,
            f"archive member {shown} is {member.size} bytes and the manifest says {entry['size']}: "
            "the archive was altered or damaged",
        )
    target = staging / member.name  # a checked name of a known kind: data/<item>, data/sets/..., data/blobs/...
    target.parent.mkdir(parents=True, exist_ok=True)
    digest = hashlib.sha256()
    source = tar.extractfile(member)
    with open(target, "xb") as out:
        while chunk := source.read(1 << 20):
            digest.update(chunk)
            out.write(chunk)
    if digest.hexdigest() != entry["sha256"]:
        raise RestoreError(
            400,
            f"archive member {shown} has SHA-256 {digest.hexdigest()}, and the manifest says {entry['sha256']}: "
            "the archive was altered or damaged",
        )
    seen.add(member.name)


# ---- 2. checking what it holds ---------------------------------------------------------------
def _json(path: Path, what: str):
    try:
        return json.loads(path.read_bytes())
    except (ValueError, UnicodeDecodeError) as e:
        raise RestoreError(400, f"{what} in the backup is not JSON: {e}") from None


def _safe_set_path(path) -> bool:
    return isinstance(path, str) and name_problem(path) is None


def _check_set(set_id: str, path: Path, blobs: dict[str, Path]) -> dict:
    shown = f"set {set_id}"
    m = _json(path, f"{shown}'s manifest")
    if not isinstance(m, dict) or m.get("id") != set_id or not SET_ID.match(set_id):
        raise RestoreError(400, f"{shown}'s manifest does not name the set {set_id}")
    files = m.get("files")
    if not isinstance(files, list) or not files:
        raise RestoreError(400, f"{shown}'s manifest lists no files")
    for f in files:
        if not (
            isinstance(f, dict)
            and _safe_set_path(f.get("path"))
            and isinstance(f.get("sha256"), str)
            and HEX64.match(f["sha256"])
            and isinstance(f.get("size"), int)
            and isinstance(f.get("kind"), str)
            and KIND.match(f["kind"])
        ):
            raise RestoreError(
                400, f"{shown}'s manifest has a file entry that is not safe to restore: {json.dumps(f)[:200]}"
            )
        blob = blobs.get(f["sha256"])
        if blob is None:
            raise RestoreError(400, f"{shown} names the blob {f['sha256']} ({f['path']}) and the archive lacks it")
        if blob.stat().st_size != f["size"]:
            raise RestoreError(400, f"{shown}'s file {f['path']} is {f['size']} bytes and its blob is not")
    if len({f["path"] for f in files}) != len(files):
        raise RestoreError(400, f"{shown}'s manifest lists a path twice")
    if set_id_of(files) != set_id:
        raise RestoreError(400, f"{shown}'s files give another set id ({set_id_of(files)}): its manifest was altered")
    if not isinstance(m.get("created"), str) or not isinstance(m.get("validation"), dict):
        raise RestoreError(400, f"{shown}'s manifest has no created time or validation")
    return m


def _check_tokens(path: Path) -> None:
    tokens = _json(path, "tokens.json")
    ok = isinstance(tokens, dict) and all(
        isinstance(k, str)
        and HEX64.match(k)
        and isinstance(v, dict)
        and isinstance(v.get("name"), str)
        and v.get("role") in ROLES
        for k, v in tokens.items()
    )
    if not ok:
        raise RestoreError(400, "tokens.json in the backup is not a token list ({sha256: {name, role}})")


def _check_text(path: Path, what: str) -> None:
    try:
        with open(path, encoding="utf-8") as f:
            for _ in f:
                pass
    except UnicodeDecodeError as e:
        raise RestoreError(400, f"{what} in the backup is not UTF-8 text: {e}") from None


def _check_sqlite(path: Path) -> None:
    try:
        db = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro&immutable=1", uri=True)
        try:
            verdict = db.execute("PRAGMA integrity_check").fetchone()[0]
            tables = {r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        finally:
            db.close()
    except sqlite3.DatabaseError as e:
        raise RestoreError(400, f"alarms.sqlite3 in the backup is not a database SQLite can read: {e}") from None
    if verdict != "ok" or not {"history", "alarms", "meta"} <= tables:
        raise RestoreError(400, f"alarms.sqlite3 in the backup is damaged or not the agent's ({verdict})")


def _check_settings(path: Path) -> None:
    values = _json(path, "agent.json")
    unknown = set(values) - set(config.FIELDS) if isinstance(values, dict) else None
    if unknown is None or unknown:
        raise RestoreError(
            400, f"agent.json in the backup is not the agent's settings (unknown keys: {sorted(unknown or [])})"
        )


def _check_captures(path: Path) -> None:
    saved = _json(path, "captures/captures.json")
    rows = saved.get("captures") if isinstance(saved, dict) else None
    if not isinstance(rows, list) or not all(
        isinstance(r, dict) and isinstance(r.get("id"), str) and isinstance(r.get("request"), dict) for r in rows
    ):
        raise RestoreError(400, "captures/captures.json in the backup is not a list of captures (id, request)")


def check(manifest: dict, staging: Path) -> dict:
    """Checks the unpacked content (see the module's docstring): {"sets": {id: manifest}, "skip":
    [item paths not to restore], "warnings": [...]}.  Raises RestoreError naming the file."""
    root = staging / DATA
    blobs: dict[str, Path] = {}
    for entry in manifest["files"]:
        rel = entry["path"][len(DATA) :]
        blob = BLOB.match(rel)
        if blob:
            if blob.group(1) != entry["sha256"]:
                raise RestoreError(400, f"the blob {blob.group(1)} holds other content (SHA-256 {entry['sha256']})")
            blobs[blob.group(1)] = root / rel
    sets = {}
    for entry in manifest["files"]:
        found = SET_MANIFEST.match(entry["path"][len(DATA) :])
        if found:
            sets[found.group(1)] = _check_set(found.group(1), root / entry["path"][len(DATA) :], blobs)
    scopes = [e["path"][len(DATA) :] for e in manifest["files"] if SET_SCOPE.match(e["path"][len(DATA) :])]
    for rel in scopes:
        if SET_SCOPE.match(rel).group(1) not in sets:
            raise RestoreError(400, f"{rel} in the backup belongs to set {rel.split('/')[1]}, which the backup lacks")
        try:
            KEPT[SET_SCOPE.match(rel).group(2)].parse((root / rel).read_bytes(), f"{rel} in the backup")
        except KeptError as e:
            raise RestoreError(400, e.message) from None
    warnings, skip = [], []
    if (root / "tokens.json").exists():
        _check_tokens(root / "tokens.json")
    if (root / "active.json").exists():
        active = _json(root / "active.json", "active.json")
        if not isinstance(active, dict) or active.get("set_id") not in sets:
            raise RestoreError(400, "active.json in the backup names a set the backup does not hold")
    for name in ("history.jsonl", "audit.jsonl"):
        if (root / name).exists():
            _check_text(root / name, name)
    if (root / "alarms.sqlite3").exists():
        _check_sqlite(root / "alarms.sqlite3")
    if (root / "users.json").exists():
        try:
            parse_users(_json(root / "users.json", "users.json"))
        except ValueError as e:
            raise RestoreError(400, f"users.json in the backup: {e}") from None
    if (root / "agent.json").exists():
        _check_settings(root / "agent.json")
    if (root / "captures" / "captures.json").exists():
        _check_captures(root / "captures" / "captures.json")
    cert, key = root / "tls" / "cert.pem", root / "tls" / "key.pem"
    if cert.exists() and key.exists():
        try:
            check_pair(cert.read_bytes(), key.read_bytes())
        except CertificateError as e:
            warnings.append(f"the backup's TLS certificate is not restored ({e}); the one here is kept")
            skip += ["tls/cert.pem", "tls/key.pem"]
    elif cert.exists():
        warnings.append(
            "the backup has the TLS certificate but not its key (it was taken without secrets); the certificate "
            "and key here are kept"
        )
        skip.append("tls/cert.pem")
    trust = [e["path"][len(DATA) :] for e in manifest["files"] if opcua_backup.TRUST.match(e["path"][len(DATA) :])]
    try:
        opcua_skip, opcua_warnings = opcua_backup.check(root, trust)
    except opcua_backup.Refused as e:
        raise RestoreError(400, str(e)) from None
    skip, warnings = skip + opcua_skip, warnings + opcua_warnings
    trust_list = trust if opcua_backup.replaces_trust_list(root, trust) else None
    return {"sets": sets, "scopes": scopes, "skip": skip, "warnings": warnings, "opcua_trust": trust_list}


# ---- 3. the review ---------------------------------------------------------------------------
def stored_sets(data_dir: Path) -> list[str]:
    sets = data_dir / "sets"
    if not sets.is_dir():
        return []
    return sorted(d.name for d in sets.iterdir() if SET_ID.match(d.name) and (d / "manifest.json").is_file())


def plan(manifest: dict, checked: dict, staging: Path, data_dir: Path) -> dict:
    """What a restore of the checked archive would do to `data_dir` (models.RestorePlan)."""
    root = staging / DATA
    here = stored_sets(data_dir)
    archived = sorted(checked["sets"])
    now = summary_of(data_dir, here)
    theirs = summary_of(root, archived)
    files = []
    for item in ITEMS:
        if (root / item.path).exists() and item.path not in checked["skip"]:
            action = "replace" if (data_dir / item.path).exists() else "add"
            files.append({"path": item.path, "action": action, "what": item.what})
    for rel in checked.get("scopes", []):
        action = "replace" if (data_dir / rel).exists() else "add"
        set_id = SET_SCOPE.match(rel).group(1)
        what = KEPT[SET_SCOPE.match(rel).group(2)].WHAT
        files.append({"path": rel, "action": action, "what": f"a {what} kept with set {set_id}"})
    files += opcua_backup.plan_files(checked.get("opcua_trust"), data_dir)
    restored = {f["path"] for f in files}
    warnings = list(checked["warnings"])
    if "users.json" in restored and "users.json" in (manifest.get("redacted") or []):
        warnings.append(
            "the backup was taken without secrets: the users come back without their password hashes, and each "
            "needs a new password"
        )
    if "audit.jsonl" in restored and (data_dir / "audit.jsonl").exists():
        warnings.append(
            "this unit's audit log is replaced by the backup's; the current one is kept in replaced-<time>/"
        )
    if "tokens.json" in restored:
        warnings.append("the tokens become the backup's: tokens made here since stop working")

    def after(key: str, path: str):
        return theirs[key] if path in restored else now[key]

    return {
        "archive": {
            "created": manifest.get("created"),
            "agent_version": manifest.get("agent_version"),
            "host": manifest.get("host"),
            "with_secrets": bool(manifest.get("with_secrets")),
            "files": len(manifest["files"]),
            "bytes": sum(f["size"] for f in manifest["files"]),
        },
        "sets": {
            "added": [s for s in archived if s not in here],
            "present": [s for s in archived if s in here],
            "kept": [s for s in here if s not in archived],
        },
        "active_set": {"now": now["active_set"], "after": after("active_set", "active.json")},
        "tokens": {"now": now["tokens"], "after": after("tokens", "tokens.json")},
        "users": {"now": now["users"], "after": after("users", "users.json")},
        "audit_lines": {"now": now["audit_lines"], "after": after("audit_lines", "audit.jsonl")},
        "files": files,
        "warnings": warnings,
    }


def verify(archive: Path, tmp: Path, data_dir: Path, limits: Limits) -> tuple[Path, dict]:
    """Steps 1 to 3 in a fresh staging folder in `tmp`: (the staging folder, the plan with what
    stage() needs under "_checked").  The staging folder is removed when it raises."""
    staging = Path(tempfile.mkdtemp(prefix="restore-", dir=tmp))
    try:
        manifest = unpack(archive, staging, limits)
        checked = check(manifest, staging)
        review = plan(manifest, checked, staging, data_dir)
    except BaseException:
        remove_tree(staging)
        raise
    return staging, {**review, "_skip": checked["skip"], "_opcua_trust": checked["opcua_trust"]}


# ---- 4. staging and applying -----------------------------------------------------------------
def stage(staging: Path, data_dir: Path, review: dict, who: dict, client: str | None) -> Path:
    """Makes the verified staging folder the pending restore (<data>/restore-pending), applied at
    the agent's next start; a restore pending from before is replaced."""
    record = {
        "requested": now_iso(),
        "who": who,
        "client": client,
        "skip": review["_skip"],
        "opcua_trust": review.get("_opcua_trust"),
        "plan": {k: v for k, v in review.items() if not k.startswith("_")},
    }
    (staging / "restore.json").write_text(json.dumps(record, indent=1))
    pending = data_dir / PENDING
    if pending.exists():
        remove_tree(pending)
    os.rename(staging, pending)
    fd = os.open(data_dir, os.O_RDONLY | os.O_DIRECTORY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
    return pending


def _move_aside(path: Path, aside: Path, rel: str) -> None:
    target = aside / rel
    target.parent.mkdir(parents=True, exist_ok=True)
    os.replace(path, target)


def apply_pending(data_dir: Path) -> dict | None:
    """Applies <data>/restore-pending if there is one (at the agent's start, before it opens
    anything in the data folder): returns its record with "replaced_to", or None."""
    pending = data_dir / PENDING
    record_path = pending / "restore.json"
    if not record_path.is_file():
        if pending.exists():  # not a whole staged restore (cannot happen: it is renamed in whole)
            remove_tree(pending)
        return None
    record = json.loads(record_path.read_text())
    stamp = datetime.fromisoformat(record["requested"].replace("Z", "+00:00")).astimezone(UTC)
    aside = data_dir / f"replaced-{stamp:%Y%m%dT%H%M%SZ}"
    aside.mkdir(mode=0o700, exist_ok=True)
    root = pending / DATA
    store = SetStore(data_dir)
    blob_dir = root / "blobs" / "sha256"
    blob_sources = {p.name: p for p in blob_dir.iterdir()} if blob_dir.is_dir() else {}
    for manifest_path in sorted((root / "sets").glob("*/manifest.json")):
        store.adopt(json.loads(manifest_path.read_text()), blob_sources)
    for source in sorted(p for folder in KEPT for p in (root / "sets").glob(f"*/{folder}/*.json")):
        rel = source.relative_to(root).as_posix()
        if not SET_SCOPE.match(rel) or not (data_dir / "sets" / source.parent.parent.name).is_dir():
            continue
        target = data_dir / rel
        if target.exists():
            _move_aside(target, aside, rel)
        target.parent.mkdir(mode=0o755, exist_ok=True)
        os.chmod(source, 0o644)
        os.replace(source, target)
    for item in ITEMS:
        source, target = root / item.path, data_dir / item.path
        if not source.exists() or item.path in record["skip"]:
            continue
        mode = item.mode
        if target.exists():
            mode = target.stat().st_mode & 0o777
            _move_aside(target, aside, item.path)
            for suffix in ("-wal", "-shm", "-journal") if item.sqlite else ():
                extra = target.with_name(target.name + suffix)
                if extra.exists():
                    _move_aside(extra, aside, item.path + suffix)
        target.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        os.chmod(source, mode)
        os.replace(source, target)
        for dropped in item.drops:
            if (data_dir / dropped).exists():
                _move_aside(data_dir / dropped, aside, dropped)
    opcua_backup.apply(root, data_dir, record.get("opcua_trust"), lambda p, rel: _move_aside(p, aside, rel))
    active = data_dir / "active.json"
    if "active.json" not in record["skip"] and active.exists():
        set_id = json.loads(active.read_text()).get("set_id")
        link = data_dir / ".active.tmp"
        link.unlink(missing_ok=True)
        os.symlink(Path("sets") / set_id / "files", link)
        os.replace(link, data_dir / "active")
    record["replaced_to"] = str(aside)
    (aside / "restore.json").write_text(json.dumps(record, indent=1))
    remove_tree(pending)
    return record

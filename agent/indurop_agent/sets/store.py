"""store.py -- the set store under the data dir (docs/set-store.md): uploaded files kept once by
content, each set a manifest plus a read-only tree irpd loads, the activation history and the
active set.

    <data>/blobs/sha256/<hex>            every uploaded file, once, read-only
    <data>/sets/<id>/manifest.json       id, created, by, files [{path, sha256, size, kind}], validation
    <data>/sets/<id>/files/...           the set as irpd loads it: <id>/files/module.xml
    <data>/history.jsonl                 one line per activation / rollback / restore, append-only
    <data>/active.json                   the active set (replaced atomically)
    <data>/active -> sets/<id>/files     so irpd can start with --config <data>/active/module.xml
    <data>/tmp/                          uploads being received (emptied at start)

prune() deletes old sets (neither active, nor the rollback target, nor among the newest N) and then
every blob no remaining set uses (docs/set-store.md, "Pruning").

A set's id is the first 16 hex digits of the sha256 over its sorted "path NUL sha256 LF" lines, so
the same files give the same id.  Files in a set's tree are hard links to their blob, except
shared objects (.so), which are copied: the dynamic loader treats two paths of one inode as the
same library, so two sets (or two files of one set) sharing a blob would share one module instance.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import stat
import tempfile
import threading
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from ..access.auth import now_iso
from ..files import fsync_dir, write_json

SET_ID = re.compile(r"^[0-9a-f]{16}$")
EXECUTABLE_KINDS = {"executable", "thread_module", "library"}  # blobs with the execute bit
COPIED_KINDS = {"thread_module", "library"}  # materialized by copy, not hard link


class StoreError(Exception):
    """A request the store cannot carry out: an unknown set (404), nothing to roll back to (409)."""

    def __init__(self, message: str, status: int = 404):
        super().__init__(message)
        self.status = status


@dataclass
class StagedFile:
    """A received file, checked, waiting in <data>/tmp to be committed."""

    path: str  # relative to the set root, normalized ("lib/cntr1.so")
    source: Path  # where it was received
    sha256: str
    size: int
    kind: str

    def entry(self) -> dict:
        return {"path": self.path, "sha256": self.sha256, "size": self.size, "kind": self.kind}


def set_id_of(files: list[StagedFile] | list[dict]) -> str:
    """The content id: same paths with the same contents, same id."""
    pairs = sorted((f["path"], f["sha256"]) if isinstance(f, dict) else (f.path, f.sha256) for f in files)
    digest = hashlib.sha256("".join(f"{p}\0{h}\n" for p, h in pairs).encode())
    return digest.hexdigest()[:16]


def remove_tree(path: Path) -> None:
    """rmtree that also removes the read-only folders of a materialized set."""
    if not path.exists() and not path.is_symlink():
        return

    def make_writable(func, name, _exc):
        parent = os.path.dirname(name)
        os.chmod(parent, stat.S_IRWXU)
        if os.path.isdir(name) and not os.path.islink(name):
            os.chmod(name, stat.S_IRWXU)
        func(name)

    shutil.rmtree(path, onerror=make_writable)


class SetStore:
    def __init__(self, data_dir: Path):
        self.root = Path(data_dir).resolve()
        self.blobs = self.root / "blobs" / "sha256"
        self.sets = self.root / "sets"
        self.tmp = self.root / "tmp"
        self.history_path = self.root / "history.jsonl"
        self.active_path = self.root / "active.json"
        self.active_link = self.root / "active"
        for d in (self.blobs, self.sets, self.tmp):
            d.mkdir(parents=True, exist_ok=True)
        # What an earlier run left half done: uploads being received, sets being materialized.
        for leftover in [*self.tmp.iterdir(), *self.sets.glob(".partial-*")]:
            remove_tree(leftover)
        self._lock = threading.RLock()
        self._stack: list[str] = []  # the activation stack; its top is the active set
        self._load_history()

    @contextmanager
    def locked(self):
        """No upload, activation record or prune changes the store while the block runs (a backup
        takes its snapshot under it)."""
        with self._lock:
            yield

    # ---- sets -----------------------------------------------------------------------------
    def staging_dir(self) -> Path:
        """A fresh folder inside the data dir for one upload (same file system as the blobs)."""
        return Path(tempfile.mkdtemp(prefix="upload-", dir=self.tmp))

    def files_dir(self, set_id: str) -> Path:
        return self.sets / set_id / "files"

    def module_xml(self, set_id: str) -> Path:
        return self.files_dir(set_id) / "module.xml"

    def manifest(self, set_id: str) -> dict | None:
        if not SET_ID.match(set_id):
            return None
        try:
            return json.loads((self.sets / set_id / "manifest.json").read_text())
        except FileNotFoundError:
            return None

    def list(self) -> list[dict]:
        """Every set's manifest, newest first."""
        found = []
        for d in self.sets.iterdir():
            if SET_ID.match(d.name):
                m = self.manifest(d.name)
                if m is not None:
                    found.append(m)
        return sorted(found, key=lambda m: (m["created"], m["id"]), reverse=True)

    def commit(
        self, files: list[StagedFile], who: dict, validation: dict, derived_from: dict | None = None
    ) -> tuple[dict, bool]:
        """Stores a checked upload: (its manifest, True) or, for a set already stored,
        (that set's manifest, False).  The staged files are moved into the blob store.
        `derived_from`: {set_id, path} of a set made from another with one file changed (the
        Programs page's edits), kept in the manifest: a program's history is that chain."""
        set_id = set_id_of(files)
        with self._lock:
            existing = self.manifest(set_id)
            if existing is not None:
                return existing, False
            remove_tree(self.sets / set_id)  # a folder without a manifest: not a set
            for f in files:
                self._keep_blob(f)
            manifest = {
                "id": set_id,
                "created": now_iso(),
                "by": who,
                "files": [f.entry() for f in sorted(files, key=lambda f: f.path)],
                "validation": validation,
            }
            if derived_from is not None:
                manifest["derived_from"] = derived_from
            self._materialize(manifest)
            return manifest, True

    def adopt(self, manifest: dict, blob_sources: dict[str, Path]) -> bool:
        """Stores a set taken from a backup (system/restore.py, which checked it): the blobs it
        names that the store lacks are moved in from `blob_sources` (sha256 -> file), its tree is
        materialized and its manifest kept as it was (id, created, by, validation).  False when
        the set is stored already."""
        set_id = manifest["id"]
        with self._lock:
            if self.manifest(set_id) is not None:
                return False
            remove_tree(self.sets / set_id)
            for f in manifest["files"]:
                self._keep_blob(StagedFile(f["path"], blob_sources.get(f["sha256"]), f["sha256"], f["size"], f["kind"]))
            self._materialize(manifest)
            return True

    def _materialize(self, manifest: dict) -> None:
        """The set's read-only tree from its blobs, and its manifest, in sets/.partial-* renamed to
        sets/<id> at the end (a crash leaves a .partial- folder the next start removes)."""
        set_id = manifest["id"]
        partial = Path(tempfile.mkdtemp(prefix=f".partial-{set_id}-", dir=self.sets))
        try:
            tree = partial / "files"
            tree.mkdir()
            for f in sorted(manifest["files"], key=lambda f: f["path"]):
                dest = tree / f["path"]
                dest.parent.mkdir(parents=True, exist_ok=True)
                blob = self.blobs / f["sha256"]
                if f["kind"] in COPIED_KINDS:
                    shutil.copyfile(blob, dest)
                    os.chmod(dest, 0o555)
                else:
                    os.link(blob, dest)
            for d in sorted((p for p in tree.rglob("*") if p.is_dir()), key=lambda p: -len(p.parts)):
                os.chmod(d, 0o555)
            os.chmod(tree, 0o555)
            os.chmod(partial, 0o755)
            write_json(partial / "manifest.json", manifest, 0o644)
            os.rename(partial, self.sets / set_id)
            fsync_dir(self.sets)
        except BaseException:
            remove_tree(partial)
            raise

    # ---- pruning --------------------------------------------------------------------------
    def prune(self, keep_last: int, dry_run: bool = True) -> dict:
        """Deletes the sets that are not active, not the rollback target and not among the newest
        `keep_last`, then the blobs no remaining set names.  With dry_run nothing is deleted: the
        answer says what would go.  Returns {"deleted": [manifests' summaries], "kept": [ids],
        "blobs": [{"sha256", "size"}], "bytes": the bytes the blobs free, "dry_run"}."""
        if keep_last < 0:
            raise StoreError(f"keep_last must be 0 or more (it is {keep_last})", status=422)
        with self._lock:
            sets = self.list()  # newest first
            protected = {self.active_id(), self.rollback_target()} - {None}
            kept = [m for i, m in enumerate(sets) if i < keep_last or m["id"] in protected]
            kept_ids = {m["id"] for m in kept}
            going = [m for m in sets if m["id"] not in kept_ids]
            used = {f["sha256"] for m in kept for f in m["files"]}
            blobs = []
            for blob in sorted(self.blobs.iterdir()):
                if blob.name not in used and re.fullmatch(r"[0-9a-f]{64}", blob.name):
                    blobs.append({"sha256": blob.name, "size": blob.stat().st_size})
            if not dry_run:
                for m in going:
                    # renamed first (one atomic step), so that a crash leaves a .partial- folder
                    # the next start removes, never half a set under its id
                    doomed = Path(tempfile.mkdtemp(prefix=f".partial-pruned-{m['id']}-", dir=self.sets))
                    os.rename(self.sets / m["id"], doomed / m["id"])
                    remove_tree(doomed)
                for b in blobs:
                    (self.blobs / b["sha256"]).unlink(missing_ok=True)
                fsync_dir(self.sets)
                fsync_dir(self.blobs)
            return {
                "deleted": [
                    {"id": m["id"], "created": m["created"], "by": m.get("by"), "files": len(m["files"])} for m in going
                ],
                "kept": [m["id"] for m in kept],
                "blobs": blobs,
                "bytes": sum(b["size"] for b in blobs),
                "dry_run": dry_run,
            }

    def _keep_blob(self, f: StagedFile) -> None:
        """Moves a staged file into blobs/ (read-only; executable for the kinds that run), or, when
        that content is stored already, leaves the stored blob (made executable if needed)."""
        blob = self.blobs / f.sha256
        mode = 0o555 if f.kind in EXECUTABLE_KINDS else 0o444
        if blob.exists():
            if mode & 0o111 and not blob.stat().st_mode & 0o111:
                os.chmod(blob, 0o555)
            return
        os.chmod(f.source, mode)
        os.replace(f.source, blob)

    def save_validation(self, set_id: str, validation: dict) -> dict:
        with self._lock:
            manifest = self.manifest(set_id)
            if manifest is None:
                raise StoreError(f"no set {set_id}")
            manifest["validation"] = validation
            write_json(self.sets / set_id / "manifest.json", manifest, 0o644)
            return manifest

    # ---- activation state -----------------------------------------------------------------
    def active_id(self) -> str | None:
        with self._lock:
            return self._stack[-1] if self._stack else None

    def rollback_target(self) -> str | None:
        """The set that was active before the current one (None: there is none)."""
        with self._lock:
            return self._stack[-2] if len(self._stack) >= 2 else None

    def active(self) -> dict | None:
        try:
            return json.loads(self.active_path.read_text())
        except FileNotFoundError:
            return None

    def history(self) -> list[dict]:
        if not self.history_path.exists():
            return []
        out = []
        for line in self.history_path.read_text().splitlines():
            try:
                out.append(json.loads(line))
            except ValueError:
                continue  # a line cut short by a crash
        return out

    def record_activation(self, set_id: str, action: str, who: dict | None, report: dict | None) -> dict:
        """After irpd took the set: appends to history.jsonl, then replaces active.json and the
        `active` link.  action: activate | restart (an activation by a restart of irpd) | rollback |
        restore; `mode` and a restart's `downtime_ns` come from the report when it has them."""
        with self._lock:
            if self.manifest(set_id) is None:
                raise StoreError(f"no set {set_id}")
            entry = {
                "time": now_iso(),
                "action": action,
                "set_id": set_id,
                "previous": self.active_id(),
                "by": who,
                "generation": (report or {}).get("generation"),
            }
            if (report or {}).get("mode") == "restart":
                entry.update(mode="restart", downtime_ns=report.get("downtime_ns"))
            fd = os.open(self.history_path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
            try:
                os.write(fd, (json.dumps(entry) + "\n").encode())
                os.fsync(fd)
            finally:
                os.close(fd)
            self._apply(entry)
            self._write_active(entry)
            return entry

    def _apply(self, entry: dict) -> None:
        set_id, stack = entry["set_id"], self._stack
        if entry["action"] == "rollback" and len(stack) >= 2 and stack[-2] == set_id:
            stack.pop()
        elif not stack or stack[-1] != set_id:
            stack.append(set_id)

    def _write_active(self, entry: dict) -> None:
        set_id = entry["set_id"]
        write_json(
            self.active_path,
            {
                "set_id": set_id,
                "since": entry["time"],
                "action": entry["action"],
                "by": entry["by"],
                "config": str(self.module_xml(set_id)),
                "rollback_to": self.rollback_target(),
            },
            0o644,
        )
        tmp = self.root / ".active.tmp"
        tmp.unlink(missing_ok=True)
        os.symlink(Path("sets") / set_id / "files", tmp)
        os.replace(tmp, self.active_link)

    def _load_history(self) -> None:
        history = self.history()
        for entry in history:
            if isinstance(entry, dict) and isinstance(entry.get("set_id"), str):
                self._apply(entry)
        active = self.active()
        if self._stack and (
            active is None or active.get("set_id") != self._stack[-1] or not self.active_link.is_symlink()
        ):
            self._write_active(
                history[-1]
                if history[-1].get("set_id") == self._stack[-1]
                else {"set_id": self._stack[-1], "time": now_iso(), "action": "activate", "by": None}
            )

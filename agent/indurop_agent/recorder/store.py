"""store.py -- where recordings and captures live on disk (docs/recorder.md "Files"):
<data-dir>/recordings/<name>/ holds `entry.json` (the definition and state, replaced atomically)
and the MCAP files of its parts, `part-0001.mcap`, `part-0002.mcap`, ... (each with its
`part-0001.joint_states.mcap` when the recording has a /joint_states channel)

    store = Store(data_dir / "recordings", quota_bytes=8 << 30, min_free_bytes=256 << 20)
    entry = store.create("run-7", "recording", {"variables": [...]})   # StoreError 409: the name is taken
    path = entry.new_part()                  # the next part's file name (not created)
    entry.meta["state"] = "stopped"; entry.save()
    store.writing("run-7")                   # being written: never evicted nor deleted ...
    store.evict()                            # the oldest entries go until the quota holds
    store.done_writing("run-7")              # ... until this
    store.delete("run-6")

Names are 1 to 64 of [A-Za-z0-9_.-], starting with a letter or digit: never a path.  The quota
counts every file under the folder; eviction removes whole entries, oldest first (by when they
ended, else when they were created), never one being written.  The recorder's thread calls
evict() every second for every entry, recordings and captures alike.  Nothing here deletes a file
but delete() and evict().
"""

from __future__ import annotations

import json
import os
import re
import shutil
import threading
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from .mcap_out import JOINT_FILE_SUFFIX

NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
NAME_RULE = "1 to 64 letters, digits, '_', '.' or '-', starting with a letter or a digit"
META = "entry.json"
PART = re.compile(r"part-(\d{4,})\.mcap")
KINDS = ("recording", "capture")
RESERVE = ".reserve"  # room kept for saving states when the disk is full (not counted in the quota)
RESERVE_BYTES = 256 << 10


class StoreError(Exception):
    """A refusal with the HTTP status that fits it: 400 a bad name, 404 none such, 409 taken or
    being written, 507 no room."""

    def __init__(self, status: int, message: str):
        super().__init__(message)
        self.status, self.message = status, message


def now() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def check_name(name: str) -> str:
    """The name if it can name an entry; StoreError 400 saying what a name may hold otherwise."""
    if not isinstance(name, str) or not NAME.fullmatch(name):
        raise StoreError(400, f"the name {json.dumps(name)} is not allowed: use {NAME_RULE}")
    return name


def write_json(path: Path, value) -> None:
    """Replaces `path` with `value` as JSON, atomically (a crash leaves the old or the new file)."""
    temporary = path.with_name(path.name + ".tmp")
    with open(temporary, "w", encoding="utf-8") as f:
        json.dump(value, f, indent=1)
        f.write("\n")
        f.flush()
        os.fsync(f.fileno())
    os.replace(temporary, path)


@dataclass
class Entry:
    """One recording or capture: its folder and its meta (entry.json's content)."""

    folder: Path
    meta: dict

    @property
    def name(self) -> str:
        return self.folder.name

    def save(self) -> None:
        write_json(self.folder / META, self.meta)

    def parts(self) -> list[Path]:
        """The MCAP files, in part order."""
        found = [(int(m.group(1)), p) for p in self.folder.iterdir() if (m := PART.fullmatch(p.name))]
        return [p for _, p in sorted(found)]

    def files(self) -> list[Path]:
        """Every MCAP file, in part order: each part, and its .joint_states.mcap when it has one."""
        out = []
        for part in self.parts():
            out.append(part)
            joints = part.with_name(part.name.removesuffix(".mcap") + JOINT_FILE_SUFFIX)
            if joints.exists():
                out.append(joints)
        return out

    def new_part(self) -> Path:
        """The file name of the next part (one after the highest there is)."""
        parts = self.parts()
        number = int(PART.fullmatch(parts[-1].name).group(1)) + 1 if parts else 1
        return self.folder / f"part-{number:04d}.mcap"

    def size(self) -> int:
        return sum(p.stat().st_size for p in self.folder.iterdir() if p.is_file())


class Store:
    def __init__(self, root: Path, quota_bytes: int, min_free_bytes: int = 0, reserve_bytes: int = RESERVE_BYTES):
        self.root = Path(root)
        self.quota_bytes = quota_bytes
        self.min_free_bytes = min_free_bytes
        self.reserve_bytes = reserve_bytes
        self.lock = threading.RLock()  # creation, deletion and eviction, one at a time
        self._writing: set[str] = set()
        self.root.mkdir(parents=True, exist_ok=True)
        for stale in self.root.glob(f"*/{META}.tmp"):
            stale.unlink(missing_ok=True)  # a save a crash interrupted: entry.json is the old one
        self.keep_reserve()

    def keep_reserve(self) -> None:
        """Makes the reserve file (reserve_bytes taken on the disk) if it is not there and there
        is room: a full disk then still has room to save the state of what it stopped."""
        path = self.root / RESERVE
        if not self.reserve_bytes or path.exists():
            return
        try:
            with open(path, "wb") as f:
                os.posix_fallocate(f.fileno(), 0, self.reserve_bytes)
        except OSError:
            path.unlink(missing_ok=True)

    def release_reserve(self) -> None:
        """Frees the reserve (the disk is full); keep_reserve() makes it again once there is room."""
        (self.root / RESERVE).unlink(missing_ok=True)

    def writing(self, name: str) -> None:
        """`name` is being written: evict() and delete() leave it alone until done_writing(name)."""
        with self.lock:
            self._writing.add(name)

    def done_writing(self, name: str) -> None:
        with self.lock:
            self._writing.discard(name)

    def busy(self) -> set[str]:
        with self.lock:
            return set(self._writing)

    # ---- entries ------------------------------------------------------------------------------------
    def create(self, name: str, kind: str, meta: dict) -> Entry:
        """A new entry's folder and entry.json; StoreError 409 when the name is taken."""
        check_name(name)
        if kind not in KINDS:
            raise ValueError(f"kind {kind!r} is not one of {', '.join(KINDS)}")
        with self.lock:
            folder = self.root / name
            try:
                folder.mkdir()
            except FileExistsError:
                raise StoreError(
                    409, f"there is a recording or capture named '{name}' already; pick another name or delete it first"
                ) from None
            entry = Entry(folder, {"name": name, "kind": kind, "created": now(), **meta})
            try:
                entry.save()
            except OSError:
                shutil.rmtree(folder, ignore_errors=True)
                raise
            return entry

    def get(self, name: str) -> Entry:
        check_name(name)
        folder = self.root / name
        try:
            meta = json.loads((folder / META).read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise StoreError(
                404, f"no recording or capture named '{name}' (GET /api/v1/recordings lists them)"
            ) from None
        except (OSError, ValueError) as e:
            meta = {"name": name, "kind": "recording", "state": "damaged", "reason": f"{META} cannot be read: {e}"}
        return Entry(folder, meta)

    def entries(self) -> list[Entry]:
        """Every entry, oldest first."""
        out = []
        for folder in self.root.iterdir():
            if folder.is_dir() and NAME.fullmatch(folder.name) and (folder / META).exists():
                try:
                    out.append(self.get(folder.name))
                except StoreError:
                    continue  # deleted meanwhile
        return sorted(out, key=lambda e: (str(e.meta.get("created", "")), e.name))

    def delete(self, name: str) -> None:
        """Removes an entry and its files; StoreError 409 while it is being written."""
        with self.lock:
            entry = self.get(name)
            if name in self._writing:
                raise StoreError(409, f"'{name}' is being written: stop it first (POST /api/v1/recordings/{name}/stop)")
            shutil.rmtree(entry.folder)

    # ---- room -----------------------------------------------------------------------------------------
    def used(self) -> int:
        """Bytes of every file under the folder (but the reserve)."""
        total = 0
        for dirpath, _, files in os.walk(self.root):
            for f in files:
                if f == RESERVE and dirpath == str(self.root):
                    continue
                try:
                    total += os.lstat(os.path.join(dirpath, f)).st_size
                except OSError:
                    pass
        return total

    def disk_free(self) -> int:
        """Bytes free for this process on the folder's file system."""
        return shutil.disk_usage(self.root).free

    def evict(self, needed: int = 0) -> list[str]:
        """Deletes whole entries, the one that ended first first, until the folder holds at most
        quota_bytes - needed; never one being written.  Returns the names deleted (the quota may
        still be exceeded when only entries being written are left)."""
        gone = []
        with self.lock:
            busy = self._writing
            used = self.used()
            if used + needed <= self.quota_bytes:
                return gone
            candidates = [e for e in self.entries() if e.name not in busy]
            candidates.sort(key=lambda e: (str(e.meta.get("ended") or e.meta.get("created") or ""), e.name))
            for entry in candidates:
                if used + needed <= self.quota_bytes:
                    break
                size = entry.size()
                shutil.rmtree(entry.folder, ignore_errors=True)
                used -= size
                gone.append(entry.name)
        return gone

"""kept.py -- named JSON files kept beside a stored set (docs/set-store.md "Kept with a set"): the
trace configurations (recorder/scope_configs.py, sets/<id>/scopes/) and the watch lists
(sets/watch_lists.py, sets/<id>/watches/).  A set is content-addressed and immutable, so they are
kept beside its files, not in them; they go wherever the set folder goes: a prune removes them with
it, a backup takes them (system/backup.py), a set derived from it by an edit gets a copy.

    kept = ScopeConfigs(store)              # a subclass names its folder, model, limits and words
    kept.put(set_id, "square", config, who)  # KeptError: 404 no such set, 400 a bad name, 409 too many
    kept.list(set_id); kept.get(set_id, "square"); kept.delete(set_id, "square")

Names follow the recorder's rule (recorder/store.py NAME): never a path.  Every change is written
atomically (files.write_json) under the store's lock, so that a prune never meets half a folder.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from pydantic import BaseModel, ValidationError

from ..access.auth import now_iso
from ..files import fsync_dir, write_atomically
from ..recorder.store import NAME, NAME_RULE
from .store import SET_ID, SetStore

SUFFIX = ".json"
MODE = 0o644  # like a set's manifest: nothing secret


class KeptError(Exception):
    """A refusal with its HTTP status: 400 a bad name, 404 no such set or file, 409 the set holds the
    most it may, 413 a file too large, 422 a file that is not what it should be."""

    def __init__(self, status: int, message: str):
        super().__init__(message)
        self.status, self.message = status, message


def check_name(name: str) -> str:
    if not isinstance(name, str) or not NAME.fullmatch(name):
        raise KeptError(400, f"the name {json.dumps(name)} is not allowed: use {NAME_RULE}")
    return name


class Kept:
    FOLDER: str  # under sets/<id>/
    MODEL: type[BaseModel]  # what a file's "config" is
    MAX_COUNT: int  # files per set
    MAX_BYTES: int  # one file
    WHAT: str  # "trace configuration"

    def __init__(self, store: SetStore):
        self.store = store

    @classmethod
    def parse(cls, raw: bytes, where: str) -> dict:
        """A saved file's content, checked: {"name", "saved", "by", "config"} with `config` valid as
        MODEL.  KeptError 413/422 naming `where` otherwise."""
        if len(raw) > cls.MAX_BYTES:
            raise KeptError(413, f"{where} is {len(raw)} bytes; a {cls.WHAT} is at most {cls.MAX_BYTES}")
        try:
            saved = json.loads(raw)
        except (ValueError, UnicodeDecodeError) as e:
            raise KeptError(422, f"{where} is not JSON: {e}") from None
        if not isinstance(saved, dict) or not isinstance(saved.get("name"), str):
            raise KeptError(422, f"{where} is not a {cls.WHAT} (no name)")
        try:
            config = cls.MODEL.model_validate(saved.get("config"))
        except ValidationError as e:
            first = e.errors()[0]
            at = ".".join(str(p) for p in first["loc"])
            raise KeptError(422, f"{where} is not a {cls.WHAT}: {at}: {first['msg']}") from None
        by = saved.get("by")
        return {
            "name": saved["name"],
            "saved": saved.get("saved") if isinstance(saved.get("saved"), str) else "",
            "by": by if isinstance(by, dict) else None,
            "config": config.model_dump(mode="json"),
        }

    @staticmethod
    def encode(name: str, config: BaseModel, who: dict | None, saved: str | None = None) -> bytes:
        body = {"name": name, "saved": saved or now_iso(), "by": who, "config": config.model_dump(mode="json")}
        return json.dumps(body, indent=1).encode()

    def folder(self, set_id: str) -> Path:
        """sets/<id>/<FOLDER> of a stored set; KeptError 404 when there is no such set."""
        if not isinstance(set_id, str) or not SET_ID.match(set_id) or self.store.manifest(set_id) is None:
            raise KeptError(404, f"no set {set_id!r} in the set store (GET /sets lists them)")
        return self.store.sets / set_id / self.FOLDER

    def _file(self, set_id: str, name: str) -> Path:
        folder = self.folder(set_id)
        if folder.is_symlink() or (folder.exists() and not folder.is_dir()):
            raise KeptError(409, f"{folder} is not a folder the agent made: move it away")
        return folder / f"{check_name(name)}{SUFFIX}"

    def _read(self, path: Path) -> bytes:
        if path.is_symlink():  # never made by the agent: not followed
            raise FileNotFoundError(path)
        return path.read_bytes()

    def names(self, set_id: str) -> list[str]:
        folder = self.folder(set_id)
        if folder.is_symlink() or not folder.is_dir():
            return []
        found = []
        for p in folder.iterdir():
            stem = p.name.removesuffix(SUFFIX)
            if p.name.endswith(SUFFIX) and NAME.fullmatch(stem) and p.is_file() and not p.is_symlink():
                found.append(stem)
        return sorted(found)

    def list(self, set_id: str) -> list[dict]:
        """The set's files, by name: each as get() answers it, with its size (a damaged file is
        listed with `error`)."""
        with self.store.locked():
            out = []
            for name in self.names(set_id):
                path = self._file(set_id, name)
                try:
                    raw = self._read(path)
                except OSError:
                    continue  # deleted meanwhile
                try:
                    entry = self.parse(raw, f"{self.WHAT} {name}")
                    out.append({**entry, "name": name, "size": len(raw), "error": None})
                except KeptError as e:
                    out.append(
                        {"name": name, "saved": "", "by": None, "config": None, "size": len(raw), "error": e.message}
                    )
            return out

    def get(self, set_id: str, name: str) -> dict:
        with self.store.locked():
            path = self._file(set_id, name)
            try:
                raw = self._read(path)
            except FileNotFoundError:
                raise KeptError(404, f"set {set_id} has no {self.WHAT} {name!r}") from None
            return {**self.parse(raw, f"{self.WHAT} {name}"), "name": name, "size": len(raw), "error": None}

    def put(self, set_id: str, name: str, config: BaseModel, who: dict | None) -> tuple[dict, bool]:
        """Saves (or replaces) a file: (what get() answers, whether it is new)."""
        data = self.encode(check_name(name), config, who)
        if len(data) > self.MAX_BYTES:
            raise KeptError(413, f"the {self.WHAT} is {len(data)} bytes saved; at most {self.MAX_BYTES}")
        with self.store.locked():
            return self._write(set_id, name, data)

    def _write(self, set_id: str, name: str, data: bytes) -> tuple[dict, bool]:
        path = self._file(set_id, name)
        new = not path.exists()
        if new and len(self.names(set_id)) >= self.MAX_COUNT:
            raise KeptError(409, f"set {set_id} holds {self.MAX_COUNT} {self.WHAT}s, the most it may: delete one first")
        folder = path.parent
        if not folder.is_dir():
            folder.mkdir(mode=0o755)  # sets/<id> exists: the manifest was read under the lock
            fsync_dir(folder.parent)
        write_atomically(path, data, MODE)
        return {**self.parse(data, name), "name": name, "size": len(data), "error": None}, new

    def delete(self, set_id: str, name: str) -> None:
        with self.store.locked():
            path = self._file(set_id, name)
            try:
                os.unlink(path)
            except FileNotFoundError:
                raise KeptError(404, f"set {set_id} has no {self.WHAT} {name!r}") from None
            fsync_dir(path.parent)

    def copy(self, source: str, target: str) -> None:
        """Gives the set `target` (made from `source` by an edit) a copy of each of `source`'s files
        it lacks; a damaged file is not copied."""
        with self.store.locked():
            for name in self.names(source):
                try:
                    raw = self._read(self._file(source, name))
                    self.parse(raw, name)
                    if not self._file(target, name).exists():
                        self._write(target, name, raw)
                except (OSError, KeptError):
                    continue

    def files(self, set_id: str) -> list[Path]:
        """The files of a set (for a backup: the store's lock is held by the caller)."""
        try:
            return [self._file(set_id, n) for n in self.names(set_id)]
        except KeptError:
            return []

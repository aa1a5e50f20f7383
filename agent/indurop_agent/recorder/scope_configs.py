"""scope_configs.py -- trace configurations kept beside a stored set (docs/recorder.md "Trace
configurations"): <data>/sets/<id>/scopes/<name>.json, each a capture request (the model POST
/captures takes) and what the Scope page needs to show it again.  A set is content-addressed and
immutable (docs/set-store.md), so they are kept beside its files, not in them; they go wherever the
set folder goes: a prune removes them with it, a backup takes them (system/backup.py).

    configs = ScopeConfigs(store)              # the agent's SetStore
    configs.put(set_id, "square", config, who)  # ScopeError: 404 no such set, 400 a bad name, 409 too many
    configs.list(set_id); configs.get(set_id, "square"); configs.delete(set_id, "square")

Names follow the recorder's rule (recorder/store.py NAME): never a path.  Every change is written
atomically (files.write_json) under the store's lock, so that a prune never meets half a folder.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from pydantic import ValidationError

from ..access.auth import now_iso
from ..api.scope_models import MAX_CONFIG_BYTES, MAX_CONFIGS, ScopeConfig
from ..files import fsync_dir, write_atomically
from ..sets.store import SET_ID, SetStore
from .store import NAME, NAME_RULE

FOLDER = "scopes"
SUFFIX = ".json"
MODE = 0o644  # like a set's manifest: nothing secret


class ScopeError(Exception):
    """A refusal with its HTTP status: 400 a bad name, 404 no such set or configuration, 409 the set
    holds the most it may, 413 a configuration too large, 422 a file that is not a configuration."""

    def __init__(self, status: int, message: str):
        super().__init__(message)
        self.status, self.message = status, message


def check_name(name: str) -> str:
    if not isinstance(name, str) or not NAME.fullmatch(name):
        raise ScopeError(400, f"the name {json.dumps(name)} is not allowed: use {NAME_RULE}")
    return name


def parse(raw: bytes, where: str) -> dict:
    """A saved file's content, checked: {"name", "saved", "by", "config"} with `config` valid as a
    ScopeConfig.  ScopeError 413/422 naming `where` otherwise."""
    if len(raw) > MAX_CONFIG_BYTES:
        raise ScopeError(413, f"{where} is {len(raw)} bytes; a trace configuration is at most {MAX_CONFIG_BYTES}")
    try:
        saved = json.loads(raw)
    except (ValueError, UnicodeDecodeError) as e:
        raise ScopeError(422, f"{where} is not JSON: {e}") from None
    if not isinstance(saved, dict) or not isinstance(saved.get("name"), str):
        raise ScopeError(422, f"{where} is not a trace configuration (no name)")
    try:
        config = ScopeConfig.model_validate(saved.get("config"))
    except ValidationError as e:
        first = e.errors()[0]
        at = ".".join(str(p) for p in first["loc"])
        raise ScopeError(422, f"{where} is not a trace configuration: {at}: {first['msg']}") from None
    by = saved.get("by")
    return {
        "name": saved["name"],
        "saved": saved.get("saved") if isinstance(saved.get("saved"), str) else "",
        "by": by if isinstance(by, dict) else None,
        "config": config.model_dump(mode="json"),
    }


def encode(name: str, config: ScopeConfig, who: dict | None, saved: str | None = None) -> bytes:
    body = {
        "name": name,
        "saved": saved or now_iso(),
        "by": who,
        "config": config.model_dump(mode="json"),
    }
    return json.dumps(body, indent=1).encode()


class ScopeConfigs:
    def __init__(self, store: SetStore):
        self.store = store

    def folder(self, set_id: str) -> Path:
        """sets/<id>/scopes of a stored set; ScopeError 404 when there is no such set."""
        if not isinstance(set_id, str) or not SET_ID.match(set_id) or self.store.manifest(set_id) is None:
            raise ScopeError(404, f"no set {set_id!r} in the set store (GET /sets lists them)")
        return self.store.sets / set_id / FOLDER

    def _file(self, set_id: str, name: str) -> Path:
        folder = self.folder(set_id)
        if folder.is_symlink() or (folder.exists() and not folder.is_dir()):
            raise ScopeError(409, f"{folder} is not a folder the agent made: move it away")
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
        """The set's configurations, by name: each as get() answers it, with its size (a damaged
        file is listed with `error`)."""
        with self.store.locked():
            out = []
            for name in self.names(set_id):
                path = self._file(set_id, name)
                try:
                    raw = self._read(path)
                except OSError:
                    continue  # deleted meanwhile
                try:
                    entry = parse(raw, f"trace configuration {name}")
                    out.append({**entry, "name": name, "size": len(raw), "error": None})
                except ScopeError as e:
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
                raise ScopeError(404, f"set {set_id} has no trace configuration {name!r}") from None
            return {**parse(raw, f"trace configuration {name}"), "name": name, "size": len(raw), "error": None}

    def put(self, set_id: str, name: str, config: ScopeConfig, who: dict | None) -> tuple[dict, bool]:
        """Saves (or replaces) a configuration: (what get() answers, whether it is new)."""
        data = encode(check_name(name), config, who)
        if len(data) > MAX_CONFIG_BYTES:
            raise ScopeError(413, f"the configuration is {len(data)} bytes saved; at most {MAX_CONFIG_BYTES}")
        with self.store.locked():
            path = self._file(set_id, name)
            new = not path.exists()
            if new and len(self.names(set_id)) >= MAX_CONFIGS:
                raise ScopeError(
                    409,
                    f"set {set_id} holds {MAX_CONFIGS} trace configurations, the most it may: delete one first",
                )
            folder = path.parent
            if not folder.is_dir():
                folder.mkdir(mode=0o755)  # sets/<id> exists: the manifest was read under the lock
                fsync_dir(folder.parent)
            write_atomically(path, data, MODE)
            return {**parse(data, name), "name": name, "size": len(data), "error": None}, new

    def delete(self, set_id: str, name: str) -> None:
        with self.store.locked():
            path = self._file(set_id, name)
            try:
                os.unlink(path)
            except FileNotFoundError:
                raise ScopeError(404, f"set {set_id} has no trace configuration {name!r}") from None
            fsync_dir(path.parent)

    def files(self, set_id: str) -> list[Path]:
        """The configuration files of a set (for a backup: the store's lock is held by the caller)."""
        try:
            return [self._file(set_id, n) for n in self.names(set_id)]
        except ScopeError:
            return []

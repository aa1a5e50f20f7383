"""sets.py -- a new joint map becomes a new version of the running set: the running set's files
with robot.json replaced, stored content-addressed like any upload (so it has history and can be
rolled back) and activated by a hot reload that keeps every module (same files, same properties).

A running set that is not in the store yet (irpd started directly on a build folder) is first
imported from its folder: every regular file, the running config stored as module.xml (a module.xml
beside it that is not the running one is left out), checked as an upload is."""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

from fastapi import HTTPException

from ..sets import uploads
from ..sets.activation import irpd_validation
from ..sets.store import StagedFile, remove_tree
from .mapping import ROBOT_JSON

NOT_CHECKED_YET = {"valid": None, "errors": [], "warnings": ["not checked yet"], "schedule": None}


def running_set(state, status: dict, who: dict) -> tuple[str, list[dict], bool]:
    """The store's id of the set irpd runs and its files: (id, files, imported now)."""
    store, config = state.store, Path(status["set"])
    set_id = status.get("set_id")
    if set_id:
        manifest = store.manifest(set_id)
        if manifest is not None and store.module_xml(set_id).resolve() == config.resolve():
            return set_id, manifest["files"], False
    manifest = import_folder(state, config, who)
    return manifest["id"], manifest["files"], True


def _stage_copy(source: Path, dest: Path) -> tuple[str, int]:
    digest, size = hashlib.sha256(), 0
    with open(source, "rb") as src, open(dest, "xb") as out:
        while chunk := src.read(1 << 20):
            digest.update(chunk)
            size += len(chunk)
            out.write(chunk)
    return digest.hexdigest(), size


def import_folder(state, config: Path, who: dict) -> dict:
    """Stores the folder irpd runs `config` from as a set (its manifest, with irpd's check)."""
    folder, limits, store = config.parent, uploads.Limits.of(state.settings), state.store
    where = f"the running set's folder {folder}"
    staging = store.staging_dir()
    try:
        received, total = [], 0
        for p in sorted(folder.rglob("*")):
            rel = p.relative_to(folder).as_posix()
            if p.is_symlink() or not p.is_file() or any(part.startswith(".") for part in rel.split("/")):
                continue
            if p.name == "module.xml" and p.resolve() != config.resolve():
                continue  # a config that is not the one running
            name = "module.xml" if p.resolve() == config.resolve() else rel
            if len(received) >= limits.max_files:
                raise HTTPException(413, f"{where} holds more than {limits.max_files} files (max_files)")
            dest = staging / f"f{len(received):05d}"
            sha, size = _stage_copy(p, dest)
            total += size
            if size > limits.max_file_bytes or total > limits.max_upload_bytes:
                raise HTTPException(
                    413, f"{where}: {rel} makes it larger than a set may be (max_file_bytes, max_upload_bytes)"
                )
            received.append(uploads.Received(name, dest, sha, size))
        try:
            files = uploads.check_set(received)
        except uploads.UploadError as e:
            raise HTTPException(e.status_code, f"{where} cannot be stored as a set: {e.detail}") from None
        manifest, new = store.commit(files, who, NOT_CHECKED_YET)
        if new or manifest["validation"]["valid"] is None:
            validation = irpd_validation(
                state.irpd_swap, store.module_xml(manifest["id"]), state.settings.swap_timeout_s
            )
            manifest = store.save_validation(manifest["id"], validation)
        state.events.add(
            "upload",
            f"the running set's folder {folder} stored as set {manifest['id']} "
            f"({len(files)} files, {'new' if new else 'already stored'})",
            set_id=manifest["id"],
        )
        return manifest
    finally:
        remove_tree(staging)


def with_robot_json(state, base_files: list[dict], robot_json: bytes, who: dict) -> dict:
    """Stores the base set's files with robot.json replaced; returns the new set's manifest (the
    same set again if nothing changed)."""
    store = state.store
    staging = store.staging_dir()
    try:
        files = [
            StagedFile(f["path"], store.blobs / f["sha256"], f["sha256"], f["size"], f["kind"])
            for f in base_files
            if f["path"] != ROBOT_JSON
        ]
        dest = staging / ROBOT_JSON
        dest.write_bytes(robot_json)
        files.append(StagedFile(ROBOT_JSON, dest, hashlib.sha256(robot_json).hexdigest(), len(robot_json), "robot"))
        manifest, new = store.commit(files, who, NOT_CHECKED_YET)
        if new or manifest["validation"]["valid"] is None:
            validation = irpd_validation(
                state.irpd_swap, store.module_xml(manifest["id"]), state.settings.swap_timeout_s
            )
            manifest = store.save_validation(manifest["id"], validation)
        return manifest
    finally:
        shutil.rmtree(staging, ignore_errors=True)

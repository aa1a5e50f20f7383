"""opcua_backup.py -- the OPC UA server's files in backups (docs/administration.md, docs/opcua.md
"Backups"): its certificate (backup.ITEMS: opcua/server-cert.der, its key opcua/server-key.pem only
with secrets, as tls/key.pem) and the trust list, the client certificates in opcua/pki/trusted and
opcua/pki/rejected, taken here, checked and put back by restore.py.

A restore that holds the server's certificate or any trust-list file replaces the trust list whole:
the files there now are moved aside with the rest (a certificate trusted here but not in the backup
is not trusted after it).  The certificate comes back only with its key (a backup with secrets) and
only when the two match; else the server keeps its own.  The server reads the trust list again at
its next session, and loads a restored certificate when it starts again.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from cryptography.hazmat.primitives.serialization import load_pem_private_key

from ..opcua.pki import FOLDERS, MAX_FILE_BYTES, load

CERT, KEY = "opcua/server-cert.der", "opcua/server-key.pem"
TRUST = re.compile(r"^opcua/pki/(trusted|rejected)/([A-Za-z0-9_@-][A-Za-z0-9._@-]{0,127})$")
MAX_TRUST_FILES = 1000  # per folder


class Refused(Exception):
    """A trust-list file of a backup that is not a certificate (restore.py makes it a 400)."""


def trust_files(data_dir: Path) -> list[str]:
    """The trust list's files to back up (relative to the data folder): regular files of a name a
    backup may hold, that are certificates.  Links and other files are left out."""
    out = []
    for folder in FOLDERS:
        try:
            entries = sorted(os.scandir(data_dir / "opcua" / "pki" / folder), key=lambda e: e.name)
        except OSError:
            continue
        for e in entries[:MAX_TRUST_FILES]:
            rel = f"opcua/pki/{folder}/{e.name}"
            if not TRUST.match(rel) or not e.is_file(follow_symlinks=False):
                continue
            try:
                if e.stat(follow_symlinks=False).st_size > MAX_FILE_BYTES:
                    continue
                load(Path(e.path))
            except (OSError, ValueError):
                continue
            out.append(rel)
    return out


def check(root: Path, trust: list[str]) -> tuple[list[str], list[str]]:
    """The unpacked backup's OPC UA files (root: its data folder; trust: its trust-list files):
    (item paths not to restore, warnings).  Raises Refused for a trust-list file that is not a
    certificate."""
    for rel in trust:
        try:
            load(root / rel)
        except ValueError as e:
            raise Refused(f"{rel} in the backup is not a certificate: {e}") from None
    skip, warnings = [], []
    cert, key = root / CERT, root / KEY
    if cert.exists() and key.exists():
        try:
            public = load(cert).public_key().public_numbers()
            if load_pem_private_key(key.read_bytes(), None).public_key().public_numbers() != public:
                raise ValueError("the key is not the certificate's")
        except (ValueError, TypeError) as e:
            warnings.append(f"the backup's OPC UA server certificate is not restored ({e}); the one here is kept")
            skip += [CERT, KEY]
    elif cert.exists():
        warnings.append(
            "the backup has the OPC UA server's certificate but not its key (it was taken without secrets): the "
            "server keeps its own certificate, and clients that trusted the backup's must trust this one"
        )
        skip.append(CERT)
    elif key.exists():
        skip.append(KEY)
    if cert.exists() and CERT not in skip:
        warnings.append("the OPC UA server serves the restored certificate once it starts again")
    return skip, warnings


def replaces_trust_list(root: Path, trust: list[str]) -> bool:
    """Whether the backup has the OPC UA server's files at all (then its trust list, even empty,
    replaces the one here)."""
    return bool(trust) or (root / CERT).exists()


def plan_files(trust: list[str] | None, data_dir: Path) -> list[dict]:
    """The trust list's lines of the restore's review (trust: the backup's trust list, None when it
    has none): what it adds, replaces and removes."""
    if trust is None:
        return []
    files = []
    for rel in trust:
        files.append(
            {
                "path": rel,
                "action": "replace" if (data_dir / rel).exists() else "add",
                "what": f"an OPC UA client certificate ({rel.split('/')[2]})",
            }
        )
    for rel in trust_files(data_dir):
        if rel not in trust:
            files.append({"path": rel, "action": "remove", "what": "an OPC UA client certificate the backup lacks"})
    return files


def apply(root: Path, data_dir: Path, trust: list[str] | None, move_aside) -> None:
    """Puts the backup's trust list (None: it has none, nothing changes) in place of the one here,
    each file here moved aside first; every step a rename: run again after a crash, it finishes."""
    if trust is None:
        return
    for folder in FOLDERS:
        here = data_dir / "opcua" / "pki" / folder
        if here.is_dir():
            for p in sorted(here.iterdir()):
                rel = f"opcua/pki/{folder}/{p.name}"
                if rel in trust and not (root / rel).exists():
                    continue  # the backup's, put here by a run of this that a crash cut short
                move_aside(p, rel)
        here.mkdir(mode=0o700, parents=True, exist_ok=True)
    for rel in trust:
        source = root / rel
        if source.exists():
            os.chmod(source, 0o640)
            os.replace(source, data_dir / rel)

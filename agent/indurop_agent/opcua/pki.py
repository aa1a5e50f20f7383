"""pki.py -- the OPC UA server's trust list on disk (<data>/opcua/pki/trusted and rejected): what a
certificate file says (subject, SHA-1 and SHA-256 thumbprints, validity, application URI) and the
moves between the folders that the agent's API and irpctl make (docs/opcua.md "The trust list").

Only the standard library and `cryptography`: the agent imports it without asyncua.  Every move is a
rename inside <data>/opcua/pki (atomic on one file system); the server reads the trusted folder again
at the next CreateSession when its file names change (security.TrustList), so no restart is needed.
"""

from __future__ import annotations

import hashlib
import os
import re
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives.serialization import Encoding

SUFFIXES = (".der", ".pem", ".crt")  # what the server reads in pki/trusted
FOLDERS = ("trusted", "rejected")
MAX_FILES = 1000  # per folder listed: a bound on what one request reads
MAX_FILE_BYTES = 64 << 10  # a certificate is a few KiB; larger files are not read
THUMBPRINT = re.compile(r"[0-9a-fA-F]{40}|[0-9a-fA-F]{64}")
BAD_THUMBPRINT = "a thumbprint is 40 (SHA-1) or 64 (SHA-256) hexadecimal digits, as GET /opcua lists them"


class PkiError(Exception):
    """A move refused: `status` 400 (not a thumbprint) or 404 (no such certificate)."""

    def __init__(self, status: int, message: str):
        super().__init__(message)
        self.status = status


@dataclass
class CertFile:
    folder: str  # trusted or rejected
    path: Path
    der: bytes
    cert: x509.Certificate

    @property
    def sha1(self) -> str:
        return hashlib.sha1(self.der).hexdigest()  # OPC UA's thumbprint is SHA-1 by definition

    @property
    def sha256(self) -> str:
        return hashlib.sha256(self.der).hexdigest()

    def matches(self, thumbprint: str) -> bool:
        t = thumbprint.lower()
        return t == (self.sha1 if len(t) == 40 else self.sha256)

    def describe(self) -> dict:
        c, now = self.cert, datetime.now(UTC)
        return {
            "folder": self.folder,
            "file": self.path.name,
            "subject": c.subject.rfc4514_string(),
            "issuer": c.issuer.rfc4514_string(),
            "sha1": self.sha1,
            "sha256": self.sha256,
            "not_before": c.not_valid_before_utc.isoformat(),
            "not_after": c.not_valid_after_utc.isoformat(),
            "valid_now": c.not_valid_before_utc <= now <= c.not_valid_after_utc,
            "application_uri": application_uri_of(c),
            "ca": is_ca(c),
        }


def load(path: Path) -> x509.Certificate:
    """A certificate file, DER or PEM; ValueError when it is not one."""
    data = path.read_bytes()
    return x509.load_pem_x509_certificate(data) if b"-----BEGIN" in data else x509.load_der_x509_certificate(data)


def der_of(cert: x509.Certificate) -> bytes:
    return cert.public_bytes(Encoding.DER)


def application_uri_of(cert: x509.Certificate) -> str | None:
    try:
        alt = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    except x509.ExtensionNotFound:
        return None
    uris = alt.get_values_for_type(x509.UniformResourceIdentifier)
    return uris[0] if uris else None


def is_ca(cert: x509.Certificate) -> bool:
    try:
        return bool(cert.extensions.get_extension_for_class(x509.BasicConstraints).value.ca)
    except x509.ExtensionNotFound:
        return False


class Pki:
    """<data>/opcua/pki: its two folders, read and changed by thumbprint."""

    def __init__(self, opcua_dir: Path):
        self.root = opcua_dir / "pki"

    def folder(self, name: str) -> Path:
        return self.root / name

    def scan(self) -> tuple[list[CertFile], list[str]]:
        """Every certificate file in both folders (trusted first, by name), and the files there that
        are not certificates, or that the server does not read (in trusted, a name not ending in
        .der, .pem or .crt), as folder/name.  Links are not followed; missing folders are empty."""
        found, unreadable = [], []
        for name in FOLDERS:
            try:
                entries = sorted(os.scandir(self.folder(name)), key=lambda e: e.name)
            except OSError:
                continue
            for e in entries[:MAX_FILES]:
                if e.name.startswith(".") or not e.is_file(follow_symlinks=False):
                    continue
                path = Path(e.path)
                if name == "trusted" and path.suffix.lower() not in SUFFIXES:  # the server does not read it
                    unreadable.append(f"{name}/{e.name}")
                    continue
                try:
                    if e.stat(follow_symlinks=False).st_size > MAX_FILE_BYTES:
                        raise ValueError("too large")
                    cert = load(path)
                except (OSError, ValueError):
                    unreadable.append(f"{name}/{e.name}")
                    continue
                found.append(CertFile(name, path, der_of(cert), cert))
        return found, unreadable

    def listing(self) -> dict:
        found, unreadable = self.scan()
        return {
            "trusted": [f.describe() for f in found if f.folder == "trusted"],
            "rejected": [f.describe() for f in found if f.folder == "rejected"],
            "unreadable": unreadable,
        }

    def find(self, thumbprint: str) -> list[CertFile]:
        """The files holding the certificate of `thumbprint` (SHA-1 or SHA-256, any case)."""
        if not isinstance(thumbprint, str) or not THUMBPRINT.fullmatch(thumbprint):
            raise PkiError(400, f"{thumbprint[:80]!r}: {BAD_THUMBPRINT}")
        hits = [f for f in self.scan()[0] if f.matches(thumbprint)]
        if not hits:
            raise PkiError(404, f"no certificate {thumbprint.lower()} in the OPC UA trust list (trusted or rejected)")
        return hits

    def move(self, thumbprint: str, to: str) -> tuple[CertFile, str]:
        """Moves the certificate into `to` (trusted or rejected), removing other copies of it; the
        certificate and its file name now (renamed when that name holds another certificate)."""
        hits = self.find(thumbprint)
        there = [f for f in hits if f.folder == to]
        keep = there[0] if there else hits[0]
        name = keep.path.name
        if keep.folder != to:
            dest = self.folder(to)
            dest.mkdir(mode=0o700, parents=True, exist_ok=True)
            if (dest / name).exists():
                name = f"{keep.path.stem}-{keep.sha256[:16]}{keep.path.suffix}"
            if keep.path.suffix.lower() not in SUFFIXES:  # the server reads only these in trusted
                name += ".der" if b"-----BEGIN" not in keep.path.read_bytes() else ".pem"
            os.rename(keep.path, dest / name)
        for f in hits:
            if f is not keep:
                f.path.unlink(missing_ok=True)
        return keep, name

    def remove(self, thumbprint: str) -> list[CertFile]:
        """Deletes every file of the certificate, in both folders."""
        hits = self.find(thumbprint)
        for f in hits:
            f.path.unlink(missing_ok=True)
        return hits

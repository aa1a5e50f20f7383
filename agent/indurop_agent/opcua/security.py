"""security.py -- who may open a session, with which role, and which client applications are trusted
(docs/opcua.md "Security").

- Users: a user name and password are checked against the agent's users (<data>/users.json, argon2
  hashes, read only: the agent alone writes the file; it is read again when it changes); X.509 user
  certificates are mapped to a name and role by the settings; anonymous sessions only when allowed.
  Roles are the agent's: viewer reads, browses and subscribes, operator and admin also write.
  Wrong passwords lock the client address and the user name out (the agent's Lockout).
- The server's certificate and key: made at first start under <data>/opcua/ (the key 0600), with
  the host's names and addresses in subjectAltName; made again when expired.
- Client applications: a certificate is trusted when it is in <data>/opcua/pki/trusted (or issued
  by a CA there); an unknown one is copied into pki/rejected and refused (BadCertificateUntrusted)
  until an admin trusts it (the agent's POST /opcua/certificates/{thumbprint}/trust, irpctl opcua
  trust, the OPC UA page: a rename, pki.py).  The trusted folder is read again at a session when its
  files changed.
"""

from __future__ import annotations

import hashlib
import ipaddress
import json
import os
import socket
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from argon2 import PasswordHasher
from asyncua import ua
from asyncua.common.utils import ServiceError
from asyncua.crypto import cert_gen, uacrypto
from asyncua.crypto.permission_rules import User, UserRole
from asyncua.crypto.truststore import TrustStore
from asyncua.crypto.validator import CertificateValidator, CertificateValidatorOptions
from cryptography import x509
from cryptography.hazmat.primitives.serialization import Encoding
from cryptography.x509.oid import ExtendedKeyUsageOID

from ..access.audit import AuditLog
from ..access.auth import allows
from ..access.security import Lockout
from ..access.users import parse_users, password_matches
from .pki import Pki
from .settings import OpcuaSettings

CERT_DAYS = 5 * 365


@dataclass
class OpcUser(User):
    """asyncua's user (every one of ours is UserRole.User: no one changes the address space) with
    the agent's role and how the session was authenticated."""

    agent_role: str = "viewer"
    via: str = "password"  # password, certificate or anonymous

    def may_write(self) -> bool:
        return allows(self.agent_role, "operator")


def application_uri() -> str:
    return f"urn:{socket.gethostname()}:indurop:opcua"


class Users:
    """asyncua's UserManager: the session's identity token against the agent's users."""

    def __init__(self, settings: OpcuaSettings, audit: AuditLog):
        self.settings = settings
        self.audit = audit
        self.path = settings.data_dir / "users.json"
        self.hasher = PasswordHasher()
        self.lockout = Lockout(settings.lockout_attempts, settings.lockout_window_s)
        self._users: dict = {}
        self._stamp: tuple | None = None
        self._decoy = self.hasher.hash(os.urandom(16).hex())
        self.certificates: dict[bytes, tuple[str, str]] = {}  # DER -> (name, role)
        for entry in settings.user_certificates:
            der = uacrypto.der_from_x509(x509_load(Path(entry["certificate"])))
            self.certificates[der] = (entry["name"], entry["role"])
        # Set by the session right before asyncua asks get_user (one thread: nothing comes between).
        self.token = "anonymous"
        self.client = "unknown"

    def _load(self) -> dict:
        try:
            st = self.path.stat()
            stamp = (st.st_mtime_ns, st.st_size, st.st_ino)
        except OSError:
            self._users, self._stamp = {}, None
            return self._users
        if stamp != self._stamp:
            try:
                self._users = parse_users(json.loads(self.path.read_text()))
            except (OSError, ValueError) as e:
                print(f"indurop-opcua: {self.path}: {e}; no user can sign in until it is readable", flush=True)
                self._users = {}
            self._stamp = stamp
        return self._users

    def get_user(self, iserver, username=None, password=None, certificate=None) -> OpcUser | None:
        client, token = self.client, self.token
        if token == "certificate":
            known = self.certificates.get(certificate) if certificate else None
            if known is None:
                self._note(None, client, "certificate", "a user certificate not in user_certificates")
                return None
            self._note(known[0], client, "certificate", None, role=known[1])
            return OpcUser(role=UserRole.User, name=known[0], agent_role=known[1], via="certificate")
        if token == "username":
            return self._password(username or "", password or "", client)
        if self.settings.allow_anonymous:
            return OpcUser(
                role=UserRole.User, name="anonymous", agent_role=self.settings.anonymous_role, via="anonymous"
            )
        self._note(None, client, "anonymous", "anonymous sessions are not allowed")
        return None

    def _password(self, name: str, password: str, client: str) -> OpcUser | None:
        locked = self.lockout.retry_after(client) or self.lockout.retry_after("user:" + name)
        if locked:
            self._note(name, client, "password", f"locked out for {locked} s after too many wrong passwords")
            return None
        user = self._load().get(name)
        good = password_matches(self.hasher, user.hash if user and not user.disabled else self._decoy, password)
        if user is None or user.disabled or not good:
            for key in (client, "user:" + name):
                if self.lockout.failed(key):
                    self.audit.write(
                        "lockout", who=None, client=client, target=key, result="ok",
                        detail=f"{self.lockout.attempts} wrong OPC UA passwords within {self.lockout.window_s:g} s",
                        via="opcua",
                    )  # fmt: skip
            self._note(name, client, "password", "wrong user name or password, or the user is disabled")
            return None
        self._note(name, client, "password", None, role=user.role)
        return OpcUser(role=UserRole.User, name=name, agent_role=user.role, via="password")

    def _note(self, name, client, via, refused, role=None) -> None:
        """One audit line per session sign-in, accepted or refused (as the agent's sign_in)."""
        who = {"id": None, "name": name, "role": role, "user": name if via == "password" else None, "via": "opcua"}
        extra = {"result": "error", "opcua_status": "BadUserAccessDenied", "detail": refused} if refused else {}
        self.audit.write("sign_in", who=who, client=client, target=name, method=via, **({"result": "ok"} | extra))


def x509_load(path: Path) -> x509.Certificate:
    data = path.read_bytes()
    return x509.load_pem_x509_certificate(data) if b"-----BEGIN" in data else x509.load_der_x509_certificate(data)


def host_names(settings: OpcuaSettings) -> tuple[list[str], list[str]]:
    """(DNS names, IP addresses) for the certificate's subjectAltName."""
    names = list(settings.hostnames) or [socket.gethostname(), socket.getfqdn(), "localhost", "127.0.0.1"]
    if settings.host not in ("0.0.0.0", "::") and settings.host not in names:
        names.append(settings.host)
    dns, ips = [], []
    for n in dict.fromkeys(names):
        try:
            ips.append(str(ipaddress.ip_address(n)))
        except ValueError:
            dns.append(n)
    return dns, ips


def ensure_certificate(settings: OpcuaSettings) -> tuple[Path, Path, str]:
    """The server's certificate (DER) and key (PEM, 0600) under <data>/opcua/, made when missing,
    unreadable or expired; (cert, key, what was done)."""
    folder = settings.pki
    for d in (folder, folder / "pki", folder / "pki" / "trusted", folder / "pki" / "rejected"):
        d.mkdir(mode=0o700, parents=True, exist_ok=True)
    cert_path, key_path = folder / "server-cert.der", folder / "server-key.pem"
    try:
        cert = x509.load_der_x509_certificate(cert_path.read_bytes())
        key_path.stat()
        if cert.not_valid_after_utc > datetime.now(UTC):
            return cert_path, key_path, "kept"
        why = "made again: the old one expired"
    except (OSError, ValueError):
        why = "made"
    key = cert_gen.generate_private_key()
    dns, ips = host_names(settings)
    alt = [x509.UniformResourceIdentifier(application_uri())]
    alt += [x509.DNSName(n) for n in dns] + [x509.IPAddress(ipaddress.ip_address(i)) for i in ips]
    cert = cert_gen.generate_self_signed_app_certificate(
        key,
        f"indurop OPC UA server on {socket.gethostname()}",
        {"organizationName": "indurop"},
        alt,
        extended=[ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH],
        days=CERT_DAYS,
    )
    fd = os.open(key_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "wb") as f:
        f.write(cert_gen.dump_private_key_as_pem(key))
    os.chmod(key_path, 0o600)
    cert_path.write_bytes(cert.public_bytes(Encoding.DER))
    return cert_path, key_path, why


def thumbprint(der: bytes) -> str:
    return hashlib.sha256(der).hexdigest()


class TrustList:
    """The client applications' certificates: pki/trusted and pki/rejected.  Used as asyncua's
    certificate_validator (CreateSession): a certificate out of its validity or whose URI is not
    the application's is refused as asyncua's validator says; then it must be trusted."""

    def __init__(self, folder: Path):
        self.trusted_dir, self.rejected_dir = folder / "pki" / "trusted", folder / "pki" / "rejected"
        self.basic = CertificateValidator(
            CertificateValidatorOptions.BASIC_VALIDATION | CertificateValidatorOptions.PEER_CLIENT
        )
        self._stamp: tuple | None = None
        self._trusted: set[bytes] = set()
        self._store: TrustStore | None = None
        self.refused = 0

    async def _reload(self) -> None:
        try:
            files = sorted(p for p in self.trusted_dir.iterdir() if p.suffix.lower() in (".der", ".pem", ".crt"))
            stamp = tuple((p.name, p.stat().st_mtime_ns) for p in files)
        except OSError:
            files, stamp = [], ()
        if stamp == self._stamp:
            return
        trusted = set()
        for p in files:
            try:
                trusted.add(uacrypto.der_from_x509(x509_load(p)))
            except (OSError, ValueError) as e:
                print(f"indurop-opcua: {p}: not a certificate ({e}); ignored", flush=True)
        self._trusted, self._store = trusted, None
        if trusted:  # a CA among them trusts what it issued (the library checks the chain)
            store = TrustStore([self.trusted_dir], [])
            try:
                await store.load_trust()
                self._store = store
            except Exception as e:  # a file the library cannot read: exact matches still work
                print(f"indurop-opcua: {self.trusted_dir}: {e}", flush=True)
        self._stamp = stamp

    async def __call__(self, cert: x509.Certificate, description: ua.ApplicationDescription) -> None:
        await self.basic.validate(cert, description)  # ServiceError: time range, application URI
        await self._reload()
        der = uacrypto.der_from_x509(cert)
        if der in self._trusted:
            return
        if self._store is not None and self._store.is_trusted(cert):
            return
        self.refused += 1
        name = f"{_safe(description.ApplicationUri or 'client')}-{thumbprint(der)[:16]}.der"
        try:
            if not any(p.read_bytes() == der for p in self.rejected_dir.glob("*.der")):
                (self.rejected_dir / name).write_bytes(der)
        except OSError as e:
            print(f"indurop-opcua: {self.rejected_dir}: {e}", flush=True)
        raise ServiceError(ua.StatusCodes.BadCertificateUntrusted)

    def listing(self) -> dict:
        """The trusted and rejected certificates (pki.py's description of each) and the refusals."""
        return Pki(self.trusted_dir.parents[1]).listing() | {"refused": self.refused}


def _safe(text: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in text)[:64]

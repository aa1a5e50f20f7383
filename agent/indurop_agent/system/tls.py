"""tls.py -- the agent's TLS certificate: made self-signed at the package's first install, described
(SHA-256 fingerprint, validity, names) for GET /system and the install log, and replaced by an
admin's own certificate and key after checking them (the `cryptography` package does the X.509).

    python -m indurop_agent.system.tls ensure DATA_DIR [--name HOST ...]
        makes DATA_DIR/tls/cert.pem and key.pem unless both exist; prints the fingerprint
    python -m indurop_agent.system.tls show CERT.pem

The key is ECDSA P-256 (every current browser and TLS library takes it, and it is made in
milliseconds); the certificate is valid for ten years from the install (an appliance's self-signed
certificate is trusted by its fingerprint, not by its age; browsers limit the lifetime of publicly
trusted certificates only) and names localhost, 127.0.0.1, ::1, the machine's host name and the
addresses that name resolves to.
"""

from __future__ import annotations

import argparse
import ipaddress
import socket
import ssl
import sys
import tempfile
from datetime import UTC, datetime, timedelta
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec, ed448, ed25519, rsa
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from ..files import write_atomically

CERT_NAME, KEY_NAME = "cert.pem", "key.pem"
VALID_DAYS = 3650
MAX_PEM_BYTES = 256 << 10  # a certificate chain or a key larger than this is refused
MIN_RSA_BITS = 2048


class CertificateError(ValueError):
    """A certificate or key that cannot be used; the message says what to fix."""


def tls_paths(data_dir: Path) -> tuple[Path, Path]:
    """Where the package keeps the agent's certificate and key: <data>/tls/cert.pem and key.pem."""
    return data_dir / "tls" / CERT_NAME, data_dir / "tls" / KEY_NAME


def fingerprint(cert: x509.Certificate) -> str:
    """The SHA-256 fingerprint as browsers show it: 32 hex bytes separated by colons."""
    return cert.fingerprint(hashes.SHA256()).hex(":").upper()


def _names(cert: x509.Certificate) -> list[str]:
    try:
        san = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    except x509.ExtensionNotFound:
        return []
    return [str(n) for n in san.get_values_for_type(x509.DNSName)] + [
        str(a) for a in san.get_values_for_type(x509.IPAddress)
    ]


def describe(cert: x509.Certificate, now: datetime | None = None) -> dict:
    """What GET /system shows of a certificate (models.TlsCertificate)."""
    now = now or datetime.now(UTC)
    not_after = cert.not_valid_after_utc
    return {
        "fingerprint_sha256": fingerprint(cert),
        "subject": cert.subject.rfc4514_string(),
        "issuer": cert.issuer.rfc4514_string(),
        "self_signed": cert.issuer == cert.subject,
        "names": _names(cert),
        "not_before": cert.not_valid_before_utc.isoformat().replace("+00:00", "Z"),
        "not_after": not_after.isoformat().replace("+00:00", "Z"),
        "days_left": int((not_after - now).total_seconds() // 86400),
    }


def read_certificate(path: Path) -> x509.Certificate:
    """The first certificate of a PEM file (the server's own; a chain may follow it)."""
    try:
        return x509.load_pem_x509_certificates(Path(path).read_bytes())[0]
    except OSError as e:
        raise CertificateError(f"cannot read the certificate {path}: {e.strerror}") from e
    except ValueError as e:
        raise CertificateError(f"{path} is not a PEM certificate: {e}") from e


# ---- making one ------------------------------------------------------------------------------
def default_names() -> tuple[list[str], list[ipaddress.IPv4Address | ipaddress.IPv6Address]]:
    """localhost and this machine's host names; loopback and the addresses its host name resolves to."""
    host = socket.gethostname()
    dns = ["localhost"]
    for name in (host, socket.getfqdn()):
        if name and name not in dns and not _is_ip(name):
            dns.append(name)
    ips: list = [ipaddress.ip_address("127.0.0.1"), ipaddress.ip_address("::1")]
    try:
        for *_, sockaddr in socket.getaddrinfo(host, None):
            ip = ipaddress.ip_address(sockaddr[0].split("%")[0])
            if ip not in ips:
                ips.append(ip)
    except (OSError, ValueError):
        pass  # a host name that does not resolve: the certificate names the loopback only
    return dns, ips


def _is_ip(text: str) -> bool:
    try:
        ipaddress.ip_address(text)
        return True
    except ValueError:
        return False


def self_signed(dns: list[str], ips: list, days: int = VALID_DAYS) -> tuple[bytes, bytes]:
    """A new ECDSA P-256 key and a self-signed certificate for `dns` and `ips`: (cert PEM, key PEM)."""
    key = ec.generate_private_key(ec.SECP256R1())
    name = x509.Name(
        [
            x509.NameAttribute(NameOID.COMMON_NAME, (dns[1] if len(dns) > 1 else dns[0])[:64]),
            x509.NameAttribute(NameOID.ORGANIZATION_NAME, "indurop appliance"),
        ]
    )
    now = datetime.now(UTC)
    cert = (
        x509.CertificateBuilder()
        .subject_name(name)
        .issuer_name(name)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - timedelta(minutes=5))  # a clock a little behind still takes it
        .not_valid_after(now + timedelta(days=days))
        .add_extension(
            x509.SubjectAlternativeName([x509.DNSName(d) for d in dns] + [x509.IPAddress(i) for i in ips]),
            critical=False,
        )
        # its own trust anchor (irpctl --ca cert.pem, curl --cacert): a CA that may sign nothing else
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .add_extension(
            x509.KeyUsage(
                digital_signature=True,
                content_commitment=False,
                key_encipherment=False,
                data_encipherment=False,
                key_agreement=False,
                key_cert_sign=True,
                crl_sign=False,
                encipher_only=False,
                decipher_only=False,
            ),
            critical=True,
        )
        .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH]), critical=False)
        .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()), critical=False)
        .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(key.public_key()), critical=False)
        .sign(key, hashes.SHA256())
    )
    key_pem = key.private_bytes(
        serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption()
    )
    return cert.public_bytes(serialization.Encoding.PEM), key_pem


# ---- checking an admin's own -----------------------------------------------------------------
def check_pair(cert_pem: bytes, key_pem: bytes, now: datetime | None = None) -> dict:
    """Checks an uploaded certificate (chain) and key: PEM, the key not encrypted and of a usable
    type and size, the key that of the first certificate, valid now; then that Python's TLS
    accepts the pair as uvicorn will load it.  Returns describe() of the certificate; raises
    CertificateError naming the problem."""
    now = now or datetime.now(UTC)
    for what, pem in (("certificate", cert_pem), ("key", key_pem)):
        if not pem.strip():
            raise CertificateError(f"the {what} is empty")
        if len(pem) > MAX_PEM_BYTES:
            raise CertificateError(f"the {what} is {len(pem)} bytes; at most {MAX_PEM_BYTES} are accepted")
    try:
        chain = x509.load_pem_x509_certificates(cert_pem)
    except ValueError as e:
        raise CertificateError(f"the certificate is not PEM (-----BEGIN CERTIFICATE-----): {e}") from e
    cert = chain[0]
    try:
        key = serialization.load_pem_private_key(key_pem, password=None)
    except TypeError as e:  # encrypted
        raise CertificateError("the key is encrypted; upload it without a passphrase (openssl pkey -in key.pem)") from e
    except Exception as e:  # noqa: BLE001 -- ValueError, UnsupportedAlgorithm, ...: all mean "not a usable key"
        raise CertificateError(f"the key is not a PEM private key (-----BEGIN PRIVATE KEY-----): {e}") from e
    if isinstance(key, rsa.RSAPrivateKey) and key.key_size < MIN_RSA_BITS:
        raise CertificateError(f"the RSA key has {key.key_size} bits; at least {MIN_RSA_BITS} are needed")
    if not isinstance(
        key, (rsa.RSAPrivateKey, ec.EllipticCurvePrivateKey, ed25519.Ed25519PrivateKey, ed448.Ed448PrivateKey)
    ):
        raise CertificateError(f"a {type(key).__name__} cannot serve TLS; give an RSA or ECDSA key")
    public = serialization.PublicFormat.SubjectPublicKeyInfo
    if key.public_key().public_bytes(serialization.Encoding.DER, public) != cert.public_key().public_bytes(
        serialization.Encoding.DER, public
    ):
        raise CertificateError(
            "the key does not belong to the certificate (their public keys differ); the certificate must "
            "come first in its file"
        )
    if now < cert.not_valid_before_utc:
        raise CertificateError(f"the certificate is not valid before {cert.not_valid_before_utc:%Y-%m-%d %H:%M} UTC")
    if now >= cert.not_valid_after_utc:
        raise CertificateError(f"the certificate expired on {cert.not_valid_after_utc:%Y-%m-%d %H:%M} UTC")
    with tempfile.TemporaryDirectory() as d:  # what uvicorn will do with them
        cert_file, key_file = Path(d) / CERT_NAME, Path(d) / KEY_NAME
        cert_file.write_bytes(cert_pem)
        key_file.write_bytes(key_pem)
        try:
            ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER).load_cert_chain(cert_file, key_file)
        except ssl.SSLError as e:
            raise CertificateError(f"TLS refuses the pair: {e.reason or e}") from e
    return describe(cert, now)


# ---- writing ---------------------------------------------------------------------------------
def install(cert_path: Path, key_path: Path, cert_pem: bytes, key_pem: bytes) -> None:
    """Writes the pair (the key 0600, the certificate 0644), each replaced atomically; the ones
    they replace are kept as <name>.previous."""
    cert_path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
    for path, data, mode in ((key_path, key_pem, 0o600), (cert_path, cert_pem, 0o644)):
        if path.exists():
            write_atomically(path.with_name(path.name + ".previous"), path.read_bytes(), mode)
        write_atomically(path, data, mode)


def ensure(data_dir: Path, dns: list[str] | None = None) -> tuple[Path, bool]:
    """Makes <data>/tls/cert.pem and key.pem (self-signed) unless both exist: (cert path, made now)."""
    cert_path, key_path = tls_paths(data_dir)
    if cert_path.exists() and key_path.exists():
        return cert_path, False
    names, ips = default_names()
    for extra in dns or []:
        if _is_ip(extra):
            ips.append(ipaddress.ip_address(extra))
        elif extra not in names:
            names.append(extra)
    cert_pem, key_pem = self_signed(names, ips)
    install(cert_path, key_path, cert_pem, key_pem)
    return cert_path, True


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m indurop_agent.system.tls", description="the agent's TLS certificate")
    sub = ap.add_subparsers(dest="command", required=True)
    e = sub.add_parser("ensure", help="make DATA_DIR/tls/cert.pem and key.pem (self-signed) unless they exist")
    e.add_argument("data_dir", type=Path)
    e.add_argument("--name", action="append", default=[], help="another host name or address for the certificate")
    s = sub.add_parser("show", help="a certificate's fingerprint and validity")
    s.add_argument("cert", type=Path)
    a = ap.parse_args(argv)
    try:
        if a.command == "ensure":
            cert_path, made = ensure(a.data_dir, a.name)
            info = describe(read_certificate(cert_path))
            verb = "made a self-signed TLS certificate" if made else "the TLS certificate is"
            print(f"indurop: {verb} {cert_path}")
        else:
            info = describe(read_certificate(a.cert))
        print(f"indurop: SHA-256 fingerprint {info['fingerprint_sha256']}")
        print(f"indurop: valid until {info['not_after']}; names: {', '.join(info['names']) or '-'}")
    except (CertificateError, OSError) as err:
        print(f"indurop: {err}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())

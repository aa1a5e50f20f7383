"""test_system_tls.py -- the agent's TLS certificate (system/tls.py): the self-signed one the package
makes (names, modes, fingerprint, kept when it exists), the checks of an uploaded pair (each
refusal names what is wrong), and a real agent serving HTTPS: GET /system shows the fingerprint of
the certificate it serves, POST /system/tls replaces it and the agent, restarted, serves the new
one; plain HTTP is not answered.  docs/administration.md, "HTTPS"."""

from __future__ import annotations

import hashlib
import ipaddress
import ssl
import stat
from datetime import UTC, datetime, timedelta

import httpx
import pytest
from agent_helpers import API, free_port, start_agent, stop
from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec, rsa
from cryptography.x509.oid import NameOID
from indurop_agent.system import tls

LOOPBACK = [ipaddress.ip_address("127.0.0.1")]


def pair(days: int = 30, start_days: int = -1, key=None, bits: int = 2048) -> tuple[bytes, bytes]:
    """A self-signed certificate for 127.0.0.1 valid from `start_days` for `days`, and its key."""
    key = key or rsa.generate_private_key(public_exponent=65537, key_size=bits)
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "test")])
    now = datetime.now(UTC)
    cert = (
        x509.CertificateBuilder()
        .subject_name(name)
        .issuer_name(name)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now + timedelta(days=start_days))
        .not_valid_after(now + timedelta(days=start_days + days))
        .add_extension(x509.SubjectAlternativeName([x509.IPAddress(LOOPBACK[0])]), critical=False)
        .sign(key, hashes.SHA256())
    )
    pem = key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption())
    return cert.public_bytes(serialization.Encoding.PEM), pem


# ---- the self-signed certificate ---------------------------------------------------------------
def test_ensure_makes_a_self_signed_pair_once_with_a_private_key(tmp_path):
    cert_path, made = tls.ensure(tmp_path)
    assert made and cert_path == tmp_path / "tls" / "cert.pem"
    key_path = tmp_path / "tls" / "key.pem"
    assert stat.S_IMODE(key_path.stat().st_mode) == 0o600
    assert stat.S_IMODE((tmp_path / "tls").stat().st_mode) == 0o700
    cert = x509.load_pem_x509_certificate(cert_path.read_bytes())
    info = tls.describe(cert)
    der = cert.public_bytes(serialization.Encoding.DER)
    assert (
        info["fingerprint_sha256"] == hashlib.sha256(der).digest().hex(":").upper()
        and len(info["fingerprint_sha256"]) == 95
    )
    assert info["fingerprint_sha256"].count(":") == 31
    assert {"localhost", "127.0.0.1", "::1"} <= set(info["names"])
    assert info["self_signed"] is True and info["days_left"] >= 3649
    tls.check_pair(cert_path.read_bytes(), key_path.read_bytes())  # the agent would serve it
    before = cert_path.read_bytes()
    assert tls.ensure(tmp_path) == (cert_path, False) and cert_path.read_bytes() == before  # kept


def test_the_ensure_command_prints_the_fingerprint(tmp_path, capsys):
    assert tls.main(["ensure", str(tmp_path), "--name", "cell7.plant"]) == 0
    out = capsys.readouterr().out
    info = tls.describe(tls.read_certificate(tmp_path / "tls" / "cert.pem"))
    assert info["fingerprint_sha256"] in out and "cell7.plant" in info["names"]


# ---- an uploaded pair's checks -----------------------------------------------------------------
def test_a_good_pair_is_described():
    cert, key = pair()
    info = tls.check_pair(cert, key)
    assert info["subject"] == "CN=test" and info["names"] == ["127.0.0.1"] and info["days_left"] in (28, 29)


@pytest.mark.parametrize(
    "make, words",
    [
        (lambda: pair(days=1, start_days=-10), "expired"),
        (lambda: pair(start_days=2), "not valid before"),
        (lambda: (pair()[0], pair()[1]), "does not belong to the certificate"),
        (
            lambda: (pair()[0], b"-----BEGIN PRIVATE KEY-----\nnot base64\n-----END PRIVATE KEY-----\n"),
            "not a PEM private key",
        ),
        (lambda: (b"hello", pair()[1]), "not PEM"),
        (lambda: (b"", pair()[1]), "empty"),
        (lambda: pair(bits=1024), "1024 bits"),
        (lambda: (pair()[0], b"x" * (300 << 10)), "bytes; at most"),
    ],
    ids=["expired", "not-yet-valid", "another-key", "bad-key", "bad-cert", "empty", "weak-rsa", "huge"],
)
def test_an_unusable_pair_is_refused_naming_why(make, words):
    cert, key = make()
    with pytest.raises(tls.CertificateError) as e:
        tls.check_pair(cert, key)
    assert words in str(e.value)


def test_an_encrypted_key_is_refused_with_how_to_decrypt_it():
    key = ec.generate_private_key(ec.SECP256R1())
    cert, _ = pair(key=key)
    encrypted = key.private_bytes(
        serialization.Encoding.PEM,
        serialization.PrivateFormat.PKCS8,
        serialization.BestAvailableEncryption(b"secret"),
    )
    with pytest.raises(tls.CertificateError, match="encrypted"):
        tls.check_pair(cert, encrypted)


# ---- a real agent on HTTPS ---------------------------------------------------------------------
def served_fingerprint(port: int) -> str:
    pem = ssl.get_server_certificate(("127.0.0.1", port))
    return tls.fingerprint(x509.load_pem_x509_certificate(pem.encode()))


def test_the_agent_serves_its_certificate_and_an_admin_replaces_it(tmp_path):
    data = tmp_path / "data"
    cert_path, _ = tls.ensure(data)
    key_path = data / "tls" / "key.pem"
    port = free_port()
    args = ("--tls-cert", str(cert_path), "--tls-key", str(key_path))
    env = {"INDUROP_SUPERVISOR": "test"}
    agent = start_agent(port, data, tmp_path / "no-irpd.sock", *args, ca=cert_path, env=env)
    try:
        url = f"https://127.0.0.1:{port}{API}"
        h = {"Authorization": f"Bearer {(data / 'admin-token').read_text().strip()}"}
        with pytest.raises(httpx.HTTPError):  # plain HTTP is not answered
            httpx.get(f"http://127.0.0.1:{port}{API}/health", timeout=5)
        s = httpx.get(f"{url}/system", headers=h, verify=str(cert_path), timeout=30).json()
        assert s["agent"]["scheme"] == "https"
        assert s["tls"]["fingerprint_sha256"] == served_fingerprint(port) and s["tls"]["error"] is None

        old = cert_path.read_bytes()
        cert, key = pair()
        bad = httpx.post(
            f"{url}/system/tls",
            json={"certificate": cert.decode(), "key": pair()[1].decode()},
            headers=h,
            verify=str(cert_path),
            timeout=30,
        )
        assert bad.status_code == 400 and "does not belong" in bad.json()["detail"]
        assert cert_path.read_bytes() == old  # a refused pair changes nothing

        r = httpx.post(
            f"{url}/system/tls",
            json={"certificate": cert.decode(), "key": key.decode()},
            headers=h,
            verify=str(cert_path),
            timeout=30,
        )
        assert r.status_code == 200, r.text
        assert r.json()["restarting"] is True
        new_fingerprint = r.json()["certificate"]["fingerprint_sha256"]
        assert agent.wait(20) == 75  # it restarts to serve the new pair
        assert cert_path.read_bytes() == cert and (data / "tls" / "cert.pem.previous").read_bytes() == old
        assert stat.S_IMODE(key_path.stat().st_mode) == 0o600
        new_ca = tmp_path / "new.pem"
        new_ca.write_bytes(cert)
        agent = start_agent(port, data, tmp_path / "no-irpd.sock", *args, ca=new_ca, env=env)
        assert served_fingerprint(port) == new_fingerprint
        entry = [line for line in (data / "audit.jsonl").read_text().splitlines() if '"tls_upload"' in line]
        assert len(entry) == 2 and '"result": "error"' in entry[0] and '"result": "ok"' in entry[1]
    finally:
        stop(agent)


def test_a_certificate_cannot_be_uploaded_to_an_agent_on_plain_http(make_agent):
    agent = make_agent()
    cert, key = pair()
    r = agent.client.post(
        f"{API}/system/tls", json={"certificate": cert.decode(), "key": key.decode()}, headers=agent.h()
    )
    assert r.status_code == 409 and "plain HTTP" in r.json()["detail"]
    assert agent.client.post(f"{API}/system/tls", json={"certificate": "x"}, headers=agent.h()).status_code == 422
    for role in ("viewer", "operator"):
        assert (
            agent.client.post(
                f"{API}/system/tls", json={"certificate": "x", "key": "y"}, headers=agent.h(role)
            ).status_code
            == 403
        )


def test_a_certificate_outside_the_data_folder_is_not_replaced(make_agent, tmp_path):
    cert, key = pair()
    (tmp_path / "c.pem").write_bytes(cert)
    (tmp_path / "k.pem").write_bytes(key)
    agent = make_agent(tls_cert=tmp_path / "c.pem", tls_key=tmp_path / "k.pem")
    r = agent.client.post(
        f"{API}/system/tls", json={"certificate": cert.decode(), "key": key.decode()}, headers=agent.h()
    )
    assert r.status_code == 409 and "outside its data folder" in r.json()["detail"]
    assert agent.client.get(f"{API}/system", headers=agent.h()).json()["tls"]["names"] == ["127.0.0.1"]

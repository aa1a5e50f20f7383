"""test_opcua_trust.py -- GET /opcua and the trust list's routes on an in-process agent (no irpd, no
OPC UA server: its status.json and PKI folders are written here as the server writes them): the
state and its warning, the certificates with both thumbprints, trust / reject / remove as renames
in the folders, audited, admin only; bad thumbprints 400 and unknown ones 404 with nothing changed;
irpctl opcua status, certs, trust, reject and rm against a real agent.
The server taking the change without a restart: tests/python/opcua/test_node_opcua.py."""

from __future__ import annotations

import hashlib
import json
import os
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest
from agent_helpers import API, free_port, start_agent, stop
from cryptography import x509
from cryptography.hazmat.primitives import hashes
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.hazmat.primitives.serialization import Encoding
from cryptography.x509.oid import NameOID
from indurop_agent.cli import irpctl as cli


def certificate(name: str, uri: str, days: int = 30) -> bytes:
    """A self-signed client application certificate (DER) naming `uri`."""
    key = ec.generate_private_key(ec.SECP256R1())
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, name)])
    now = datetime.now(UTC)
    cert = (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - timedelta(days=1))
        .not_valid_after(now + timedelta(days=days))
        .add_extension(x509.SubjectAlternativeName([x509.UniformResourceIdentifier(uri)]), critical=False)
        .sign(key, hashes.SHA256())
    )
    return cert.public_bytes(Encoding.DER)


def pki(agent) -> Path:
    root = agent.data / "opcua" / "pki"
    for f in ("trusted", "rejected"):
        (root / f).mkdir(parents=True, exist_ok=True)
    return root


def server_status(agent, age_s: float = 0, **overrides) -> None:
    updated = (datetime.now(UTC) - timedelta(seconds=age_s)).isoformat().replace("+00:00", "Z")
    body = {
        "format": 1,
        "pid": 4242,
        "started": updated,
        "updated": updated,
        "status_file_s": 5.0,
        "endpoint": "opc.tcp://127.0.0.1:4840/",
        "application_uri": "urn:host:indurop:opcua",
        "security": {"policies": ["Basic256Sha256"], "security_none": False, "anonymous": False, "warnings": []},
        "certificate": {"file": "server-cert.der", "subject": "CN=x", "sha1": "a" * 40, "sha256": "b" * 64},
        "trust": {"trusted": [], "rejected": [], "refused": 3},
        "irpd": True,
        "layout_hash": "c" * 64,
        "sessions": 2,
        "subscriptions": 1,
        "monitored_items": 17,
        **overrides,
    }
    (agent.data / "opcua").mkdir(parents=True, exist_ok=True)
    (agent.data / "opcua" / "status.json").write_text(json.dumps(body))


def state(agent, role: str = "viewer") -> dict:
    r = agent.client.get(f"{API}/opcua", headers=agent.h(role))
    assert r.status_code == 200, r.text
    return r.json()


def change(agent, verb: str, thumbprint: str, role: str = "admin"):
    if verb == "remove":
        return agent.client.delete(f"{API}/opcua/certificates/{thumbprint}", headers=agent.h(role))
    return agent.client.post(f"{API}/opcua/certificates/{thumbprint}/{verb}", headers=agent.h(role))


def test_without_a_server_the_state_is_off_and_the_lists_empty_and_nothing_is_made(agent):
    s = state(agent)
    assert s["server"] == "off" and "has not run" in s["message"]
    assert s["trusted"] == [] and s["rejected"] == [] and s["endpoint"] is None
    assert not (agent.data / "opcua").exists()


def test_the_state_from_status_json_with_the_insecure_warning_and_stale_when_old(agent):
    server_status(agent)
    s = state(agent)
    assert s["server"] == "ok" and s["message"] == ""
    assert s["endpoint"] == "opc.tcp://127.0.0.1:4840/" and s["sessions"] == 2 and s["monitored_items"] == 17
    assert s["refused"] == 3 and s["security"]["warnings"] == [] and s["certificate"]["sha1"] == "a" * 40
    warning = "anonymous sessions are allowed (role viewer)"
    server_status(
        agent, security={"policies": ["None"], "security_none": True, "anonymous": True, "warnings": [warning]}
    )
    s = state(agent)
    assert s["security"]["anonymous"] and s["security"]["security_none"] and s["security"]["warnings"] == [warning]
    server_status(agent, age_s=60)
    s = state(agent)
    assert s["server"] == "stale" and "stopped or stuck" in s["message"] and s["age_s"] >= 59
    (agent.data / "opcua" / "status.json").write_text("{not json")
    assert state(agent)["server"] == "unreadable"


def test_certificates_are_listed_with_both_thumbprints_uri_and_validity(agent):
    root = pki(agent)
    der = certificate("UaExpert@ws1", "urn:ws1:UnifiedAutomation:UaExpert")
    (root / "rejected" / "uaexpert.der").write_bytes(der)
    (root / "trusted" / "notes.txt").write_text("not a certificate")
    s = state(agent)
    [c] = s["rejected"]
    assert c["file"] == "uaexpert.der" and c["folder"] == "rejected" and c["subject"] == "CN=UaExpert@ws1"
    assert c["sha1"] == hashlib.sha1(der).hexdigest() and c["sha256"] == hashlib.sha256(der).hexdigest()
    assert c["application_uri"] == "urn:ws1:UnifiedAutomation:UaExpert" and c["valid_now"] and not c["ca"]
    assert s["trusted"] == [] and s["unreadable"] == ["trusted/notes.txt"]


def test_trust_reject_and_remove_move_the_file_are_audited_and_need_an_admin(agent):
    root = pki(agent)
    der = certificate("mes", "urn:plant:mes")
    sha1, sha256 = hashlib.sha1(der).hexdigest(), hashlib.sha256(der).hexdigest()
    (root / "rejected" / "mes.der").write_bytes(der)
    for role in ("viewer", "operator"):
        r = change(agent, "trust", sha1, role)
        assert r.status_code == 403 and "needs the admin role" in r.json()["detail"]
    assert (root / "rejected" / "mes.der").exists()
    inode = (root / "rejected" / "mes.der").stat().st_ino
    r = change(agent, "trust", sha1.upper())
    assert r.status_code == 200, r.text
    assert r.json()["changed"] and r.json()["certificate"]["folder"] == "trusted"
    assert os.listdir(root / "rejected") == [] and (root / "trusted" / "mes.der").stat().st_ino == inode  # renamed
    assert state(agent)["trusted"][0]["sha256"] == sha256
    r = change(agent, "trust", sha256)
    assert r.status_code == 200 and not r.json()["changed"] and "already in trusted" in r.json()["detail"]
    r = change(agent, "reject", sha256)
    assert r.status_code == 200 and r.json()["certificate"]["folder"] == "rejected"
    assert os.listdir(root / "trusted") == [] and os.listdir(root / "rejected") == ["mes.der"]
    r = change(agent, "remove", sha1)
    assert r.status_code == 200 and "removed rejected/mes.der" in r.json()["detail"]
    assert os.listdir(root / "rejected") == []
    lines = [a for a in agent.audit() if a["action"].startswith("opcua_")]
    assert [(a["action"], a["result"]) for a in lines] == [  # the refused roles never reach the route
        ("opcua_trust", "ok"),
        ("opcua_trust", "ok"),
        ("opcua_reject", "ok"),
        ("opcua_remove", "ok"),
    ]
    ok = [a for a in lines if a["result"] == "ok"]
    assert all(a["target"] == sha256 and a["subject"] == "CN=mes" for a in ok)


def test_trusting_into_a_name_taken_by_another_certificate_keeps_both(agent):
    root = pki(agent)
    mine, other = certificate("a", "urn:a"), certificate("b", "urn:b")
    (root / "rejected" / "client.der").write_bytes(mine)
    (root / "trusted" / "client.der").write_bytes(other)
    r = change(agent, "trust", hashlib.sha256(mine).hexdigest())
    assert r.status_code == 200, r.text
    names = sorted(os.listdir(root / "trusted"))
    assert names == ["client-" + hashlib.sha256(mine).hexdigest()[:16] + ".der", "client.der"]
    assert (root / "trusted" / "client.der").read_bytes() == other


@pytest.mark.parametrize(
    "thumbprint, status, words",
    [
        ("xyz", 400, "40 (SHA-1) or 64 (SHA-256) hexadecimal digits"),
        ("a" * 39, 400, "hexadecimal digits"),
        ("g" * 40, 400, "hexadecimal digits"),
        ("..%2f..%2fusers.json", 400, "hexadecimal digits"),
        ("%2e%2e", 400, "hexadecimal digits"),
        ("a" * 40, 404, "no certificate"),
        ("0" * 64, 404, "no certificate"),
    ],
)
def test_bad_and_unknown_thumbprints_are_refused_and_change_nothing(agent, thumbprint, status, words):
    root = pki(agent)
    der = certificate("c", "urn:c")
    (root / "rejected" / "c.der").write_bytes(der)
    for verb in ("trust", "reject", "remove"):
        r = change(agent, verb, thumbprint)
        assert r.status_code in (status, 404), (verb, r.status_code, r.text)  # a path the router cannot match: 404
        if r.status_code == status:
            assert words in r.json()["detail"], r.text
    assert os.listdir(root / "rejected") == ["c.der"] and os.listdir(root / "trusted") == []
    assert (root / "rejected" / "c.der").read_bytes() == der


# ---- irpctl opcua ---------------------------------------------------------------------------------
@pytest.fixture
def irpctl(tmp_path, capsys, monkeypatch):
    """A real agent (no irpd) with one rejected client certificate, and irpctl against it."""
    for name in ("INDUROP_URL", "INDUROP_TOKEN", "INDUROP_TOKEN_FILE"):
        monkeypatch.delenv(name, raising=False)
    port, data = free_port(), tmp_path / "data"
    root = data / "opcua" / "pki"
    for f in ("trusted", "rejected"):
        (root / f).mkdir(parents=True)
    der = certificate("UaExpert@ws1", "urn:ws1:UaExpert")
    (root / "rejected" / "uaexpert.der").write_bytes(der)
    agent = start_agent(port, data, tmp_path / "no-irpd.sock")

    def run(*argv: str) -> tuple[int, str, str]:
        capsys.readouterr()
        code = cli.main(["--url", f"http://127.0.0.1:{port}", "--token-file", str(data / "admin-token"), *argv])
        out, err = capsys.readouterr()
        return code, out, err

    run.root, run.der = root, der
    yield run
    stop(agent)


def test_irpctl_opcua_status_certs_trust_reject_and_rm(irpctl):
    sha1 = hashlib.sha1(irpctl.der).hexdigest()
    code, out, _ = irpctl("opcua", "status")
    assert code == 0 and "OPC UA server: off" in out and "0 trusted, 1 rejected" in out
    code, out, _ = irpctl("opcua", "certs")
    assert code == 0 and "rejected  CN=UaExpert@ws1  urn:ws1:UaExpert" in out and sha1 in out
    code, out, _ = irpctl("opcua", "trust", sha1[:8])  # the start of a thumbprint is enough
    assert code == 0 and "moved to trusted/uaexpert.der" in out, out
    assert os.listdir(irpctl.root / "trusted") == ["uaexpert.der"]
    code, out, _ = irpctl("--json", "opcua", "reject", sha1)
    assert code == 0 and json.loads(out)["certificate"]["folder"] == "rejected"
    code, out, err = irpctl("opcua", "rm", "0123456789")
    assert code == 1 and "no certificate's thumbprint starts with 0123456789" in err
    code, out, err = irpctl("opcua", "rm", "abc")
    assert code == 2 and "at least 6 hex digits" in err
    code, out, err = irpctl("opcua", "trust", "../users.json")
    assert code == 2 and "hexadecimal digits" in err
    code, out, err = irpctl("opcua", "trust", "a" * 65)
    assert code == 2 and "hexadecimal digits" in err
    code, out, _ = irpctl("opcua", "rm", sha1)
    assert code == 0 and "removed rejected/uaexpert.der" in out
    code, out, _ = irpctl("opcua", "certs")
    assert code == 0 and "no client certificates" in out


def test_a_trusted_file_the_server_would_not_read_is_listed_as_unreadable(agent):
    root = pki(agent)
    (root / "trusted" / "mes.cer").write_bytes(certificate("mes", "urn:mes"))  # not .der, .pem or .crt
    s = state(agent)
    assert s["trusted"] == [] and s["unreadable"] == ["trusted/mes.cer"]

"""test_opcua_backup.py -- the OPC UA server's files in backups (system/opcua_backup.py), on in-process
agents as test_system_backup.py does: the server's certificate and the trust list always, its key
only with secrets; a restore with secrets brings back the certificate, the key and the trust list
whole (what was trusted here and not in the backup moved aside); without secrets the server keeps
its own certificate; a trust-list file that is not a certificate refuses the archive and changes
nothing; a key that is not the certificate's is not restored.  docs/administration.md, docs/opcua.md."""

from __future__ import annotations

import os

from indurop_agent.opcua.security import ensure_certificate
from indurop_agent.opcua.settings import OpcuaSettings
from test_opcua_trust import certificate
from test_system_backup import backup, members, quiet_restarts, refused, repack, restarted, restore, with_manifest


def with_opcua(agent, trusted: dict[str, bytes], rejected: dict[str, bytes]) -> dict[str, bytes]:
    """The OPC UA server's files in the agent's data folder, as the server makes them: its
    certificate and key, and the trust list.  Returns them by path."""
    ensure_certificate(OpcuaSettings(data_dir=agent.data, hostnames=("localhost",)))
    pki = agent.data / "opcua" / "pki"
    for folder, files in (("trusted", trusted), ("rejected", rejected)):
        for name, der in files.items():
            (pki / folder / name).write_bytes(der)
    return {
        str(p.relative_to(agent.data)): p.read_bytes()
        for p in sorted((agent.data / "opcua").rglob("*"))
        if p.is_file() and p.name != "status.json"
    }


def test_a_backup_holds_the_certificate_and_trust_list_and_the_key_only_with_secrets(make_agent):
    agent = make_agent()
    mes, stranger = certificate("mes", "urn:plant:mes"), certificate("x", "urn:x")
    files = with_opcua(agent, {"mes.der": mes}, {"urn_x-0123.der": stranger})
    (agent.data / "opcua" / "pki" / "trusted" / "notes.txt").write_text("not a certificate")  # left out
    os.symlink("/etc/passwd", agent.data / "opcua" / "pki" / "trusted" / "link.der")  # left out
    plain, secret = members(backup(agent)), members(backup(agent, with_secrets="true"))
    opcua = {k: v for k, v in plain.items() if k.startswith("data/opcua/")}
    assert opcua == {
        "data/opcua/server-cert.der": files["opcua/server-cert.der"],
        "data/opcua/pki/trusted/mes.der": mes,
        "data/opcua/pki/rejected/urn_x-0123.der": stranger,
    }
    assert secret["data/opcua/server-key.pem"] == files["opcua/server-key.pem"]


def test_a_restore_with_secrets_brings_back_the_certificate_key_and_the_trust_list_whole(make_agent):
    source, target = make_agent(), make_agent()
    mes, scada, old = certificate("mes", "urn:mes"), certificate("scada", "urn:scada"), certificate("old", "urn:old")
    files = with_opcua(source, {"mes.der": mes}, {"scada.der": scada})
    mine = with_opcua(target, {"old.der": old}, {})
    assert mine["opcua/server-cert.der"] != files["opcua/server-cert.der"]
    quiet_restarts(target)
    archive = backup(source, with_secrets="true")
    review = restore(target, archive, dry_run=True).json()
    actions = {f["path"]: f["action"] for f in review["files"]}
    assert actions["opcua/server-cert.der"] == "replace" and actions["opcua/server-key.pem"] == "replace"
    assert actions["opcua/pki/trusted/mes.der"] == "add" and actions["opcua/pki/trusted/old.der"] == "remove"
    assert any("serves the restored certificate once it starts again" in w for w in review["warnings"])
    assert restore(target, archive, dry_run=False).status_code == 200
    restarted(target)
    for rel in ("opcua/server-cert.der", "opcua/server-key.pem"):
        assert (target.data / rel).read_bytes() == files[rel]
    assert (target.data / "opcua" / "server-key.pem").stat().st_mode & 0o777 == 0o600
    pki = target.data / "opcua" / "pki"
    assert os.listdir(pki / "trusted") == ["mes.der"] and os.listdir(pki / "rejected") == ["scada.der"]
    (aside,) = target.data.glob("replaced-*")
    assert (aside / "opcua" / "pki" / "trusted" / "old.der").read_bytes() == old  # no longer trusted, kept
    assert (aside / "opcua" / "server-key.pem").read_bytes() == mine["opcua/server-key.pem"]


def test_a_restore_without_secrets_keeps_the_servers_own_certificate(make_agent):
    source, target = make_agent(), make_agent()
    mes = certificate("mes", "urn:mes")
    with_opcua(source, {"mes.der": mes}, {})
    mine = with_opcua(target, {}, {})
    quiet_restarts(target)
    archive = backup(source)
    review = restore(target, archive, dry_run=True).json()
    assert any("not its key" in w for w in review["warnings"])
    assert "opcua/server-cert.der" not in {f["path"] for f in review["files"]}
    assert restore(target, archive, dry_run=False).status_code == 200
    restarted(target)
    for rel in ("opcua/server-cert.der", "opcua/server-key.pem"):
        assert (target.data / rel).read_bytes() == mine[rel]
    assert (target.data / "opcua" / "pki" / "trusted" / "mes.der").read_bytes() == mes


def test_a_trust_list_file_that_is_not_a_certificate_is_refused(make_agent):
    source, target = make_agent(), make_agent()
    with_opcua(source, {"mes.der": certificate("mes", "urn:mes")}, {})
    files = members(backup(source))
    del files["manifest.json"]
    files["data/opcua/pki/trusted/mes.der"] = b"-----BEGIN CERTIFICATE-----\nnot one\n"
    refused(target, repack(with_manifest(files)), 400, "opcua/pki/trusted/mes.der", "not a certificate")


def test_trust_list_names_a_backup_cannot_hold_are_refused(make_agent):
    source, target = make_agent(), make_agent()
    with_opcua(source, {}, {})
    files = members(backup(source))
    del files["manifest.json"]
    files["data/opcua/pki/issuers/ca.der"] = certificate("ca", "urn:ca")
    refused(target, repack(with_manifest(files)), 400, "data/opcua/pki/issuers/ca.der", "not a file a backup holds")


def test_a_key_that_is_not_the_certificates_is_not_restored(make_agent):
    source, other, target = make_agent(), make_agent(), make_agent()
    with_opcua(source, {}, {})
    with_opcua(other, {}, {})
    mine = with_opcua(target, {}, {})
    files = members(backup(source, with_secrets="true"))
    del files["manifest.json"]
    files["data/opcua/server-key.pem"] = (other.data / "opcua" / "server-key.pem").read_bytes()
    quiet_restarts(target)
    archive = repack(with_manifest(files))
    review = restore(target, archive, dry_run=True)
    assert review.status_code == 200, review.text
    assert any("the key is not the certificate's" in w for w in review.json()["warnings"])
    assert restore(target, archive, dry_run=False).status_code == 200
    restarted(target)
    assert (target.data / "opcua" / "server-key.pem").read_bytes() == mine["opcua/server-key.pem"]

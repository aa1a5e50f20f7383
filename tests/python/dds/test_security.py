"""test_security.py -- DDS Security as the bridge's settings configure it (docs/dds.md "Security"):
the Cyclone DDS XML made by settings.cyclone_config, with certificates and signed governance and
permissions made here (cryptography), lets two participants with valid certificates talk, and one
without security or with a certificate of another CA sees nothing.  The participants are the test's
C peer on Debian's libddsc 0.10.2, whose security plugins are installed; the bridge itself runs the
cyclonedds wheel, built without them, and refuses to start with security rather than run without."""

from __future__ import annotations

import datetime
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.hazmat.primitives.serialization import pkcs7
from cryptography.x509.oid import NameOID

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import ROOT, output, start_bridge, stop  # noqa: E402

sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.dds.settings import BridgeSettings, cyclone_config, parse_args  # noqa: E402

PLUGINS = Path("/usr/lib/x86_64-linux-gnu/libddsc0debian")  # Debian's libddsc0debian
DOMAIN = 190 + os.getpid() % 40  # Cyclone's governance parser takes domain ids up to 230
TOPIC = "rt/secure/value"

pytestmark = pytest.mark.skipif(
    not (PLUGINS / "libdds_security_auth.so").exists(), reason=f"Debian's libddsc0debian has no {PLUGINS}"
)

GOVERNANCE = """<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
 <domain_access_rules><domain_rule>
  <domains><id_range><min>0</min><max>230</max></id_range></domains>
  <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
  <enable_join_access_control>true</enable_join_access_control>
  <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
  <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
  <rtps_protection_kind>ENCRYPT</rtps_protection_kind>
  <topic_access_rules><topic_rule>
   <topic_expression>*</topic_expression>
   <enable_discovery_protection>true</enable_discovery_protection>
   <enable_liveliness_protection>true</enable_liveliness_protection>
   <enable_read_access_control>true</enable_read_access_control>
   <enable_write_access_control>true</enable_write_access_control>
   <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
   <data_protection_kind>ENCRYPT</data_protection_kind>
  </topic_rule></topic_access_rules>
 </domain_rule></domain_access_rules>
</dds>
"""
GRANT = """  <grant name="{cn}">
   <subject_name>{subject}</subject_name>
   <validity><not_before>2020-01-01T00:00:00</not_before><not_after>2099-01-01T00:00:00</not_after></validity>
   <allow_rule><domains><id_range><min>0</min><max>230</max></id_range></domains>
    <publish><topics><topic>*</topic></topics></publish>
    <subscribe><topics><topic>*</topic></topics></subscribe>
   </allow_rule>
   <default>DENY</default>
  </grant>
"""


def _name(cn: str) -> x509.Name:
    return x509.Name(
        [x509.NameAttribute(NameOID.COMMON_NAME, cn), x509.NameAttribute(NameOID.ORGANIZATION_NAME, "indurop test")]
    )


def _certificate(subject: x509.Name, key, issuer: x509.Name, issuer_key, ca: bool) -> x509.Certificate:
    now = datetime.datetime.now(datetime.UTC)
    b = (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(issuer)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(days=1))
        .not_valid_after(now + datetime.timedelta(days=7))
    )
    if ca:
        b = b.add_extension(x509.BasicConstraints(ca=True, path_length=None), critical=True)
    return b.sign(issuer_key, hashes.SHA256())


def _write_pem(path: Path, obj) -> str:
    if isinstance(obj, x509.Certificate):
        path.write_bytes(obj.public_bytes(serialization.Encoding.PEM))
    else:
        path.write_bytes(
            obj.private_bytes(
                serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption()
            )
        )
    return str(path)


@pytest.fixture(scope="module")
def pki(tmp_path_factory) -> dict[str, dict]:
    """Security settings for participants a and b (one CA, both granted every topic) and for c,
    whose certificate another CA signed."""
    out = tmp_path_factory.mktemp("pki")
    cas = {}
    for ca in ("ca", "other-ca"):
        key = ec.generate_private_key(ec.SECP256R1())
        cas[ca] = (key, _certificate(_name(ca), key, _name(ca), key, True))
        _write_pem(out / f"{ca}.pem", cas[ca][1])
    ca_key, ca_cert = cas["ca"]

    def sign(name: str, text: str) -> str:
        signed = (
            pkcs7.PKCS7SignatureBuilder()
            .set_data(text.encode())
            .add_signer(ca_cert, ca_key, hashes.SHA256())
            .sign(serialization.Encoding.SMIME, [pkcs7.PKCS7Options.Text, pkcs7.PKCS7Options.DetachedSignature])
        )
        (out / name).write_bytes(signed)
        return str(out / name)

    grants = "".join(GRANT.format(cn=cn, subject=_name(cn).rfc4514_string()) for cn in ("a", "b", "c"))
    governance = sign("governance.p7s", GOVERNANCE)
    permissions = sign("permissions.p7s", f"<dds>\n <permissions>\n{grants} </permissions>\n</dds>\n")
    settings = {}
    for cn, ca in (("a", "ca"), ("b", "ca"), ("c", "other-ca")):
        key = ec.generate_private_key(ec.SECP256R1())
        settings[cn] = {
            "identity_ca": str(out / f"{ca}.pem"),
            "identity_certificate": _write_pem(
                out / f"{cn}.pem", _certificate(_name(cn), key, _name(ca), cas[ca][0], False)
            ),
            "private_key": _write_pem(out / f"{cn}.key", key),
            "permissions_ca": str(out / "ca.pem"),
            "governance": governance,
            "permissions": permissions,
            "plugins": str(PLUGINS),
        }
    return settings


def env(security: dict | None) -> dict:
    config = cyclone_config(BridgeSettings(domain_id=DOMAIN, security=security), pinned=True)
    return {**os.environ, "CYCLONEDDS_URI": config}


def reader(peer: Path, security: dict | None) -> subprocess.Popen:
    return subprocess.Popen(
        [str(peer), "read", "float64", TOPIC, "1", "12"],
        env=env(security),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def write(peer: Path, security: dict | None, count: int = 20) -> None:
    r = subprocess.run(
        [str(peer), "write", "float64", TOPIC, "0.5", str(count)],
        env=env(security),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 0, r.stderr


def test_two_participants_with_valid_certificates_talk(ros2_reader, pki):
    b = reader(ros2_reader, pki["b"])
    write(ros2_reader, pki["a"])
    out, err = b.communicate(timeout=60)
    assert b.returncode == 0, err
    lines = out.splitlines()
    assert '"topic": "rt/secure/value"' in lines[0] and lines[-1] == '{"data": 0.5}'


@pytest.mark.parametrize("who", ["none", "c"])
def test_a_participant_without_security_or_with_another_ca_s_certificate_sees_nothing(ros2_reader, pki, who):
    r = reader(ros2_reader, None if who == "none" else pki["c"])
    write(ros2_reader, pki["a"], 200)
    out, err = r.communicate(timeout=60)
    assert r.returncode != 0 and "data" not in out, (out, err)  # 3: nothing read in its 12 s


def test_the_settings_name_what_is_wrong_with_the_security_files(pki, tmp_path, capsys):
    config = tmp_path / "bridge.json"
    for security, words in (
        (
            {**pki["a"], "governance": "governance.p7s"},
            "security.governance 'governance.p7s': an absolute path that exists",
        ),
        ({k: v for k, v in pki["a"].items() if k != "permissions"}, "security: missing permissions"),
    ):
        config.write_text(json.dumps({"security": security}))
        with pytest.raises(SystemExit):
            parse_args(["--config", str(config)])
        assert words in capsys.readouterr().err


def test_the_bridge_with_security_on_the_wheel_s_cyclone_refuses_to_start(pki, tmp_path):
    config = tmp_path / "bridge.json"
    config.write_text(json.dumps({"security": pki["a"]}))
    bridge = start_bridge(tmp_path / "none.sock", DOMAIN, "--config", str(config))
    try:
        bridge.wait(60)
    finally:
        stop(bridge)
    text = output(bridge)
    assert bridge.returncode == 2, text
    assert "DDS Security is configured, and the cyclonedds wheel's libddsc is built without it" in text

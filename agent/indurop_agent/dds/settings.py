"""settings.py -- the DDS bridge's settings (command line, then an optional JSON file) and the
Cyclone DDS configuration made from them (docs/dds.md "Settings"), DDS Security's included
(docs/dds.md "Security").
"""

from __future__ import annotations

import argparse
import ipaddress
import re
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

from ..settings_file import settings_values
from .bridge_schema import SCHEMA

# A controller's name on the line, in the imports and the diagnostics (dds.json's schema says it).
NAME = re.compile(SCHEMA["$defs"]["controller"]["pattern"])


@dataclass
class BridgeSettings:
    irpd_socket: str = "/run/indurop/irpd.sock"
    # DDS domain (0..232, as ROS_DOMAIN_ID) and the network interface it uses; "lo": loopback only,
    # with unicast discovery on 127.0.0.1 (the loopback device has no multicast).
    domain_id: int = 0
    interface: str = "lo"
    # Other hosts' addresses for unicast discovery on a network without multicast (not on "lo").
    peers: tuple[str, ...] = ()
    # Prepended to every topic of this controller ("cell1" -> rt/cell1/joint_states); "" for none.
    namespace: str = ""
    # What DiagnosticStatus.hardware_id and the bridge's own status name this controller.
    name: str = "indurop"
    poll_ms: float = 1.0  # how often the trace rings and the subscriptions are read
    status_s: float = 0.5  # how often irpd's status is asked (a new set, a restart)
    # The owner name under which the bridge asks irpd to trace its channels.
    trace_owner: str = "dds"
    # The line (docs/dds.md "The line"): this controller's agent as other controllers link to it
    # (its web UI), how often the controller announces itself, its liveliness lease, how long a lost
    # controller stays listed, and the file the view of the line is written to for the agent ("":
    # none).  `name` is the controller's name on the line: unique on the domain.
    agent_url: str = ""
    line_period_s: float = 1.0
    line_lease_s: float = 3.0
    line_forget_s: float = 3600.0
    line_file: str = "/run/indurop-dds/line.json"
    # DDS Security (--config only): the files of SECURITY_FILES by those names, and "plugins", the
    # folder of libdds_security_{auth,ac,crypto}.so when they are not on the library path.
    security: dict | None = None


SECURITY_FILES = ("identity_ca", "identity_certificate", "private_key", "permissions_ca", "governance", "permissions")


def _check(s: BridgeSettings) -> BridgeSettings:
    if not 0 <= s.domain_id <= 232:
        raise ValueError(f"domain_id {s.domain_id}: a DDS domain id for ROS 2 is 0..232")
    if not re.fullmatch(r"[A-Za-z0-9_.:-]{1,15}", s.interface):
        raise ValueError(f"interface {s.interface!r}: a network interface name such as lo or eth0")
    for p in s.peers:
        ipaddress.ip_address(p)  # ValueError names it
    if s.namespace and not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*(/[A-Za-z][A-Za-z0-9_]*)*", s.namespace):
        raise ValueError(f"namespace {s.namespace!r}: letters, digits, _ and /, starting with a letter")
    if not 0.05 <= s.poll_ms <= 1000:
        raise ValueError(f"poll_ms {s.poll_ms}: from 0.05 to 1000")
    if not NAME.fullmatch(s.name):
        raise ValueError(f"name {s.name!r}: 1 to 63 letters, digits, _, . and -")
    if s.agent_url and not re.fullmatch(r"https?://[^\s/?#]+(/[^\s]*)?", s.agent_url):
        raise ValueError(f"agent_url {s.agent_url!r}: an http:// or https:// URL, e.g. https://cell1:8443/")
    if not 0.1 <= s.line_period_s <= 60:
        raise ValueError(f"line_period_s {s.line_period_s}: from 0.1 to 60")
    if not 2 * s.line_period_s <= s.line_lease_s <= 3600:
        raise ValueError(
            f"line_lease_s {s.line_lease_s}: at least twice line_period_s ({s.line_period_s}) and at most 3600"
        )
    if s.line_forget_s <= 0:
        raise ValueError(f"line_forget_s {s.line_forget_s}: more than 0")
    if s.security is not None:
        if not isinstance(s.security, dict):
            raise ValueError(f"security: an object of {', '.join(SECURITY_FILES)} and plugins")
        unknown = sorted(set(s.security) - {*SECURITY_FILES, "plugins"})
        missing = [k for k in SECURITY_FILES if k not in s.security]
        if unknown or missing:
            raise ValueError(
                f"security: {'unknown ' + unknown[0] if unknown else 'missing ' + missing[0]}; "
                f"it names {', '.join(SECURITY_FILES)} (files) and plugins (a folder, optional)"
            )
        for k, v in s.security.items():
            if not isinstance(v, str) or not Path(v).is_absolute() or not Path(v).exists():
                raise ValueError(f"security.{k} {v!r}: an absolute path that exists")
    return s


def cyclone_config(s: BridgeSettings, pinned: bool = False) -> str:
    """The Cyclone DDS XML for these settings (Domain(domain_id, config=...)); `pinned`: for the
    settings' domain only, as CYCLONEDDS_URI for a program that joins the default domain."""
    if s.interface == "lo":
        general = '<Interfaces><NetworkInterface name="lo"/></Interfaces><AllowMulticast>false</AllowMulticast>'
        peers = ["127.0.0.1"]
    else:
        general = f"<Interfaces><NetworkInterface name={quoteattr(s.interface)}/></Interfaces>"
        peers = list(s.peers)
    discovery = "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>64</MaxAutoParticipantIndex>"
    if peers:
        discovery += "<Peers>" + "".join(f"<Peer address={quoteattr(escape(p))}/>" for p in peers) + "</Peers>"
    return (
        f'<CycloneDDS xmlns="https://cdds.io/config"><Domain Id="{s.domain_id if pinned else "any"}">'
        f"<General>{general}</General><Discovery>{discovery}</Discovery>{security_config(s.security)}"
        "</Domain></CycloneDDS>"
    )


def security_config(security: dict | None) -> str:
    """Cyclone DDS's <Security>: the builtin plugins (authentication, access control, cryptography)
    and the files; "" without security."""
    if not security:
        return ""

    def library(name: str, init: str) -> str:
        path = f"{security['plugins']}/lib{name}.so" if security.get("plugins") else name
        return f"<Library path={quoteattr(path)} initFunction={quoteattr('init_' + init)} finalizeFunction={quoteattr('finalize_' + init)}/>"

    def file(key: str) -> str:
        return escape("file:" + security[key])

    return (
        "<Security><Authentication>"
        f"{library('dds_security_auth', 'authentication')}"
        f"<IdentityCA>{file('identity_ca')}</IdentityCA>"
        f"<IdentityCertificate>{file('identity_certificate')}</IdentityCertificate>"
        f"<PrivateKey>{file('private_key')}</PrivateKey>"
        "</Authentication><AccessControl>"
        f"{library('dds_security_ac', 'access_control')}"
        f"<PermissionsCA>{file('permissions_ca')}</PermissionsCA>"
        f"<Governance>{file('governance')}</Governance>"
        f"<Permissions>{file('permissions')}</Permissions>"
        "</AccessControl><Cryptographic>"
        f"{library('dds_security_crypto', 'crypto')}"
        "</Cryptographic></Security>"
    )


def parse_args(argv: list[str] | None = None) -> BridgeSettings:
    ap = argparse.ArgumentParser(
        prog="indurop-dds-bridge",
        description="Publishes the controller's joints, timing and mapped variables on Cyclone DDS for ROS 2 "
        "(docs/dds.md).",
    )
    ap.add_argument("--config", type=Path, help="a JSON file with any of the settings below (same names)")
    ap.add_argument("--irpd-socket", help="irpd's control socket (default /run/indurop/irpd.sock)")
    ap.add_argument("--domain-id", type=int, help="the DDS domain, 0..232 (default 0)")
    ap.add_argument("--interface", help="the network interface DDS uses (default lo: this host only)")
    ap.add_argument("--peer", action="append", dest="peers", help="a host's address for unicast discovery")
    ap.add_argument("--namespace", help="prepended to every topic (default none)")
    ap.add_argument("--name", help="this controller's name in the diagnostics (default indurop)")
    ap.add_argument("--poll-ms", type=float, help="how often the rings and subscriptions are read (default 1)")
    ap.add_argument("--agent-url", help="this controller's web UI, as the line links to it (e.g. https://cell1:8443/)")
    ap.add_argument("--line-period-s", type=float, help="how often the controller announces itself (default 1)")
    ap.add_argument("--line-lease-s", type=float, help="its liveliness lease on the line (default 3)")
    ap.add_argument(
        "--line-file",
        help="where the line's view is written for the agent (default /run/indurop-dds/line.json; '': none)",
    )
    ap.add_argument(
        "--print-cyclonedds-uri",
        action="store_true",
        help="print the Cyclone DDS configuration these settings make and exit: CYCLONEDDS_URI for another DDS "
        "program (a reader) on the same domain and interface",
    )
    args = ap.parse_args(argv)
    values = settings_values(ap, args, BridgeSettings)
    if "peers" in values:
        values["peers"] = tuple(values["peers"])
    try:
        settings = _check(BridgeSettings(**values))
    except (TypeError, ValueError) as e:
        ap.error(str(e))
        raise
    if args.print_cyclonedds_uri:
        print(cyclone_config(settings, pinned=True))
        ap.exit(0)
    return settings

"""settings.py -- indurop-opcua's settings: the command line, then an optional JSON file (the same
names), checked with a message that names what to fix.  Every limit of the server is here, with its
default; docs/opcua.md lists them."""

from __future__ import annotations

import argparse
import ipaddress
import re
from dataclasses import dataclass
from pathlib import Path

from ..access.auth import ROLES
from ..settings_file import settings_values

MiB = 1 << 20
# The security policies the server offers (OPC UA's names) and the message security modes.
POLICIES = ("Basic256Sha256", "Aes128_Sha256_RsaOaep", "None")
MODES = ("Sign", "SignAndEncrypt")


@dataclass
class OpcuaSettings:
    # Where it listens: opc.tcp://host:port/ (host 0.0.0.0: every interface).
    host: str = "127.0.0.1"
    port: int = 4840
    # The agent's data folder: users.json (the users and their roles), audit.jsonl (every write is
    # audited there), and opcua/ (the server's certificate and key, the PKI folders, status.json).
    data_dir: Path = Path("/var/lib/indurop")
    irpd_socket: str = "/run/indurop/irpd.sock"
    # The agent, which owns the alarms' acknowledgement: Acknowledge and Confirm go to its
    # /opcua/alarms routes with the token it writes in <data>/opcua-token (docs/opcua.md "Alarms").
    # agent_ca: the certificate (PEM) an https agent_url is checked against (the agent's own
    # self-signed one); none: the system's CAs.
    agent_url: str = "http://127.0.0.1:8080/"
    agent_ca: str = ""
    # The owner name under which the server asks irpd to trace the variables clients monitor.
    trace_owner: str = "opcua"
    # The names and addresses clients reach the server by, put in its certificate's subjectAltName
    # (none: the host's name, its fully qualified name, localhost and 127.0.0.1, and `host` when it
    # is an address other than 0.0.0.0).
    hostnames: tuple[str, ...] = ()
    # Security: the policies offered with Sign and SignAndEncrypt; "None" only when listed here
    # (a warning in the log and security_none in status.json).  Anonymous sessions only when
    # allow_anonymous (the same warning), with anonymous_role.
    security_policies: tuple[str, ...] = ("Basic256Sha256", "Aes128_Sha256_RsaOaep")
    allow_anonymous: bool = False
    anonymous_role: str = "viewer"
    # X.509 user certificates: [{"certificate": "/path/user.der or .pem", "name": "mes", "role": "operator"}].
    user_certificates: tuple[dict, ...] = ()
    # Wrong passwords: this many from one client address, or for one user name, within the window
    # lock it out for the window (the agent's Lockout; every session refused meanwhile).
    lockout_attempts: int = 10
    lockout_window_s: float = 60.0
    # Sampling and publishing (docs/opcua.md "Subscriptions").
    min_sampling_interval_ms: float = 10.0
    max_sampling_interval_ms: float = 3_600_000.0
    min_publishing_interval_ms: float = 20.0
    max_queue_size: int = 1000
    max_notifications_per_publish: int = 2000  # data changes in one NotificationMessage, at most
    poll_ms: float = 5.0  # how often the trace rings are read and due items sampled
    status_s: float = 1.0  # how often irpd's status, modules and stats are asked
    status_file_s: float = 5.0  # how often <data>/opcua/status.json is written
    # Bounds (answered with OPC UA status codes).
    max_sessions: int = 32
    max_subscriptions_per_session: int = 16
    max_subscriptions: int = 256
    max_monitored_items_per_session: int = 5000
    max_monitored_items: int = 20000
    max_monitored_items_per_call: int = 2000
    max_nodes_per_read: int = 2000
    max_nodes_per_write: int = 200
    max_nodes_per_browse: int = 2000
    max_request_bytes: int = 4 * MiB
    max_connections: int = 64

    @property
    def pki(self) -> Path:
        return self.data_dir / "opcua"

    @property
    def endpoint(self) -> str:
        return f"opc.tcp://{self.host}:{self.port}/"

    @property
    def insecure(self) -> list[str]:
        """What is configured that lets a client in without security: for the log and status.json."""
        out = []
        if "None" in self.security_policies:
            out.append("security policy None is offered: messages are neither signed nor encrypted")
        if self.allow_anonymous:
            out.append(f"anonymous sessions are allowed (role {self.anonymous_role})")
        return out


def check(s: OpcuaSettings) -> OpcuaSettings:
    """The settings if they hold together; ValueError naming the first that does not."""
    try:
        ipaddress.ip_address(s.host)
    except ValueError:
        if not re.fullmatch(r"[A-Za-z0-9.-]{1,253}", s.host):
            raise ValueError(f"host {s.host!r}: an address (0.0.0.0 for every interface) or a host name") from None
    if not re.fullmatch(r"https?://[^\s/?#]+/?", s.agent_url):
        raise ValueError(
            f"agent_url {s.agent_url!r}: the agent's http:// or https:// address, e.g. https://127.0.0.1:8443/"
        )
    if s.agent_ca and not Path(s.agent_ca).is_file():
        raise ValueError(f"agent_ca {s.agent_ca!r}: a PEM certificate file that exists")
    if not 1 <= s.port <= 65535:
        raise ValueError(f"port {s.port}: 1..65535")
    if not s.security_policies:
        raise ValueError(f"security_policies: at least one of {', '.join(POLICIES)}")
    for p in s.security_policies:
        if p not in POLICIES:
            raise ValueError(f"security_policies: {p!r} is not one of {', '.join(POLICIES)}")
    if s.anonymous_role not in ROLES:
        raise ValueError(f"anonymous_role {s.anonymous_role!r}: one of {', '.join(ROLES)}")
    if not re.fullmatch(r"[a-z][a-z0-9_-]{0,31}", s.trace_owner):
        raise ValueError(f"trace_owner {s.trace_owner!r}: lowercase letters, digits, _ and -")
    for i, entry in enumerate(s.user_certificates):
        where = f"user_certificates[{i}]"
        if not isinstance(entry, dict) or set(entry) - {"certificate", "name", "role"}:
            raise ValueError(f"{where}: an object of certificate (a file), name and role")
        if entry.get("role") not in ROLES:
            raise ValueError(f"{where}.role {entry.get('role')!r}: one of {', '.join(ROLES)}")
        if not isinstance(entry.get("name"), str) or not re.fullmatch(r"[A-Za-z0-9._@-]{1,64}", entry["name"]):
            raise ValueError(f"{where}.name: 1 to 64 letters, digits, '.', '_', '@' or '-'")
        if not isinstance(entry.get("certificate"), str) or not Path(entry["certificate"]).is_file():
            raise ValueError(f"{where}.certificate {entry.get('certificate')!r}: a DER or PEM file that exists")
    if not 1 <= s.min_sampling_interval_ms <= s.max_sampling_interval_ms:
        raise ValueError("min_sampling_interval_ms: at least 1 and at most max_sampling_interval_ms")
    if not 1 <= s.min_publishing_interval_ms <= 60_000:
        raise ValueError("min_publishing_interval_ms: 1 to 60000")
    if not 0.5 <= s.poll_ms <= s.min_sampling_interval_ms:
        raise ValueError(f"poll_ms {s.poll_ms}: from 0.5 to min_sampling_interval_ms")
    positive = (
        "max_queue_size",
        "max_notifications_per_publish",
        "max_sessions",
        "max_subscriptions_per_session",
        "max_subscriptions",
        "max_monitored_items_per_session",
        "max_monitored_items",
        "max_monitored_items_per_call",
        "max_nodes_per_read",
        "max_nodes_per_write",
        "max_nodes_per_browse",
        "max_connections",
        "lockout_attempts",
    )
    for name in positive:
        if getattr(s, name) < 1:
            raise ValueError(f"{name} {getattr(s, name)}: at least 1")
    if s.max_request_bytes < 64 * 1024:
        raise ValueError(f"max_request_bytes {s.max_request_bytes}: at least 65536")
    if s.lockout_window_s <= 0 or s.status_s <= 0 or s.status_file_s <= 0:
        raise ValueError("lockout_window_s, status_s and status_file_s: more than 0")
    return s


def parse_args(argv: list[str] | None = None) -> OpcuaSettings:
    ap = argparse.ArgumentParser(
        prog="indurop-opcua",
        description="The controller's shared variables, module figures and alarms as an OPC UA server (docs/opcua.md).",
    )
    ap.add_argument("--config", type=Path, help="a JSON file with any of the settings (docs/opcua.md; same names)")
    ap.add_argument("--host", help="the address to listen on (default 127.0.0.1; 0.0.0.0: every interface)")
    ap.add_argument("--port", type=int, help="the TCP port (default 4840)")
    ap.add_argument("--data-dir", type=Path, help="the agent's data folder (default /var/lib/indurop)")
    ap.add_argument("--irpd-socket", help="irpd's control socket (default /run/indurop/irpd.sock)")
    ap.add_argument("--agent-url", help="the agent, for Acknowledge and Confirm (default http://127.0.0.1:8080/)")
    ap.add_argument("--agent-ca", help="the PEM certificate an https --agent-url is checked against")
    ap.add_argument("--hostname", action="append", dest="hostnames", help="a name or address for the certificate")
    ap.add_argument(
        "--security-policy",
        action="append",
        dest="security_policies",
        choices=POLICIES,
        help="a policy to offer (default Basic256Sha256 and Aes128_Sha256_RsaOaep; None only when given)",
    )
    ap.add_argument("--allow-anonymous", action="store_true", default=None, help="let anonymous sessions in")
    args = ap.parse_args(argv)
    values = settings_values(ap, args, OpcuaSettings)
    for name in ("hostnames", "security_policies", "user_certificates"):
        if name in values:
            values[name] = tuple(values[name])
    if "data_dir" in values:
        values["data_dir"] = Path(values["data_dir"])
    try:
        return check(OpcuaSettings(**values))
    except (TypeError, ValueError) as e:
        ap.error(str(e))
        raise

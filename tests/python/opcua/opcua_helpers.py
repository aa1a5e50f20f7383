"""opcua_helpers.py -- a live controller for the OPC UA tests: irpd on a set, the agent (its users: an
admin token, an operator and a viewer made through its API), indurop-opcua on 127.0.0.1 with small
limits, and asyncua clients that sign in with a client certificate the server trusts."""

from __future__ import annotations

import asyncio
import json
import os
import shutil
import sys
from pathlib import Path

import httpx
import pytest
from asyncua import Client, ua
from asyncua.client.ua_client import UaClient
from asyncua.common.utils import create_nonce
from asyncua.crypto import uacrypto
from asyncua.crypto.cert_gen import setup_self_signed_certificate
from asyncua.crypto.security_policies import SecurityPolicyAes128Sha256RsaOaep, SecurityPolicyBasic256Sha256
from cryptography.x509.oid import ExtendedKeyUsageOID

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import (
    ALARMING,
    API,
    BUILD,
    ROOT,
    SIGNALS,
    copy_cell,
    free_port,
    module_entry,
    output,
    signals_with_an_alarm,
    start_agent,
    start_irpd,
    start_opcua,
    stop,
    wait_dispatching,
    wait_until,
)

sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.access.auth import now_iso
from indurop_agent.irpd.client import IrpdClient

NAMESPACE = "urn:indurop:controller"
PASSWORDS = {"oper": "turn-the-crank-1", "view": "look-but-dont-touch"}
ROLES = {"oper": "operator", "view": "viewer"}
LIMITS = {  # small, so that the tests reach them quickly
    "max_sessions": 8,
    "max_monitored_items_per_session": 300,
    "max_monitored_items_per_call": 400,
    "max_nodes_per_read": 500,
    "max_request_bytes": 256 * 1024,
    "status_s": 0.5,
    "status_file_s": 0.5,
}
CELL = BUILD / "sets" / "plc-robot"
NO_CELL = pytest.mark.skipif(not (CELL / "Robot.so").exists(), reason=f"the plc-robot cell is not built ({CELL})")
NO_SIGNALS = pytest.mark.skipif(
    not (SIGNALS / "module.xml").exists() or not ALARMING.exists(), reason=f"the signals set is not built ({SIGNALS})"
)
POLICIES = {"Basic256Sha256": SecurityPolicyBasic256Sha256, "Aes128_Sha256_RsaOaep": SecurityPolicyAes128Sha256RsaOaep}


class Controller:
    """irpd on `config`, the agent with an operator and a viewer, and indurop-opcua."""

    def __init__(self, tmp: Path, config: Path, instance: str, settings: dict | None = None):
        self.tmp, self.sock, self.data = tmp, tmp / "irpd.sock", tmp / "data"
        self.irpd = start_irpd(self.sock, config, f"{instance}-{os.getpid()}")
        self.control = IrpdClient(str(self.sock), timeout_s=30)
        wait_dispatching(self.control)
        self.agent_port = free_port()
        self.agent = start_agent(self.agent_port, self.data, self.sock)
        self.api = f"http://127.0.0.1:{self.agent_port}{API}"
        self.admin = {"Authorization": f"Bearer {(self.data / 'admin-token').read_text().strip()}"}
        for name, role in ROLES.items():
            r = httpx.post(
                f"{self.api}/users",
                json={"name": name, "role": role, "password": PASSWORDS[name]},
                headers=self.admin,
                timeout=30,
            )
            assert r.status_code == 201, r.text
        # An X.509 user certificate the settings map to the operator "mes" (docs/opcua.md "Security").
        self.user_key, self.user_cert = tmp / "mes-key.pem", tmp / "mes-cert.der"
        asyncio.run(make_client_certificate(self.user_key, self.user_cert, "urn:indurop:test:mes"))
        mes = {"certificate": str(self.user_cert), "name": "mes", "role": "operator"}
        agent = {"agent_url": f"http://127.0.0.1:{self.agent_port}/"}  # Acknowledge and Confirm go there
        self.settings = {**LIMITS, **agent, "user_certificates": [mes], **(settings or {})}
        (tmp / "opcua.json").write_text(json.dumps(self.settings))
        self.port = free_port()
        self.url = f"opc.tcp://127.0.0.1:{self.port}/"
        self.start_server()
        self.client_key, self.client_cert = tmp / "client-key.pem", tmp / "client-cert.der"
        asyncio.run(make_client_certificate(self.client_key, self.client_cert, "urn:indurop:test:client"))
        trusted = self.data / "opcua" / "pki" / "trusted"
        shutil.copy(self.client_cert, trusted / "test-client.der")

    def start_server(self) -> None:
        status = self.data / "opcua" / "status.json"
        status.unlink(missing_ok=True)
        self.opcua = start_opcua(
            self.sock, self.data, self.port, "--config", str(self.tmp / "opcua.json"), log=self.tmp / "opcua.log"
        )
        wait_until(lambda: self.server_status().get("layout_hash") is not None, 60, 0.1)

    def restart_server(self) -> None:
        stop(self.opcua)
        self.start_server()

    def server_status(self) -> dict:
        try:
            return json.loads((self.data / "opcua" / "status.json").read_text())
        except (OSError, ValueError):
            return {}

    def fresh_status(self) -> dict:
        """The server's status.json as written after now (it is written every status_file_s)."""
        since = now_iso()
        return wait_until(lambda: (s := self.server_status()).get("updated", "") > since and s, 60, 0.05)

    def rest(self, path: str):
        r = httpx.get(f"{self.api}{path}", headers=self.admin, timeout=30)
        assert r.status_code == 200, r.text
        return r.json()

    def audit(self) -> list[dict]:
        return [json.loads(line) for line in (self.data / "audit.jsonl").read_text().splitlines()]

    async def connect(self, user: str | None = "oper", password: str | None = None, policy: str = "Basic256Sha256",
                      mode=ua.MessageSecurityMode.SignAndEncrypt, cert: tuple[Path, Path] | None = None,
                      identity: tuple[Path, Path] | None = None,
                      hook: tuple[bytes | None, bytes | None] | None = None) -> Client:  # fmt: skip
        """An asyncua client connected over `policy` and `mode` with the trusted client certificate (or
        `cert`: (key, certificate)), signed in as `user`, or with the X.509 user certificate
        `identity` (key, certificate), or anonymously (neither); `hook`: tamper()'s arguments."""
        c = Client(self.url, timeout=30)
        c.application_uri = "urn:indurop:test:client"
        if user is not None:
            c.set_user(user)
            c.set_password(password if password is not None else PASSWORDS[user])
        key, certificate = cert or (self.client_key, self.client_cert)
        await c.set_security(POLICIES[policy], str(certificate), str(key), mode=mode)
        # asyncua signs in with the application certificate when there is no user name; the tests
        # say which identity they mean
        c.user_certificate, c.user_private_key = None, None
        if identity is not None:
            c.user_certificate = await uacrypto.load_certificate(str(identity[1]))
            c.user_private_key = await uacrypto.load_private_key(str(identity[0]))
        if hook is not None:
            tamper(c, *hook)
        await c.connect()
        return c

    def output(self) -> str:
        return output(self.opcua)

    def close(self) -> None:
        for p in (self.opcua, self.agent):
            stop(p)
        self.control.close()
        stop(self.irpd)


# Leaves that are measurements, not state: a cycle's I/O time takes a few values in turn, so it can
# read the same before and after an OPC UA read and another value during it.
MEASURED = ("PLC_ROBOT.IO_STATUS.last_cycle_us",)


def compare_held_leaves(read: list[tuple[str, object]], before: dict, after: dict) -> None:
    """Checks each (leaf, value) an OPC UA client read against GET /variables of before and after
    the read, where the two agree (the leaf held still) and it is not MEASURED; at least half the
    leaves must be compared."""
    compared = 0
    for leaf, v in read:
        if before[leaf] == after[leaf] and leaf not in MEASURED:
            assert v == before[leaf], (leaf, v, before[leaf])
            compared += 1
    assert compared >= len(before) // 2, f"only {compared} of {len(before)} leaves held still"


def tamper(c: Client, named: bytes | None, signature: bytes | None) -> None:
    """What a client with another stack could send: CreateSession naming the certificate `named`
    (b"": none) rather than its channel's, ActivateSession signed with `signature`."""
    create, activate = c.uaclient.create_session, c.uaclient.activate_session

    async def create_naming(params):
        if named is not None:
            params.ClientCertificate = named or None
        return await create(params)

    async def activate_signed(params):
        if signature is not None:
            params.ClientSignature.Signature = signature
        return await activate(params)

    c.uaclient.create_session, c.uaclient.activate_session = create_naming, activate_signed


def live_cell(tmp_path_factory, name: str) -> Controller:
    """A Controller on a copy of the PLC + robot cell (a module fixture's), its folder and module.xml
    in .folder and .xml."""
    tmp = tmp_path_factory.mktemp(name)
    config, _ = copy_cell(tmp / "plc-robot")
    c = Controller(tmp, config, name)
    c.folder, c.xml = tmp / "plc-robot", config
    return c


def live_signals(tmp_path_factory, name: str) -> Controller:
    """A Controller on the signals set with the conveyor's alarm (raised while .folder/jam exists)."""
    tmp = tmp_path_factory.mktemp(name)
    c = Controller(tmp, signals_with_an_alarm(tmp / "signals"), name)
    c.folder = tmp / "signals"
    return c


async def make_client_certificate(key: Path, cert: Path, uri: str) -> None:
    await setup_self_signed_certificate(
        key, cert, uri, "localhost", [ExtendedKeyUsageOID.CLIENT_AUTH], {"organizationName": "indurop tests"}
    )


async def ns_of(c: Client) -> int:
    return await c.get_namespace_index(NAMESPACE)


async def leaves_under(c: Client, node) -> list:
    """Every variable under `node` (depth first), as (node, browse path)."""
    out = []

    async def walk(n, prefix):
        for child in await n.get_children(refs=ua.ObjectIds.HierarchicalReferences):
            name = (await child.read_browse_name()).Name
            cls = await child.read_node_class()
            if cls == ua.NodeClass.Variable:
                out.append(child)
            elif cls == ua.NodeClass.Object:
                await walk(child, f"{prefix}/{name}")

    await walk(node, "")
    return out


async def raw_session(url: str, user: str, password: str, open_channel: bool = True) -> UaClient:
    """A session made with asyncua's low-level client, the way a hand-written client makes one: a
    secure channel with SecurityPolicy None (or none opened at all), no client certificate, no
    endpoint picked from GetEndpoints, and a user name and password sent in clear."""
    port = int(url.rsplit(":", 1)[1].strip("/"))
    uac = UaClient(timeout=10)
    await uac.connect_socket("127.0.0.1", port)
    await uac.send_hello(url)
    if open_channel:
        params = ua.OpenSecureChannelParameters()
        params.ClientProtocolVersion, params.RequestType = 0, ua.SecurityTokenRequestType.Issue
        params.SecurityMode, params.RequestedLifetime, params.ClientNonce = ua.MessageSecurityMode.None_, 600_000, b""
        await uac.open_secure_channel(params)
    session = ua.CreateSessionParameters()
    session.ClientDescription = ua.ApplicationDescription(ApplicationUri="urn:indurop:test:raw")
    session.ClientDescription.ApplicationType = ua.ApplicationType.Client
    session.EndpointUrl, session.SessionName, session.RequestedSessionTimeout = url, "raw", 60_000
    session.ClientNonce = create_nonce(32)
    await uac.create_session(session)
    activate = ua.ActivateSessionParameters()
    activate.UserIdentityToken = ua.UserNameIdentityToken(
        PolicyId="username", UserName=user, Password=password.encode()
    )
    await uac.activate_session(activate)
    return uac

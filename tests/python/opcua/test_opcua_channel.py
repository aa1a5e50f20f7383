"""test_opcua_channel.py -- the secure channel as an outside client would try it, against indurop-opcua
beside a real irpd (the PLC + robot cell) and agent: a session over SecurityPolicy None (or with no
channel opened at all) refused unless None is configured; a CreateSession that names a trusted
client's certificate on a channel opened with another key refused, and a bad session signature;
a write to a node that does not exist answers BadNodeIdUnknown (docs/opcua.md "Security", "Writes")."""

from __future__ import annotations

import asyncio
import json
import sys
from pathlib import Path

import httpx
import pytest
from asyncua import Client, ua
from asyncua.ua.uaerrors import UaError

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import BUILD, copy_cell, free_port, output, start_opcua, stop, wait_until
from opcua_helpers import (
    NO_CELL,
    PASSWORDS,
    POLICIES,
    Controller,
    live_cell,
    make_client_certificate,
    ns_of,
    raw_session,
)

TARGET = "PLC_ROBOT.PLC_IN.Override"

pytestmark = NO_CELL


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    c = live_cell(tmp_path_factory, "opcua-channel")
    yield c
    c.close()


async def raw_read_and_write(url: str, open_channel: bool = True) -> tuple[str, object]:
    """The operator's session over None: what it got (refused: the error's name) and the value read."""
    try:
        uac = await raw_session(url, "oper", PASSWORDS["oper"], open_channel)
    except (UaError, ConnectionError, TimeoutError) as e:
        return type(e).__name__, None
    try:
        ns = (await uac.read(_read(ua.NodeId(ua.ObjectIds.Server_NamespaceArray))))[0].Value.Value.index(
            "urn:indurop:controller"
        )
        read = (await uac.read(_read(ua.NodeId(TARGET, ns))))[0].Value
        value = read.Value
        write = ua.WriteParameters()
        write.NodesToWrite = [
            ua.WriteValue(
                NodeId=ua.NodeId(TARGET, ns),
                AttributeId=ua.AttributeIds.Value,
                Value=ua.DataValue(ua.Variant(value + 7, read.VariantType)),
            )
        ]
        return (await uac.write(write))[0].name, value
    finally:
        uac.disconnect_socket()


def _read(*nodeids: ua.NodeId) -> ua.ReadParameters:
    params = ua.ReadParameters()
    params.NodesToRead = [ua.ReadValueId(NodeId=n, AttributeId=ua.AttributeIds.Value) for n in nodeids]
    return params


def target(cell) -> int:
    r = httpx.get(f"{cell.api}/variables/{TARGET}", headers=cell.admin, timeout=30)
    assert r.status_code == 200, r.text
    return r.json()["value"]


def test_a_session_over_security_none_is_refused_unless_none_is_configured(cell, tmp_path):
    before = target(cell)
    sign_ins = len([a for a in cell.audit() if a["action"] == "sign_in"])
    for open_channel in (True, False):  # a None channel, and a session asked for before any channel
        got, value = asyncio.run(raw_read_and_write(cell.url, open_channel))
        assert value is None and got not in ("Good", "BadUserAccessDenied"), (open_channel, got)
    assert target(cell) == before
    assert len([a for a in cell.audit() if a["action"] == "sign_in"]) == sign_ins  # refused before any
    status = cell.fresh_status()
    assert status["security"]["security_none"] is False and status["security"]["warnings"] == []

    # The same client against a server configured with None (and Basic256Sha256): let in, warned about.
    # It writes its status.json often (status_file_s), so that a fresh one is its own: the cell's
    # server writes the same file every 5 s, and when its writes came just before the second one's
    # every fresh status seen would be the first server's.
    config = tmp_path / "none.json"
    config.write_text(
        json.dumps({"security_policies": ["None", "Basic256Sha256"], "trace_owner": "opcua-none", "status_file_s": 0.2})
    )
    port = free_port()
    server = start_opcua(cell.sock, cell.data, port, "--config", str(config))
    try:
        url = f"opc.tcp://127.0.0.1:{port}/"
        got = wait_until(
            lambda: (r := asyncio.run(raw_read_and_write(url)))[0] != "ConnectionRefusedError" and r, 60, 0.2
        )
        assert got == ("Good", before)
        assert "WARNING: security policy None is offered" in output(server)
        # both servers write the data folder's status.json: the second one's says None is offered
        status = wait_until(lambda: (s := cell.fresh_status())["security"]["security_none"] and s, 30, 0.05)
        assert status["security"]["warnings"] and status["endpoint"] == url
    finally:
        stop(server)


def test_create_session_must_name_the_channels_own_certificate(cell, tmp_path):
    key, cert = tmp_path / "own-key.pem", tmp_path / "own-cert.der"
    asyncio.run(make_client_certificate(key, cert, "urn:indurop:test:client"))
    trusted = cell.client_cert.read_bytes()  # a trusted client's certificate: a public file
    rejected = cell.data / "opcua" / "pki" / "rejected"

    async def attempt(named: bytes | None, own: bool = True, signature: bytes | None = None) -> str:
        """A session on a channel opened with `own` key (else the trusted client's), naming `named`
        in CreateSession, signing ActivateSession with `signature` when given."""
        c = None
        try:
            c = await cell.connect("oper", cert=(key, cert) if own else None, hook=(named, signature))
            ns = await ns_of(c)
            await c.get_node(ua.NodeId("PLC_ROBOT.IO_STATUS.cycles", ns)).read_value()
            return "connected"
        except UaError as e:
            return type(e).__name__
        finally:
            if c is not None:
                await c.disconnect()

    assert asyncio.run(attempt(trusted)) == "BadCertificateInvalid"  # the trusted one, borrowed
    assert asyncio.run(attempt(b"")) == "BadCertificateInvalid"  # none at all
    assert not [p for p in rejected.iterdir() if p.read_bytes() == cert.read_bytes()]
    assert asyncio.run(attempt(None)) == "BadCertificateUntrusted"  # its own: not trusted
    assert [p for p in rejected.iterdir() if p.read_bytes() == cert.read_bytes()]
    assert asyncio.run(attempt(None, own=False, signature=b"\0" * 256)) == "BadApplicationSignatureInvalid"
    assert asyncio.run(attempt(None, own=False)) == "connected"  # the trusted client itself


def test_a_write_to_a_node_that_does_not_exist_is_bad_node_id_unknown(cell):
    async def go():
        c = await cell.connect("oper")
        try:
            ns = await ns_of(c)
            unknown = [ua.NodeId("PLC_ROBOT.PLC_IN.NoSuchVariable", ns), ua.NodeId(999_999, 0)]
            write = ua.WriteParameters()
            write.NodesToWrite = [
                ua.WriteValue(
                    NodeId=n, AttributeId=ua.AttributeIds.Value, Value=ua.DataValue(ua.Variant(1, ua.VariantType.Int16))
                )
                for n in unknown
            ]
            written = await c.uaclient.write(write)
            read = await c.uaclient.read(_read(*unknown))
            return [s.name for s in written], [d.StatusCode.name for d in read]
        finally:
            await c.disconnect()

    written, read = asyncio.run(go())
    assert written == read == ["BadNodeIdUnknown", "BadNodeIdUnknown"]


def test_a_session_goes_on_on_another_channel_only_with_the_certificate_it_was_made_with(cell, tmp_path):
    """A client reconnecting activates its session on a new channel (Part 4 5.6.3); someone else's
    channel, opened with another key, may not take the session over even knowing its token."""
    key, cert = tmp_path / "other-key.pem", tmp_path / "other-cert.der"
    asyncio.run(make_client_certificate(key, cert, "urn:indurop:test:client"))

    async def take_over(own: bool) -> str:
        first = await cell.connect("oper")
        await first.create_subscription(1000, None)  # a session with one outlives its connection
        token, nonce, policies = first.uaclient.session.authentication_token, first._server_nonce, first._policy_ids
        first.uaclient.disconnect_socket()
        other = Client(cell.url, timeout=30)
        other.application_uri = "urn:indurop:test:client"
        k, c = (cell.client_key, cell.client_cert) if own else (key, cert)
        await other.set_security(
            POLICIES["Basic256Sha256"], str(c), str(k), server_certificate=str(cell.data / "opcua" / "server-cert.der")
        )
        await other.connect_socket()
        try:
            await other.send_hello()
            await other.open_secure_channel()
            other.uaclient.session.restore_authentication_token(token)
            other._server_nonce, other._policy_ids = nonce, policies
            try:
                await other.activate_session("oper", PASSWORDS["oper"])
            except UaError as e:
                return type(e).__name__
            ns = await ns_of(other)
            await other.get_node(ua.NodeId("PLC_ROBOT.IO_STATUS.cycles", ns)).read_value()
            await other.close_session()
            return "resumed"
        finally:
            other.disconnect_socket()

    assert asyncio.run(take_over(own=False)) == "BadSecurityChecksFailed"
    assert asyncio.run(take_over(own=True)) == "resumed"  # the client itself, reconnecting

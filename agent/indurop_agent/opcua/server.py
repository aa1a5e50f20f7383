"""server.py -- indurop-opcua: the controller as an OPC UA server, on asyncua (docs/opcua.md).

A non-RT process beside the agent, like the DDS bridge; it reads what the agent reads and never
blocks irpd:

- irpd's control socket (connections of its own): `status`, `modules`, `stats` every status_s,
  `alarms` when the set changed, `trace` as the owner "opcua", and `write` for clients' writes;
- the variable segment (reads, monitored arrays and what the rings cannot carry), the trace rings
  (monitored scalars) and the alarm segment, all mapped read-only.

The event loop runs asyncua's server, the Sampler (sampling.py, every poll_ms), the alarm events
(every 100 ms) and the status poll (every status_s), which follows the running set: the layout's
nodes (address_space.py), the figures, and <data>/opcua/status.json for the agent.

    indurop-opcua --irpd-socket /run/indurop/irpd.sock --data-dir /var/lib/indurop [--host 0.0.0.0] [--port 4840]
"""

from __future__ import annotations

import asyncio
import hashlib
import json
import logging
import math
import os
import signal
import sys
import time
from datetime import UTC, datetime
from pathlib import Path

from asyncua import ua
from asyncua.common.connection import TransportLimits
from asyncua.common.utils import ServiceError
from asyncua.crypto.permission_rules import User, UserRole
from asyncua.server.internal_server import InternalServer
from asyncua.server.internal_session import InternalSession
from cryptography import x509
from cryptography.hazmat.primitives.serialization import Encoding

from .. import __version__
from ..access.audit import AuditLog
from ..access.auth import now_iso
from ..files import write_atomically
from ..irpd.client import IrpdClient, IrpdRefused, IrpdUnavailable
from .acks import METHODS, AgentAlarms
from .address_space import Space
from .alarms import AlarmEvents
from .channel import Listening
from .sampling import Sampler
from .security import TrustList, Users, application_uri, ensure_certificate, thumbprint
from .settings import OpcuaSettings, parse_args
from .subscriptions import Subscriptions
from .values import Variables, index_range, narrowed
from .writes import Writes

POLICY_TYPES = {
    "Basic256Sha256": [ua.SecurityPolicyType.Basic256Sha256_Sign, ua.SecurityPolicyType.Basic256Sha256_SignAndEncrypt],
    "Aes128_Sha256_RsaOaep": [
        ua.SecurityPolicyType.Aes128Sha256RsaOaep_Sign,
        ua.SecurityPolicyType.Aes128Sha256RsaOaep_SignAndEncrypt,
    ],
    "None": [ua.SecurityPolicyType.NoSecurity],
}
REFRESH_METHODS = {  # ConditionType's: they name a subscription, which must be the caller's
    ua.NodeId(ua.ObjectIds.ConditionType_ConditionRefresh),
    ua.NodeId(ua.ObjectIds.ConditionType_ConditionRefresh2),
}
OPERATION_LIMITS = {  # advertised in Server.ServerCapabilities.OperationLimits, from the settings
    ua.ObjectIds.Server_ServerCapabilities_OperationLimits_MaxNodesPerRead: "max_nodes_per_read",
    ua.ObjectIds.Server_ServerCapabilities_OperationLimits_MaxNodesPerWrite: "max_nodes_per_write",
    ua.ObjectIds.Server_ServerCapabilities_OperationLimits_MaxNodesPerBrowse: "max_nodes_per_browse",
    ua.ObjectIds.Server_ServerCapabilities_OperationLimits_MaxMonitoredItemsPerCall: "max_monitored_items_per_call",
}


def log(message: str) -> None:
    print(f"indurop-opcua: {message}", file=sys.stderr, flush=True)


class Runtime:
    """Everything the server's parts share."""

    def __init__(self, settings: OpcuaSettings):
        self.settings = settings
        self.audit = AuditLog(settings.data_dir / "audit.jsonl")
        self.variables = Variables()
        self.irpd = IrpdClient(settings.irpd_socket, timeout_s=2.0)
        self.sampler = Sampler(
            self.variables, IrpdClient(settings.irpd_socket, timeout_s=2.0), settings.trace_owner, settings.poll_ms
        )
        self.writes = Writes(IrpdClient(settings.irpd_socket, timeout_s=2.0), self.audit, settings.endpoint)
        self.users = Users(settings, self.audit)
        self.trust = TrustList(settings.pki)
        self.iserver = Internal(self)
        self.server = Listening(iserver=self.iserver)
        self.subscriptions: Subscriptions = self.iserver.subscription_service
        self.space = Space(self.server, self.variables, settings.min_sampling_interval_ms)
        irpd = IrpdClient(settings.irpd_socket, timeout_s=2.0)
        self.alarms = AlarmEvents(self.server, self.space, irpd, AgentAlarms(settings))
        self.status: dict = {}
        self.set_key: tuple | None = None
        self.certificate: x509.Certificate | None = None
        self.started = now_iso()
        self.stopping = asyncio.Event()


class Session(InternalSession):
    """asyncua's session with the server's bounds, per-user access and writes through irpd."""

    runtime: Runtime

    def activate_session(self, params, peer_certificate):
        token = params.UserIdentityToken
        users = self.runtime.users
        users.token = (
            "username"
            if isinstance(token, ua.UserNameIdentityToken)
            else "certificate"
            if isinstance(token, ua.X509IdentityToken)
            else "anonymous"
        )
        users.client = str(self.name[0]) if isinstance(self.name, tuple) else "unknown"
        return super().activate_session(params, peer_certificate)

    def _bound(self, count: int, limit: str) -> None:
        if count > getattr(self.runtime.settings, limit):
            raise ServiceError(ua.StatusCodes.BadTooManyOperations)

    async def read(self, params):
        self._bound(len(params.NodesToRead), "max_nodes_per_read")
        results = await super().read(params)
        may_write = getattr(self.user, "may_write", lambda: False)()
        space = self.runtime.space
        for i, rv in enumerate(params.NodesToRead):
            var = space.var_of(rv.NodeId)
            if var is None:
                continue
            if rv.AttributeId == ua.AttributeIds.UserAccessLevel and not may_write:
                results[i] = ua.DataValue(ua.Variant(ua.AccessLevel.CurrentRead.mask, ua.VariantType.Byte))
            elif rv.AttributeId == ua.AttributeIds.Value and rv.IndexRange:
                picked = index_range(rv.IndexRange, len(var.leaves)) if len(var.dims) == 1 else None
                results[i] = (
                    self.runtime.variables.data_value(narrowed(var, picked))
                    if picked is not None
                    else ua.DataValue(StatusCode=ua.StatusCode(ua.StatusCodes.BadIndexRangeInvalid))
                )
        return results

    async def write(self, params):
        self._bound(len(params.NodesToWrite), "max_nodes_per_write")
        results = []
        for wv in params.NodesToWrite:
            var = self.runtime.space.var_of(wv.NodeId)
            if var is not None and wv.AttributeId == ua.AttributeIds.Value:
                results.append(await self.runtime.writes.write(self, var, wv))
            elif wv.NodeId not in self.aspace:  # as a Read of it answers (Part 4, 5.10.4)
                results.append(ua.StatusCode(ua.StatusCodes.BadNodeIdUnknown))
            elif not getattr(self.user, "may_write", lambda: False)():
                results.append(ua.StatusCode(ua.StatusCodes.BadUserAccessDenied))
            else:  # only the shared variables' values are written by clients
                results.append(ua.StatusCode(ua.StatusCodes.BadNotWritable))
        return results

    async def browse(self, params):
        self._bound(len(params.NodesToBrowse), "max_nodes_per_browse")
        return await super().browse(params)

    async def call(self, params: list[ua.CallMethodRequest]) -> list[ua.CallMethodResult]:
        """Method calls.  asyncua does not tell a method which session calls it, so two kinds are
        answered here: a ConditionRefresh must name one of this session's own subscriptions, and
        Acknowledge and Confirm on a ConditionId act as this session's user (alarms.py, acks.py)."""
        subscriptions = self.subscription_service.subscriptions

        def ours(m: ua.CallMethodRequest) -> bool:
            if m.MethodId in METHODS:
                return True
            if m.MethodId not in REFRESH_METHODS or not m.InputArguments:
                return False
            sub = subscriptions.get(m.InputArguments[0].Value)
            return sub is not None and sub.session_id != self.session_id

        taken = [ours(m) for m in params]
        answered = iter(await super().call([m for m, t in zip(params, taken, strict=True) if not t]))
        invalid = ua.CallMethodResult(StatusCode=ua.StatusCode(ua.StatusCodes.BadSubscriptionIdInvalid))
        results = []
        for m, t in zip(params, taken, strict=True):
            if not t:
                results.append(next(answered))
            elif m.MethodId in METHODS:
                results.append(await self.runtime.alarms.respond(self, m))
            else:
                results.append(invalid)
        return results

    async def translate_browsepaths_to_nodeids(self, params):
        self._bound(len(params), "max_nodes_per_browse")
        return await super().translate_browsepaths_to_nodeids(params)


class Internal(InternalServer):
    """asyncua's internal server with our subscription service, users and session limit."""

    def __init__(self, runtime: Runtime):
        super().__init__(user_manager=runtime.users)
        self.runtime = runtime
        s = runtime.settings
        self.subscription_service = Subscriptions(self.aspace, self, runtime)
        self.isession.subscription_service = self.subscription_service  # events go through it
        self.max_connections = s.max_connections
        self.max_subscriptions = s.max_subscriptions
        self.max_monitored_item_queue_size = s.max_queue_size
        # the trust list decides on the secure channel's certificate (channel.py), not asyncua's
        # certificate_validator on the one CreateSession names
        Session.runtime = runtime

    def create_session(self, name, user=User(role=UserRole.Anonymous), external=False):
        if external and len(self._external_sessions) >= self.runtime.settings.max_sessions:
            raise ServiceError(ua.StatusCodes.BadTooManySessions)
        return Session(self, self.aspace, self.subscription_service, name, user=user, external=external)


async def setup(rt: Runtime) -> None:
    s, server = rt.settings, rt.server
    cert_path, key_path, made = ensure_certificate(s)
    log(f"certificate {cert_path} ({made}), key {key_path}")
    await server.init()
    server.set_endpoint(s.endpoint)
    server.set_server_name("indurop OPC UA server")
    await server.set_application_uri(application_uri())
    server.product_uri = "urn:indurop:opcua"
    await server.set_build_info(
        "urn:indurop:opcua", "indurop", "indurop-opcua", __version__, __version__, _build_date()
    )
    await server.load_certificate(str(cert_path))
    await server.load_private_key(str(key_path))
    rt.certificate = x509.load_der_x509_certificate(cert_path.read_bytes())
    server.set_security_policy([t for p in s.security_policies for t in POLICY_TYPES[p]])
    tokens = [ua.UserNameIdentityToken]
    if s.user_certificates:
        tokens.append(ua.X509IdentityToken)
    if s.allow_anonymous:
        tokens.append(ua.AnonymousIdentityToken)
    server.set_identity_tokens(tokens)
    server.limits = TransportLimits(
        max_recv_buffer=65535,
        max_send_buffer=65535,
        max_chunk_count=math.ceil(s.max_request_bytes / 65535),
        max_message_size=s.max_request_bytes,
    )
    for nodeid, name in OPERATION_LIMITS.items():
        await server.get_node(nodeid).write_value(ua.Variant(getattr(s, name), ua.VariantType.UInt32))
    await rt.space.init()
    await rt.alarms.init()
    for warning in s.insecure:
        log(f"WARNING: {warning} (only because the settings ask for it)")


def _build_date() -> datetime:
    return datetime.fromtimestamp(Path(__file__).stat().st_mtime, UTC)


async def poll_status(rt: Runtime) -> None:
    """irpd's status, the layout's nodes, the figures, the alarms' declarations."""
    try:
        status = await asyncio.to_thread(rt.irpd.request, "status")
    except (IrpdUnavailable, IrpdRefused) as e:
        if rt.status:
            log(f"irpd: {e}")
        rt.status = {}
        return
    rt.status = status
    key = (status.get("pid"), status.get("generation"), status.get("set"))
    set_changed = key != rt.set_key
    rt.set_key = key
    rt.variables.follow((status.get("shared_memory") or {}).get("variables"))
    layout = rt.variables.layout()
    layout_hash = rt.variables.segment.hash if layout is not None else ""
    if layout_hash != rt.space.layout_hash or (layout is None and rt.space.nodes):
        removed, added = await rt.space.apply(layout, layout_hash)
        log(f"layout {layout_hash[:12] or '(none)'}: {removed} nodes removed, {added} added")
        for item in rt.sampler.retarget(rt.space.variables_by_path):
            await item.deliver(item.handle, ua.DataValue(StatusCode=ua.StatusCode(ua.StatusCodes.BadNodeIdUnknown)))
    rt.sampler.follow(status)
    await rt.space.update_status(status)
    try:
        modules = await asyncio.to_thread(rt.irpd.request, "modules")
        stats = await asyncio.to_thread(rt.irpd.request, "stats")
        await rt.space.update_figures("Modules", modules)
        await rt.space.update_figures("Dispatchers", stats.get("executors", []))
        # irpd's forces, asked only while its status counts some (docs/forcing.md)
        forces = await asyncio.to_thread(rt.irpd.request, "forces") if status.get("forces") else {"forces": []}
        await rt.space.update_forces({f["path"] for f in forces["forces"]})
    except (IrpdUnavailable, IrpdRefused):
        pass
    await rt.alarms.follow(status, set_changed)


def status_body(rt: Runtime) -> dict:
    """<data>/opcua/status.json: what the agent (and its UI) may show about the server (made in the
    event loop, which alone changes what it counts)."""
    s = rt.settings
    cert = rt.certificate
    sessions = len(rt.iserver._external_sessions)
    items = sum(len(sub.monitored_item_srv._monitored_items) for sub in rt.subscriptions.subscriptions.values())
    body = {
        "format": 1,
        "pid": os.getpid(),
        "started": rt.started,
        "updated": now_iso(),
        "status_file_s": s.status_file_s,
        "endpoint": s.endpoint,
        "application_uri": application_uri(),
        "security": {
            "policies": list(s.security_policies),
            "security_none": "None" in s.security_policies,
            "anonymous": s.allow_anonymous,
            "warnings": s.insecure,
        },
        "certificate": {
            "file": str(s.pki / "server-cert.der"),
            "subject": cert.subject.rfc4514_string() if cert else None,
            "sha1": hashlib.sha1(cert.public_bytes(Encoding.DER)).hexdigest() if cert else None,  # OPC UA's thumbprint
            "sha256": thumbprint(cert.public_bytes(Encoding.DER)) if cert else None,
            "not_after": cert.not_valid_after_utc.isoformat() if cert else None,
        },
        "irpd": bool(rt.status),
        "layout_hash": rt.space.layout_hash,
        "sessions": sessions,
        "subscriptions": len(rt.subscriptions.subscriptions),
        "monitored_items": items,
        "sampling": rt.sampler.counts(),
        "alarm_events": rt.alarms.emitted,
        "condition_refreshes": rt.alarms.refreshes,
        "agent": {"url": s.agent_url, "error": rt.alarms.agent_error},
    }
    return body


def write_status(rt: Runtime, body: dict) -> None:
    """Writes status.json with the trust list (files only: in a worker thread)."""
    body["trust"] = rt.trust.listing()
    write_atomically(rt.settings.pki / "status.json", json.dumps(body, indent=1), mode=0o640)


async def loop_status(rt: Runtime) -> None:
    next_file = 0.0
    while not rt.stopping.is_set():
        start = time.monotonic()
        try:
            await poll_status(rt)
            if start >= next_file:
                next_file = start + rt.settings.status_file_s
                await asyncio.to_thread(write_status, rt, status_body(rt))
        except Exception as e:  # never leave the loop: the next poll tries again
            log(f"status: {type(e).__name__}: {e}")
        await asyncio.sleep(max(0.0, rt.settings.status_s - (time.monotonic() - start)))


async def loop_alarms(rt: Runtime) -> None:
    while not rt.stopping.is_set():
        try:
            await rt.alarms.step()
        except Exception as e:
            log(f"alarms: {type(e).__name__}: {e}")
        await asyncio.sleep(0.1)


async def run(settings: OpcuaSettings) -> int:
    rt = Runtime(settings)
    await setup(rt)
    await poll_status(rt)
    await rt.server.start()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(sig, rt.stopping.set)
    log(
        f"listening on {settings.endpoint} ({', '.join(settings.security_policies)}; "
        f"anonymous {'allowed' if settings.allow_anonymous else 'refused'}), irpd {settings.irpd_socket}"
    )
    tasks = [asyncio.create_task(t) for t in (rt.sampler.run(), loop_status(rt), loop_alarms(rt))]
    await rt.stopping.wait()
    for t in tasks:
        t.cancel()
    await asyncio.gather(*tasks, return_exceptions=True)
    await rt.sampler.withdraw()
    await rt.alarms.agent.close()
    await rt.server.stop()
    return 0


def main(argv: list[str] | None = None) -> int:
    settings = parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(name)s: %(levelname)s: %(message)s")
    # asyncua logs every refused session and bad request at ERROR with a traceback; our audit log and
    # status codes say it once
    for name in ("asyncua.server.uaprocessor", "asyncua.server.binary_server_asyncio", "asyncuagds.validate"):
        logging.getLogger(name).setLevel(logging.CRITICAL)
    try:
        return asyncio.run(run(settings))
    except OSError as e:
        log(f"cannot listen on {settings.endpoint}: {e}")
        return 2


if __name__ == "__main__":
    sys.exit(main())

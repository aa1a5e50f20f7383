"""channel.py -- the secure channel's checks asyncua's server leaves out (docs/opcua.md "Security").

asyncua 2.1's UaProcessor (one per connection) starts every connection on a SecurityPolicyNone
channel and keeps it when a client's OpenSecureChannel names None although no None endpoint is
configured (SecureConnection.select_policy falls back to the policy it has); it also serves a
SecureMessage sent before any OpenSecureChannel (channel id 0, policy None).  And its session checks
the certificate named in CreateSession, never the one of the channel.  So a client without
certificate got a session with a password sent in clear, and a client with any key could borrow a
trusted client's (public) certificate in CreateSession.

The fixes sit where the channel is known, in a UaProcessor subclass (no patch of the library):
- a channel whose policy and mode are not among the configured endpoints' serves no session: over
  None (which clients use for GetEndpoints) only discovery is answered, every other request gets
  BadSecurityPolicyRejected; an OpenSecureChannel with another policy is refused (an Error message
  BadSecurityPolicyRejected, the connection closed), and so is a SecureMessage sent before any
  channel is open (BadSecureChannelIdInvalid);
- CreateSession on a secured channel must name the channel's own certificate (the one whose key
  signed the OpenSecureChannel; else BadCertificateInvalid), and the trust list decides on that
  certificate (BadCertificateUntrusted, kept in pki/rejected);
- ActivateSession's ClientSignature is checked against the channel's certificate before asyncua
  checks it again, so that a bad one answers BadApplicationSignatureInvalid rather than an internal
  error; a session made on one channel is activated on another (a client reconnecting) only when
  that channel has the same certificate (else BadSecurityChecksFailed).

asyncua builds the processor deep inside Server.start (Server -> BinaryServer -> OPCUAProtocol ->
UaProcessor, each by its module's name), so Listening.start repeats Server.start's few lines with
our BinaryServer, whose protocol puts our processor in place before the first byte is read.
"""

from __future__ import annotations

import logging

from asyncua import Server, ua
from asyncua.common.utils import ServiceError
from asyncua.crypto import uacrypto
from asyncua.crypto.security_policies import SecurityPolicyNone
from asyncua.server.binary_server_asyncio import BinaryServer, OPCUAProtocol
from asyncua.server.uaprocessor import UaProcessor
from asyncua.ua.ua_binary import struct_from_binary, uatcp_to_binary
from cryptography.exceptions import InvalidSignature

_logger = logging.getLogger(__name__)
CREATE_SESSION = ua.NodeId(ua.ObjectIds.CreateSessionRequest_Encoding_DefaultBinary)
ACTIVATE_SESSION = ua.NodeId(ua.ObjectIds.ActivateSessionRequest_Encoding_DefaultBinary)
DISCOVERY = {
    ua.NodeId(ua.ObjectIds.GetEndpointsRequest_Encoding_DefaultBinary),
    ua.NodeId(ua.ObjectIds.FindServersRequest_Encoding_DefaultBinary),
    ua.NodeId(ua.ObjectIds.CloseSecureChannelRequest_Encoding_DefaultBinary),
}


class ChannelRefused(Exception):
    def __init__(self, code: int, reason: str):
        super().__init__(reason)
        self.code, self.reason = code, reason


class Processor(UaProcessor):
    """asyncua's processor of one connection, with the channel's checks (above)."""

    def set_policies(self, policies):
        self.offered = list(policies)  # asyncua's SecurityPolicyFactory per configured endpoint
        super().set_policies(policies)

    async def process(self, header, body):
        try:
            if header.MessageType == ua.MessageType.SecureMessage and not self._connection.is_open():
                raise ChannelRefused(ua.StatusCodes.BadSecureChannelIdInvalid, "no secure channel is open")
            return await super().process(header, body)
        except ChannelRefused as e:
            _logger.warning("%s: %s", self.name, e.reason)
            err = ua.ErrorMessage(ua.StatusCode(e.code), e.reason)
            self._transport.write(uatcp_to_binary(ua.MessageType.Error, err))
            return False  # asyncua closes the connection

    def _offers(self, uri: str, mode) -> bool:
        return any(f.matches(uri, mode) for f in self.offered)

    def open_secure_channel(self, algohdr, seqhdr, body):
        if not self._connection.is_open():
            uri = algohdr.SecurityPolicyURI
            mode = struct_from_binary(ua.OpenSecureChannelRequest, body.copy()).Parameters.SecurityMode
            if uri != SecurityPolicyNone.URI and not self._offers(uri, mode):
                raise ChannelRefused(
                    ua.StatusCodes.BadSecurityPolicyRejected, f"security policy {uri} mode {mode.name} is not offered"
                )
        super().open_secure_channel(algohdr, seqhdr, body)

    async def _process_message(self, typeid, requesthdr, seqhdr, body):
        policy = self._connection.security_policy
        if not self._offers(policy.URI, policy.Mode) and typeid not in DISCOVERY:
            # a None channel that is not configured serves discovery only (clients ask GetEndpoints
            # over None, Part 4 5.4): no session
            _logger.warning("%s: refused over security policy None, which is not configured", self.name)
            raise ServiceError(ua.StatusCodes.BadSecurityPolicyRejected)
        if typeid == ACTIVATE_SESSION:
            session = self.session or self.iserver.lookup_external_session(requesthdr.AuthenticationToken)
            if session is not None and getattr(session, "channel_certificate", None) != policy.peer_certificate:
                # a session made on another channel (a client reconnecting) goes on only on a
                # channel with the certificate it was made with (Part 4 5.6.3)
                raise ServiceError(ua.StatusCodes.BadSecurityChecksFailed)
        if policy.URI != SecurityPolicyNone.URI:  # None, when configured: no application to check
            if typeid == CREATE_SESSION:
                await self._check_client(struct_from_binary(ua.CreateSessionParameters, body.copy()))
            elif typeid == ACTIVATE_SESSION and self.session is not None and self.session.nonce:
                signature = struct_from_binary(ua.ActivateSessionParameters, body.copy()).ClientSignature
                try:
                    policy.asymmetric_cryptography.verify(
                        policy.host_certificate + self.session.nonce, signature.Signature
                    )
                except (InvalidSignature, ValueError, TypeError) as e:
                    raise ServiceError(ua.StatusCodes.BadApplicationSignatureInvalid) from e
        result = await super()._process_message(typeid, requesthdr, seqhdr, body)
        if typeid == CREATE_SESSION and self.session is not None:
            self.session.channel_certificate = policy.peer_certificate
        return result

    async def _check_client(self, params: ua.CreateSessionParameters) -> None:
        channel = self._connection.security_policy.peer_certificate
        named = uacrypto.x509_from_der(params.ClientCertificate) if params.ClientCertificate else None
        if channel is None or named is None or uacrypto.der_from_x509(named) != channel:
            _logger.warning("%s: CreateSession names another certificate than the secure channel's", self.name)
            raise ServiceError(ua.StatusCodes.BadCertificateInvalid)
        await self.iserver.runtime.trust(uacrypto.x509_from_der(channel), params.ClientDescription)


class Connection(OPCUAProtocol):
    def connection_made(self, transport):
        super().connection_made(transport)
        if self.processor is not None:  # asyncua's own has read nothing yet: ours serves the connection
            self.processor = Processor(self.iserver, self.transport, self.limits)
            self.processor.set_policies(self.policies)


class Listener(BinaryServer):
    def _make_protocol(self) -> OPCUAProtocol:
        return Connection(
            iserver=self.iserver,
            policies=self._policies,
            clients=self.clients,
            closing_tasks=self.closing_tasks,
            limits=self.limits,
        )


class Listening(Server):
    """asyncua's Server, listening with the Listener (Server.start's steps, in the same order)."""

    async def start(self) -> None:
        await self._setup_server_nodes()
        await self.iserver.start()
        try:
            host, port = self._get_bind_socket_info()
            self.bserver = Listener(self.iserver, host, port, self.limits)
            self.bserver.set_policies(self._policies)
            await self.bserver.start()
        except Exception:
            await self.iserver.stop()
            raise

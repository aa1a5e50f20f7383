"""opcua_models.py -- the shapes of GET /opcua and the trust list's changes (api/routes/opcua.py,
docs/opcua.md "The trust list"): the OPC UA server's state as its status.json says it, and the client
applications' certificates in <data>/opcua/pki.  OpenAPI and the web UI's schema.d.ts come from them."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field


class OpcuaCertificate(BaseModel):
    """A client application's certificate in the trust list (or a CA that issues them)."""

    folder: Literal["trusted", "rejected"]
    file: str = Field(description="its file name in <data>/opcua/pki/<folder>/")
    subject: str = Field(description="RFC 4514, e.g. CN=UaExpert@host,O=...")
    issuer: str
    sha1: str = Field(description="the SHA-1 thumbprint of its DER form (OPC UA's thumbprint), lowercase hex")
    sha256: str = Field(description="the SHA-256 thumbprint, lowercase hex")
    not_before: str = Field(description="ISO 8601, UTC")
    not_after: str
    valid_now: bool = Field(description="false: expired or not yet valid (the server refuses it, trusted or not)")
    application_uri: str | None = Field(description="the URI in its subjectAltName, the client's ApplicationUri")
    ca: bool = Field(description="a CA certificate: when trusted, the certificates it issued are trusted")


class OpcuaSecurity(BaseModel):
    policies: list[str] = Field(description="the security policies offered, each with Sign and SignAndEncrypt")
    security_none: bool = Field(description="policy None is offered: messages are neither signed nor encrypted")
    anonymous: bool = Field(description="anonymous sessions are allowed")
    warnings: list[str] = Field(description="what lets a client in without security, in words; empty: none")


class OpcuaServerCertificate(BaseModel):
    file: str | None = None
    subject: str | None = None
    sha1: str | None = None
    sha256: str | None = None
    not_after: str | None = None


class OpcuaState(BaseModel):
    """GET /opcua: the OPC UA server as it last said in <data>/opcua/status.json, and its trust list
    as the folders hold it now."""

    server: Literal["ok", "off", "stale", "unreadable"] = Field(
        description="ok; off (no status.json: the server has not run with this data folder); stale (it "
        "stopped writing it: stopped, killed or stuck); unreadable (not a status this agent reads)"
    )
    message: str = Field(description="what the server state means, in words; empty when ok")
    endpoint: str | None = Field(None, description="opc.tcp://host:port/ it listens on")
    application_uri: str | None = None
    pid: int | None = None
    started: str | None = Field(None, description="when the server started (ISO 8601, UTC)")
    updated: str | None = Field(None, description="when it wrote its status")
    age_s: float | None = Field(None, description="seconds since it wrote its status")
    security: OpcuaSecurity | None = None
    certificate: OpcuaServerCertificate | None = Field(None, description="the server's own certificate")
    irpd: bool | None = Field(None, description="the server reaches irpd")
    layout_hash: str | None = None
    sessions: int | None = None
    subscriptions: int | None = None
    monitored_items: int | None = None
    refused: int | None = Field(None, description="client certificates refused since the server started")
    trusted: list[OpcuaCertificate] = Field(description="pki/trusted: sessions from these applications are let in")
    rejected: list[OpcuaCertificate] = Field(
        description="pki/rejected: applications refused (BadCertificateUntrusted), kept to be trusted or removed"
    )
    unreadable: list[str] = Field(
        description="files in the folders that are not certificates, or in trusted not named .der, .pem or .crt "
        "(the server reads neither), as folder/name"
    )


class OpcuaTrustChange(BaseModel):
    """What a trust, reject or remove did."""

    action: Literal["trust", "reject", "remove"]
    certificate: OpcuaCertificate = Field(description="the certificate as it is now (its folder and file)")
    changed: bool = Field(description="false: it already was where it was asked to go")
    detail: str


MAX_COMMENT = 1000  # characters of an Acknowledge's or Confirm's comment (the server cuts longer ones)


class OpcuaAlarmAction(BaseModel):
    """An OPC UA session's Acknowledge or Confirm, sent by the OPC UA server with its own credential
    (<data>/opcua-token) on behalf of the session's user (docs/opcua.md "Alarms")."""

    user: str = Field(min_length=1, max_length=200, description="the session's user name")
    method: Literal["password", "certificate", "anonymous"] = Field(
        description="how the session signed in: a password user's role is the agent's (users.json, now); a "
        "certificate's or an anonymous session's is the one the server's settings give"
    )
    role: str = Field(max_length=20, description="the role the server gave the session")
    session: str = Field(max_length=100, description="the server's session id (opcua-session-N)")
    client: str = Field(max_length=200, description="the OPC UA client's address")
    comment: str = Field("", max_length=MAX_COMMENT, description="the method's Comment: the history row's note")

"""opcua.py -- `irpctl opcua ...`: the OPC UA server's state and its trust list (GET /opcua, POST
/opcua/certificates/{thumbprint}/trust|reject, DELETE ...; docs/irpctl.md, docs/opcua.md "The trust
list").  irpctl.py adds OPCUA_COMMANDS to its command table as a group; each entry is (name, help, run,
arguments) as its Command.  A certificate is named by its SHA-1 or SHA-256 thumbprint, or by the
start of one (at least 6 hex digits) when only one certificate's thumbprint starts so."""

from __future__ import annotations

import re
from typing import Any

from .base import EXIT_OK, arg
from .client import ApiError
from .text import pairs, printable, table

MIN_PREFIX = 6
HEX = re.compile(r"[0-9a-fA-F]+")


def status_text(s: dict) -> str:
    if s["server"] in ("off", "unreadable"):
        head = f"OPC UA server: {s['server']} -- {printable(s['message'])}"
        return head + f"\ncertificates: {len(s['trusted'])} trusted, {len(s['rejected'])} rejected"
    sec = s.get("security") or {}
    cert = s.get("certificate") or {}
    items: list[tuple[str, Any]] = [
        ("server", s["server"] + (f" ({printable(s['message'])})" if s["message"] else "")),
        ("endpoint", s.get("endpoint")),
        ("application uri", printable(s.get("application_uri"))),
        ("pid", f"{s.get('pid')}, started {s.get('started')}, status {s.get('age_s')} s old"),
        ("policies", ", ".join(sec.get("policies") or []) + " (Sign, SignAndEncrypt)"),
        ("anonymous", "ALLOWED" if sec.get("anonymous") else "refused"),
        ("irpd", "reachable" if s.get("irpd") else "unreachable"),
        ("sessions", s.get("sessions")),
        ("subscriptions", f"{s.get('subscriptions')}, {s.get('monitored_items')} monitored items"),
        ("certificates", f"{len(s['trusted'])} trusted, {len(s['rejected'])} rejected, {s.get('refused')} refused"),
        ("server cert", f"SHA-1 {cert.get('sha1')}, until {cert.get('not_after')}"),
    ]
    out = pairs(items)
    for w in sec.get("warnings") or []:
        out += f"\nWARNING: {printable(w)}"
    return out


def certs_text(s: dict) -> str:
    certs = s["trusted"] + s["rejected"]
    if not certs:
        return "no client certificates: a client's first try puts its certificate in pki/rejected"
    rows = [
        [
            c["folder"],
            printable(c["subject"]),
            printable(c["application_uri"] or "-"),
            c["sha1"],
            c["not_after"][:10] + ("" if c["valid_now"] else " (not valid now)"),
        ]
        for c in certs
    ]
    out = table(["FOLDER", "SUBJECT", "APPLICATION URI", "SHA-1", "VALID UNTIL"], rows)
    if s["unreadable"]:
        out += "\nnot certificates: " + ", ".join(printable(u) for u in s["unreadable"])
    return out


def change_text(r: dict) -> str:
    c = r["certificate"]
    return f"{printable(c['subject'])} ({c['sha1']}): {printable(r['detail'])}"


def resolve(c, given: str) -> str:
    """A full thumbprint as given, or the one thumbprint that starts with `given`."""
    if not HEX.fullmatch(given) or len(given) > 64:
        raise ValueError(
            f"{given!r}: a thumbprint is 40 (SHA-1) or 64 (SHA-256) hexadecimal digits (irpctl opcua certs)"
        )
    if len(given) in (40, 64):
        return given
    if len(given) < MIN_PREFIX:
        raise ValueError(f"{given!r}: give at least {MIN_PREFIX} hex digits of a thumbprint (irpctl opcua certs)")
    s = c.get("/opcua")
    found = {
        x["sha256"]
        for x in s["trusted"] + s["rejected"]
        if given.lower() in (x["sha1"][: len(given)], x["sha256"][: len(given)])
    }
    if len(found) != 1:
        what = "no certificate's" if not found else f"{len(found)} certificates'"
        raise ApiError(404, f"{what} thumbprint starts with {given.lower()}: irpctl opcua certs lists them")
    return found.pop()


def cmd_status(c, a, out) -> int:
    out.show(c.get("/opcua"), status_text)
    return EXIT_OK


def cmd_certs(c, a, out) -> int:
    out.show(c.get("/opcua"), certs_text)
    return EXIT_OK


def _change(verb: str):
    def run(c, a, out) -> int:
        thumbprint = resolve(c, a.thumbprint)
        if verb == "rm":
            result = c.request("DELETE", f"/opcua/certificates/{thumbprint}")
        else:
            result = c.request("POST", f"/opcua/certificates/{thumbprint}/{verb}")
        out.show(result, change_text)
        return EXIT_OK

    return run


THUMBPRINT = arg("thumbprint", metavar="THUMBPRINT", help="SHA-1 or SHA-256, or its first digits (at least 6)")
OPCUA_COMMANDS = (
    ("status", "the OPC UA server: endpoint, security (warns of None or anonymous), sessions", cmd_status, ()),
    ("certs", "the client applications' certificates: trusted and rejected, with thumbprints", cmd_certs, ()),
    ("trust", "trust a client application's certificate: its next session is let in (admin)", _change("trust"), (THUMBPRINT,)),
    ("reject", "move a certificate to rejected: new sessions of that client are refused (admin)", _change("reject"), (THUMBPRINT,)),
    ("rm", "remove a certificate from the trust list (admin)", _change("rm"), (THUMBPRINT,)),
)  # fmt: skip

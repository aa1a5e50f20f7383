"""headers.py -- the security headers of every answer the agent gives (the web UI, its files, the
API, its errors, the API docs, the 3D view's proxy, a refused WebSocket handshake), over HTTP and
HTTPS, set in one place: SecurityHeaders, an ASGI middleware (docs/security.md, "Headers").

Content-Security-Policy: the web UI runs only its own scripts and stylesheets (no inline script,
no style="" in markup), talks only to its own origin and is framed by nobody.  Two kinds of page
get their own policy: the API docs (Swagger UI's one inline script, allowed by its hash), and the
3D view's pages (a viewer's own page, framed by the web UI of the same origin, with the inline
scripts, styles and workers its viewer needs).  Strict-Transport-Security only over HTTPS."""

from __future__ import annotations

import json

HSTS = b"max-age=31536000"

UI = {
    "default-src": "'self'",
    "script-src": "'self'",
    "style-src": "'self'",
    "img-src": "'self' data:",
    "font-src": "'self'",
    "connect-src": "'self'",
    "frame-src": "'self'",
    "worker-src": "'self'",
    "object-src": "'none'",
    "base-uri": "'none'",
    "form-action": "'self'",
    "frame-ancestors": "'none'",
}
# The viewers' pages (viser's, meshcat's) are third-party builds: inline scripts and styles, WebAssembly,
# workers and blobs, and string evaluation (viser's WebAssembly sorter is Emscripten code whose
# bindings are made with `new Function` when its client starts; without 'unsafe-eval' that throws in
# the page); still nothing from another host, and framed only by this origin's web UI.
VIEWER = {
    **UI,
    "script-src": "'self' 'unsafe-inline' 'unsafe-eval' 'wasm-unsafe-eval' blob:",
    "style-src": "'self' 'unsafe-inline'",
    "img-src": "'self' data: blob:",
    "font-src": "'self' data:",
    "connect-src": "'self' data: blob:",
    "worker-src": "'self' blob:",
    "frame-ancestors": "'self'",
}


def policy(directives: dict[str, str]) -> str:
    return "; ".join(f"{k} {v}" for k, v in directives.items())


def docs_policy(script_hashes: list[str]) -> dict[str, str]:
    """The API docs page: the UI's policy, plus Swagger UI's inline start script by its hash."""
    return {**UI, "script-src": " ".join(["'self'", *script_hashes])}


def headers_for(directives: dict[str, str] = UI) -> list[tuple[bytes, bytes]]:
    """The headers of an answer under `directives` (the web UI's by default)."""
    framed = "'self'" in directives["frame-ancestors"]
    return [
        (b"content-security-policy", policy(directives).encode()),
        (b"x-frame-options", b"SAMEORIGIN" if framed else b"DENY"),
        (b"x-content-type-options", b"nosniff"),
        (b"referrer-policy", b"no-referrer"),
    ]


class SecurityHeaders:
    """Adds the headers to every HTTP answer (replacing any a route set), and to the answer that
    refuses a WebSocket handshake.  `pages`: (path, directives) for the pages with their own
    policy: the path itself and everything under it; the first that matches wins, else UI."""

    def __init__(self, app, pages: list[tuple[str, dict[str, str]]]):
        self.app = app
        self.pages = [(path.rstrip("/"), headers_for(d)) for path, d in pages]
        self.default = headers_for(UI)

    def _headers(self, scope) -> list[tuple[bytes, bytes]]:
        path = scope["path"]
        found = next((h for p, h in self.pages if path == p or path.startswith(p + "/")), self.default)
        if scope.get("scheme") in ("https", "wss"):
            found = [*found, (b"strict-transport-security", HSTS)]
        return found

    async def __call__(self, scope, receive, send):
        if scope["type"] not in ("http", "websocket"):
            return await self.app(scope, receive, send)
        added = self._headers(scope)
        names = {name for name, _ in added}
        # A WebSocket closed before it was accepted: the server would answer a bare 403; where it
        # lets the application answer the handshake itself, the 403 gets the headers and the reason.
        answers = "websocket.http.response" in (scope.get("extensions") or {})
        accepted = False

        async def with_headers(message):
            nonlocal accepted
            kind = message["type"]
            if kind in ("http.response.start", "websocket.http.response.start"):
                kept = [(k, v) for k, v in message.get("headers", []) if k.lower() not in names]
                message = {**message, "headers": kept + added}
            elif kind == "websocket.accept":
                accepted = True
            elif kind == "websocket.close" and not accepted and answers:
                return await self._refuse(send, message.get("reason") or "the WebSocket was refused", added)
            await send(message)

        await self.app(scope, receive, with_headers)

    @staticmethod
    async def _refuse(send, reason: str, added) -> None:
        body = json.dumps({"detail": reason}).encode()
        start = {"type": "websocket.http.response.start", "status": 403}
        start["headers"] = [(b"content-type", b"application/json"), *added]
        await send(start)
        await send({"type": "websocket.http.response.body", "body": body})

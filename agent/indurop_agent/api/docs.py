"""docs.py -- the API's interactive docs at /api/v1/docs: Swagger UI from the agent's own files
(the fastapi-offline package ships Swagger UI's bundle, stylesheet and icon), so that the page works
on a plant network without internet and runs no script from another host.  The page's one inline
script (FastAPI's, which starts Swagger UI) is allowed by its hash in the page's
Content-Security-Policy (headers.py), never by 'unsafe-inline'."""

from __future__ import annotations

import base64
import hashlib
import importlib.resources
from html.parser import HTMLParser

from fastapi import FastAPI
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles


class InlineScripts(HTMLParser):
    """Collects the text of every <script> without a src."""

    def __init__(self):
        super().__init__(convert_charrefs=False)
        self.scripts: list[str] = []
        self._inside = False

    def handle_starttag(self, tag, attrs):
        if tag == "script" and not dict(attrs).get("src"):
            self._inside = True
            self.scripts.append("")

    def handle_endtag(self, tag):
        if tag == "script":
            self._inside = False

    def handle_data(self, data):
        if self._inside:
            self.scripts[-1] += data


def script_hashes(html: str) -> list[str]:
    """CSP source expressions ('sha256-...') of the page's inline scripts."""
    parser = InlineScripts()
    parser.feed(html)
    return [f"'sha256-{base64.b64encode(hashlib.sha256(s.encode()).digest()).decode()}'" for s in parser.scripts]


def swagger_page(docs_url: str, openapi_url: str, title: str) -> str:
    """The docs page; its assets are under docs_url/assets."""
    assets = f"{docs_url}/assets"
    return get_swagger_ui_html(
        openapi_url=openapi_url,
        title=f"{title} - API docs",
        swagger_js_url=f"{assets}/swagger-ui-bundle.js",
        swagger_css_url=f"{assets}/swagger-ui.css",
        swagger_favicon_url=f"{assets}/favicon.png",
        swagger_ui_parameters={"validatorUrl": None},  # no badge fetched from a validator service
    ).body.decode()


def serve_docs(app: FastAPI, docs_url: str, openapi_url: str) -> list[str]:
    """Serves the page at docs_url and Swagger UI's files under docs_url/assets (no credentials:
    the OpenAPI document is public too); returns the hashes its inline scripts need in the CSP."""
    page = swagger_page(docs_url, openapi_url, app.title)
    static = importlib.resources.files("fastapi_offline") / "static"
    app.mount(f"{docs_url}/assets", StaticFiles(directory=str(static)), name="api-docs-assets")

    @app.get(docs_url, include_in_schema=False)
    def docs() -> HTMLResponse:
        return HTMLResponse(page)

    return script_hashes(page)

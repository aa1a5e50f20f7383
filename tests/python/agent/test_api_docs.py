"""test_api_docs.py -- /api/v1/docs is Swagger UI from the agent's own files: every script,
stylesheet and icon the page names is a path on the agent that answers, none is on another host,
and no credentials are needed (the OpenAPI document is public too).  The browser's side (no
request leaves the agent, the operations render): tests/browser/apidocs.spec.ts."""

from __future__ import annotations

from html.parser import HTMLParser
from urllib.parse import urlsplit

from agent_helpers import API


class References(HTMLParser):
    def __init__(self):
        super().__init__()
        self.urls: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.urls += [v for k, v in attrs if k in ("src", "href") and v]


def test_the_docs_page_names_only_the_agents_own_files_and_they_answer(agent):
    r = agent.client.get(f"{API}/docs")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
    page = References()
    page.feed(r.text)
    assert len(page.urls) >= 3, page.urls  # the bundle, its stylesheet, the icon
    for url in page.urls:
        parts = urlsplit(url)
        assert not parts.scheme and not parts.netloc and url.startswith(f"{API}/docs/"), url
        asset = agent.client.get(url)
        assert asset.status_code == 200 and len(asset.content) > 100, url
    assert "cdn" not in r.text.lower() and "https://" not in r.text
    assert f"url: '{API}/openapi.json'" in r.text
    assert agent.client.get(f"{API}/openapi.json").status_code == 200

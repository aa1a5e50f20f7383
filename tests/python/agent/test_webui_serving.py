"""test_webui_serving.py -- the agent serves the built web UI at / (no token: the UI signs in with
one) while /api/v1 answers as before, unknown API paths stay JSON 404s, and without a build GET /
says how to make one."""

from __future__ import annotations

from pathlib import Path

import pytest
from agent_helpers import API, free_port, output, start_agent, stop
from indurop_agent import config

INDEX = "<!doctype html><title>indurop</title><div id=app data-testid=app></div>"


@pytest.fixture
def dist(tmp_path) -> Path:
    d = tmp_path / "dist"
    (d / "assets").mkdir(parents=True)
    (d / "index.html").write_text(INDEX)
    (d / "assets" / "app.js").write_text("console.log('indurop');\n")
    return d


def test_the_ui_is_served_at_the_root_without_a_token(make_agent, dist):
    agent = make_agent(webui_dir=dist)
    r = agent.client.get("/")
    assert r.status_code == 200 and r.text == INDEX and r.headers["content-type"].startswith("text/html")
    r = agent.client.get("/assets/app.js")
    assert r.status_code == 200 and "indurop" in r.text
    r = agent.client.get("/index.html", headers={"Authorization": "Bearer not-a-token"})
    assert r.status_code == 200  # a stale token in the browser does not matter for the files


def test_the_api_is_unaffected_by_the_ui(make_agent, dist):
    agent = make_agent(webui_dir=dist)
    assert agent.client.get(f"{API}/health").json()["agent"] == "ok"
    assert agent.client.get(f"{API}/status").status_code == 401
    r = agent.client.get(f"{API}/status", headers=agent.h("viewer"))
    assert r.status_code == 503 and "not reachable" in r.json()["detail"]  # irpd is absent here
    assert agent.client.get(f"{API}/openapi.json").json()["info"]["title"] == "indurop agent"


@pytest.mark.parametrize(
    "method, path",
    [("GET", f"{API}/unknown"), ("POST", f"{API}/unknown"), ("GET", "/api"), ("DELETE", f"{API}/nothing/here")],
)
def test_unknown_api_paths_are_json_404s(make_agent, dist, method, path):
    r = make_agent(webui_dir=dist).client.request(method, path)
    assert r.status_code == 404, r.text
    assert r.headers["content-type"] == "application/json" and "openapi.json" in r.json()["detail"]


def test_a_file_the_ui_does_not_have_is_a_404(make_agent, dist):
    r = make_agent(webui_dir=dist).client.get("/missing.js")
    assert r.status_code == 404 and r.json()["detail"]


def test_the_ui_files_are_not_counted_as_failed_sign_ins(make_agent, dist):
    agent = make_agent(webui_dir=dist, lockout_attempts=2)
    for _ in range(5):
        assert agent.client.get("/", headers={"Authorization": "Bearer wrong"}).status_code == 200
    assert agent.client.get(f"{API}/status", headers=agent.h("viewer")).status_code == 503  # not locked out


def test_without_a_build_the_root_says_how_to_build_it(make_agent, tmp_path):
    empty = tmp_path / "no-ui"
    empty.mkdir()
    agent = make_agent(webui_dir=empty)
    r = agent.client.get("/")
    assert r.status_code == 404 and "cd webui && npm ci && npm run build" in r.json()["detail"]
    assert agent.client.get(f"{API}/health").status_code == 200


def test_the_webui_dir_is_a_command_line_and_config_setting(tmp_path):
    assert config.parse(["--webui-dir", str(tmp_path)]).webui_dir == tmp_path
    cfg = tmp_path / "agent.json"
    cfg.write_text(f'{{"webui_dir": "{tmp_path / "ui"}"}}')
    assert config.parse(["--config", str(cfg)]).webui_dir == tmp_path / "ui"
    assert config.parse([]).webui_dir is None  # the default is decided at start: config.default_webui_dir()


def test_the_startup_line_gives_the_ui_address(tmp_path, dist):
    port = free_port()
    agent = start_agent(port, tmp_path / "data", tmp_path / "no-irpd.sock", "--webui-dir", str(dist))
    stop(agent)
    out = output(agent)
    assert f"the web UI at http://127.0.0.1:{port}/" in out, out

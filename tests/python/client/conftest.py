# conftest.py -- fixtures for the client and irpctl tests (the peers are in client_helpers.py):
# cells of a real irpd + agent, the contract's stream server, a fake v2 agent, irpctl in-process.
from __future__ import annotations

import httpx
import pytest
from client_helpers import Cell, FakeAgent, HttpsStatus, StreamServer, tls_context
from indurop_agent.cli import irpctl as cli


def pytest_configure(config):
    config.addinivalue_line(
        "markers",
        "contract_v2: needs the agent routes of notes/contract-v2 (sets, PATCH, writes, stream, events, audit)",
    )


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    """One cell for the tests that only read."""
    c = Cell(tmp_path_factory.mktemp("cell"))
    yield c
    c.close()


@pytest.fixture
def fresh_cell(tmp_path):
    """A cell of its own, for the tests that change the running set."""
    c = Cell(tmp_path)
    yield c
    c.close()


class Run:
    """irpctl's main() in this process: (exit code, stdout, stderr)."""

    def __init__(self, capsys):
        self.capsys = capsys

    def __call__(self, *argv: str) -> tuple[int, str, str]:
        self.capsys.readouterr()
        code = cli.main(list(argv))
        out, err = self.capsys.readouterr()
        return code, out, err


@pytest.fixture
def irpctl(capsys, monkeypatch):
    for name in ("INDUROP_URL", "INDUROP_TOKEN", "INDUROP_TOKEN_FILE"):
        monkeypatch.delenv(name, raising=False)
    return Run(capsys)


@pytest.fixture
def stream_server():
    s = StreamServer()
    yield s
    s.close()


@pytest.fixture
def fake_agent(monkeypatch):
    """irpctl's Client talks to a FakeAgent."""
    from indurop_agent.cli import client as client_module

    agent = FakeAgent()

    def make(url, token=None, **kw):
        return client_module.Client(url, token, transport=httpx.MockTransport(agent), **kw)

    monkeypatch.setattr(cli, "Client", make)
    return agent


@pytest.fixture
def tls_peers(tmp_path):
    """(an https agent answering /status, a wss stream server, the CA file that checks both)."""
    ctx, cert = tls_context(tmp_path)
    https, wss = HttpsStatus(ctx), StreamServer(ctx)
    yield https, wss, cert
    https.close()
    wss.close()

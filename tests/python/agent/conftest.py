# conftest.py -- fixtures of the agent's tests: an in-process agent (FastAPI TestClient, no irpd)
# with a token per role, and real ELF files built with gcc.  Plain helpers: agent_helpers.py.

from __future__ import annotations

import shutil
import subprocess
import sys

import pytest
from agent_helpers import ROOT, Agent, Elves

sys.path.insert(0, str(ROOT / "agent"))

from fastapi.testclient import TestClient  # noqa: E402
from indurop_agent.api.app import create_app  # noqa: E402
from indurop_agent.config import Settings  # noqa: E402


@pytest.fixture
def make_agent(tmp_path):
    """make_agent(**settings) -> an Agent with admin, operator and viewer tokens; irpd is absent."""
    clients = []

    def make(**overrides) -> Agent:
        data = tmp_path / f"data{len(clients)}"
        settings = Settings(data_dir=data, irpd_socket=str(tmp_path / "no-irpd.sock"), **overrides)
        app = create_app(settings, restore=False)
        app.state.tokens.ensure_admin()
        tokens = {"admin": (data / "admin-token").read_text().strip()}
        for role in ("operator", "viewer"):
            tokens[role], _ = app.state.tokens.add(f"test-{role}", role)
        client = TestClient(app)
        clients.append(client)
        return Agent(client, data, tokens)

    yield make
    for c in clients:
        c.close()


@pytest.fixture
def agent(make_agent) -> Agent:
    return make_agent()


@pytest.fixture(scope="session")
def elves(tmp_path_factory) -> Elves:
    gcc = shutil.which("gcc")
    if gcc is None:
        pytest.fail("gcc is needed to build the ELF fixtures (packaging/deps.sh installs it)")
    d = tmp_path_factory.mktemp("elves")

    def build(name: str, source: str, *flags: str) -> bytes:
        (d / f"{name}.c").write_text(source)
        subprocess.run([gcc, *flags, "-o", str(d / name), str(d / f"{name}.c")], check=True, capture_output=True)
        return (d / name).read_bytes()

    return Elves(
        module=build("module.so", "void run(void) {}\n", "-shared", "-fPIC"),
        descriptor=build(
            "descr.so", "const void *indurop_module_v1_descriptor(void) { return 0; }\n", "-shared", "-fPIC"
        ),
        library=build("lib.so", "int helper(int x) { return x + 1; }\n", "-shared", "-fPIC"),
        pie=build("pie", "int main(void) { return 0; }\n", "-pie", "-fPIE"),
        exec_=build("exec", "int main(void) { return 0; }\n", "-no-pie"),
    )

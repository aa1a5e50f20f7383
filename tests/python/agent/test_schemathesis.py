"""test_schemathesis.py -- schemathesis generates requests from the agent's own OpenAPI spec
(every route, every parameter, valid and invalid bodies) and sends them, with an admin token, to
a real agent in front of a real irpd: no answer may be a 5xx.  The stream (WebSocket) is not in
the spec; tests/python/agent/test_stream.py covers it."""

from __future__ import annotations

import json
import os

import pytest
import schemathesis
from agent_helpers import free_port, start_agent, start_irpd, stop
from hypothesis import HealthCheck, settings
from schemathesis.checks import not_a_server_error

schemathesis.experimental.OPEN_API_3_1.enable()  # FastAPI writes OpenAPI 3.1

# Enough cases per operation to hit its bad inputs, few enough for CI's time (50 took 200 s of a
# worker's time, a tenth of the Python suite's).
EXAMPLES = 25
# Not sent: a valid request restarts irpd (test_system_live.py covers it), or follows a log for as
# long as the client stays (test_system_logs.py).
NOT_FUZZED = {("POST", "/api/v1/system/restart/irpd"), ("GET", "/api/v1/system/logs/{log}/follow")}


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("schemathesis")
    sock = tmp / "irpd.sock"
    irpd = start_irpd(sock, instance=f"schemathesis-{os.getpid()}")  # two runs at once do not collide
    port = free_port()
    data = tmp / "data"
    # Generated sign-ins fail by the hundred: they must not lock the test's own address (and so
    # every later operation) out.  The lockouts have tests of their own (test_users.py).
    config = tmp / "agent.json"
    config.write_text(json.dumps({"lockout_attempts": 1_000_000, "signin_attempts": 1_000_000}))
    agent = start_agent(port, data, sock, "--config", str(config))
    token = (data / "admin-token").read_text().strip()
    yield {"url": f"http://127.0.0.1:{port}", "headers": {"Authorization": f"Bearer {token}"}}
    stop(agent)
    stop(irpd)


@pytest.fixture(scope="module")
def api_schema(live):
    return schemathesis.from_uri(f"{live['url']}/api/v1/openapi.json", base_url=live["url"])


schema = schemathesis.from_pytest_fixture("api_schema")


@schema.parametrize()
@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=list(HealthCheck))
def test_no_generated_request_gets_a_server_error(case, live):
    if (case.method.upper(), case.path) in NOT_FUZZED:
        return
    response = case.call(headers=live["headers"], timeout=60)
    case.validate_response(response, checks=(not_a_server_error,))

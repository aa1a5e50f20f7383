"""test_agent.py -- indurop-agent against a real irpd on loopback: health, token auth, status,
schedule and modules through the control socket, and irpd going away and coming back."""

from __future__ import annotations

import stat
import time

import httpx
import pytest
from agent_helpers import IRPD, free_port, start_agent, start_irpd, stop

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")


@pytest.fixture
def cell(tmp_path):
    sock = tmp_path / "irpd.sock"
    irpd = start_irpd(sock)
    port = free_port()
    data = tmp_path / "data"
    agent = start_agent(port, data, sock)
    url = f"http://127.0.0.1:{port}/api/v1"
    token = (data / "admin-token").read_text().strip()
    state = {"irpd": irpd, "sock": sock, "tmp": tmp_path}
    yield url, token, data, state
    stop(agent)
    stop(state["irpd"])


def test_health_needs_no_token_and_sees_irpd(cell):
    url, *_ = cell
    r = httpx.get(f"{url}/health")
    assert r.status_code == 200
    assert r.json()["irpd"] == "ok" and r.json()["running"] is True


def test_the_first_start_writes_an_admin_token_readable_only_by_its_owner(cell):
    _, token, data, _ = cell
    assert len(token) >= 32
    assert stat.S_IMODE((data / "admin-token").stat().st_mode) == 0o600
    assert token not in (data / "tokens.json").read_text()  # stored hashed


@pytest.mark.parametrize("path", ["/status", "/schedule", "/modules", "/jitter"])
def test_every_route_but_health_needs_a_valid_token(cell, path):
    url, *_ = cell
    assert httpx.get(f"{url}{path}").status_code == 401
    assert httpx.get(f"{url}{path}", headers={"Authorization": "Bearer not-a-token"}).status_code == 401


def test_status_schedule_and_modules_come_from_irpd(cell):
    url, token, *_ = cell
    h = {"Authorization": f"Bearer {token}"}
    status = httpx.get(f"{url}/status", headers=h).json()
    assert status["basic_period_ns"] == 100000 and status["macro_period_ns"] == 500000
    assert status["running"] is True
    schedule = httpx.get(f"{url}/schedule", headers=h).json()
    assert schedule["slots"][0]["modules"] == ["cntr3", "cntr2", "cntr1", "cntr4"]
    assert [s["modules"] for s in schedule["slots"][1:]] == [["cntr3", "cntr2"]] * 4
    modules = httpx.get(f"{url}/modules", headers=h).json()
    assert [m["name"] for m in modules] == ["cntr1", "cntr2", "cntr3", "cntr4", "event1", "visionEvt", "nonReaTime"]
    assert modules[1]["runs"] > 0


def test_the_agent_survives_irpd_going_away_and_reconnects_by_itself(cell):
    url, token, _, state = cell
    h = {"Authorization": f"Bearer {token}"}
    stop(state["irpd"])
    assert httpx.get(f"{url}/health").json()["irpd"] == "unreachable"
    r = httpx.get(f"{url}/status", headers=h)
    assert r.status_code == 503 and "not reachable" in r.json()["detail"]
    state["irpd"] = start_irpd(state["sock"])
    assert httpx.get(f"{url}/status", headers=h).json()["running"] is True


def test_openapi_is_served_under_api_v1(cell):
    url, *_ = cell
    spec = httpx.get(f"{url}/openapi.json").json()
    assert {"/api/v1/health", "/api/v1/status", "/api/v1/schedule", "/api/v1/modules"} <= set(spec["paths"])


# The role each route needs (reads: viewer; module changes: operator; token management: admin), with
# a body that route accepts and the status it then answers.  Only requests that change nothing:
# the module change is a dry run.
DRY_RUN = {"changes": [{"name": "cntr1", "period_ns": 1000000}], "dry_run": True}
CAPTURE = {
    "variables": ["knu.Robot.tick"],
    "trigger": {"kind": "manual"},
    "pre": {"rows": 10},
    "post": {"rows": 10},
}
ROUTES = [
    ("GET", "/status", "viewer", None, 200),
    ("GET", "/schedule", "viewer", None, 200),
    ("GET", "/modules", "viewer", None, 200),
    ("GET", "/modules/cntr1", "viewer", None, 200),
    ("GET", "/jitter", "viewer", None, 200),
    ("GET", "/jitter/histograms", "viewer", None, 200),
    ("GET", "/host", "viewer", None, 200),
    ("GET", "/variables", "viewer", None, 200),
    ("GET", "/variables/knu.Robot.tick", "viewer", None, 200),
    ("POST", "/variables/read", "viewer", {"paths": ["knu.Robot.tick"]}, 200),
    ("GET", "/forces", "viewer", None, 200),  # forcing (docs/forcing.md)
    ("GET", "/events", "viewer", None, 200),
    ("GET", "/alarms", "viewer", None, 200),
    ("GET", "/alarms/history", "viewer", None, 200),
    ("GET", "/alarms/history.csv", "viewer", None, 200),
    ("GET", "/line", "viewer", None, 200),  # the line (docs/dds.md): no bridge here, "off"
    ("GET", "/opcua", "viewer", None, 200),  # the OPC UA server (docs/opcua.md): none here, "off"
    # the trust list (tests/python/agent/test_opcua_trust.py): no such certificate here
    ("POST", f"/opcua/certificates/{'0' * 64}/trust", "admin", None, 404),
    ("POST", f"/opcua/certificates/{'0' * 64}/reject", "admin", None, 404),
    ("DELETE", f"/opcua/certificates/{'0' * 64}", "admin", None, 404),
    ("GET", "/recordings", "viewer", None, 200),
    ("POST", "/alarms/ack", "operator", {}, 200),
    ("GET", "/layout", "viewer", None, 200),
    ("GET", "/sets", "viewer", None, 200),
    ("GET", "/auth/me", "viewer", None, 200),
    ("POST", "/modules/changes", "operator", DRY_RUN, 200),
    ("GET", "/audit", "admin", None, 200),
    ("GET", "/tokens", "admin", None, 200),
    ("POST", "/tokens", "admin", {"name": "x", "role": "viewer"}, 201),
    ("GET", "/users", "admin", None, 200),
    ("POST", "/users", "admin", {"name": "matrix", "role": "viewer", "password": "a long password 1"}, 201),
    ("GET", "/system", "admin", None, 200),
    ("POST", "/sets/prune", "admin", {"keep_last": 1000, "dry_run": True}, 200),
    ("GET", "/captures", "viewer", None, 200),
    ("GET", "/captures/limits", "viewer", None, 200),
    ("POST", "/captures", "operator", CAPTURE, 201),
    # trace configurations kept with a set (tests/python/agent/test_scopes.py): no such set here
    ("GET", "/sets/0123456789abcdef/scopes", "viewer", None, 404),
    ("GET", "/sets/0123456789abcdef/scopes/x", "viewer", None, 404),
    ("PUT", "/sets/0123456789abcdef/scopes/x", "operator", {"capture": CAPTURE}, 404),
    ("DELETE", "/sets/0123456789abcdef/scopes/x", "operator", None, 404),
    # watch lists kept with a set (tests/python/agent/test_monitor_api.py): no such set here
    ("GET", "/sets/0123456789abcdef/watches", "viewer", None, 404),
    ("GET", "/sets/0123456789abcdef/watches/x", "viewer", None, 404),
    ("PUT", "/sets/0123456789abcdef/watches/x", "operator", {"paths": []}, 404),
    ("DELETE", "/sets/0123456789abcdef/watches/x", "operator", None, 404),
]
ROLES = ["viewer", "operator", "admin"]


def test_the_role_matrix_over_every_route(cell):
    url, admin, *_ = cell
    tokens = {"admin": admin}
    for role in ("viewer", "operator"):
        r = httpx.post(
            f"{url}/tokens", json={"name": f"t-{role}", "role": role}, headers={"Authorization": f"Bearer {admin}"}
        )
        assert r.status_code == 201, r.text
        assert r.json()["role"] == role
        tokens[role] = r.json()["token"]
    for method, path, needed, body, ok in ROUTES:
        assert httpx.request(method, f"{url}{path}", json=body).status_code == 401, path
        for role in ROLES:
            r = httpx.request(
                method, f"{url}{path}", json=body, timeout=40, headers={"Authorization": f"Bearer {tokens[role]}"}
            )
            allowed = ROLES.index(role) >= ROLES.index(needed)
            assert r.status_code == (ok if allowed else 403), (method, path, role, r.status_code, r.text)
            if not allowed:
                assert f"needs the {needed} role" in r.json()["detail"]


def test_every_route_of_the_api_is_in_the_role_matrix(cell):
    """A new route must be added to ROUTES (PATCH, PUT, DELETE and the set routes have their own tests)."""
    url, *_ = cell
    spec = httpx.get(f"{url}/openapi.json").json()
    listed = {(m, p) for m, p, *_ in ROUTES}
    covered_elsewhere = {
        ("GET", "/health"),
        ("PATCH", "/modules/{name}"),
        ("PUT", "/variables/{path}"),
        ("PUT", "/forces/{path}"),  # tests/python/opcua/test_forces_cell.py
        ("DELETE", "/forces/{path}"),
        ("GET", "/programs"),  # test_programs_api.py: 401, a viewer reads and checks, apply needs admin
        ("GET", "/programs/source"),
        ("POST", "/programs/check"),
        ("POST", "/programs/apply"),
        ("POST", "/programs/monitor"),  # test_monitor_api.py: 401, a viewer monitors
        ("GET", "/programs/diagram"),  # test_diagram_api.py: 401, a viewer draws and monitors
        ("POST", "/programs/diagram/monitor"),
        ("GET", "/programs/history"),
        ("GET", "/programs/diff"),
        ("GET", "/programs/export"),  # test_programs_api.py: 401, a viewer downloads the PLCopen XML
        ("POST", "/sets"),
        ("GET", "/sets/active"),
        ("GET", "/sets/{set_id}"),
        ("POST", "/sets/{set_id}/activate"),
        ("POST", "/sets/rollback"),
        ("POST", "/sets/{set_id}/check"),  # test_online_layout.py
        ("DELETE", "/tokens/{token_id}"),
        ("GET", "/robot"),
        ("GET", "/robot/urdf"),
        ("PUT", "/robot/joints"),
        ("POST", "/alarms/{key}/ack"),  # test_alarms_api.py
        ("POST", "/alarms/{key}/confirm"),
        ("GET", "/opcua/alarms"),  # tests/python/opcua/test_opcua_alarm_ack.py: the server's token only
        ("POST", "/opcua/alarms/{key}/ack"),
        ("POST", "/opcua/alarms/{key}/confirm"),
        ("POST", "/alarms/{key}/shelve"),
        ("POST", "/alarms/{key}/unshelve"),
        ("POST", "/session"),  # test_users.py: sessions, and their role matrix
        ("GET", "/session"),
        ("DELETE", "/session"),
        ("GET", "/users/{name}"),
        ("PATCH", "/users/{name}"),
        ("PUT", "/users/{name}/password"),
        ("GET", "/users/{name}/tokens"),
        ("POST", "/system/restart/irpd"),  # test_system_live.py
        ("POST", "/system/restart/agent"),
        ("GET", "/system/logs/{log}"),  # test_system_logs.py
        ("GET", "/system/logs/{log}/follow"),
        ("GET", "/system/backup"),  # test_system_backup.py
        ("POST", "/system/restore"),
        ("POST", "/system/tls"),  # test_system_tls.py
        ("POST", "/recordings"),  # tests/python/recorder/test_recorder_live.py
        ("GET", "/recordings/{name}"),
        ("POST", "/recordings/{name}/stop"),
        ("DELETE", "/recordings/{name}"),
        ("GET", "/recordings/{name}/download"),
        ("GET", "/recordings/{name}/export"),
        ("GET", "/captures/{capture_id}"),  # tests/python/recorder/test_captures_live.py
        ("GET", "/captures/{capture_id}/shots/{shot}"),
        ("POST", "/captures/{capture_id}/arm"),
        ("POST", "/captures/{capture_id}/disarm"),
        ("POST", "/captures/{capture_id}/trigger"),
        ("DELETE", "/captures/{capture_id}"),
    }
    templates = {
        ("GET", "/modules/cntr1"): ("GET", "/modules/{name}"),
        ("GET", "/variables/knu.Robot.tick"): ("GET", "/variables/{path}"),
        **{
            (m, p): (m, p.replace("0123456789abcdef", "{set_id}").replace("/x", "/{name}"))
            for m, p, *_ in ROUTES
            if "/scopes" in p or "/watches" in p
        },
        **{(m, p): (m, p.replace("0" * 64, "{thumbprint}")) for m, p, *_ in ROUTES if "/opcua/" in p},
    }
    listed = {templates.get(r, r) for r in listed}
    for path, operations in spec["paths"].items():
        for method in operations:
            route = (method.upper(), path.removeprefix("/api/v1"))
            assert route in listed or route in covered_elsewhere, f"{route} is not in the role matrix"


def test_a_bad_token_request_gets_a_422_that_says_what_to_fix(cell):
    url, admin, *_ = cell
    h = {"Authorization": f"Bearer {admin}"}
    r = httpx.post(f"{url}/tokens", json={"name": "../evil", "role": "root"}, headers=h)
    assert r.status_code == 422
    fields = {tuple(e["loc"]) for e in r.json()["detail"]}
    assert ("body", "name") in fields and ("body", "role") in fields


def test_jitter_gives_every_record_with_its_percentiles(cell):
    url, admin, *_ = cell
    j = httpx.get(f"{url}/jitter", headers={"Authorization": f"Bearer {admin}"}).json()
    assert j["executors"][0]["name"] == "dispatcher"
    assert {"p50", "p99", "p999", "max"} <= set(j["modules"][0]["jitter_ns"])


def test_variables_are_listed_and_read_live_from_shared_memory(cell):
    url, admin, *_ = cell
    h = {"Authorization": f"Bearer {admin}"}
    listing = httpx.get(f"{url}/variables", headers=h).json()
    paths = [v["path"] for v in listing["variables"]]
    assert "knu.Robot.tick" in paths and "joint[1].y" in paths and "knu.Robot.joints[9].z" in paths
    first = httpx.get(f"{url}/variables/knu.Robot.tick", headers=h).json()["value"]
    time.sleep(0.2)
    second = httpx.get(f"{url}/variables/knu.Robot.tick", headers=h).json()["value"]
    assert second > first and second % 10 == 0  # cntr2 adds 10 every 100 us
    x = httpx.get(f"{url}/variables/joint[0].x", headers=h).json()["value"]
    assert 0 <= x <= 181
    r = httpx.get(f"{url}/variables/knu.Robot.nothing", headers=h)
    assert r.status_code == 404 and "no variable 'knu.Robot.nothing'" in r.json()["detail"]


def test_a_struct_path_answers_every_leaf_of_the_struct(cell):
    url, admin, *_ = cell
    h = {"Authorization": f"Bearer {admin}"}
    r = httpx.get(f"{url}/variables/joint[1]", headers=h)
    assert r.status_code == 200, r.text
    answer = r.json()
    assert answer["path"] == "joint[1]" and "value" not in answer
    assert answer["layout_hash"] == httpx.get(f"{url}/variables", headers=h).json()["layout_hash"]
    assert [(v["path"], v["type"]) for v in answer["values"]] == [
        ("joint[1].x", "double"),
        ("joint[1].y", "double"),
        ("joint[1].z", "double"),
    ]
    assert all(isinstance(v["value"], float) for v in answer["values"])


def test_an_array_path_answers_its_elements_in_order_and_a_namespace_all_it_holds(cell):
    url, admin, *_ = cell
    h = {"Authorization": f"Bearer {admin}"}
    listing = [v["path"] for v in httpx.get(f"{url}/variables", headers=h).json()["variables"]]
    joints = httpx.get(f"{url}/variables/knu.Robot.joints", headers=h).json()
    assert [v["path"] for v in joints["values"]] == [f"knu.Robot.joints[{i}].{c}" for i in range(10) for c in "xyz"]
    namespace = httpx.get(f"{url}/variables/knu.Robot", headers=h).json()
    assert [v["path"] for v in namespace["values"]] == [p for p in listing if p.startswith("knu.Robot.")]
    assert namespace["values"][0]["path"] == "knu.Robot.tick" and namespace["values"][0]["type"] == "uint32_t"
    assert isinstance(namespace["values"][0]["value"], int)


def test_a_leaf_path_answers_as_before(cell):
    url, admin, *_ = cell
    r = httpx.get(f"{url}/variables/joint[1].y", headers={"Authorization": f"Bearer {admin}"})
    assert r.status_code == 200
    assert set(r.json()) == {"path", "value", "layout_hash", "forced"} and r.json()["path"] == "joint[1].y"
    assert r.json()["forced"] is False  # forcing (docs/forcing.md)


def test_a_path_that_names_nothing_is_a_404_with_the_nearest_names(cell):
    url, admin, *_ = cell
    for path, near in [
        ("joint[1].w", "'joint[1].x'"),  # a leaf that is not there: the nearest ones
        ("knu.Robot.joint", "'knu.Robot.joints'"),  # a group misspelt
        ("knu.Rob", "'knu.Robot'"),  # the start of a name is no group
        ("PLC_ROBOT", None),  # not in this layout at all
        ("joint[6]", "'joint[5]'"),  # past the end of the array
    ]:
        r = httpx.get(f"{url}/variables/{path}", headers={"Authorization": f"Bearer {admin}"})
        assert r.status_code == 404, path
        detail = r.json()["detail"]
        assert f"no variable '{path}' (neither a leaf nor a group)" in detail and "GET /api/v1/variables" in detail
        assert (near in detail.partition("; did you mean ")[2]) if near else "did you mean" not in detail, detail

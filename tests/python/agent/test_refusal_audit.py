"""test_refusal_audit.py -- refused requests reach the audit log, read back as an admin through
GET /api/v1/audit: a 401, a role refusal (403), a CSRF refusal (403) and a body refused by
validation (422), each with who (when known), the route, why and the client's address, never a
password; a flood of one kind is bounded (refusals.py's bucket) and summed up in one
`refusals_suppressed` line; and wrong current_passwords on PUT /users/{name}/password lock the name
as wrong sign-ins do (a `lockout` line and event, 429 with Retry-After)."""

from __future__ import annotations

import pytest
from agent_helpers import API
from indurop_agent.access.refusals import BURST
from test_users import FAST, add, as_cookie, password_of, session, sign_in, users  # noqa: F401 (users: a fixture)

SECRET = "Refusal-Audit-Secret-77"


def audit(agent, limit: int = 10000) -> list[dict]:
    r = agent.client.get(f"{API}/audit", params={"limit": limit}, headers=agent.h("admin"))
    assert r.status_code == 200, r.text
    return r.json()


def refused(agent, kind: str) -> list[dict]:
    return [e for e in audit(agent) if e["action"] == "refused" and e["kind"] == kind]


def test_a_request_without_credentials_is_audited_as_a_401(users):  # noqa: F811
    assert users.client.get(f"{API}/status").status_code == 401
    [line] = refused(users, "unauthenticated")
    assert line["status"] == 401 and line["result"] == "error" and line["who"] is None
    assert line["target"] == f"GET {API}/status" and line["client"] == "testclient" and "bearer token" in line["detail"]


def test_a_role_too_low_is_audited_as_a_403_with_who(users):  # noqa: F811
    assert users.client.get(f"{API}/users", headers=users.h("viewer")).status_code == 403
    sid, _ = session(users, "victor")
    assert users.client.get(f"{API}/users/alice", headers=as_cookie(sid)).status_code == 403
    token, user = refused(users, "forbidden")
    assert token["who"]["name"] == "test-viewer" and token["target"] == f"GET {API}/users"
    assert "admin role" in token["detail"] and token["status"] == 403
    assert user["who"]["user"] == "victor" and user["target"] == f"GET {API}/users/alice"


def test_a_change_without_the_csrf_token_is_audited_as_a_csrf_refusal(users):  # noqa: F811
    sid, _ = session(users, "oscar")
    body = {"password": "a brand new password", "current_password": password_of("oscar")}
    assert users.client.put(f"{API}/users/oscar/password", json=body, headers=as_cookie(sid)).status_code == 403
    [line] = refused(users, "csrf")
    assert line["who"]["user"] == "oscar" and line["status"] == 403 and "X-CSRF-Token" in line["detail"]
    assert line["target"] == f"PUT {API}/users/oscar/password"
    assert password_of("oscar") not in (users.data / "audit.jsonl").read_text()


def test_a_body_refused_by_validation_is_audited_without_its_values(users):  # noqa: F811
    r = users.client.post(f"{API}/users", json={"name": "bob", "password": SECRET}, headers=users.h())
    assert r.status_code == 422
    assert users.client.post(f"{API}/session", content=f"password={SECRET}").status_code == 422
    by_admin, anonymous = refused(users, "invalid")
    assert by_admin["who"]["name"] == "admin" and by_admin["target"] == f"POST {API}/users"
    assert "role" in by_admin["detail"] and by_admin["status"] == 422
    assert anonymous["who"] is None and anonymous["target"] == f"POST {API}/session"
    assert SECRET not in (users.data / "audit.jsonl").read_text()


def test_a_flood_of_refusals_is_bounded_and_summed_up(make_agent):
    agent = make_agent(**FAST)
    flood = 3 * BURST
    for i in range(flood):
        assert agent.client.get(f"{API}/status", params={"n": i}).status_code == 401
    assert agent.client.get(f"{API}/users", headers=agent.h("viewer")).status_code == 403  # another kind
    lines = audit(agent)
    assert len([e for e in lines if e.get("kind") == "unauthenticated"]) == BURST
    [summary] = [e for e in lines if e["action"] == "refusals_suppressed"]
    assert summary["target"] == "unauthenticated" and summary["suppressed"] == flood - BURST
    assert f"{flood - BURST} refusals" in summary["detail"]
    assert len([e for e in lines if e.get("kind") == "forbidden"]) == 1  # each kind has its own bucket
    assert len([e for e in audit(agent) if e["action"] == "refusals_suppressed"]) == 1  # written once


@pytest.fixture
def locking(make_agent):
    agent = make_agent(signin_attempts=5, signin_window_s=300, lockout_attempts=100, **FAST)
    add(agent, "alice", "admin")
    add(agent, "oscar", "operator")
    return agent


def test_wrong_current_passwords_lock_the_name_with_a_lockout_line_an_event_and_retry_after(locking):
    sid, csrf = session(locking, "oscar")
    url = f"{API}/users/oscar/password"
    codes = []
    for i in range(6):
        body = {"password": "a brand new password", "current_password": f"guess number {i}"}
        r = locking.client.put(url, json=body, headers=as_cookie(sid, csrf))
        codes.append(r.status_code)
        if r.status_code == 429:
            assert 0 < int(r.headers["Retry-After"]) <= 300 and "locked" in r.json()["detail"], r.headers
    assert codes == [422, 422, 422, 422, 429, 429], codes
    [lockout] = [e for e in audit(locking) if e["action"] == "lockout"]
    assert lockout["target"] == "oscar" and "5 wrong passwords" in lockout["detail"]
    events = locking.client.get(f"{API}/events", headers=locking.h("viewer")).json()["events"]
    assert any(e["kind"] == "lockout" and "'oscar'" in e["message"] for e in events), events
    r = sign_in(locking, "oscar")  # the right password: the name is locked
    assert r.status_code == 429 and int(r.headers["Retry-After"]) > 0

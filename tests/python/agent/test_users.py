"""test_users.py -- users, passwords and browser sessions in an in-process agent (no irpd): the
first admin made with the admin token, the name and password rules, sign-in and its cookie, CSRF,
sign-out, session fixation, the idle and absolute timeouts, the lockout of a guessed name and of a
flooding address, disabled users (tokens revoked, sessions ended), tokens owned by users, password
changes and resets, rehashing, the audit, the WebSockets' cookie and Origin checks, and the role ×
route matrix for sessions of every role, a disabled user and an expired session."""

from __future__ import annotations

import json
import stat

import pytest
from agent_helpers import API, Agent
from argon2 import PasswordHasher
from starlette.websockets import WebSocketDisconnect
from test_hostile_input import HOSTILE_TEXT, NEEDS, SAMPLE

# Cheap hashes: the tests sign in hundreds of times (the default costs 64 MiB and ~0.1 s each).
FAST = {"argon2_time_cost": 1, "argon2_memory_kib": 1024, "argon2_parallelism": 1}
COOKIE = "indurop_session"
ROLES = ("viewer", "operator", "admin")


@pytest.fixture
def users(make_agent) -> Agent:
    """An agent with alice (admin), oscar (operator) and victor (viewer), password <name>-password-1."""
    agent = make_agent(**FAST)
    for name, role in (("alice", "admin"), ("oscar", "operator"), ("victor", "viewer")):
        add(agent, name, role)
    return agent


def password_of(name: str) -> str:
    """A password of `name`'s that follows the rules (it must not contain the name: each letter shifted)."""
    return "".join(chr(ord(c) + 1) for c in name) + "-password-1"


def add(agent: Agent, name: str, role: str, password: str | None = None):
    r = agent.client.post(
        f"{API}/users", json={"name": name, "role": role, "password": password or password_of(name)}, headers=agent.h()
    )
    assert r.status_code == 201, r.text
    return r.json()


def sign_in(agent: Agent, name: str, password: str | None = None, **headers):
    """POST /session; the answer (the test client keeps no cookie: each request names its own)."""
    r = agent.client.post(
        f"{API}/session", json={"name": name, "password": password or password_of(name)}, headers=headers
    )
    agent.client.cookies.clear()
    return r


def session(agent: Agent, name: str) -> tuple[str, str]:
    """A signed-in session of `name`: (its cookie's value, its CSRF token)."""
    r = sign_in(agent, name)
    assert r.status_code == 200, r.text
    return r.cookies[COOKIE], r.json()["csrf_token"]


def as_cookie(sid: str, csrf: str | None = None, **more) -> dict:
    return {"Cookie": f"{COOKIE}={sid}", **({"X-CSRF-Token": csrf} if csrf else {}), **more}


# ---- the first admin, the rules ------------------------------------------------------------------------
def test_the_first_start_has_no_user_and_the_admin_token_makes_the_first_admin(make_agent):
    agent = make_agent(**FAST)
    state = agent.client.get(f"{API}/session").json()
    assert state["signed_in"] is False and state["first_run"] is True
    assert (
        agent.client.post(f"{API}/users", json={"name": "root", "role": "admin", "password": "x" * 12}).status_code
        == 401
    )
    user = add(agent, "ada", "admin", "a long first password")
    assert user["role"] == "admin" and user["created_by"] == "admin" and user["last_sign_in"] is None
    assert "hash" not in user
    assert agent.client.get(f"{API}/session").json()["first_run"] is False
    stored = agent.data / "users.json"
    assert stat.S_IMODE(stored.stat().st_mode) == 0o600
    text = stored.read_text()
    assert "a long first password" not in text and "$argon2id$" in text
    assert sign_in(agent, "ada", "a long first password").status_code == 200


@pytest.mark.parametrize("name", ["A", "a", "Alice", "9lives", "al ice", "al/ice", "a" * 33, "", *HOSTILE_TEXT])
def test_a_bad_user_name_is_a_422_naming_the_field_and_the_rule(users, name):
    r = users.client.post(
        f"{API}/users", json={"name": name, "role": "viewer", "password": "long enough password"}, headers=users.h()
    )
    assert r.status_code == 422, r.text
    error = r.json()["detail"][0]
    assert error["loc"] == ["body", "name"] and "lowercase letters, digits" in error["msg"]


@pytest.mark.parametrize(
    "password, words",
    [
        ("short", "at least 12 characters"),
        ("x" * 1025, "at most 1024"),
        ("my name is Bertha!", "must not contain the user name"),
        ("BERTHA-with-more", "must not contain the user name"),
        ("tab\tin the middle", "no control characters"),
    ],
)
def test_a_password_the_rules_refuse_is_a_422_naming_the_field(users, password, words):
    r = users.client.post(
        f"{API}/users", json={"name": "bertha", "role": "viewer", "password": password}, headers=users.h()
    )
    assert r.status_code == 422, r.text
    error = r.json()["detail"][0]
    assert error["loc"] == ["body", "password"] and words in error["msg"], error
    assert users.client.get(f"{API}/users/bertha", headers=users.h()).status_code == 404


def test_a_password_that_is_not_text_is_refused_never_a_500(users):
    """JSON can carry an unpaired surrogate, which no hash function takes (UTF-8 cannot hold it)."""
    bad = "\\ud800" * 12
    json_headers = {"Content-Type": "application/json"}
    r = users.client.post(f"{API}/session", content=f'{{"name": "alice", "password": "{bad}"}}', headers=json_headers)
    assert r.status_code in (401, 422), r.text
    body = f'{{"name": "bert", "role": "viewer", "password": "{bad}"}}'
    r = users.client.post(f"{API}/users", content=body, headers={**users.h(), **json_headers})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"] == ["body", "password"], r.text


def test_a_name_is_taken_once_and_users_are_disabled_not_deleted(users):
    r = users.client.post(
        f"{API}/users", json={"name": "alice", "role": "viewer", "password": "another password"}, headers=users.h()
    )
    assert r.status_code == 409 and "already a user 'alice'" in r.json()["detail"]


# ---- sign-in, the cookie, CSRF, sign-out ----------------------------------------------------------------
def test_signing_in_gives_an_httponly_strict_cookie_and_the_csrf_token(users):
    r = sign_in(users, "oscar")
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["signed_in"] and body["name"] == "oscar" and body["role"] == "operator"
    assert body["csrf_header"] == "X-CSRF-Token" and len(body["csrf_token"]) >= 32
    cookie = r.headers["set-cookie"]
    assert cookie.startswith(f"{COOKIE}=") and "HttpOnly" in cookie and "SameSite=strict" in cookie
    assert "Path=/" in cookie and "Secure" not in cookie  # plain HTTP here
    assert "Max-Age" not in cookie and "expires" not in cookie.lower()  # gone when the browser closes
    sid = r.cookies[COOKIE]
    assert sid not in (users.data / "sessions.json").read_text()  # stored hashed
    assert stat.S_IMODE((users.data / "sessions.json").stat().st_mode) == 0o600
    me = users.client.get(f"{API}/auth/me", headers=as_cookie(sid)).json()
    assert (me["name"], me["role"], me["user"], me["via"]) == ("oscar", "operator", "oscar", "session")
    state = users.client.get(f"{API}/session", headers=as_cookie(sid)).json()
    assert state["signed_in"] and state["csrf_token"] == body["csrf_token"]
    assert users.client.get(f"{API}/users/alice", headers=users.h()).json()["last_sign_in"] is None
    assert users.client.get(f"{API}/users/oscar", headers=users.h()).json()["last_sign_in"] is not None


def test_the_cookie_is_secure_when_the_browser_came_over_https(make_agent):
    agent = make_agent(**FAST)
    add(agent, "ada", "admin")
    from fastapi.testclient import TestClient

    tls = TestClient(agent.client.app, base_url="https://testserver")
    r = tls.post(f"{API}/session", json={"name": "ada", "password": password_of("ada")})
    assert r.status_code == 200 and "Secure" in r.headers["set-cookie"]


def test_a_wrong_password_an_unknown_name_and_a_disabled_user_get_the_same_answer(users):
    users.client.patch(f"{API}/users/victor", json={"disabled": True}, headers=users.h())
    answers = {
        sign_in(users, n, p).json()["detail"]
        for n, p in (("oscar", "wrong password"), ("nobody", "x"), ("victor", None))
    }
    assert answers == {"wrong user name or password (or the user is disabled)"}


def test_a_change_made_with_the_cookie_needs_the_csrf_token_a_bearer_token_does_not(users):
    sid, csrf = session(users, "alice")
    body = {"name": "ci", "role": "viewer"}
    for headers in (as_cookie(sid), as_cookie(sid, "not-the-token"), as_cookie(sid, csrf.upper())):
        r = users.client.post(f"{API}/tokens", json=body, headers=headers)
        assert r.status_code == 403 and "X-CSRF-Token" in r.json()["detail"], r.text
    r = users.client.patch(f"{API}/users/oscar", json={"role": "viewer"}, headers=as_cookie(sid))
    assert r.status_code == 403 and "X-CSRF-Token" in r.json()["detail"]
    assert users.client.get(f"{API}/users/oscar", headers=users.h()).json()["role"] == "operator"
    r = users.client.put(f"{API}/variables/x", json={"value": 1}, headers=as_cookie(sid))
    assert r.status_code == 403 and "X-CSRF-Token" in r.json()["detail"]
    assert users.client.get(f"{API}/users", headers=as_cookie(sid)).status_code == 200  # reads need none
    assert users.client.post(f"{API}/tokens", json=body, headers=as_cookie(sid, csrf)).status_code == 201
    assert users.client.post(f"{API}/tokens", json=body, headers=users.h()).status_code == 201  # bearer: none


def test_a_session_cookie_is_refused_after_signing_out(users):
    sid, csrf = session(users, "oscar")
    assert users.client.get(f"{API}/sets", headers=as_cookie(sid)).status_code == 200
    assert users.client.delete(f"{API}/session", headers=as_cookie(sid)).status_code == 403  # no CSRF token
    r = users.client.delete(f"{API}/session", headers=as_cookie(sid, csrf))
    assert r.status_code == 204 and f'{COOKIE}=""' in r.headers["set-cookie"] and "Max-Age=0" in r.headers["set-cookie"]
    r = users.client.get(f"{API}/sets", headers=as_cookie(sid))
    assert r.status_code == 401 and "session has ended" in r.json()["detail"]
    assert users.client.get(f"{API}/session", headers=as_cookie(sid)).json()["signed_in"] is False
    assert [e["action"] for e in users.audit() if e["action"] != "refused"][-2:] == ["sign_in", "sign_out"]
    assert [(e["kind"], e["status"]) for e in users.audit() if e["action"] == "refused"] == [
        ("csrf", 403),
        ("unauthenticated", 401),
    ]


def test_every_sign_in_draws_a_new_session_id_and_ends_the_one_the_browser_had(users):
    planted = "attacker-chosen-session-id"
    r = sign_in(users, "oscar", Cookie=f"{COOKIE}={planted}")
    sid = r.cookies[COOKIE]
    assert sid != planted
    assert users.client.get(f"{API}/sets", headers=as_cookie(planted)).status_code == 401
    again = sign_in(users, "oscar", Cookie=f"{COOKIE}={sid}").cookies[COOKIE]
    assert again != sid
    assert users.client.get(f"{API}/sets", headers=as_cookie(sid)).status_code == 401  # replaced, ended
    assert users.client.get(f"{API}/sets", headers=as_cookie(again)).status_code == 200


def test_a_session_ends_after_its_idle_time_and_its_lifetime_and_background_requests_do_not_count(make_agent):
    agent = make_agent(session_idle_s=600, session_lifetime_s=3600, **FAST)
    add(agent, "ada", "admin")
    now = [1_000_000.0]
    agent.client.app.state.sessions.clock = lambda: now[0]
    sid, _ = session(agent, "ada")

    def status_after(seconds: float, **headers) -> int:
        now[0] += seconds
        return agent.client.get(f"{API}/sets", headers=as_cookie(sid, **headers)).status_code

    assert status_after(590) == 200  # a request of the user: the idle time starts again
    assert status_after(590, **{"X-Indurop-Background": "1"}) == 200  # the UI's poll: it does not
    assert status_after(20, **{"X-Indurop-Background": "1"}) == 401  # 610 s since the user's last request
    sid, _ = session(agent, "ada")
    for _ in range(6):
        assert status_after(590) == 200  # 3540 s old, used all along
    assert status_after(70) == 401  # 3610 s old: past its lifetime, however busy
    r = agent.client.get(f"{API}/sets", headers=as_cookie(sid))
    assert "no request for 10 min, or older than 1 h" in r.json()["detail"]


def test_sessions_outlive_a_restart_of_the_agent(users):
    sid, _ = session(users, "oscar")
    from fastapi.testclient import TestClient
    from indurop_agent.api.app import create_app
    from indurop_agent.config import Settings

    restarted = create_app(Settings(data_dir=users.data, irpd_socket="/nonexistent.sock", **FAST), restore=False)
    assert TestClient(restarted).get(f"{API}/auth/me", headers=as_cookie(sid)).json()["name"] == "oscar"


# ---- guessing ---------------------------------------------------------------------------------------------
def test_wrong_passwords_lock_the_name_even_for_the_right_one_and_it_is_audited(make_agent):
    agent = make_agent(signin_attempts=3, signin_window_s=300, lockout_attempts=100, **FAST)
    add(agent, "ada", "admin")
    add(agent, "bob", "viewer")
    now = [5000.0]
    agent.client.app.state.name_lockout.clock = lambda: now[0]
    codes = [sign_in(agent, "ada", f"guess {i}").status_code for i in range(4)]
    assert codes == [401, 401, 429, 429], codes
    r = sign_in(agent, "ada")
    assert r.status_code == 429 and 0 < int(r.headers["Retry-After"]) <= 300 and "locked" in r.json()["detail"]
    assert sign_in(agent, "bob").status_code == 200  # the others are not locked
    lockout = [e for e in agent.audit() if e["action"] == "lockout"][-1]
    assert lockout["target"] == "ada" and "3 wrong passwords" in lockout["detail"]
    now[0] += 301
    assert sign_in(agent, "ada").status_code == 200
    failed = [e for e in agent.audit() if e["action"] == "sign_in" and e["result"] == "error"]
    assert [e["target"] for e in failed] == ["ada", "ada", "ada"] and failed[0]["who"] is None


def test_a_flood_from_one_address_locks_the_address_out_for_names_and_tokens_alike(make_agent):
    agent = make_agent(lockout_attempts=5, signin_attempts=100, **FAST)
    add(agent, "ada", "admin")
    codes = [sign_in(agent, f"name{i}", "guess").status_code for i in range(5)]
    assert codes == [401] * 4 + [429], codes
    r = sign_in(agent, "ada")  # the right password, from that address
    assert r.status_code == 429 and "from testclient" in r.json()["detail"]
    assert agent.client.get(f"{API}/sets", headers=agent.h("viewer")).status_code == 429  # tokens too


# ---- disabled users, roles, tokens -----------------------------------------------------------------------
def test_disabling_a_user_revokes_their_tokens_and_ends_their_sessions(users):
    sid, _ = session(users, "oscar")
    token = users.client.post(
        f"{API}/tokens", json={"name": "ci", "role": "operator", "owner": "oscar"}, headers=users.h()
    )
    assert token.status_code == 201 and token.json()["owner"] == "oscar"
    bearer = {"Authorization": f"Bearer {token.json()['token']}"}
    assert users.client.get(f"{API}/auth/me", headers=bearer).json()["user"] == "oscar"
    listed = users.client.get(f"{API}/users/oscar/tokens", headers=users.h()).json()
    assert [t["name"] for t in listed] == ["ci"]
    assert [t["name"] for t in users.client.get(f"{API}/tokens?owner=oscar", headers=users.h()).json()] == ["ci"]
    r = users.client.patch(f"{API}/users/oscar", json={"disabled": True}, headers=users.h())
    assert r.status_code == 200 and r.json()["disabled"] and r.json()["tokens"] == 0 and r.json()["sessions"] == 0
    assert users.client.get(f"{API}/sets", headers=as_cookie(sid)).status_code == 401
    assert users.client.get(f"{API}/sets", headers=bearer).status_code == 401
    assert sign_in(users, "oscar").status_code == 401
    entry = [e for e in users.audit() if e["action"] == "user_change"][-1]
    assert entry["disabled"] is True and entry["sessions_ended"] == 1
    assert entry["tokens_revoked"] == [token.json()["id"]] and entry["who"]["name"] == "admin"
    assert users.client.patch(f"{API}/users/oscar", json={"disabled": False}, headers=users.h()).status_code == 200
    assert sign_in(users, "oscar").status_code == 200
    assert users.client.get(f"{API}/sets", headers=bearer).status_code == 401  # revoked for good


def test_a_role_change_applies_at_once_and_caps_the_users_tokens(users):
    sid, csrf = session(users, "oscar")
    token = users.client.post(
        f"{API}/tokens", json={"name": "ci", "role": "operator", "owner": "oscar"}, headers=users.h()
    )
    bearer = {"Authorization": f"Bearer {token.json()['token']}"}
    r = users.client.post(f"{API}/tokens", json={"name": "up", "role": "admin", "owner": "oscar"}, headers=users.h())
    assert r.status_code == 422 and r.json()["detail"][0]["loc"] == ["body", "role"]
    assert users.client.post(f"{API}/alarms/ack", headers=as_cookie(sid, csrf)).status_code == 200
    users.client.patch(f"{API}/users/oscar", json={"role": "viewer"}, headers=users.h())
    r = users.client.post(f"{API}/alarms/ack", headers=as_cookie(sid, csrf))
    assert r.status_code == 403 and "the user has viewer" in r.json()["detail"]
    r = users.client.post(f"{API}/alarms/ack", headers=bearer)
    assert r.status_code == 403 and "the token has viewer" in r.json()["detail"]


def test_the_last_enabled_admin_can_be_neither_disabled_nor_demoted(users):
    for change in ({"disabled": True}, {"role": "operator"}):
        r = users.client.patch(f"{API}/users/alice", json=change, headers=users.h())
        assert r.status_code == 409 and "last enabled admin" in r.json()["detail"]
    add(users, "bea", "admin")
    assert users.client.patch(f"{API}/users/alice", json={"disabled": True}, headers=users.h()).status_code == 200


def test_the_appliance_admin_token_can_go_once_an_admin_user_exists(make_agent):
    agent = make_agent(**FAST)
    admin_id = next(
        t["id"] for t in agent.client.get(f"{API}/tokens", headers=agent.h()).json() if t["role"] == "admin"
    )
    r = agent.client.delete(f"{API}/tokens/{admin_id}", headers=agent.h())
    assert r.status_code == 409 and "no enabled admin user" in r.json()["detail"]
    add(agent, "ada", "admin")
    sid, csrf = session(agent, "ada")
    assert agent.client.delete(f"{API}/tokens/{admin_id}", headers=as_cookie(sid, csrf)).status_code == 204
    assert agent.client.get(f"{API}/sets", headers=agent.h()).status_code == 401


def test_others_records_are_for_admins(users):
    sid, _ = session(users, "victor")
    assert users.client.get(f"{API}/users/victor", headers=as_cookie(sid)).json()["name"] == "victor"
    assert users.client.get(f"{API}/users/victor/tokens", headers=as_cookie(sid)).json() == []
    for path in ("/users/oscar", "/users/oscar/tokens", "/users"):
        assert users.client.get(f"{API}{path}", headers=as_cookie(sid)).status_code == 403, path


# ---- passwords -------------------------------------------------------------------------------------------
def test_changing_ones_own_password_needs_the_present_one_and_ends_the_other_sessions(users):
    sid, csrf = session(users, "oscar")
    other, _ = session(users, "oscar")
    url = f"{API}/users/oscar/password"
    r = users.client.put(url, json={"password": "a brand new password"}, headers=as_cookie(sid, csrf))
    assert r.status_code == 422 and r.json()["detail"][0]["loc"] == ["body", "current_password"]
    r = users.client.put(
        url, json={"password": "a brand new password", "current_password": "wrong"}, headers=as_cookie(sid, csrf)
    )
    assert r.status_code == 422 and "not the present password" in r.json()["detail"][0]["msg"]
    same = password_of("oscar")
    r = users.client.put(url, json={"password": same, "current_password": same}, headers=as_cookie(sid, csrf))
    assert r.status_code == 422 and "differ from the present one" in r.json()["detail"][0]["msg"]
    r = users.client.put(
        url, json={"password": "a brand new password", "current_password": same}, headers=as_cookie(sid, csrf)
    )
    assert r.status_code == 204, r.text
    assert users.client.get(f"{API}/sets", headers=as_cookie(sid)).status_code == 200  # this one goes on
    assert users.client.get(f"{API}/sets", headers=as_cookie(other)).status_code == 401
    assert sign_in(users, "oscar").status_code == 401
    assert sign_in(users, "oscar", "a brand new password").status_code == 200
    entry = [e for e in users.audit() if e["action"] == "user_password"][-1]
    assert entry["how"] == "changed" and entry["who"]["name"] == "oscar" and entry["result"] == "ok"
    assert "a brand new password" not in (users.data / "audit.jsonl").read_text()


def test_an_admin_resets_a_password_the_user_cannot_reset_anothers(users):
    victor, vcsrf = session(users, "victor")
    r = users.client.put(
        f"{API}/users/oscar/password", json={"password": "a password by victor"}, headers=as_cookie(victor, vcsrf)
    )
    assert r.status_code == 403
    alice, acsrf = session(users, "alice")
    r = users.client.put(
        f"{API}/users/victor/password", json={"password": "reset by the admin"}, headers=as_cookie(alice, acsrf)
    )
    assert r.status_code == 204, r.text
    assert users.client.get(f"{API}/sets", headers=as_cookie(victor)).status_code == 401
    assert sign_in(users, "victor", "reset by the admin").status_code == 200
    entry = [e for e in users.audit() if e["action"] == "user_password"][-1]
    assert (entry["how"], entry["target"], entry["who"]["name"], entry["who"]["via"]) == (
        "reset",
        "victor",
        "alice",
        "session",
    )


def test_a_hash_made_with_other_parameters_is_renewed_at_the_next_sign_in(make_agent):
    agent = make_agent(**FAST)
    store = agent.client.app.state.users
    old = store.hasher
    store.hasher = PasswordHasher(time_cost=1, memory_cost=512, parallelism=1)
    add(agent, "ada", "admin")
    before = json.loads((agent.data / "users.json").read_text())["users"]["ada"]["hash"]
    assert "m=512," in before
    store.hasher = old
    assert sign_in(agent, "ada").status_code == 200
    after = json.loads((agent.data / "users.json").read_text())["users"]["ada"]["hash"]
    assert "m=1024," in after and after != before
    assert sign_in(agent, "ada").status_code == 200


# ---- WebSockets --------------------------------------------------------------------------------------------
def test_the_websockets_take_the_cookie_only_from_the_agents_own_origin(users):
    sid, csrf = session(users, "victor")
    own = {"cookie": f"{COOKIE}={sid}", "origin": "http://testserver"}
    with users.client.websocket_connect(f"{API}/alarms/live", headers=own) as ws:
        assert "snapshot" in ws.receive_json()
    for origin in ("http://evil.example", "null", None):
        headers = {"cookie": own["cookie"], **({"origin": origin} if origin else {})}
        with users.client.websocket_connect(f"{API}/alarms/live", headers=headers) as ws:
            with pytest.raises(WebSocketDisconnect) as closed:
                ws.receive_json()
        assert closed.value.code == 4403 and "Origin" in closed.value.reason, origin
    # signed out: an open WebSocket is closed, a new one refused
    with users.client.websocket_connect(f"{API}/alarms/live", headers=own) as ws:
        ws.receive_json()
        users.client.delete(f"{API}/session", headers=as_cookie(sid, csrf))
        with pytest.raises(WebSocketDisconnect) as closed:
            ws.receive_json()
        assert closed.value.code == 4401 and "session has ended" in closed.value.reason
    with users.client.websocket_connect(f"{API}/alarms/live", headers=own) as ws:
        with pytest.raises(WebSocketDisconnect) as closed:
            ws.receive_json()
    assert closed.value.code == 4401


# ---- the role × route matrix for sessions ---------------------------------------------------------------
def test_the_role_matrix_over_every_route_for_sessions_a_disabled_user_and_an_expired_session(users):
    """Every route that needs a role, signed in by a session cookie (with its CSRF token): below the
    role 403, at or above it anything but 401/403; a disabled user's and an expired session 401."""
    sessions = {name: session(users, name) for name in ("victor", "oscar", "alice")}
    role_of = {"victor": "viewer", "oscar": "operator", "alice": "admin"}
    add(users, "dora", "operator")
    disabled = session(users, "dora")
    users.client.patch(f"{API}/users/dora", json={"disabled": True}, headers=users.h())
    add(users, "eve", "operator")
    store = users.client.app.state.sessions
    clock = store.clock
    store.clock = lambda: clock() - store.idle_s - 1  # eve signed in longer ago than the idle time
    expired = session(users, "eve")
    store.clock = clock
    for route, needed in sorted((k, v) for k, v in NEEDS.items() if v):
        method, template = route
        for name, (sid, csrf) in [*sessions.items(), ("dora", disabled), ("eve", expired)]:
            path = template
            for key, value in SAMPLE.items():
                path = path.replace(key, name if key == "{name}" and template.startswith("/users") else value)
            r = users.client.request(method, f"{API}{path}", headers=as_cookie(sid, csrf))
            if name in ("dora", "eve"):
                assert r.status_code == 401, (route, name, r.status_code, r.text)
            elif ROLES.index(role_of[name]) < ROLES.index(needed):
                assert r.status_code == 403 and f"needs the {needed} role" in r.text, (route, name, r.text)
            else:
                assert r.status_code not in (401, 403), (route, name, r.status_code, r.text)


# ---- the session store's bounds ------------------------------------------------------------------------
def test_a_user_cannot_pile_sessions_up_the_least_recent_give_way(tmp_path):
    from indurop_agent.access.sessions import SessionStore

    now = [100.0]
    store = SessionStore(tmp_path / "sessions.json", idle_s=600, lifetime_s=3600, max_per_user=3, clock=lambda: now[0])
    ids = []
    for _ in range(4):
        now[0] += 1
        ids.append(store.create("ada", "10.0.0.1")[0])
    assert store.find(ids[0]) is None and all(store.find(i) for i in ids[1:])
    assert store.count("ada") == 3
    stored = json.loads((tmp_path / "sessions.json").read_text())["sessions"]
    assert len(stored) == 3 and not any(i in json.dumps(stored) for i in ids)

"""test_error_bodies.py -- a refused request's answer never carries what was sent: 422s name where
the problem is and what is wrong (loc, msg), never the value (a password sent with a missing role,
too long, or in a body that is not JSON must not come back in the answer)."""

from __future__ import annotations

import json

import pytest
from agent_helpers import API
from test_users import as_cookie, session, users  # noqa: F401 (users: a fixture)

SECRET = "Echo-Check-Secret-0042"


def assert_not_echoed(r, loc: list) -> None:
    """A 422 that names `loc` with a message, and holds the secret nowhere (body or headers)."""
    assert r.status_code == 422, r.text
    assert SECRET not in r.text and SECRET not in str(r.headers)
    problems = r.json()["detail"]
    assert any(p["loc"] == loc and p["msg"] for p in problems), problems
    assert all(set(p) <= {"loc", "msg", "type"} for p in problems), problems


def test_a_user_without_a_role_is_refused_without_echoing_the_password(users):  # noqa: F811
    r = users.client.post(f"{API}/users", json={"name": "bob", "password": SECRET}, headers=users.h())
    assert_not_echoed(r, ["body", "role"])


def test_a_password_over_1024_characters_is_refused_without_echoing_it(users):  # noqa: F811
    long = SECRET * 50
    r = users.client.post(f"{API}/users", json={"name": "bob", "role": "viewer", "password": long}, headers=users.h())
    assert_not_echoed(r, ["body", "password"])
    r = users.client.post(f"{API}/session", json={"name": "alice", "password": long})
    assert_not_echoed(r, ["body", "password"])


@pytest.mark.parametrize("how", ["text/plain", "form"])
def test_a_sign_in_that_is_not_json_is_refused_without_echoing_the_password(users, how):  # noqa: F811
    fields = {"name": "alice", "password": SECRET}
    if how == "form":
        r = users.client.post(f"{API}/session", data=fields)
    else:
        r = users.client.post(f"{API}/session", content=json.dumps(fields), headers={"Content-Type": how})
    assert_not_echoed(r, ["body"])


def test_an_unknown_field_beside_a_password_is_named_not_echoed(users):  # noqa: F811
    sid, csrf = session(users, "oscar")
    body = {"password": "a brand new password", "current_password": "x", "also": SECRET}
    r = users.client.put(f"{API}/users/oscar/password", json=body, headers=as_cookie(sid, csrf))
    assert_not_echoed(r, ["body", "also"])

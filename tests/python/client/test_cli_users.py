"""test_cli_users.py -- `irpctl user ...` against a real agent: the first admin added with the admin
token (the password on standard input, or asked twice on a terminal), list and show, role, disable
(the user's tokens stop working) and enable, a reset and one's own password change with a token of
one's own, the tokens a user owns; and `irpctl audit` printing a hostile user name harmless."""

from __future__ import annotations

import io
import json

import httpx
import pytest
from indurop_agent.cli import users as cli_users

API = "/api/v1"


@pytest.fixture
def stdin(monkeypatch):
    """stdin(text): what irpctl reads as its standard input (not a terminal)."""

    def give(text: str) -> None:
        monkeypatch.setattr("sys.stdin", io.StringIO(text))

    return give


def sign_in(cell, name: str, password: str) -> int:
    return httpx.post(f"{cell.url}{API}/session", json={"name": name, "password": password}).status_code


def test_the_first_admin_and_the_users_from_the_command_line(irpctl, fresh_cell, stdin):
    c = fresh_cell
    code, out, _ = irpctl(*c.args("user", "list"))
    assert code == 0 and "no users yet" in out
    stdin("first admin password\n")
    code, out, err = irpctl(*c.args("user", "add", "ada", "--role", "admin", "--password-stdin"))
    assert code == 0, err
    assert "user ada added (admin)" in out
    assert sign_in(c, "ada", "first admin password") == 200
    stdin("short\n")
    code, _, err = irpctl(*c.args("user", "add", "bob", "--role", "operator", "--password-stdin"))
    assert code == 1 and "body.password: a password has at least 12 characters" in err
    stdin("correct horse 11\n")
    assert irpctl(*c.args("user", "add", "bob", "--role", "operator", "--password-stdin"))[0] == 0

    code, out, _ = irpctl(*c.args("user", "list"))
    lines = out.splitlines()
    assert lines[0].split() == ["NAME", "ROLE", "STATE", "LAST", "SIGN-IN", "TOKENS", "SESSIONS"]
    assert lines[1].split()[:3] == ["ada", "admin", "enabled"] and lines[2].split()[:4] == [
        "bob",
        "operator",
        "enabled",
        "never",
    ]
    code, out, _ = irpctl(*c.args("--json", "user", "show", "bob"))
    assert json.loads(out)["role"] == "operator" and "hash" not in json.loads(out)

    assert irpctl(*c.args("user", "role", "bob", "viewer"))[0] == 0
    token = httpx.post(
        f"{c.url}{API}/tokens",
        json={"name": "bobs-script", "role": "viewer", "owner": "bob"},
        headers={"Authorization": f"Bearer {c.token}"},
    ).json()["token"]
    code, out, _ = irpctl(*c.args("user", "tokens", "bob"))
    assert code == 0 and "bobs-script" in out
    # bob changes his own password with his own token: the present one first
    stdin("correct horse 11\nstaple battery 22\n")
    code, out, err = irpctl("--url", c.url, "--token", token, "user", "passwd", "bob", "--password-stdin")
    assert code == 0, err
    assert "changed" in out and sign_in(c, "bob", "staple battery 22") == 200
    stdin("reset by the admin 1\n")
    code, out, _ = irpctl(*c.args("user", "passwd", "bob", "--password-stdin"))
    assert code == 0 and "reset" in out and sign_in(c, "bob", "reset by the admin 1") == 200

    code, out, _ = irpctl(*c.args("user", "disable", "bob"))
    assert code == 0 and "bob: viewer, disabled" in out
    assert sign_in(c, "bob", "reset by the admin 1") == 401
    code, _, err = irpctl("--url", c.url, "--token", token, "status")
    assert code == 1 and "unknown token" in err  # revoked with the user
    assert irpctl(*c.args("user", "enable", "bob"))[0] == 0
    assert sign_in(c, "bob", "reset by the admin 1") == 200
    code, _, err = irpctl(*c.args("user", "disable", "ada"))
    assert code == 1 and "last enabled admin" in err


def test_the_password_is_asked_twice_on_a_terminal_and_must_match(irpctl, fresh_cell, monkeypatch):
    answers = iter(["a terminal password", "a terminal password", "one password", "another one"])
    monkeypatch.setattr(cli_users, "_ask", lambda prompt: next(answers))
    code, out, err = irpctl(*fresh_cell.args("user", "add", "tess", "--role", "viewer"))
    assert code == 0, err
    assert sign_in(fresh_cell, "tess", "a terminal password") == 200
    code, _, err = irpctl(*fresh_cell.args("user", "add", "tom", "--role", "viewer"))
    assert code == 2 and "the two passwords differ" in err


def test_without_a_terminal_or_password_stdin_irpctl_says_what_to_give(irpctl, fresh_cell, stdin):
    stdin("")
    code, _, err = irpctl(*fresh_cell.args("user", "add", "tess", "--role", "viewer"))
    assert code == 2 and "--password-stdin" in err


def test_irpctl_audit_shows_a_hostile_user_name_without_its_control_characters(irpctl, fresh_cell):
    name = "\x1b[31mred\x1b[0m\nforged line %s%n"
    assert httpx.post(f"{fresh_cell.url}{API}/session", json={"name": name, "password": "x"}).status_code == 401
    code, out, _ = irpctl(*fresh_cell.args("audit", "--limit", "1"))
    assert code == 0 and "\x1b" not in out and "forged line" in out
    assert len(out.strip().splitlines()) == 2  # the header and one line
    assert "\\x1b[31mred" in out

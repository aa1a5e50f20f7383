"""users.py -- `irpctl user ...`: list, add, disable, enable, passwd, role and tokens of the people
who sign in (docs/irpctl.md, docs/administration.md).  irpctl itself signs in with a bearer token;
the first admin is added with the admin token the agent wrote at its first start:

    irpctl --token-file /var/lib/indurop/admin-token user add alice --role admin

Passwords are asked twice on the terminal, never taken from the command line (it shows in `ps` and
in the shell's history); --password-stdin reads them from standard input instead, one per line.
"""

from __future__ import annotations

import getpass
import sys

from .client import Client
from .text import Out, pairs, printable, table

ROLES = ("viewer", "operator", "admin")


def users_text(users: list[dict]) -> str:
    if not users:
        return "no users yet: irpctl user add NAME --role admin (with the admin token)"
    rows = [
        [
            u["name"],
            u["role"],
            "disabled" if u["disabled"] else "enabled",
            u.get("last_sign_in") or "never",
            u["tokens"],
            u["sessions"],
        ]
        for u in users
    ]
    return table(["NAME", "ROLE", "STATE", "LAST SIGN-IN", "TOKENS", "SESSIONS"], rows, "llllrr")


def user_text(u: dict) -> str:
    return pairs(
        [
            ("name", u["name"]),
            ("role", u["role"]),
            ("state", "disabled" if u["disabled"] else "enabled"),
            ("created", f"{u['created']} by {printable(u.get('created_by') or '-')}"),
            ("last sign-in", u.get("last_sign_in") or "never"),
            ("password changed", u["password_changed"]),
            ("tokens", u["tokens"]),
            ("sessions", u["sessions"]),
        ]
    )


def tokens_text(tokens: list[dict]) -> str:
    if not tokens:
        return "no tokens"
    return table(["ID", "NAME", "ROLE", "CREATED"], [[t["id"], t["name"], t["role"], t["created"]] for t in tokens])


def _lines(count: int) -> list[str]:
    """`count` lines of standard input (--password-stdin), without their line ends."""
    lines = sys.stdin.read().splitlines()
    if len(lines) < count:
        raise ValueError(f"--password-stdin: expected {count} line(s) on standard input, got {len(lines)}")
    return lines[:count]


def _ask(prompt: str) -> str:
    if not sys.stdin.isatty():
        raise ValueError("no terminal to ask the password on: give --password-stdin and the password on stdin")
    return getpass.getpass(prompt)


def _new_password(name: str) -> str:
    first = _ask(f"new password for {name}: ")
    if _ask("the same again: ") != first:
        raise ValueError("the two passwords differ; nothing was changed")
    return first


def cmd_list(c: Client, a, out: Out) -> int:
    out.show(c.users(), users_text)
    return 0


def cmd_show(c: Client, a, out: Out) -> int:
    out.show(c.user(a.name), user_text)
    return 0


def cmd_add(c: Client, a, out: Out) -> int:
    password = _lines(1)[0] if a.password_stdin else _new_password(a.name)
    user = c.add_user(a.name, a.role, password)
    out.show(user, lambda u: f"user {u['name']} added ({u['role']}); they sign in at the web UI with this password")
    return 0


def cmd_passwd(c: Client, a, out: Out) -> int:
    """One's own password needs the present one too (asked first; on stdin: first line)."""
    own = c.get("/auth/me").get("user") == a.name
    if a.password_stdin:
        lines = _lines(2 if own else 1)
        current, password = (lines[0], lines[1]) if own else (None, lines[0])
    else:
        current = _ask(f"present password of {a.name}: ") if own else None
        password = _new_password(a.name)
    c.set_password(a.name, password, current)
    out.show(
        {"name": a.name, "changed": True},
        lambda _: (
            f"password of {a.name} {'changed' if own else 'reset'}; "
            + ("your other sessions were signed out" if own else "their sessions were signed out")
        ),
    )
    return 0


def _change(what):
    """A command that changes a user: what(args) -> the change (role, disabled)."""

    def run(c: Client, a, out: Out) -> int:
        user = c.change_user(a.name, **what(a))
        out.show(user, lambda u: f"{u['name']}: {u['role']}, {'disabled' if u['disabled'] else 'enabled'}")
        return 0

    return run


def cmd_tokens(c: Client, a, out: Out) -> int:
    out.show(c.user_tokens(a.name), tokens_text)
    return 0


NAME = (("name",), {"metavar": "NAME"})
PASSWORD_STDIN = (
    ("--password-stdin",),
    {
        "action": "store_true",
        "help": "read the password from standard input (one's own: the present one, then the new one, a line each)",
    },
)

# (name, help, run, arguments as (flags, add_argument keywords)): irpctl.py makes them `irpctl user NAME`.
USER_COMMANDS = (
    ("list", "every user: role, state, last sign-in, tokens, sessions (admin)", cmd_list, ()),
    ("show", "one user (admin, or oneself)", cmd_show, (NAME,)),
    (
        "add",
        "add a user with a role; asks the password twice (admin; the first admin with the admin token)",
        cmd_add,
        (NAME, (("--role",), {"choices": ROLES, "required": True}), PASSWORD_STDIN),
    ),
    (
        "disable",
        "disable a user: their tokens are revoked, their sessions end (admin)",
        _change(lambda a: {"disabled": True}),
        (NAME,),
    ),
    ("enable", "enable a disabled user again (admin)", _change(lambda a: {"disabled": False}), (NAME,)),
    (
        "passwd",
        "change one's own password (asks the present one), or reset another user's (admin)",
        cmd_passwd,
        (NAME, PASSWORD_STDIN),
    ),
    (
        "role",
        "change a user's role (admin)",
        _change(lambda a: {"role": a.role}),
        (NAME, (("role",), {"choices": ROLES})),
    ),
    ("tokens", "the tokens a user owns (admin, or oneself)", cmd_tokens, (NAME,)),
)

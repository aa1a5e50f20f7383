"""link.py -- the OPC UA server's credential at the agent (docs/opcua.md "Alarms"): a random token in
<data>/opcua-token (mode 0600, the service user's: the agent and the server run as the same user),
made by the agent at its start and read by the server when it calls the agent.  With it the server
acknowledges and confirms alarms on behalf of its session's user, through the agent's
/opcua/alarms routes only (api/routes/opcua_alarms.py), which check that user's role and audit."""

from __future__ import annotations

import os
import secrets
from pathlib import Path

TOKEN_FILE = "opcua-token"


def ensure_token(data_dir: Path) -> str:
    """The token, made (0600) when the file is missing or empty."""
    path = data_dir / TOKEN_FILE
    token = read_token(data_dir)
    if token:
        return token
    token = secrets.token_urlsafe(32)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w") as f:
        f.write(token + "\n")
    os.chmod(path, 0o600)
    return token


def read_token(data_dir: Path) -> str | None:
    try:
        return (data_dir / TOKEN_FILE).read_text().strip() or None
    except OSError:
        return None

"""client_errors.py -- the Python client's one error, ApiError, and how a refusal's `detail` becomes
its message; client.py and its parts (client_system.py, client_record.py) raise it."""

from __future__ import annotations

import json

import httpx


class ApiError(Exception):
    """The API refused a request (status = the HTTP status, message = the server's `detail`), or
    could not be reached at all (status 0)."""

    def __init__(self, status: int, message: str, problems: list[dict] | None = None):
        super().__init__(f"{status}: {message}" if status else message)
        self.status = status
        self.message = message
        self.problems = problems or []  # a refused upload's errors, each {message, code, file, line, column}

    @property
    def unreachable(self) -> bool:
        """No answer from the agent, or the agent cannot reach irpd (503)."""
        return self.status in (0, 503)


def refused(response: httpx.Response) -> ApiError:
    """The ApiError of a refusal: its `detail`, and its `problems` when it has several (ST compile errors)."""
    body = _body(response)
    found = body.get("problems") if isinstance(body, dict) else None
    problems = [p for p in found if isinstance(p, dict)] if isinstance(found, list) else None
    return ApiError(response.status_code, detail(response), problems)


def problem_line(p: dict) -> str:
    """`main.st:12:9: error[type]: message` (stc's form, docs/st.md "Errors"): the known parts of the place."""
    where = ":".join(str(p[k]) for k in ("file", "line", "column") if p.get(k))
    code = f"error[{p['code']}]" if p.get("code") else "error"
    return f"{where + ': ' if where else ''}{code}: {p.get('message', '')}"


def detail(response: httpx.Response) -> str:
    """The server's `detail` of a refusal, as text."""
    body = _body(response)
    said = body.get("detail") if isinstance(body, dict) else None
    if isinstance(said, list):  # FastAPI's 422: one entry per field
        return "; ".join(f"{'.'.join(str(p) for p in e.get('loc', []))}: {e.get('msg', e)}" for e in said)
    if said is None:
        return response.text.strip() or response.reason_phrase
    return said if isinstance(said, str) else json.dumps(said)


def _body(response: httpx.Response):
    """The answer's JSON, or None when it is not JSON."""
    try:
        return response.json()
    except ValueError:
        return None

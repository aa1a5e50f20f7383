"""scope.py -- `irpctl scope list|get|save|rm`: the trace configurations kept with a stored set
(docs/irpctl.md, docs/recorder.md "Trace configurations"), by default the active set's.  irpctl.py adds
SCOPE_COMMANDS as the subcommands of `scope`; each entry is (name, help, run, arguments).

    irpctl scope list [--set ID]
    irpctl scope get NAME [-o FILE]          # the configuration, as `scope save` takes it
    irpctl scope save NAME FILE              # a configuration, or a bare capture request (what `capture arm` sends)
    irpctl scope rm NAME
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from urllib.parse import quote

from ..recorder.trigger_text import describe_trigger
from .base import EXIT_OK, arg
from .client import ApiError
from .text import Out, printable, table


def _set_id(c, a) -> str:
    """--set, else the set active through the agent."""
    if a.set:
        return a.set
    try:
        return c.get("/sets/active")["id"]
    except ApiError as e:
        if e.status == 404:
            raise ApiError(404, "no set has been activated through the agent: give --set ID (irpctl sets)") from None
        raise


def _path(set_id: str, name: str | None = None) -> str:
    return f"/sets/{quote(set_id, safe='')}/scopes" + (f"/{quote(name, safe='')}" if name is not None else "")


def scopes_text(answer: dict) -> str:
    rows = []
    for s in answer["scopes"]:
        config = s.get("config")
        capture = config["capture"] if config else None
        rows.append(
            [
                printable(s["name"]),
                printable(describe_trigger(capture["trigger"]))
                if capture
                else f"(damaged: {printable(s.get('error'))})",
                printable(", ".join(capture["variables"])) if capture else "-",
                printable((s.get("by") or {}).get("name", "-")),
                s.get("saved") or "-",
            ]
        )
    head = f"set {answer['set_id']}: {len(rows)} of at most {answer['max_configs']} trace configurations"
    if not rows:
        return head
    return head + "\n" + table(["NAME", "TRIGGER", "VARIABLES", "BY", "SAVED"], rows)


def cmd_list(c, a, out: Out) -> int:
    out.show(c.get(_path(_set_id(c, a))), scopes_text)
    return EXIT_OK


def cmd_get(c, a, out: Out) -> int:
    saved = c.get(_path(_set_id(c, a), a.name))
    if a.output:
        text = json.dumps(saved["config"], indent=2, ensure_ascii=False) + "\n"
        if a.output == "-":
            sys.stdout.write(text)
        else:
            Path(a.output).write_text(text)
            if not out.as_json:
                out.line(f"wrote {a.output}")
        return EXIT_OK
    out.show(saved, lambda s: json.dumps(s["config"], indent=2, ensure_ascii=False))
    return EXIT_OK


def cmd_save(c, a, out: Out) -> int:
    source = sys.stdin if a.file == "-" else None
    try:
        body = json.loads(source.read() if source else Path(a.file).read_text())
    except ValueError as e:
        raise ValueError(f"{a.file} is not JSON: {e}") from None
    if isinstance(body, dict) and "capture" not in body and "trigger" in body:
        body = {"capture": body}  # a bare capture request
    set_id = _set_id(c, a)
    saved = c.request("PUT", _path(set_id, a.name), json=body)
    out.show(saved, lambda s: f"saved {s['name']} with set {s['set_id']}")
    return EXIT_OK


def cmd_rm(c, a, out: Out) -> int:
    set_id = _set_id(c, a)
    c.request("DELETE", _path(set_id, a.name))
    if not out.as_json:
        out.line(f"deleted {a.name} of set {set_id}")
    return EXIT_OK


SET = arg("--set", metavar="ID", help="the stored set (default: the active one)")
NAME = arg("name", metavar="NAME")
SCOPE_COMMANDS = (
    ("list", "the trace configurations kept with a set", cmd_list, (SET,)),
    (
        "get",
        "one configuration, as `scope save` takes it",
        cmd_get,
        (NAME, SET, arg("-o", "--output", metavar="FILE", help="write it to FILE (- : standard output)")),
    ),
    (
        "save",
        "save a configuration with a set under NAME, replacing one of that name (operator)",
        cmd_save,
        (
            NAME,
            arg(
                "file", metavar="FILE", help="JSON: a configuration ({capture, plotted, mode, xy}) or a capture request"
            ),
            SET,
        ),
    ),
    ("rm", "delete a configuration (operator)", cmd_rm, (NAME, SET)),
)

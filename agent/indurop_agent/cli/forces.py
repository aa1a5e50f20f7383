"""forces.py -- `irpctl force PATH VALUE`, `irpctl unforce PATH [--restore]`, `irpctl forces`: the
variables irpd holds forced (GET/PUT/DELETE /api/v1/forces; docs/forcing.md, docs/irpctl.md).
irpctl.py puts these commands in its table."""

from __future__ import annotations

import time
from urllib.parse import quote

from .base import EXIT_OK
from .text import format_value, printable, table


def _since(ns: int) -> str:
    return time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(ns / 1e9))


def force_line(f: dict) -> str:
    return f"{f['path']} forced to {format_value(f['value'])} by {printable(f['by'])} (was {format_value(f['before'])})"


def forces_text(answer: dict) -> str:
    forces = answer["forces"]
    if not forces:
        return "no variable is forced"
    rows = [
        [f["path"], format_value(f["value"]), format_value(f["before"]), printable(f["by"]), _since(f["since_ns"])]
        for f in forces
    ]
    head = f"{len(forces)} force{'s' if len(forces) != 1 else ''} active (at most {answer['max_forces']})"
    return head + "\n" + table(["PATH", "VALUE", "BEFORE", "BY", "SINCE"], rows, "lrrll")


def cmd_force(c, a, out) -> int:
    answer = c.request("PUT", f"/forces/{quote(a.path, safe='')}", json={"value": a.value})
    out.show(answer, force_line)
    return EXIT_OK


def cmd_unforce(c, a, out) -> int:
    answer = c.request("DELETE", f"/forces/{quote(a.path, safe='')}", params={"restore": str(a.restore).lower()})
    out.show(
        answer,
        lambda x: (
            f"{a.path} no longer forced, {'restored to' if x['restored'] else 'left at'} {format_value(x['left'])}"
        ),
    )
    return EXIT_OK


def cmd_forces(c, a, out) -> int:
    out.show(c.get("/forces"), forces_text)
    return EXIT_OK

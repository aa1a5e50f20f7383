"""line.py -- `irpctl line`: the controllers this controller's DDS bridge sees on its domain
(GET /line; docs/irpctl.md, docs/dds.md "The line").  irpctl.py adds LINE_COMMANDS to its command
table; each entry is (name, help, run, arguments) as its Command."""

from __future__ import annotations

import time

from .base import EXIT_OK
from .text import _uptime, format_duration, printable, table

HEADERS = ["NAME", "STATE", "HEALTH", "SET", "JITTER P99", "ALARMS", "UP", "LAST SEEN", "WEB UI"]


def _seen(c: dict, now: float) -> str:
    if c["alive"]:
        return f"{c['age_s']:.0f} s ago"
    lost = time.strftime("%H:%M:%S", time.localtime(c["last_seen"]))
    return f"lost, last {lost}"


def line_text(view: dict, now: float | None = None) -> str:
    """The line as a table (this controller marked *), the reasons of those not ok below it; or why
    there is no line to show."""
    now = time.time() if now is None else now
    if view["bridge"] != "ok":
        return f"no line: {printable(view['message'])}"
    rows = []
    for c in view["controllers"]:
        alarms = str(c["alarms_active"])
        if c["alarms"]:
            alarms += f" ({c['alarms'][0]['severity']})"
        rows.append(
            [
                printable(c["name"]) + (" *" if c["this"] else ""),
                c["state"],
                c["health"],
                printable(c["set_name"] or "-"),
                "-" if c["jitter_p99_ns"] is None else format_duration(c["jitter_p99_ns"]),
                alarms,
                _uptime(c["uptime_ns"]) if c["uptime_ns"] else "-",
                _seen(c, now),
                printable(c["agent_url"] or "-"),
            ]
        )
    head = f"domain {view['domain_id']} on {printable(view['interface'])}, as {printable(view['this'])} (*) sees it"
    out = [head, table(HEADERS, rows, "llllrrrll")]
    notes = [
        f"{printable(c['name'])}: {printable('; '.join(c['reasons']))}" for c in view["controllers"] if c["reasons"]
    ]
    return "\n".join(out + ([""] + notes if notes else []))


def cmd_line(c, a, out) -> int:
    out.show(c.get("/line"), line_text)
    return EXIT_OK


LINE_COMMANDS = (
    (
        "line",
        "the controllers on this controller's DDS domain: state, health, jitter, alarms, web UI",
        cmd_line,
        (),
    ),
)

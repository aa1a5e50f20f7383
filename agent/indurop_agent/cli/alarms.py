"""alarms.py -- `irpctl events`, `alarms`, `ack` and `shelve`: irpd's and the agent's event log,
the alarms that need attention and their history, followed as they come; acknowledging and shelving
(GET /events, GET /alarms[/history], POST /alarms/{key}/ack|shelve; docs/irpctl.md, docs/alarms.md).
irpctl.py puts these commands in its table."""

from __future__ import annotations

import json
import sys
import time
from typing import Any

from .base import EXIT_OK, EXIT_USAGE
from .client import Client
from .text import EVENT_HEADERS, TRANSITION_HEADERS, Out, alarms_text, events_rows, history_text, table, transition_row


def cmd_events(c: Client, a, out: Out) -> int:
    answer = c.events(since=a.since, limit=a.limit)
    events, cursors = _events_of(answer, (a.since, None))
    if not a.follow:
        lost = answer.get("dropped", 0) if isinstance(answer, dict) else 0
        note = f"\n({lost} older events were overwritten before they were read)" if lost else ""
        out.show(answer, lambda _: (table(EVENT_HEADERS, events_rows(events), "r") if events else "no events") + note)
        return EXIT_OK
    if out.as_json:
        for e in events:
            out.line(json.dumps(e, ensure_ascii=False))
    else:
        out.line(table(EVENT_HEADERS, events_rows(events), "r") if events else "  ".join(EVENT_HEADERS))
    try:
        while True:
            time.sleep(a.interval)
            events, cursors = _events_of(c.events(since=cursors[0], agent_since=cursors[1], limit=a.limit), cursors)
            for e in events:
                if out.as_json:
                    out.line(json.dumps(e, ensure_ascii=False))
                else:
                    out.line("  ".join(str(x) for x in events_rows([e])[0]))
    except KeyboardInterrupt:
        return EXIT_OK


def _events_of(answer: Any, cursors: tuple[int, int | None]) -> tuple[list[dict], tuple[int, int | None]]:
    """(events, the cursors to ask next: irpd's `next`, the agent's `agent_next`) from GET /events."""
    if not isinstance(answer, dict):  # a bare list: the cursor is past the last seq seen
        events = answer or []
        return events, (max([cursors[0] - 1] + [e.get("seq", 0) for e in events]) + 1, None)
    return answer.get("events") or [], (answer.get("next", cursors[0]), answer.get("agent_next", cursors[1]))


ALARM_FILTERS = ("since", "until", "module", "key", "severity", "state")


def cmd_alarms(c: Client, a, out: Out) -> int:
    """The alarms that need attention (or, with --history, their transitions); --follow goes on
    printing transitions as they come (polling the history with its seq cursor)."""
    filters = {k: getattr(a, k) for k in ALARM_FILTERS if getattr(a, k) is not None}
    if a.history:
        page = c.alarm_history(**filters, limit=a.limit, offset=a.offset)
        out.show(page, history_text)
        last = max([t["seq"] for t in page["transitions"]], default=0)
    else:
        only_history = [f"--{k}" for k in ("since", "until", "state") if k in filters]
        if only_history:
            print(f"irpctl alarms: {', '.join(only_history)} go with --history", file=sys.stderr)
            return EXIT_USAGE
        listed = c.alarms()
        listed["alarms"] = [
            x
            for x in listed["alarms"]
            if all(x.get(k) == filters[k] for k in ("module", "key", "severity") if k in filters)
        ]
        out.show(listed, alarms_text)
        last = None
    if not a.follow:
        return EXIT_OK
    if last is None:
        last = max([t["seq"] for t in c.alarm_history(limit=1)["transitions"]], default=0)
    if not out.as_json:
        out.line()
        out.line("  ".join(TRANSITION_HEADERS))
    try:
        while True:
            time.sleep(a.interval)
            page = c.alarm_history(**filters, after=last, limit=1000)
            for t in reversed(page["transitions"]):
                out.line(
                    json.dumps(t, ensure_ascii=False) if out.as_json else "  ".join(str(x) for x in transition_row(t))
                )
                last = max(last, t["seq"])
    except KeyboardInterrupt:
        return EXIT_OK


def cmd_ack(c: Client, a, out: Out) -> int:
    if (a.key is None) == (not a.all):
        print("irpctl ack: give an alarm KEY (irpctl alarms lists them) or --all, not both", file=sys.stderr)
        return EXIT_USAGE
    if a.module and not a.all:
        print("irpctl ack: --module goes with --all (a KEY names its module already)", file=sys.stderr)
        return EXIT_USAGE
    if a.all:
        answer = c.acknowledge_all(a.module)
        out.show(answer, lambda x: f"acknowledged {len(x['acknowledged'])}: {', '.join(x['acknowledged']) or '-'}")
    else:
        out.show(c.acknowledge(a.key), lambda x: f"{x['key']}: {x['state']}")
    return EXIT_OK


def cmd_shelve(c: Client, a, out: Out) -> int:
    if not a.reason.strip():
        print("irpctl shelve: --reason must say why (it goes into the history)", file=sys.stderr)
        return EXIT_USAGE
    shelved = c.shelve(a.key, a.minutes, a.reason)
    out.show(shelved, lambda x: f"{x['key']}: shelved until {x['shelved_until']} ({x['shelve_reason']})")
    return EXIT_OK

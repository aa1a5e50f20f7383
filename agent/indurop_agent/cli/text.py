"""text.py -- how irpctl prints: durations ("100 µs"), values, aligned tables, and one renderer
per API answer (status, modules, schedule, jitter, swap reports, uploads, sets, events, audit).
Parsing of durations and values typed on the command line is here too."""

from __future__ import annotations

import json
import re
import sys
from collections.abc import Callable, Iterable
from decimal import Decimal, InvalidOperation
from typing import Any

# -- durations -------------------------------------------------------------------------------------
_UNITS = {"ns": 1, "us": 1_000, "µs": 1_000, "μs": 1_000, "ms": 1_000_000, "s": 1_000_000_000}
_DURATION = re.compile(r"\s*(\d+(?:\.\d*)?|\.\d+)\s*(ns|us|µs|μs|ms|s)?\s*")


def parse_duration(text: str) -> int:
    """ "1ms", "100us", "2.5ms", "500000ns", "500000" (plain ns) -> whole nanoseconds (> 0)."""
    m = _DURATION.fullmatch(text)
    if not m:
        raise ValueError(f"'{text}' is not a duration: give e.g. 1ms, 100us, 2.5ms, 500000ns or plain ns")
    try:
        ns = Decimal(m[1]) * _UNITS[m[2] or "ns"]
    except InvalidOperation:
        raise ValueError(f"'{text}' is not a duration") from None
    if ns != ns.to_integral_value():
        raise ValueError(f"'{text}' is not a whole number of nanoseconds")
    if ns <= 0:
        raise ValueError(f"'{text}': a period must be longer than 0")
    return int(ns)


def _number(x: float, exact: bool) -> str:
    if exact:
        text = f"{x:.9f}".rstrip("0").rstrip(".")
        return text or "0"
    if abs(x) >= 100:
        return f"{x:.0f}"
    return f"{x:.3g}"


def format_duration(ns: float | int | None, exact: bool = False) -> str:
    """100000 -> "100 µs", 2500000 -> "2.5 ms"; exact=False rounds to 3 significant digits."""
    if ns is None:
        return "-"
    for unit, scale in (("s", 1_000_000_000), ("ms", 1_000_000), ("µs", 1_000)):
        if abs(ns) >= scale:
            return f"{_number(ns / scale, exact)} {unit}"
    return f"{_number(float(ns), exact)} ns"


def _period(ns: int | None) -> str:
    return format_duration(ns, exact=True) if ns else "-"


def _size(n: int | None) -> str:
    if n is None:
        return "-"
    for unit, scale in (("MB", 1_000_000), ("kB", 1_000)):
        if n >= scale:
            return f"{n / scale:.1f} {unit}"
    return f"{n} B"


def _uptime(ns: int) -> str:
    s = int(ns // 1_000_000_000)
    d, s = divmod(s, 86400)
    h, s = divmod(s, 3600)
    m, s = divmod(s, 60)
    parts = [f"{d} d"] * bool(d) + [f"{h} h"] * bool(h) + [f"{m} min"] * bool(m) + [f"{s} s"]
    return " ".join(parts)


def format_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return f"{v:.9g}"
    return "-" if v is None else str(v)


def parse_value(text: str) -> int | float | bool:
    """A variable value on the command line: true/false, an integer or a number."""
    low = text.strip().lower()
    if low in ("true", "false"):
        return low == "true"
    if re.fullmatch(r"[+-]?\d+", low):
        return int(low)
    try:
        value = float(low)
    except ValueError:
        raise ValueError(f"'{text}' is not a value: give a number (12, -0.5, 1e-3) or true/false") from None
    if value != value or value in (float("inf"), float("-inf")):
        raise ValueError(f"'{text}': give a finite number")
    return value


# -- output ----------------------------------------------------------------------------------------
_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")


def printable(value: Any) -> str:
    """Text a client sent (a user name, a path), as a terminal may show it: control characters
    (escape sequences, newlines) written as \\xNN, so that it can neither colour nor forge a line."""
    return _CONTROL.sub(lambda m: f"\\x{ord(m.group()):02x}", str(value))


def table(headers: list[str], rows: Iterable[Iterable[Any]], align: str = "") -> str:
    """Columns padded to their widest cell; align is one letter per column, l or r (default l)."""
    cells = [[str(c) for c in row] for row in rows]
    widths = [max([len(h)] + [len(r[i]) for r in cells]) for i, h in enumerate(headers)]

    def line(row: list[str]) -> str:
        out = [c.rjust(w) if align[i : i + 1] == "r" else c.ljust(w) for i, (c, w) in enumerate(zip(row, widths))]
        return "  ".join(out).rstrip()

    return "\n".join([line(headers)] + [line(r) for r in cells])


def pairs(items: list[tuple[str, Any]]) -> str:
    width = max(len(k) for k, _ in items)
    return "\n".join(f"{k.ljust(width)}  {v}" for k, v in items)


def _p(record: dict, key: str, pct: str) -> str:
    """A percentile of a timing histogram; "-" while it has no samples."""
    h = record.get(key) or {}
    return format_duration(h.get(pct)) if h.get("count", 1) else "-"


def _names(names: list[str] | None) -> str:
    return ", ".join(names) if names else "-"


# -- what irpctl prints ----------------------------------------------------------------------------
class Out:
    """Where a command writes: JSON (--json) or text."""

    def __init__(self, as_json: bool, stream=None):
        self.as_json = as_json
        self.stream = stream or sys.stdout

    def json(self, data: Any) -> None:
        print(json.dumps(data, indent=2, ensure_ascii=False), file=self.stream)

    def line(self, text: str = "") -> None:
        print(text, file=self.stream, flush=True)

    def show(self, data: Any, text: Callable[[Any], str]) -> None:
        self.json(data) if self.as_json else self.line(text(data))


def status_text(s: dict) -> str:
    set_line = s.get("set") or "-"
    extra = []
    if s.get("set_id"):
        extra.append(f"id {s['set_id']}")
    if "generation" in s:
        extra.append(f"generation {s['generation']}")
    if extra:
        set_line += f"  ({', '.join(extra)})"
    mode = "real-time (SCHED_FIFO)" if s.get("realtime") else "not real-time (no SCHED_FIFO: timing is best effort)"
    shm = s.get("shared_memory") or {}
    items = [
        ("set", set_line),
        ("running", ("yes, " if s.get("running") else "no, ") + mode),
        ("basic period", _period(s.get("basic_period_ns"))),
        ("macro period", _period(s.get("macro_period_ns"))),
        ("uptime", _uptime(s.get("uptime_ns", 0))),
        ("cycles", s.get("cycles", "-")),
        ("modules", s.get("modules", "-")),
        ("overruns", s.get("overruns", "-")),
        ("missed", f"{s.get('missed', '-')}  (skipped {s.get('skipped', '-')}, caught up {s.get('caught_up', '-')})"),
        ("figures lost", f"{s.get('stats_dropped', '-')}  (runs not in the statistics: sample ring full)"),
        ("shared memory", ", ".join(f"{v} ({k})" for k, v in shm.items() if v) or "-"),
        ("retain", _retain(s.get("retain"))),
    ]
    return pairs(items)


def _retain(r: dict | None) -> str:
    """The retain store's line (docs/retain.md): what is kept, where, and a failed write."""
    if not r:
        return "- (nothing kept: no state folder or no shared variables)"
    line = f"{r['variables']} variable(s), sequence {r['sequence']}, {r['file'] or 'no copy yet'}"
    return line + (f"; last write failed: {r['last_error']}" if r.get("last_error") else "")


def modules_text(mods: list[dict]) -> str:
    return table(
        [
            "NAME",
            "TYPE",
            "OPERATION",
            "PERIOD",
            "DEADLINE",
            "PRIO",
            "STATE",
            "RUNS",
            "JITTER p99",
            "EXEC p99",
            "OVERRUNS",
            "MISSED",
        ],
        [
            [
                m.get("name"),
                m.get("moduletype", "-"),
                m.get("operationtype", "-"),
                _period(m.get("period_ns")),
                _period(m.get("deadline_ns")),
                m.get("priority", "-"),
                m.get("state", "-"),
                m.get("runs", "-"),
                _p(m, "jitter_ns", "p99"),
                _p(m, "exec_ns", "p99"),
                m.get("overruns", "-"),
                m.get("missed", "-"),
            ]
            for m in mods
        ],
        "lllrrrlrrrrr",
    )


def module_text(m: dict) -> str:
    items = [
        (k, m[k]) for k in ("name", "moduletype", "operationtype", "executor", "state", "priority", "file") if k in m
    ]
    items += [("period", _period(m.get("period_ns"))), ("deadline", _period(m.get("deadline_ns")))]
    items += [(k, m[k]) for k in ("enabled", "runs", "overruns", "missed", "skipped", "errors") if k in m]
    for key, label in (("jitter_ns", "jitter"), ("latency_ns", "latency"), ("exec_ns", "exec")):
        if key in m:
            items.append((label, "  ".join(f"{p} {_p(m, key, p)}" for p in ("p50", "p99", "p999", "max"))))
    return pairs(items)


def schedule_text(s: dict) -> str:
    slots = s.get("slots", [])
    head = (
        f"basic period {_period(s.get('basic_period_ns'))}, macro period {_period(s.get('macro_period_ns'))}, "
        f"{len(slots)} slots"
    )
    slot_table = table(
        ["SLOT", "AT", "MODULES (priority order)"],
        [
            [x.get("index"), _period(x.get("offset_ns")) if x.get("offset_ns") else "0", " ".join(x.get("modules", []))]
            for x in slots
        ],
        "rr",
    )
    parts = [head, "", slot_table]
    if s.get("modules"):
        parts += [
            "",
            table(
                ["MODULE", "TYPE", "OPERATION", "PERIOD", "DEADLINE", "PRIO", "EXECUTOR"],
                [
                    [
                        m.get("name"),
                        m.get("moduletype"),
                        m.get("operationtype"),
                        _period(m.get("period_ns")),
                        _period(m.get("deadline_ns")),
                        m.get("priority"),
                        m.get("executor", "-"),
                    ]
                    for m in s["modules"]
                ],
                "lllrrrl",
            ),
        ]
    return "\n".join(parts)


def jitter_text(j: dict) -> str:
    records = [*j.get("executors", []), *j.get("modules", [])]
    rows = [
        [
            r.get("name"),
            r.get("kind", "-"),
            _period(r.get("period_ns")),
            r.get("runs", "-"),
            *(_p(r, "jitter_ns", pct) for pct in ("p50", "p99", "p999", "max")),
            _p(r, "latency_ns", "p99"),
            _p(r, "exec_ns", "p99"),
            _p(r, "exec_ns", "max"),
            r.get("overruns", "-"),
            r.get("missed", "-"),
        ]
        for r in records
    ]
    return f"cycles {j.get('cycles', '-')}; jitter per Eq. (1), latency = wake-up to start\n\n" + table(
        [
            "NAME",
            "KIND",
            "PERIOD",
            "RUNS",
            "JITTER p50",
            "p99",
            "p99.9",
            "max",
            "LATENCY p99",
            "EXEC p99",
            "EXEC max",
            "OVERRUNS",
            "MISSED",
        ],
        rows,
        "llrrrrrrrrrrr",
    )


def variable_changes(changes: dict | None) -> str:
    """A check's or a swap's shared-variable changes on one line ("" when none): added, removed, moved
    (with why a value is not kept), converted (with the types) and the modules replaced for it."""
    if not changes or not any(changes.get(k) for k in ("added", "removed", "moved", "converted", "replaced")):
        return ""
    moved = [
        m.get("path")
        + (f" {m['from_type']} -> {m['to_type']}" if m.get("from_type") and m.get("to_type") else "")
        + (f" (not convertible without loss: {m['reason']})" if m.get("reason") else "")
        for m in changes.get("moved") or []
    ]
    converted = [
        f"{c.get('path')} ({c.get('from_type')} -> {c.get('to_type')})" for c in changes.get("converted") or []
    ]
    return "; ".join(
        part
        for part in (
            f"added {', '.join(changes['added'])}" if changes.get("added") else "",
            f"removed {', '.join(changes['removed'])}" if changes.get("removed") else "",
            f"moved {', '.join(moved)}" if moved else "",
            f"converted {', '.join(converted)}" if converted else "",
            f"modules replaced for it {', '.join(changes['replaced'])}" if changes.get("replaced") else "",
        )
        if part
    )


def swap_text(r: dict) -> str:
    reports = r.get("reports") or [r]
    blocks = []
    for rep in reports:
        name = rep.get("set", "-")
        if rep.get("set_id"):
            name += f" (set {rep['set_id']})"
        if rep.get("mode") == "restart":
            blocks.append(
                pairs(
                    [
                        ("restarted onto", f"{name}, same pid {rep.get('pid', '-')}"),
                        ("downtime", format_duration(rep.get("downtime_ns"))),
                        ("expected", format_duration(rep.get("expected_downtime_ns"))),
                    ]
                )
            )
            continue
        blocks.append(
            pairs(
                [
                    ("swapped to", f"{name}, generation {rep.get('generation', '-')}"),
                    ("at cycle", rep.get("swap_cycle", "-")),
                    ("kept", _names(rep.get("kept"))),
                    ("started", _names(rep.get("started"))),
                    ("stopped", _names(rep.get("stopped"))),
                    ("replaced", _names(rep.get("replaced"))),
                    ("missed periods", rep.get("missed_periods", "-")),
                    ("variables", variable_changes(rep.get("variables")) or "unchanged"),
                    ("request to swap", format_duration(rep.get("request_to_swap_ns"))),
                    ("total", format_duration(rep.get("total_ns"))),
                ]
            )
        )
    return "\n\n".join(blocks)


def _count(n: int, thing: str) -> str:
    return f"{n} {thing}" + ("" if n == 1 else "s")


def _verdict(valid: bool | None) -> str:
    return {True: "valid", False: "NOT valid", None: "not checked"}[valid]


def validation_text(v: dict | None) -> str:
    if not v:
        return "validation: -"
    lines = [
        f"validation: {_verdict(v.get('valid'))} "
        f"({_count(len(v.get('errors') or []), 'error')}, {_count(len(v.get('warnings') or []), 'warning')})"
    ]
    lines += [f"  error: {e}" for e in v.get("errors") or []]
    lines += [f"  warning: {w}" for w in v.get("warnings") or []]
    s = v.get("schedule")
    if s:
        lines.append(
            f"schedule: basic period {_period(s.get('basic_period_ns'))}, "
            f"macro period {_period(s.get('macro_period_ns'))}, {len(s.get('slots', []))} slots"
        )
    if v.get("online") is False and v.get("restart"):
        r = v["restart"]
        expected = r.get("expected_downtime_ns")
        lines.append(
            f"online: no, only a restart of irpd can run it (--mode restart or auto"
            f"{', expected downtime ' + _period(expected) if expected else ''}): {r.get('reason')}"
        )
    elif v.get("online"):
        lines.append("online: yes (a hot swap)")
    fates = v.get("modules")
    if fates:
        lines.append(
            "modules: "
            + "; ".join(f"{fate} {_names(fates.get(fate))}" for fate in ("kept", "started", "stopped", "replaced"))
        )
    changes = variable_changes(v.get("variables"))
    if changes:
        lines.append("variables: " + changes)
    return "\n".join(lines)


def upload_text(u: dict) -> str:
    files = u.get("files") or []
    by = f" by {_who(u['by'])}" if u.get("by") else ""
    head = f"set {u.get('id')}  ({_count(len(files), 'file')}, created {u.get('created', '-')}{by})"
    ftable = table(
        ["FILE", "SIZE", "KIND", "SHA256"],
        [[f.get("path"), _size(f.get("size")), f.get("kind", "-"), (f.get("sha256") or "")[:16]] for f in files],
        "lrl",
    )
    return "\n".join([head, ftable, validation_text(u.get("validation"))])


def sets_text(sets: list[dict]) -> str:
    if not sets:
        return "no sets uploaded (irpctl upload DIR stores one)"
    return table(
        ["ID", "CREATED", "BY", "FILES", "VALID", "ACTIVE"],
        [
            [
                s.get("id"),
                s.get("created", "-"),
                _who(s.get("by")),
                s.get("files", "-"),
                {True: "yes", False: "no"}.get(s.get("valid"), "?"),
                "*" if s.get("active") else "",
            ]
            for s in sets
        ],
        "lllrll",
    )


def _who(who: Any) -> str:
    """A token's owner: {"id", "name", "role"} -> "name (role)"."""
    if isinstance(who, dict):
        return f"{who.get('name', '?')} ({who['role']})" if who.get("role") else str(who.get("name", "?"))
    return "-" if who is None else str(who)


def set_text(s: dict) -> str:
    return upload_text(s) + (f"\nactive: {'yes' if s.get('active') else 'no'}" if "active" in s else "")


EVENT_HEADERS = ["SEQ", "TIME", "FROM", "KIND", "MODULE", "MESSAGE"]


def events_rows(events: list[dict]) -> list[list[Any]]:
    return [
        [
            e.get("seq", "-"),
            e.get("time", "-"),
            e.get("source", "irpd"),
            e.get("kind", "-"),
            e.get("module") or "-",
            e.get("message", ""),
        ]
        for e in events
    ]


def audit_text(entries: list[dict]) -> str:
    if not entries:
        return "the audit log is empty"
    rows = []
    for e in entries:
        result = e.get("result", "-")
        if e.get("status") or e.get("detail"):
            result += f" ({' '.join(str(x) for x in (e.get('status'), e.get('detail')) if x)})"
        rows.append(
            [
                e.get("time", "-"),
                printable(_who(e.get("who"))),
                e.get("client") or "-",
                e.get("action", "-"),
                printable(e.get("target") or "-"),
                printable(result),
            ]
        )
    return table(["TIME", "WHO", "CLIENT", "ACTION", "TARGET", "RESULT"], rows)


# -- alarms ------------------------------------------------------------------------------------------
STATE_WORDS = {
    "active_unacknowledged": "ACTIVE, unack",
    "active_acknowledged": "active, ack",
    "cleared_unacknowledged": "cleared, unack",
    "normal": "normal",
    "shelved": "shelved",
}


def _when(iso_time: str | None) -> str:
    """An ISO 8601 UTC time as the operator reads it: 2026-01-31 12:00:00 (UTC)."""
    return iso_time[:19].replace("T", " ") if iso_time else "-"


def alarms_text(listed: dict) -> str:
    c = listed.get("counts") or {}
    counts = f"{c.get('active', 0)} active, {c.get('unacknowledged', 0)} unacknowledged, {c.get('shelved', 0)} shelved"
    alarms = listed.get("alarms") or []
    segment = listed.get("segment") or {}
    note = f"\n(irpd's alarm segment is not read: {segment['error']})" if segment.get("error") else ""
    if not alarms:
        return f"no alarms ({counts}){note}"
    rows = []
    for a in alarms:
        state = STATE_WORDS.get(a.get("state"), a.get("state", "-"))
        if a.get("state") == "shelved":
            state += f" until {_when(a.get('shelved_until'))[11:]} ({a.get('shelve_reason')})"
        detail = f" -- {a['detail']}" if a.get("detail") else ""
        rows.append(
            [
                a.get("key"),
                state,
                a.get("severity"),
                _when(a.get("raised") or a.get("changed")),
                a.get("text", "") + detail,
            ]
        )
    return table(["KEY", "STATE", "SEVERITY", "RAISED (UTC)", "TEXT"], rows) + f"\n\n{counts}{note}"


TRANSITION_HEADERS = ["SEQ", "TIME (UTC)", "KEY", "EVENT", "STATE", "SEVERITY", "TEXT"]


def transition_row(t: dict) -> list[Any]:
    words = [t.get("text", "")]
    if t.get("detail"):
        words.append(f"-- {t['detail']}")
    if t.get("who"):
        words.append(f"by {_who(t['who'])}")
    if t.get("note"):
        words.append(f"({t['note']})")
    return [
        t.get("seq", "-"),
        _when(t.get("time")),
        t.get("key", "-"),
        t.get("event", "-"),
        STATE_WORDS.get(t.get("state"), t.get("state") or "-"),
        t.get("severity") or "-",
        " ".join(words),
    ]


def history_text(page: dict) -> str:
    """A history page (newest first from the API), printed oldest first."""
    transitions = list(reversed(page.get("transitions") or []))
    if not transitions:
        return "no transitions"
    shown = (
        f"\n({len(transitions)} of {page.get('total')}; --limit and --offset page)"
        if page.get("total", 0) > len(transitions)
        else ""
    )
    return table(TRANSITION_HEADERS, [transition_row(t) for t in transitions], "r") + shown

"""capture.py -- `irpctl capture arm|disarm|list|get|trigger|delete`: the triggered captures
(docs/irpctl.md, docs/recorder.md "Triggered captures").  irpctl.py adds CAPTURE_COMMANDS as the
subcommands of `capture`; each entry is (name, help, run, arguments) as its Command.

    irpctl capture arm SIG.wave[0] --when 'SIG.wave[4] rising 0' --pre 200 --post 100ms
    irpctl capture arm SIG.wave[0] --when 'SIG.wave[4] above 0.5 for 10' --when 'SIG.sample above 5000' --any
    irpctl capture arm PLC_ROBOT.PLC_OUT.Error --on fault --pre 1s --post 100ms --repeat 0
    irpctl capture get ID [--shot N] [--csv FILE]
"""

from __future__ import annotations

import argparse
import csv
import sys
from datetime import UTC, datetime

from ..recorder.trigger_text import describe_trigger
from .base import EXIT_OK, arg
from .text import Out, format_duration, pairs, parse_duration, printable, table

WHEN_FORMS = (
    "PATH rising|falling|either THRESHOLD, PATH above|below VALUE [for ROWS], PATH equal VALUE [tol T] [for ROWS], "
    "PATH inside|outside LOW HIGH [for ROWS]"
)


def _float(text: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what} '{text}' is not a number") from None
    if value != value or value in (float("inf"), float("-inf")):
        raise argparse.ArgumentTypeError(f"{what} must be a finite number, not '{text}'")
    return value


def parse_when(text: str) -> dict:
    """One condition, as `--when` takes it (WHEN_FORMS)."""
    words = text.split()
    if len(words) < 3:
        raise argparse.ArgumentTypeError(f"'{text}': give {WHEN_FORMS}")
    path, kind, rest = words[0], words[1], words[2:]
    hold = 1
    if len(rest) >= 2 and rest[-2] == "for":
        try:
            hold = int(rest[-1])
        except ValueError:
            raise argparse.ArgumentTypeError(f"'for {rest[-1]}': give a whole number of rows") from None
        rest = rest[:-2]
    if kind in ("rising", "falling", "either") and len(rest) == 1:
        return {"kind": "edge", "variable": path, "direction": kind, "threshold": _float(rest[0], "the threshold")}
    if kind in ("above", "below") and len(rest) == 1:
        return {
            "kind": "level",
            "variable": path,
            "compare": kind,
            "value": _float(rest[0], "the value"),
            "hold_rows": hold,
        }
    if kind == "equal" and len(rest) in (1, 3) and (len(rest) == 1 or rest[1] == "tol"):
        tol = _float(rest[2], "the tolerance") if len(rest) == 3 else 0.0
        return {
            "kind": "level",
            "variable": path,
            "compare": "equal",
            "value": _float(rest[0], "the value"),
            "tolerance": tol,
            "hold_rows": hold,
        }
    if kind in ("inside", "outside") and len(rest) == 2:
        low, high = _float(rest[0], "low"), _float(rest[1], "high")
        return {"kind": "window", "variable": path, "where": kind, "low": low, "high": high, "hold_rows": hold}
    raise argparse.ArgumentTypeError(
        f"'{text}': '{kind}' with {len(rest)} values is not a condition; give {WHEN_FORMS}"
    )


def parse_on(text: str) -> dict:
    """An event trigger: alarm, alarm:KEY, fault, swap or manual."""
    kind, _, key = text.partition(":")
    if kind == "alarm":
        return {"kind": "alarm", "key": key or None}
    if kind in ("fault", "swap", "manual") and not key:
        return {"kind": kind}
    raise argparse.ArgumentTypeError(f"'{text}': give alarm, alarm:KEY (e.g. alarm:main/8), fault, swap or manual")


def parse_length(text: str) -> dict:
    """A pre- or post-trigger length: a whole number of rows, or a duration (100ms, 1.5s)."""
    if text.strip().isdigit():
        return {"rows": int(text)}
    try:
        return {"seconds": parse_duration(text) / 1e9}
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}': give rows (e.g. 200) or a duration (e.g. 100ms, 1.5s)") from None


# -- what it prints --------------------------------------------------------------------------------
def _time(ns: int | None) -> str:
    return datetime.fromtimestamp(ns / 1e9, UTC).strftime("%Y-%m-%d %H:%M:%S.%f")[:-3] if ns else "-"


def captures_text(answer: dict) -> str:
    captures = answer["captures"]
    if not captures:
        return "no captures: irpctl capture arm VARIABLE... --when 'PATH rising 0' --pre 200 --post 100"
    rows = []
    for c in captures:
        last = c["shots"][-1] if c["shots"] else None
        rows.append(
            [
                c["id"],
                printable(c["name"] or "-"),
                c["state"],
                printable(describe_trigger(c["request"]["trigger"])),
                f"{c['pre_rows']}/{c['post_rows']}",
                len(c["shots"]),
                last["trigger_seq"] if last else "-",
                printable(c["message"] or ""),
            ]
        )
    return table(["ID", "NAME", "STATE", "TRIGGER", "PRE/POST", "SHOTS", "LAST TRIGGER SEQ", "NOTE"], rows, "llllrrrl")


def capture_text(c: dict) -> str:
    basic = c["basic_period_ns"]
    items = [
        ("capture", f"{c['id']} {printable(c['name'])}".strip()),
        (
            "state",
            c["state"] + (f" (pre-trigger buffer {c['pre_filled']}/{c['pre_rows']})" if c["state"] == "armed" else ""),
        ),
        ("trigger", printable(describe_trigger(c["request"]["trigger"]))),
        ("channels", ", ".join(printable(ch["path"]) for ch in c["channels"])),
        ("pre / post", f"{c['pre_rows']} / {c['post_rows']} rows" + (f" of {format_duration(basic)}" if basic else "")),
        ("repeat", c["request"]["repeat"] or "until disarmed"),
        ("shots taken", f"{c['shots_taken']} since armed at {c['armed_at'] or '-'} by {c['by'] or '-'}"),
        ("rows lost", c["lost_rows"]),
    ]
    if c.get("message"):
        items.append(("note", printable(c["message"])))
    out = [pairs(items)]
    if c["shots"]:
        rows = [
            [
                s["shot"],
                s["trigger_seq"],
                s["cause"],
                _time(s["trigger_time_ns"]),
                s["pre_rows"],
                s["post_rows"],
                s["drops"],
            ]
            for s in c["shots"]
        ]
        out += ["", table(["SHOT", "TRIGGER SEQ", "CAUSE", "TRIGGERED (UTC)", "PRE", "POST", "DROPS"], rows, "rrllrrr")]
    return "\n".join(out)


# -- the commands ----------------------------------------------------------------------------------
def cmd_arm(c, a, out: Out) -> int:
    if a.again:
        if a.variables or a.when or a.on:
            raise ValueError("--again ID arms a capture again as it was asked for: give no variables, --when or --on")
        out.show(c.request("POST", f"/captures/{a.again}/arm"), capture_text)
        return EXIT_OK
    if not a.variables:
        raise ValueError("give the variables to capture (and --when or --on), or --again ID")
    if bool(a.when) == bool(a.on):
        raise ValueError("give the trigger: --when CONDITION (up to 4) or --on alarm|alarm:KEY|fault|swap|manual")
    if a.pre is None or a.post is None:
        raise ValueError("give --pre and --post (rows, or a duration such as 100ms)")
    if a.when:
        trigger = {"kind": "condition", "combine": "or" if a.any else "and", "conditions": a.when}
    else:
        trigger = a.on
        if a.severity:
            trigger["severity"] = a.severity
    body = {
        "name": a.name or "",
        "variables": a.variables,
        "trigger": trigger,
        "pre": a.pre,
        "post": a.post,
        "repeat": a.repeat,
    }
    out.show(c.request("POST", "/captures", json=body), capture_text)
    return EXIT_OK


def _write_csv(f, rows: dict) -> None:
    w = csv.writer(f)
    w.writerow(["seq", "t_ns", *(ch["path"] for ch in rows["channels"])])
    for k, seq in enumerate(rows["seq"]):
        w.writerow([seq, rows["t_ns"][k], *("" if col[k] is None else repr(col[k]) for col in rows["columns"])])


def cmd_get(c, a, out: Out) -> int:
    capture = c.get(f"/captures/{a.id}")
    if a.csv is None:
        out.show(capture, capture_text)
        return EXIT_OK
    rows = c.get(f"/captures/{a.id}/shots/{a.shot}", channel=a.channel or None)
    if a.csv == "-":
        _write_csv(sys.stdout, rows)
        return EXIT_OK
    with open(a.csv, "w", newline="", encoding="utf-8") as f:
        _write_csv(f, rows)
    s = rows["summary"]
    out.show(
        capture,
        lambda x: (
            capture_text(x)
            + f"\n\nshot {s['shot']} (trigger seq {s['trigger_seq']}): {len(rows['seq'])} rows written to {a.csv}"
        ),
    )
    return EXIT_OK


def _simple(method: str, suffix: str):
    def run(c, a, out: Out) -> int:
        answer = c.request(method, f"/captures/{a.id}{suffix}")
        if answer is None:
            out.line(f"capture {a.id} deleted")
        else:
            out.show(answer, lambda x: f"capture {x['id']}: {x['state']}")
        return EXIT_OK

    return run


ID = arg("id", metavar="ID")
CAPTURE_COMMANDS = (
    (
        "arm",
        "arm a capture of VARIABLEs on a trigger, with pre- and post-trigger rows (operator)",
        cmd_arm,
        (
            arg("variables", nargs="*", metavar="VARIABLE", help="numeric scalars, e.g. 'SIG.wave[0]'"),
            arg("--when", action="append", type=parse_when, metavar="CONDITION", help=f"up to 4: {WHEN_FORMS}"),
            arg("--any", action="store_true", help="trigger when any --when holds (default: all of them, row by row)"),
            arg("--on", type=parse_on, metavar="EVENT", help="alarm, alarm:KEY, fault, swap or manual"),
            arg(
                "--severity",
                choices=("low", "medium", "high", "critical"),
                help="with --on alarm: at least this severity",
            ),
            arg("--pre", type=parse_length, metavar="LENGTH", help="rows before the trigger row: N rows or a duration"),
            arg("--post", type=parse_length, metavar="LENGTH", help="rows after it: N rows or a duration"),
            arg(
                "--repeat",
                type=int,
                default=1,
                metavar="N",
                help="shots to take, re-armed after each (0: until disarmed)",
            ),
            arg("--name", metavar="TEXT"),
            arg("--again", metavar="ID", help="arm an idle or done capture again, as it was asked for"),
        ),
    ),
    (
        "disarm",
        "disarm a capture; a shot being collected is saved with its rows (operator)",
        _simple("POST", "/disarm"),
        (ID,),
    ),
    ("trigger", "trigger an armed capture now (operator)", _simple("POST", "/trigger"), (ID,)),
    ("delete", "delete a capture and its shots (operator)", _simple("DELETE", ""), (ID,)),
    (
        "list",
        "every capture: state, trigger, shots",
        lambda c, a, out: out.show(c.get("/captures"), captures_text) or EXIT_OK,
        (),
    ),
    (
        "get",
        "one capture and its shots; --csv writes a shot's rows",
        cmd_get,
        (
            ID,
            arg("--shot", type=int, default=0, metavar="N", help="which shot (default 0: the newest)"),
            arg("--csv", metavar="FILE", help="write the shot's rows as CSV to FILE (- : standard output)"),
            arg("--channel", action="append", metavar="PATH", help="only these channels (repeat it)"),
        ),
    ),
)

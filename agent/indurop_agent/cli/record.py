"""record.py -- `irpctl record ...`: start, stop, list, get, rm, download and export recordings
on the appliance (docs/irpctl.md, docs/recorder.md).  irpctl.py adds RECORD_COMMANDS to its command
table as the group `record`; each entry is (name, help, run, arguments) as its Command.

    irpctl record start run-7 SIG.sample SIG.wave[0]=V --duration 60 --decimation 10
    irpctl record list
    irpctl record export run-7 --format parquet -o run-7.parquet
"""

from __future__ import annotations

import argparse
import sys

from .base import EXIT_OK, arg
from .client import Client
from .text import Out, _size, pairs, printable, table


def _variable(text: str) -> str | dict:
    """PATH or PATH=UNIT."""
    path, eq, unit = text.partition("=")
    if not path:
        raise argparse.ArgumentTypeError(f"'{text}': give a variable's path, e.g. SIG.wave[0] or SIG.wave[0]=V")
    return {"path": path, "unit": unit} if eq else path


def _positive(kind):
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
        if not value > 0:
            raise argparse.ArgumentTypeError(f"'{text}': give more than 0")
        return value

    return parse


def _duration(r: dict) -> str:
    d = r.get("duration_s")
    return "-" if d is None else f"{d:.1f} s"


def recordings_text(listed: dict) -> str:
    rows = [
        [
            printable(r["name"]) + ("" if r["kind"] == "recording" else f" ({r['kind']})"),
            r["state"] + (f" ({r['cause']})" if r.get("cause") and r["cause"] != "manual" else ""),
            len(r["variables"]),
            r["rows"],
            r["drops"],
            len(r["gaps"]),
            _duration(r),
            _size(r["size"]),
            r["created"][:19].replace("T", " "),
        ]
        for r in listed["recordings"]
    ]
    out = table(["NAME", "STATE", "VARS", "ROWS", "DROPS", "GAPS", "DURATION", "SIZE", "CREATED"], rows, "llrrrrrrl")
    if not rows:
        out = "no recordings: irpctl record start NAME PATH ... starts one"
    quota = f"{_size(listed['used_bytes'])} of {_size(listed['quota_bytes'])} quota, {_size(listed['disk_free_bytes'])} free on disk"
    channels = listed.get("channels")
    if channels is None:
        traced = "trace channels: irpd unreachable"
    else:
        owners = ", ".join(f"{k} {v}" for k, v in sorted(channels["owners"].items()) if v)
        traced = f"trace channels: {channels['traced']} of {channels['limit']}" + (f" ({owners})" if owners else "")
    return "\n".join([out, "", quota, traced])


def recording_text(r: dict) -> str:
    variables = ", ".join(v["path"] + (f" [{v['unit']}]" if v["unit"] else "") for v in r["variables"])
    stop = r.get("stop") or {}
    until = [f"{stop['duration_s']:g} s"] if stop.get("duration_s") else []
    until += [_size(stop["max_bytes"])] if stop.get("max_bytes") else []
    items = [
        ("name", printable(r["name"])),
        ("state", r["state"] + (f": {printable(r['reason'])}" if r.get("reason") else "")),
        ("variables", printable(variables)),
        ("decimation", r.get("decimation") or "-"),
        ("stops", " or ".join(until) or "when stopped"),
        ("rows", f"{r['rows']} ({r['drops']} dropped)"),
        ("duration", _duration(r)),
        ("from", r.get("first_time") or "-"),
        ("to", r.get("last_time") or "-"),
        ("size", _size(r["size"])),
        ("joint states", ", ".join(r["joint_states"]) or "-"),
        ("created", f"{r['created']} by {printable(r.get('created_by') or '-')}"),
    ]
    parts = (
        "no part yet (no row recorded)"
        if not r["parts"]
        else table(
            ["PART", "ROWS", "FIRST SEQ", "LAST SEQ", "DROPS", "SIZE", "CLOSED"],
            [
                [
                    p["file"],
                    p["rows"],
                    p["first_seq"],
                    p["last_seq"],
                    p["drops"],
                    _size(p["size"]),
                    "yes" if p["closed"] else "no",
                ]
                for p in r["parts"]
            ],
            "lrrrrrl",
        )
    )
    gaps = [
        f"gap before part {g['part'] + 1}: after row {g['last_seq']}, from row {g['first_seq']}"
        + (f", {g['missing']} rows missing" if g["missing"] is not None else "")
        + f" ({printable(g['reason'])})"
        for g in r["gaps"]
    ]
    return "\n".join([pairs(items), "", parts, *gaps])


def cmd_start(c: Client, a, out: Out) -> int:
    r = c.record_start(a.name, a.variables, a.decimation, a.duration, a.max_bytes)
    out.show(r, recording_text)
    return EXIT_OK


def cmd_rm(c: Client, a, out: Out) -> int:
    c.record_delete(a.name)
    if not out.as_json:
        out.line(f"deleted {a.name}")
    return EXIT_OK


def _wrote(out: Out, path, what: str) -> int:
    if out.as_json:
        out.json({"file": str(path)})
    else:
        print(f"irpctl: wrote {what} to {path}", file=sys.stderr)
    return EXIT_OK


def cmd_download(c: Client, a, out: Out) -> int:
    path = c.record_download(a.name, a.output, a.part)
    return _wrote(out, path, f"{a.name}'s files" if path.suffix == ".zip" else f"{a.name}'s MCAP file")


def cmd_export(c: Client, a, out: Out) -> int:
    return _wrote(out, c.record_export(a.name, a.output, a.format), f"{a.name}'s rows as {a.format}")


def _shown(fetch, render):
    def run(c: Client, a, out: Out) -> int:
        out.show(fetch(c, a), render)
        return EXIT_OK

    return run


NAME = arg("name", metavar="NAME")
RECORD_COMMANDS = (
    (
        "start",
        "start recording variables at every basic period into an MCAP file on the appliance (operator)",
        cmd_start,
        (
            NAME,
            arg("variables", nargs="+", type=_variable, metavar="PATH[=UNIT]", help="scalar variables, with a unit"),
            arg("--decimation", type=_positive(int), default=1, metavar="N", help="every N-th row (default 1)"),
            arg("--duration", type=_positive(float), metavar="S", help="stop after S seconds of rows"),
            arg("--max-bytes", type=_positive(int), metavar="B", help="stop once its files hold B bytes"),
        ),
    ),
    (
        "stop",
        "stop a recording; its file is closed and kept (operator)",
        _shown(lambda c, a: c.record_stop(a.name), recording_text),
        (NAME,),
    ),
    (
        "list",
        "every recording and capture, the quota, the trace channels",
        _shown(lambda c, a: c.recordings(), recordings_text),
        (),
    ),
    (
        "get",
        "one recording: state, rows, drops, parts, gaps",
        _shown(lambda c, a: c.recording(a.name), recording_text),
        (NAME,),
    ),
    ("rm", "delete a recording and its files (operator)", cmd_rm, (NAME,)),
    (
        "download",
        "download a recording's MCAP file (a .zip when it has several)",
        cmd_download,
        (
            NAME,
            arg("-o", "--output", metavar="FILE", help="where (default: the name the agent gives, here)"),
            arg("--part", type=_positive(int), metavar="N", help="only part N"),
        ),
    ),
    (
        "export",
        "a recording's rows as CSV or Parquet",
        cmd_export,
        (
            NAME,
            arg("--format", choices=("csv", "parquet"), default="csv"),
            arg("-o", "--output", metavar="FILE", help="where (default: NAME.csv or NAME.parquet, here)"),
        ),
    ),
)

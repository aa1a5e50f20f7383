"""irpctl.py -- irpctl, the command line of the agent's API: status, modules, sets, hot reload,
variables, the sample stream, events and alarms (alarms.py), users (users.py), the administration of
system.py, the line of controllers (line.py), the recordings (record.py), the triggered captures
(capture.py) and the OPC UA server's trust list (opcua.py) (docs/irpctl.md).

Human output by default (aligned tables, durations as "100 µs"), the API's JSON with --json.
Exit codes (base.py): 0 done, 1 the API refused (4xx, 409), 2 usage, 3 the agent or irpd unreachable.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .alarms import cmd_ack, cmd_alarms, cmd_events, cmd_shelve
from .base import EXIT_OK, EXIT_REFUSED, EXIT_UNREACHABLE, EXIT_USAGE, arg, parse_time
from .capture import CAPTURE_COMMANDS
from .client import ApiError, Client
from .client_errors import problem_line
from .forces import cmd_force, cmd_forces, cmd_unforce
from .line import LINE_COMMANDS
from .opcua import OPCUA_COMMANDS
from .record import RECORD_COMMANDS
from .scope import SCOPE_COMMANDS
from .system import SETS_ARGS, SYSTEM_COMMANDS, cmd_sets
from .text import (
    Out,
    audit_text,
    format_value,
    jitter_text,
    module_text,
    modules_text,
    parse_duration,
    parse_value,
    schedule_text,
    set_text,
    status_text,
    swap_text,
    table,
    upload_text,
)
from .users import USER_COMMANDS

DEFAULT_URL = "http://127.0.0.1:8080"


# -- the commands: (client, args, out) -> exit code ----------------------------------------------------
def _show(fetch: Callable[[Client, argparse.Namespace], Any], render: Callable[[Any], str]):
    """A command that asks the API one thing and shows it (as a table, or its JSON with --json)."""

    def run(c: Client, a: argparse.Namespace, out: Out) -> int:
        out.show(fetch(c, a), render)
        return EXIT_OK

    return run


def _variables_text(v: dict) -> str:
    return f"layout {v.get('layout_hash', '-')[:16]}\n\n" + table(
        ["PATH", "TYPE", "SIZE"], [[x["path"], x.get("type"), x.get("size")] for x in v["variables"]], "llr"
    )


def _upload(c: Client, a) -> dict:
    sources = [Path(s) for s in a.sources]
    return c.upload(sources[0] if len(sources) == 1 else sources, root=getattr(a, "root", None))


def cmd_upload(c: Client, a, out: Out) -> int:
    u = _upload(c, a)
    if not a.activate:
        out.show(u, upload_text)
        return EXIT_OK
    if (u.get("validation") or {}).get("valid") is False:  # None (not checked): irpd checks it on activation
        out.show(u, upload_text)
        print(
            f"irpctl: set {u.get('id')} is not valid, so it was not activated; fix the errors above and upload again",
            file=sys.stderr,
        )
        return EXIT_REFUSED
    report = c.activate(u["id"], a.mode)
    if out.as_json:
        out.json({"upload": u, "swap": report})
    else:
        out.line(upload_text(u))
        out.line()
        out.line(swap_text(report))
    return EXIT_OK


def cmd_validate(c: Client, a, out: Out) -> int:
    """Exit 0 valid, 1 not valid, 3 irpd could not check it."""
    u = _upload(c, a)
    out.show(u, upload_text)
    valid = (u.get("validation") or {}).get("valid")
    if not out.as_json:
        out.line(
            {
                True: f"(stored as set {u.get('id')}; `irpctl activate {u.get('id')}` runs it)",
                False: "(stored, but irpd would refuse it: fix the errors above)",
                None: "(stored, but not checked: is irpd running? upload again to check it)",
            }[valid]
        )
    return _verdict_exit(u)


def _verdict_exit(s: dict) -> int:
    """A checked set's exit status: 0 valid, 1 not valid, 3 irpd could not check it."""
    return {True: EXIT_OK, False: EXIT_REFUSED, None: EXIT_UNREACHABLE}[(s.get("validation") or {}).get("valid")]


def cmd_check(c: Client, a, out: Out) -> int:
    """The dry run of an activation; exit as validate."""
    s = c.check(a.id)
    out.show(s, set_text)
    return _verdict_exit(s)


def cmd_layout(c: Client, a, out: Out) -> int:
    text = c.layout()
    if a.output in (None, "-"):
        sys.stdout.write(text)
    else:
        Path(a.output).write_text(text, encoding="utf-8")
        print(
            f"wrote {a.output} (layout {json.loads(text).get('hash', '?')[:16]}): lay a changed .glb out against it "
            f"with glbc --previous {a.output}"
        )
    return EXIT_OK


def cmd_read(c: Client, a, out: Out) -> int:
    """A leaf's value, or each leaf of a group (a namespace, a struct, an array or an element)."""
    answers = []
    for p in a.paths:
        x = c.variable(p)
        answers.append({"path": p, "value": x["value"]} if "value" in x else {"path": p, "values": x["values"]})
    if out.as_json:
        out.json(answers[0] if len(answers) == 1 else answers)
        return EXIT_OK
    leaves = [leaf for x in answers for leaf in x.get("values", [x])]
    out.line(
        f"{leaves[0]['path']} = {format_value(leaves[0]['value'])}"
        if len(answers) == 1 and "value" in answers[0]
        else table(["PATH", "VALUE"], [[x["path"], format_value(x["value"])] for x in leaves], "lr")
    )
    return EXIT_OK


def cmd_write(c: Client, a, out: Out) -> int:
    value = c.write(a.path, a.value)
    out.show({"path": a.path, "value": value}, lambda x: f"{x['path']} = {format_value(x['value'])}")
    return EXIT_OK


def cmd_watch(c: Client, a, out: Out) -> int:
    n = 0
    first_t = None
    widths: list[int] = []
    stream = c.watch(a.paths, decimation=a.decimation, seconds=a.seconds)
    try:
        with stream:
            for seq, t_ns, values in stream:
                if out.as_json:
                    out.line(json.dumps({"seq": seq, "t_ns": t_ns, "values": values}))
                else:
                    if first_t is None:
                        first_t = t_ns
                        headers = ["SEQ", "T (ms)", *values]
                        widths = [max(len(h), 12) for h in headers]
                        out.line("  ".join(h.rjust(w) for h, w in zip(headers, widths)))
                    cells = [str(seq), f"{(t_ns - first_t) / 1e6:.3f}", *(format_value(v) for v in values.values())]
                    out.line("  ".join(x.rjust(w) for x, w in zip(cells, widths)))
                n += 1
                if a.count and n >= a.count:
                    break
    except KeyboardInterrupt:
        pass
    print(f"irpctl: {n} samples; the server dropped {stream.dropped}", file=sys.stderr)
    return EXIT_OK


def cmd_trace(c: Client, a, out: Out) -> int:
    rows = 0
    f = sys.stdout if a.csv == "-" else open(a.csv, "w", newline="")
    stream = c.watch(a.paths, decimation=a.decimation, seconds=a.seconds)
    try:
        writer = csv.writer(f)
        with stream:
            for seq, t_ns, values in stream:
                if not rows:  # the channel names as the server gives them
                    writer.writerow(["seq", "t_ns", *values])
                writer.writerow([seq, t_ns, *values.values()])
                rows += 1
    except KeyboardInterrupt:
        pass
    finally:
        if not rows:
            csv.writer(f).writerow(["seq", "t_ns", *a.paths])
        if f is not sys.stdout:
            f.close()
    where = "stdout" if a.csv == "-" else a.csv
    summary = {"samples": rows, "channels": len(a.paths), "dropped": stream.dropped, "file": where}
    if out.as_json and a.csv != "-":
        out.json(summary)
    else:
        print(
            f"irpctl: wrote {rows} samples of {len(a.paths)} channels to {where}; the server dropped {stream.dropped}",
            file=sys.stderr,
        )
    return EXIT_OK


# -- argument types ----------------------------------------------------------------------------------
def _argument(convert: Callable[[str], Any], what: str | None, minimum: float | None = None, at_least: str = ""):
    """An argparse type: `convert` the text (a ValueError's message, or "'text' is not <what>", is
    the usage error), then check it is at least `minimum` ("'text': <at_least>" otherwise)."""

    def parse(text: str):
        try:
            value = convert(text)
        except ValueError as e:
            raise argparse.ArgumentTypeError(str(e) if what is None else f"'{text}' is not {what}") from None
        if minimum is not None and not value >= minimum:
            raise argparse.ArgumentTypeError(f"'{text}': {at_least}")
        return value

    return parse


_duration_arg = _argument(parse_duration, None)
_value_arg = _argument(parse_value, None)
_int_arg = _argument(int, "a whole number")
_positive_int = _argument(int, "a whole number", 1, "give 1 or more")
_nonneg_int = _argument(int, "a whole number", 0, "give 0 or more")
_seconds = _argument(float, "a number of seconds", math.nextafter(0.0, 1.0), "give more than 0 seconds")
_minutes = _argument(float, "a number of minutes", math.nextafter(0.0, 1.0), "give more than 0 minutes")
_time_arg = _argument(parse_time, None)


def _connection_options(parser: argparse.ArgumentParser, top: bool) -> None:
    """The global options, accepted before and after the command (after it they override)."""

    def d(value):
        return value if top else argparse.SUPPRESS

    g = parser.add_argument_group("connection and output")
    g.add_argument(
        "--url",
        default=d(None),
        metavar="URL",
        help=f"the agent, e.g. https://cell7:8443 (default $INDUROP_URL or {DEFAULT_URL})",
    )
    g.add_argument("--token", default=d(None), help="bearer token (default $INDUROP_TOKEN)")
    g.add_argument(
        "--token-file",
        default=d(None),
        metavar="FILE",
        help="read the token from FILE (default $INDUROP_TOKEN_FILE), e.g. <data-dir>/admin-token",
    )
    g.add_argument("--json", action="store_true", default=d(False), help="print the API's JSON")
    g.add_argument("--ca", default=d(None), metavar="FILE", help="CA certificate(s) to check an https agent with")
    g.add_argument(
        "--insecure", action="store_true", default=d(False), help="accept any https certificate (testing only)"
    )
    g.add_argument("--timeout", type=_seconds, default=d(10.0), metavar="S", help="per request, seconds (default 10)")


# -- the command table -------------------------------------------------------------------------------
MODE = arg(
    "--mode",
    choices=("online", "restart", "auto"),
    default="online",
    help="online (default): hot reload, refused for a set that needs a restart; restart: irpd restarts "
    "onto the set (same pid, outputs to safe values, downtime reported); auto: a restart only when needed",
)
SOURCES = (
    arg(
        "sources",
        nargs="+",
        metavar="DIR|FILE|ARCHIVE",
        help="a set folder (holding module.xml), the set's files, or a .tar.gz",
    ),
    arg("--root", metavar="DIR", help="with FILEs: name them relative to DIR (default: their common folder)"),
)
MODULE = arg("module", metavar="MODULE")
STREAM = (
    arg("paths", nargs="+", metavar="PATH"),
    arg(
        "--decimation",
        type=_positive_int,
        default=1,
        metavar="N",
        help="every N-th basic period (default 1: every sample)",
    ),
)


@dataclass(frozen=True)
class Command:
    name: str
    help: str
    run: Callable[[Client, argparse.Namespace, Out], int] | None
    args: tuple[tuple[tuple[str, ...], dict], ...] = ()
    exclusive: tuple[tuple[tuple[str, ...], dict], ...] = ()  # at most one of these
    sub: tuple[Command, ...] = ()  # a group: `irpctl NAME SUBCOMMAND ...` (run is None)


COMMANDS: tuple[Command, ...] = (
    Command(
        "status", "the running set: periods, uptime, cycles, overruns", _show(lambda c, a: c.status(), status_text)
    ),
    Command("modules", "every module with its period, state and timing", _show(lambda c, a: c.modules(), modules_text)),
    Command(
        "module",
        "one module in detail",
        _show(lambda c, a: c.module(a.name), module_text),
        (arg("name", metavar="MODULE"),),
    ),
    Command(
        "schedule",
        "the slot table (basic/macro period, modules per slot)",
        _show(lambda c, a: c.schedule(), schedule_text),
    ),
    Command(
        "jitter", "timing of every dispatcher and module (percentiles)", _show(lambda c, a: c.jitter(), jitter_text)
    ),
    Command(
        "upload",
        "store a module set: a folder, its files, or a .tar.gz",
        cmd_upload,
        (*SOURCES, arg("--activate", action="store_true", help="activate it (hot reload) when valid"), MODE),
    ),
    Command(
        "validate", "upload a set and show irpd's validation report (exit 1 when not valid)", cmd_validate, SOURCES
    ),
    Command(
        "sets",
        "the uploaded sets, newest first; `sets prune --keep N` deletes old ones (admin)",
        cmd_sets,
        SETS_ARGS,
    ),
    Command(
        "set",
        "one uploaded set: files and validation",
        _show(lambda c, a: c.set(a.id), set_text),
        (arg("id", metavar="ID"),),
    ),
    Command(
        "check",
        "the dry run of an activation: irpd checks an uploaded set against what runs now (operator)",
        cmd_check,
        (arg("id", metavar="ID"),),
    ),
    Command(
        "activate",
        "hot-reload (or restart) irpd onto an uploaded set",
        _show(lambda c, a: c.activate(a.id, a.mode), swap_text),
        (arg("id", metavar="ID"), MODE),
    ),
    Command(
        "rollback",
        "activate the set that was active before the current one",
        _show(lambda c, a: c.rollback(a.mode), swap_text),
        (MODE,),
    ),
    Command(
        "set-period",
        "change a module's period (hot reload)",
        _show(lambda c, a: c.patch_module(a.module, period_ns=a.period), swap_text),
        (MODULE, arg("period", type=_duration_arg, metavar="PERIOD", help="1ms, 100us, 2.5ms, 500000ns or plain ns")),
    ),
    Command(
        "set-priority",
        "change a module's priority (lowest value runs first)",
        _show(lambda c, a: c.patch_module(a.module, priority=a.priority), swap_text),
        (MODULE, arg("priority", type=_int_arg, metavar="N")),
    ),
    Command(
        "enable",
        "enable a module (hot reload)",
        _show(lambda c, a: c.patch_module(a.module, enabled=True), swap_text),
        (MODULE,),
    ),
    Command(
        "disable",
        "disable a module (hot reload)",
        _show(lambda c, a: c.patch_module(a.module, enabled=False), swap_text),
        (MODULE,),
    ),
    Command(
        "variables", "every shared variable of the running layout", _show(lambda c, a: c.variables(), _variables_text)
    ),
    Command(
        "layout",
        "the running layout.json, for glbc --previous",
        cmd_layout,
        (arg("-o", "--output", metavar="FILE", help="write it to FILE (default: standard output)"),),
    ),
    Command(
        "read",
        "read shared variables: leaves, or every leaf of a group (struct, array, namespace)",
        cmd_read,
        (arg("paths", nargs="+", metavar="PATH", help="e.g. knu.Robot.tick 'joint[1].y' 'joint[1]' knu.Robot"),),
    ),
    Command(
        "write",
        "write a shared variable",
        cmd_write,
        (arg("path", metavar="PATH"), arg("value", type=_value_arg, metavar="VALUE", help="a number or true/false")),
    ),
    Command(
        "force",
        "force a shared variable: every reader sees VALUE, whatever modules write (operator)",
        cmd_force,
        (
            arg("path", metavar="PATH", help="a leaf: a scalar, a struct member or an array element"),
            arg("value", type=_value_arg, metavar="VALUE", help="a number or true/false"),
        ),
    ),
    Command(
        "unforce",
        "end a force, leaving the forced value (or, with --restore, the value before it)",
        cmd_unforce,
        (
            arg("path", metavar="PATH"),
            arg("--restore", action="store_true", help="write back the value it had before the force"),
        ),
    ),
    Command("forces", "the forced variables: who forced what, when", cmd_forces, ()),
    Command(
        "watch",
        "print the samples of variables as they come",
        cmd_watch,
        STREAM,
        (
            arg("--count", type=_positive_int, metavar="N", help="stop after N samples"),
            arg("--seconds", type=_seconds, metavar="S", help="stop after S seconds"),
        ),
    ),
    Command(
        "trace",
        "record the samples of variables to a CSV file",
        cmd_trace,
        (
            *STREAM,
            arg("--seconds", type=_seconds, required=True, metavar="S", help="how long to record"),
            arg("--csv", required=True, metavar="FILE", help="where to write (- for stdout)"),
        ),
    ),
    Command(
        "events",
        "irpd's and the agent's events (swaps, faults, misses, uploads)",
        cmd_events,
        (
            arg("--since", type=_nonneg_int, default=0, metavar="SEQ", help="events from SEQ on"),
            arg("--limit", type=_positive_int, metavar="N"),
            arg("--follow", "-f", action="store_true", help="keep printing new events (Ctrl-C stops)"),
            arg("--interval", type=_seconds, default=1.0, metavar="S", help="with --follow: poll every S s"),
        ),
    ),
    Command(
        "alarms",
        "the alarms that need attention (--history: their transitions)",
        cmd_alarms,
        (
            arg("--history", action="store_true", help="the transitions (raised, cleared, acknowledged, shelved)"),
            arg("--follow", "-f", action="store_true", help="keep printing transitions as they come (Ctrl-C stops)"),
            arg(
                "--since",
                type=_time_arg,
                metavar="TIME",
                help="with --history: from TIME (ISO 8601, or 30m, 2h, 1d ago)",
            ),
            arg("--until", type=_time_arg, metavar="TIME", help="with --history: up to TIME"),
            arg("--module", metavar="MODULE", help="one module's (irpd, agent: the platform's)"),
            arg("--key", metavar="KEY", help="one alarm's, e.g. PLC/8"),
            arg("--severity", choices=("low", "medium", "high", "critical")),
            arg(
                "--state",
                choices=("active_unacknowledged", "active_acknowledged", "cleared_unacknowledged", "normal", "shelved"),
                help="with --history: transitions that left an alarm in this state",
            ),
            arg(
                "--limit", type=_positive_int, default=100, metavar="N", help="with --history: at most N (default 100)"
            ),
            arg("--offset", type=_nonneg_int, default=0, metavar="N", help="with --history: skip the newest N"),
            arg("--interval", type=_seconds, default=1.0, metavar="S", help="with --follow: poll every S s"),
        ),
    ),
    Command(
        "ack",
        "acknowledge an alarm, or all of them (operator)",
        cmd_ack,
        (
            arg("key", nargs="?", metavar="KEY", help="the alarm, e.g. PLC/8 (irpctl alarms lists them)"),
            arg("--all", action="store_true", help="every unacknowledged alarm"),
            arg("--module", metavar="MODULE", help="with --all: only this module's"),
        ),
    ),
    Command(
        "shelve",
        "set an alarm aside for a time, with a reason (operator)",
        cmd_shelve,
        (
            arg("key", metavar="KEY", help="the alarm, e.g. PLC/8"),
            arg("--minutes", type=_minutes, required=True, metavar="N", help="how long (at most a week)"),
            arg("--reason", required=True, metavar="TEXT", help="why, for the history"),
        ),
    ),
    Command(
        "unshelve",
        "bring a shelved alarm back before its time (operator)",
        _show(lambda c, a: c.unshelve(a.key), lambda x: f"{x['key']}: {x['state']}"),
        (arg("key", metavar="KEY"),),
    ),
    Command(
        "audit",
        "the audit log (admin)",
        _show(lambda c, a: c.audit(limit=a.limit), audit_text),
        (arg("--limit", type=_positive_int, metavar="N"),),
    ),
    Command(
        "user",
        "the people who sign in: list, show, add, disable, enable, passwd, role, tokens",
        None,
        sub=tuple(Command(name, text, run, args) for name, text, run, args in USER_COMMANDS),
    ),
    *(Command(*spec) for spec in SYSTEM_COMMANDS),  # system, backup, restore, restart, logs, tls
    *(Command(*spec) for spec in LINE_COMMANDS),  # line
    Command(
        "record",
        "recordings on the appliance: start, stop, list, get, rm, download, export",
        None,
        sub=tuple(Command(*spec) for spec in RECORD_COMMANDS),
    ),
    Command(
        "capture",
        "triggered captures of variables: arm, disarm, trigger, list, get (CSV), delete",
        None,
        sub=tuple(Command(*spec) for spec in CAPTURE_COMMANDS),
    ),
    Command(
        "scope",
        "trace configurations kept with a set: list, get, save, rm",
        None,
        sub=tuple(Command(*spec) for spec in SCOPE_COMMANDS),
    ),
    Command(
        "opcua",
        "the OPC UA server: status, certs, and its trust list: trust, reject, rm",
        None,
        sub=tuple(Command(*spec) for spec in OPCUA_COMMANDS),
    ),
)


def _add_command(sub, command: Command) -> None:
    p = sub.add_parser(command.name, help=command.help, description=command.help)
    _connection_options(p, top=False)
    if command.sub:
        inner = p.add_subparsers(dest="subcommand", metavar="SUBCOMMAND", required=True)
        for c in command.sub:
            _add_command(inner, c)
        return
    p.set_defaults(func=command.run)
    for flags, kw in command.args:
        p.add_argument(*flags, **kw)
    if command.exclusive:
        group = p.add_mutually_exclusive_group()
        for flags, kw in command.exclusive:
            group.add_argument(*flags, **kw)


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="irpctl",
        description="indurop's command line: the agent's API (/api/v1) from a shell.",
        epilog="exit codes: 0 done, 1 the API refused, 2 usage, 3 the agent or irpd unreachable. "
        "docs/irpctl.md has an example of every command.",
    )
    _connection_options(ap, top=True)
    sub = ap.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for command in COMMANDS:
        _add_command(sub, command)
    return ap


def _token(a) -> str | None:
    """--token, else --token-file, else $INDUROP_TOKEN, else $INDUROP_TOKEN_FILE."""
    if a.token:
        return a.token
    source = a.token_file or (None if os.environ.get("INDUROP_TOKEN") else os.environ.get("INDUROP_TOKEN_FILE"))
    if source:
        try:
            token = Path(source).read_text().strip()
        except OSError as e:
            raise ValueError(
                f"cannot read the token file {source}: {e.strerror}; give --token-file FILE or --token"
            ) from None
        if not token:
            raise ValueError(f"the token file {source} is empty; give --token-file FILE or --token")
        return token
    return os.environ.get("INDUROP_TOKEN") or None


def _hint(e: ApiError, token: str | None) -> str:
    """What to do about an error, when the server's message alone may not say it."""
    if e.status == 0 and "CERTIFICATE_VERIFY_FAILED" in e.message:
        return "give the CA that signed the agent's certificate with --ca FILE (--insecure on a test bench)"
    if e.status == 0:
        return "is indurop-agent running there? --url or $INDUROP_URL say where it is"
    if e.status == 401 and not token:
        return (
            "give a token: --token, --token-file FILE, $INDUROP_TOKEN or $INDUROP_TOKEN_FILE "
            "(the agent's first start wrote an admin token to <data-dir>/admin-token)"
        )
    if e.status == 401:
        return "this agent does not know the token given: check --token / --token-file / $INDUROP_TOKEN*"
    if e.status == 403 and "WebSocket" not in e.message:
        return "use a token with that role (an admin can make one: POST /api/v1/tokens, for a user of that role)"
    if e.status in (404, 405) and e.message.endswith(("Not Found", "Method Not Allowed")):
        return "this agent does not offer that route: is it older than irpctl?"
    if e.status == 503:
        return "the agent is up but irpd does not answer: is irpd running?"
    return ""


def main(argv: list[str] | None = None) -> int:
    ap = build_parser()
    try:
        a = ap.parse_args(argv)
    except SystemExit as e:  # usage errors (2) and --help (0)
        return int(e.code or 0)
    url = a.url or os.environ.get("INDUROP_URL") or DEFAULT_URL
    try:
        token = _token(a)
        client = Client(url, token, ca=a.ca, verify=not a.insecure, timeout=a.timeout)
    except ValueError as e:
        print(f"irpctl: {e}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as e:
        print(f"irpctl: --ca {a.ca}: {e.strerror or e}; give a PEM file of CA certificates", file=sys.stderr)
        return EXIT_USAGE
    try:
        with client:
            return a.func(client, a, Out(a.json))
    except ApiError as e:
        hint = _hint(e, token)
        where = f"{e.status}: " if e.status else ""
        if e.problems:  # every error on a line of its own, as the compiler prints them
            said = e.message.split("\n", 1)[0]
            print("\n".join([f"irpctl: {where}{said}", *map(problem_line, e.problems)]), file=sys.stderr)
        else:
            print(f"irpctl: {where}{e.message}" + (f"\n  ({hint})" if hint else ""), file=sys.stderr)
        return EXIT_UNREACHABLE if e.unreachable else EXIT_REFUSED
    except BrokenPipeError:  # irpctl ... | head
        return EXIT_OK
    except (ValueError, OSError) as e:  # a bad source for upload, a --csv file that cannot be written
        print(f"irpctl: {e}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())

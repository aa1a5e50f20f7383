# cli.py -- the stc command line.  `stc check FILES... [--layout layout.json] [--json]` parses and checks
# a set's ST sources with the standard library; errors print as `file:line:col: error[code]: message`
# (or a JSON list of {file, line, column, code, message}).  Exit 0 when clean, 1 on an error in the
# input, 2 on a usage error.  `stc build` (code generation: emit_cpp.py, emit_glb.py, tasks.py) is
# to come; build() below is where it joins: it starts from check()'s Program.

from __future__ import annotations

import argparse
import json
import sys

from .check import Program, check
from .errors import StError, StErrors
from .layout import load as load_layout
from .parse import parse_file

USAGE_ERROR, INPUT_ERROR = 2, 1


def _arguments() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="stc", description="The IEC 61131-3 Structured Text compiler (docs/st.md).")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    c = sub.add_parser("check", help="parse and check ST sources; print their errors")
    c.add_argument("files", nargs="+", metavar="FILE.st", help="the set's ST sources (one program together)")
    c.add_argument(
        "--layout",
        metavar="layout.json",
        help="the set's glbc layout: AT %%path bindings and qualified access are checked against it",
    )
    c.add_argument(
        "--json", action="store_true", help="print the errors as a JSON list of {file, line, column, code, message}"
    )
    return p


def front(files: list[str], layout_path: str | None) -> Program:
    """Parse + check: the front end every stc command starts with; raises StErrors."""
    errors: list[StError] = []
    units = []
    layout = None
    if layout_path:
        try:
            layout = load_layout(layout_path)
        except StError as e:
            errors.append(e)
    for f in files:
        try:
            units.append(parse_file(f))
        except StError as e:
            errors.append(e)  # one syntax error per file; the other files are still read
    if errors:
        raise StErrors(errors)
    return check(units, layout)


def main(argv: list[str] | None = None) -> int:
    args = _arguments().parse_args(argv)
    try:
        front(args.files, args.layout)
    except StErrors as e:
        _report(e.errors, args.json)
        return INPUT_ERROR
    except StError as e:
        _report([e], args.json)
        return INPUT_ERROR
    if args.json:
        print("[]")
    return 0


def _report(errors: list[StError], as_json: bool) -> None:
    if as_json:
        print(json.dumps([e.as_json() for e in errors], indent=1))
    else:
        for e in errors:
            print(e, file=sys.stderr)

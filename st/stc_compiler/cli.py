# cli.py -- the stc command line.  `stc check FILES... [--layout layout.json] [--json]` parses and checks
# a set's ST sources with the standard library; `stc build -o OUT ...` also writes the layout, the C++,
# module.xml and the modules (build.py); `stc export -o OUT.xml FILES...` writes the sources as one PLCopen XML
# 2.01 project (plcopen/plcopen_export).  Errors print as `file:line:col: error[code]: message` (or a
# JSON list of {file, line, column, code, message}).  Exit 0 when clean, 1 on an error in the input,
# 2 on a usage error.

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .check import Program, check
from .errors import StError, StErrors
from .layout import load as load_layout
from .parse import read_source

USAGE_ERROR, INPUT_ERROR = 2, 1


def _arguments() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="stc", description="The IEC 61131-3 Structured Text compiler (docs/st.md).")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    c = sub.add_parser("check", help="parse and check ST sources; print their errors")
    _sources_and_json(c)
    c.add_argument(
        "--layout",
        metavar="layout.json",
        help="the set's glbc layout: AT %%path bindings and qualified access are checked against it",
    )
    b = sub.add_parser(
        "build",
        help="compile ST sources into the set's layout, C++, module.xml and thread modules (docs/st-compiler.md)",
    )
    _sources_and_json(b)
    b.add_argument("-o", dest="out", required=True, metavar="OUT", help="output folder (created if missing)")
    b.add_argument(
        "--glb", action="append", default=[], metavar="F.glb", help="a .glb file of the set (laid out first; repeat)"
    )
    b.add_argument(
        "--set-layout",
        metavar="SET_LAYOUT.json",
        help="the layout the set's C++ modules were built against (glbc of its .glb files): it stays valid",
    )
    b.add_argument(
        "--previous",
        metavar="RUNNING_LAYOUT.json",
        help="the running layout (irpctl layout -o ...): the variables keep their places (online change)",
    )
    b.add_argument(
        "--module-xml", metavar="HAND.xml", help="the set's hand-written module.xml: its other modules are kept"
    )
    b.add_argument(
        "--cpp-dir",
        metavar="DIR",
        help="where the generated <Instance>.cpp go (default OUT): a build folder, so that OUT holds only the set",
    )
    b.add_argument("--sdk", metavar="PREFIX", help="the indurop SDK: an installed prefix (/usr) or a build folder")
    b.add_argument("--cxx", metavar="CXX", help="the C++ compiler (default: $CXX, else g++)")
    b.add_argument("-j", dest="jobs", type=int, default=0, metavar="N", help="compile N instances at once")
    b.add_argument("--no-compile", action="store_true", help="write the C++ and module.xml but compile nothing")
    x = sub.add_parser("export", help="write the sources as one PLCopen XML 2.01 project (docs/plcopen-xml.md)")
    _sources_and_json(x)
    x.add_argument("-o", dest="out", required=True, metavar="OUT.xml", help="the file written ('-': standard output)")
    x.add_argument("--name", default="indurop", help="the project's name in the file (contentHeader)")
    return p


def _sources_and_json(p: argparse.ArgumentParser) -> None:
    p.add_argument("files", nargs="+", metavar="FILE.st", help="the set's ST sources (one program together)")
    p.add_argument(
        "--json", action="store_true", help="print the errors as a JSON list of {file, line, column, code, message}"
    )


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
            units.append(read_source(f))
        except StError as e:
            errors.append(e)  # one syntax error per file; the other files are still read
        except StErrors as e:  # a PLCopen XML project: an error per POU
            errors.extend(e.errors)
    if errors:
        raise StErrors(errors)
    return check(units, layout)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = _arguments().parse_args(argv)
    if args.command == "build":
        return _run(lambda: _build(args, argv), args.json)
    if args.command == "export":
        return _run(lambda: _export(args), args.json)
    return _run(lambda: front(args.files, args.layout), args.json)


def _run(command, as_json: bool) -> int:
    """Runs a command; its errors reported, 0 or INPUT_ERROR."""
    try:
        command()
    except StErrors as e:
        _report(e.errors, as_json)
        return INPUT_ERROR
    except StError as e:
        _report([e], as_json)
        return INPUT_ERROR
    if as_json:
        print("[]")
    return 0


def _report(errors: list[StError], as_json: bool) -> None:
    if as_json:
        print(json.dumps([e.as_json() for e in errors], indent=1))
    else:
        for e in errors:
            print(e, file=sys.stderr)


def _build(args, argv: list[str]) -> None:
    from .build import Options, build

    opts = Options(
        args.out,
        args.files,
        args.glb,
        args.set_layout,
        args.previous,
        args.module_xml,
        not args.no_compile,
        args.sdk,
        args.cxx,
        args.jobs,
        args.cpp_dir,
    )
    build(opts, argv)


def _export(args) -> None:
    """`stc export`: the project written to args.out (plcopen/ is beside st/, put on the path as glb/ is)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "plcopen"))
    from plcopen_export import export_files

    data = export_files(args.files, name=args.name)
    if args.out == "-":
        sys.stdout.buffer.write(data)
        sys.stdout.flush()
    else:
        Path(args.out).write_bytes(data)

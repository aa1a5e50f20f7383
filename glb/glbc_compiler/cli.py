# cli.py -- the glbc command line: read the .glb files, lay them out (against the running layout
# with --previous, evolve.py), write
# DIR/indurop/generated.h and DIR/layout.json.  Exit 0 on success, 1 on an input error
# (file:line:col diagnostic on stderr), 2 on a usage error.

from __future__ import annotations

import argparse
import os
import re
import sys
import tempfile

from . import __version__
from .emit_header import render as render_header
from .emit_layout import document
from .emit_layout import render as render_layout
from .errors import GlbError, Loc, Source
from .evolve import place, read_previous, summary
from .layout import DEFAULT_MAX_SIZE, build
from .parser import parse_file

USAGE_ERROR, INPUT_ERROR = 2, 1


def _size(text: str) -> int:
    """--max-size: bytes, or with a K, M or G suffix (binary: 16M = 16 MiB)."""
    m = re.fullmatch(r"\s*([0-9]+)\s*([KMG]?)(?:i?B)?\s*", text, re.IGNORECASE)
    if not m or int(m.group(1)) == 0:
        raise argparse.ArgumentTypeError(f"expected a positive number of bytes (e.g. 16777216 or 16M), got '{text}'")
    return int(m.group(1)) * {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30}[m.group(2).upper()]


def _arguments() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="glbc",
        description="Compile .glb shared-variable declarations into DIR/indurop/generated.h (C++20, "
        "for modules) and DIR/layout.json (for irpd, the agent and the UI).",
        epilog="Several files make one segment; their namespaces are kept apart.  See docs/glbc.md.",
    )
    p.add_argument("files", nargs="+", metavar="FILE.glb", help=".glb files, in the order their variables are laid out")
    p.add_argument("-o", dest="out", required=True, metavar="DIR", help="output folder (created if missing)")
    p.add_argument(
        "--max-size",
        type=_size,
        default=DEFAULT_MAX_SIZE,
        metavar="BYTES",
        help=f"limit of the segment's data area (default {DEFAULT_MAX_SIZE}, 16 MiB; K/M/G suffixes allowed)",
    )
    p.add_argument(
        "--previous",
        metavar="FILE",
        help="the layout.json that runs now: its variables keep their offsets and locks, new and changed "
        "ones go where no earlier layout had a variable (docs/glbc.md)",
    )
    p.add_argument("--version", action="version", version=f"glbc {__version__}")
    return p


def _read(name: str) -> Source:
    try:
        with open(name, "rb") as f:
            data = f.read()
    except OSError as e:
        raise GlbError(f"cannot read file: {e.strerror or e}", file=name) from None
    return source(name, data)


def source(name: str, data: bytes) -> Source:
    """A file's bytes as a Source; GlbError pointing at the first byte that is not UTF-8."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        # Point at the offending byte: the text before it decodes.
        head = data[: e.start].decode("utf-8")
        line = head.count("\n") + 1
        col = len(head) - (head.rfind("\n") + 1) + 1
        src = Source.from_text(name, data.decode("utf-8", errors="replace"))
        raise GlbError(
            f"invalid UTF-8 (byte 0x{data[e.start]:02x}): a .glb file is UTF-8 text", Loc(src, line, col)
        ) from None
    return Source.from_text(name, text)


def _write(path: str, text: str) -> None:
    """Writes atomically, and leaves the file alone (and its time stamp) when nothing changed, so
    that a build system does not recompile every module for an unchanged layout."""
    try:
        with open(path, encoding="utf-8") as f:
            if f.read() == text:
                return
    except (OSError, UnicodeDecodeError):
        pass
    folder = os.path.dirname(path)
    fd, tmp = tempfile.mkstemp(prefix=".glbc-", dir=folder)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as f:
            f.write(text)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def compile_files(files: list[str], out: str, max_size: int, argv: list[str], previous: str | None = None) -> dict:
    """Compiles and writes both outputs; returns the layout.json document.  Raises GlbError.  With
    `previous` (a layout.json, read before anything is written: it may be DIR/layout.json itself) the
    layout is laid out against it."""
    prev = read_previous(previous) if previous is not None else None
    layout = build([parse_file(_read(name)) for name in files], max_size)
    if prev is not None:
        place(layout, prev, max_size)
    doc = document(layout)
    header = render_header(layout, doc["hash"], argv)
    try:
        os.makedirs(os.path.join(out, "indurop"), exist_ok=True)
        _write(os.path.join(out, "indurop", "generated.h"), header)
        _write(os.path.join(out, "layout.json"), render_layout(layout))
    except OSError as e:
        raise GlbError(f"cannot write the outputs: {e.strerror or e}", file=e.filename or out) from None
    return doc


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    parser = _arguments()
    args = parser.parse_args(argv)  # exits 2 on a usage error, 0 for --help and --version
    seen: dict[str, str] = {}
    for name in args.files:
        key = os.path.realpath(name)
        if key in seen:
            parser.error(f"'{name}' is given twice (as '{seen[key]}' before)")
        seen[key] = name
    try:
        doc = compile_files(args.files, args.out, args.max_size, argv, args.previous)
    except GlbError as e:
        print(e.format(), file=sys.stderr)
        return INPUT_ERROR
    if doc.get("changes") is not None:
        print(summary(doc["changes"]), file=sys.stderr)
    return 0

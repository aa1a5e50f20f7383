"""st_export.py -- a stored set's programs as one PLCopen XML 2.01 project (docs/plcopen-xml.md
"Export"), written in the agent's own process by the exporter beside the compiler (plcopen/ next to
st/, found from the configured `stc` as st_check finds stc_compiler), from the set's sources as
stored: .st files parsed (and kept) as the Programs page's check does, PLCopen XML files imported
(their POUs keep their drawings)."""

from __future__ import annotations

import functools
import importlib
import sys
from pathlib import Path

from . import st_check


class ExportError(Exception):
    """The set's sources cannot be written as PLCopen XML: the message names what and where."""


@functools.cache
def exporter(stc: Path):
    """plcopen_export, imported from the plcopen/ folder beside stc's st/ (the source tree's, or
    share/indurop/plcopen of the package)."""
    st_check.compiler(stc)  # stc_compiler on the path first: the exporter writes its trees
    folder = Path(stc).resolve().parent.parent / "plcopen"
    if not (folder / "plcopen_export").is_dir():
        raise st_check.CompilerMissing(f"the PLCopen XML exporter is not in {folder}; install indurop's plcopen/")
    if str(folder) not in sys.path:
        sys.path.insert(0, str(folder))
    return importlib.import_module("plcopen_export")


def export(stc: Path, folder: Path, paths: list[str], name: str) -> bytes:
    """The set's sources (paths in `folder`: .st, or PLCopen XML .xml) as PLCopen XML bytes;
    ExportError with stc's words."""
    module = exporter(stc)
    errors = st_check.compiler(stc).errors
    parsed = st_check.parsed(stc)
    texts = {p: (folder / p).read_text(encoding="utf-8", errors="replace") for p in paths if p.lower().endswith(".st")}
    try:
        with st_check._LOCK:
            units = [
                parsed.unit(p, texts[p]) if p in texts else module.import_unit(p, (folder / p).read_bytes())
                for p in sorted(paths)
            ]
            return module.export(units, texts, name=name)
    except errors.StErrors as e:
        raise ExportError("; ".join(str(x) for x in e.errors)) from None
    except errors.StError as e:
        raise ExportError(str(e)) from None

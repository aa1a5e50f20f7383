# export_helpers.py -- helpers for the PLCopen XML export's tests: the compiler's and the importer's
# packages on the path, a canonical dump of a tree (its nodes without places or origins), and the
# independent reader (the PyPI package `plcopen`, xsdata classes of the schema).

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
STC = ROOT / "st" / "stc"
sys.path[:0] = [str(ROOT / "st"), str(ROOT / "plcopen")]

from stc_compiler.errors import Place  # noqa: E402


def dump(node):
    """A tree as nested tuples and lists of its fields that the source wrote (not the ones check.py
    fills), without places: two trees that say the same program dump the same."""
    if isinstance(node, (list, tuple)):
        return [dump(x) for x in node]
    if isinstance(node, dict):
        return {k: dump(v) for k, v in node.items()}
    if isinstance(node, Place):
        return None
    if dataclasses.is_dataclass(node):
        fields = {f.name: dump(getattr(node, f.name)) for f in dataclasses.fields(node) if f.init and f.name != "place"}
        return (type(node).__name__, fields)
    return node


def independent_reader(data: bytes):
    """The file read by the PyPI package `plcopen` (its xsdata model of the TC6 v2.01 schema), every
    element and attribute known to it: the plcopen.Project."""
    from xsdata.formats.dataclass.parsers import XmlParser
    from xsdata.formats.dataclass.parsers.config import ParserConfig

    from plcopen import Project

    return XmlParser(config=ParserConfig(fail_on_unknown_properties=True)).from_bytes(data, Project)


def interface_names(pou) -> list[str]:
    """The variable names of a plcopen.Project's POU interface, in its lists' order."""
    i = pou.interface
    lists = i.local_vars + i.temp_vars + i.input_vars + i.output_vars + i.in_out_vars + i.external_vars + i.global_vars
    return sorted(v.name for vl in lists for v in vl.variable)

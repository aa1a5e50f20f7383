# st_text.py -- Structured Text found inside a PLCopen XML file (an ST body, an SFC transition's
# inline condition, an inline action, an inVariable's expression) parsed by the ST compiler's own
# parser (st.lark, the one grammar), with every node's place moved to where the text is in the XML
# file and tagged with the graphical element it belongs to.

from __future__ import annotations

import dataclasses

from lxml import etree
from stc_compiler import tree as t
from stc_compiler.errors import Place, StError, StErrors
from stc_compiler.parse import parse_text

from .read import XHTML

_WRAP = "PROGRAM P\n"  # the text is parsed as the body of a PROGRAM; its first line is line 2
_TARGET = "X :=\n"  # an expression is parsed as the value of an assignment; it starts on line 3


def text_of(el: etree._Element) -> tuple[str, int]:
    """The text of a <ST>, <inline>, <expression> or formattedText element (its <xhtml:p>, else its own
    text) and the line it starts on."""
    p = el.find(f"{{{XHTML}}}p")
    src = p if p is not None else el
    return (src.text or ""), (src.sourceline or el.sourceline or 1)


def statements(file: str, text: str, line: int, origin: str = "") -> list:
    """ST statements written at `line` of `file` -> tree statements; StError placed in the XML file."""
    unit = _parse(file, f"{_WRAP}{text}\nEND_PROGRAM\n", line - 2, origin)
    return unit.pous[0].body


def expression(file: str, text: str, line: int, origin: str = "") -> t.Expr:
    """An ST expression written at `line` of `file` -> a tree expression."""
    unit = _parse(file, f"{_WRAP}{_TARGET}{text}\n;\nEND_PROGRAM\n", line - 3, origin)
    body = unit.pous[0].body
    if len(body) != 1 or not isinstance(body[0], t.Assign):
        raise StError(Place(file, line, 1, origin), "syntax", f"{text.strip()!r} is not one expression")
    return body[0].value


def _parse(file: str, wrapped: str, shift: int, origin: str) -> t.Unit:
    try:
        unit = parse_text(file, wrapped)
    except StError as e:
        raise _moved_error(e, shift, origin) from None
    except StErrors as e:
        raise StErrors([_moved_error(x, shift, origin) for x in e.errors]) from None
    _move(unit, shift, origin, set())
    return unit


def _moved(p: Place, shift: int, origin: str) -> Place:
    return Place(p.file, max(1, p.line + shift), p.col, origin or p.origin)


def _moved_error(e: StError, shift: int, origin: str) -> StError:
    return StError(_moved(e.place, shift, origin), e.code, e.message)


def _move(node, shift: int, origin: str, seen: set[int]) -> None:
    """Every node's place moved by `shift` lines and given `origin` (the tree is small: a body)."""
    replace_places(node, lambda p: _moved(p, shift, origin), seen)


def replace_places(node, new_place, seen: set[int] | None = None) -> None:
    """Every tree node's place under `node` replaced by new_place(place)."""
    seen = set() if seen is None else seen
    if id(node) in seen:
        return
    seen.add(id(node))
    if isinstance(node, dict):
        node = list(node.values())
    if isinstance(node, (list, tuple)):
        for x in node:
            replace_places(x, new_place, seen)
        return
    if not dataclasses.is_dataclass(node) or isinstance(node, Place):
        return
    for f in dataclasses.fields(node):
        value = getattr(node, f.name)
        if f.name == "place" and isinstance(value, Place):
            object.__setattr__(node, "place", new_place(value))
        elif f.init:  # fields check.py fills later (type, decl, ...) are not the tree's
            replace_places(value, new_place, seen)

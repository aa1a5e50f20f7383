# st_print.py -- Structured Text text of the tree's expressions (initial values, array bounds, task
# parameters) and of a POU's body as written in its source file (comments kept).

from __future__ import annotations

import re

from stc_compiler import tree as t
from stc_compiler.errors import Place, StError
from stc_compiler.parse import strip_comments

# binding strength of the binary operators (st.lark's levels, lowest first); unary binds at 8
_LEVEL = {"OR": 1, "XOR": 2, "AND": 3, "=": 4, "<>": 4, "<": 5, ">": 5, "<=": 5, ">=": 5}
_LEVEL |= {"+": 6, "-": 6, "*": 7, "/": 7, "MOD": 7, "**": 9}
_UNARY = 8


def expr(e) -> str:
    """The ST text of an expression; parentheses where the operators' binding needs them."""
    if isinstance(e, t.Literal):
        return e.text
    if isinstance(e, t.Name):
        return e.name
    if isinstance(e, t.Member):
        return f"{_operand(e.base)}.{e.name}"
    if isinstance(e, t.BitAccess):
        return f"{_operand(e.base)}.{e.bit}"
    if isinstance(e, t.Index):
        return f"{_operand(e.base)}[{', '.join(expr(i) for i in e.indices)}]"
    if isinstance(e, t.Call):
        return f"{expr(e.callee)}({', '.join(_arg(a) for a in e.args)})"
    if isinstance(e, t.Unary):
        space = " " if e.op == "NOT" else ""
        return f"{e.op}{space}{_wrapped(e.operand, _UNARY, False)}"
    if isinstance(e, t.Binary):
        level = _LEVEL[e.op]
        left = _wrapped(e.left, level, False)  # every level associates to the left (** too, in st.lark)
        right = _wrapped(e.right, level, True)
        return f"{left} {e.op} {right}"
    raise StError(e.place, "export", f"an expression of kind {type(e).__name__} has no ST text")


def _level(e) -> int:
    if isinstance(e, t.Binary):
        return _LEVEL[e.op]
    if isinstance(e, t.Unary):
        return _UNARY
    return 10


def _wrapped(e, level: int, strict: bool) -> str:
    """e as an operand at `level`: parenthesised when it binds less (or as much, on the side where
    the operator does not associate)."""
    inner = _level(e)
    text = expr(e)
    return f"({text})" if inner < level or (strict and inner == level) else text


def _operand(e) -> str:
    return expr(e) if _level(e) == 10 else f"({expr(e)})"


def _arg(a: t.Arg) -> str:
    if a.output:
        neg = "NOT " if a.negated else ""
        return f"{neg}{a.name} => {expr(a.value) if a.value is not None else ''}".rstrip()
    return f"{a.name} := {expr(a.value)}" if a.name else expr(a.value)


# ---- a POU's body as written -------------------------------------------------------------------

_END = {"PROGRAM": "END_PROGRAM", "FUNCTION_BLOCK": "END_FUNCTION_BLOCK", "FUNCTION": "END_FUNCTION"}
_STRING = re.compile(r"'(?:\$.|[^'$])*'|\"(?:\$.|[^\"$])*\"", re.S)


def _offset(text: str, place: Place) -> int:
    at = 0
    for _ in range(place.line - 1):
        at = text.index("\n", at) + 1
    return at + place.col - 1


def body_text(pou: t.Pou, text: str) -> str:
    """The text of `pou`'s statements in its source file `text`: from after its last END_VAR (or its
    first statement) to its END_PROGRAM/END_FUNCTION_BLOCK/END_FUNCTION, comments included."""
    clean = strip_comments(pou.place.file, text)
    clean = _STRING.sub(lambda m: " " * len(m.group()), clean)  # a keyword inside a string is no keyword
    start = _offset(text, pou.place)
    end_kw = re.compile(rf"\b{_END[pou.kind]}\b", re.I)
    m = end_kw.search(clean, start)
    if m is None:
        raise StError(pou.place, "export", f"{pou.name}: its {_END[pou.kind]} is not in {pou.place.file}")
    end = m.start()
    var_ends = [v.end() for v in re.finditer(r"\bEND_VAR\b", clean[start:end], re.I)]
    if var_ends:
        begin = start + var_ends[-1]
    elif pou.body:
        begin = _offset(text, pou.body[0].place)
    else:
        begin = end
    body = text[begin:end]
    first = body.find("\n")
    if first >= 0 and not body[:first].strip():
        body = body[first + 1 :]  # the rest of END_VAR's line
    return body.strip("\n").rstrip() + "\n" if body.strip() else ""

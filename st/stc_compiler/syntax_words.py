# syntax_words.py -- lark's terminal names in words for syntax errors ("expected ';' after the
# assignment", "expected a name"), the spellings read from the grammar itself.

from __future__ import annotations

import functools

from lark import Token, Tree

# The regular-expression terminals of st.lark, in words.
_WORDS = {
    "IDENT": "a name",
    "INTEGER": "a number",
    "BASED_INTEGER": "a number",
    "REAL_NUMBER": "a number",
    "STRING_LITERAL": "a string",
    "WSTRING_LITERAL": "a string",
    "DURATION": "a duration",
    "DATE_LITERAL": "a date",
    "TOD_LITERAL": "a time of day",
    "DT_LITERAL": "a date and time",
    "ADDRESS": "an address such as %PLC_ROBOT.PLC_IN.Start",
    "$END": "the end of the file",
}
_EXPRESSION_STARTS = {"IDENT", "INTEGER", "LPAR", "MINUS"}
_STATEMENT_STARTS = {"IF", "FOR", "WHILE", "CASE", "REPEAT"}
_OPERATORS = {
    "PLUS",
    "MINUS",
    "STAR",
    "SLASH",
    "POW",
    "MOD",
    "AND",
    "AMP",
    "OR",
    "XOR",
    "EQ",
    "NE",
    "LT",
    "GT",
    "LE",
    "GE",
}


@functools.cache
def _spellings() -> dict[str, str]:
    from .parse import parser

    out = {}
    for term in parser().terminals:
        if term.pattern.type == "str":
            out[term.name] = term.pattern.value.upper()
    return out


def word(name: str) -> str:
    if name in _WORDS:
        return _WORDS[name]
    spelled = _spellings().get(name)
    return f"'{spelled}'" if spelled else name.lower()


def describe_expected(expected) -> str:
    names = set(expected or ())
    ends = sorted(
        word(n) for n in names if _spellings().get(n, "").startswith("END_") or n in ("UNTIL", "ELSE", "ELSIF")
    )
    if _STATEMENT_STARTS <= names:
        return "a statement" + (" or " + " or ".join(ends) if ends else "")
    if _EXPRESSION_STARTS <= names:
        return "an expression"
    if "RPAR" in names and names - {"RPAR", "COMMA"} <= _OPERATORS:  # inside ( ): what closes it
        return "',' or ')'" if "COMMA" in names else "')'"
    operators = names & _OPERATORS
    if len(operators) >= 5:  # what may end an expression here, or an operator continuing it
        rest = sorted({word(n) for n in names - _OPERATORS})
        return " or ".join(rest + ["an operator"])
    words = sorted({word(n) for n in names})
    if not words:
        return "nothing more"
    if len(words) > 6:
        return ", ".join(words[:6]) + " or others"
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " or " + words[-1]


OPENERS = {
    "PROGRAM": "END_PROGRAM",
    "FUNCTION_BLOCK": "END_FUNCTION_BLOCK",
    "FUNCTION": "END_FUNCTION",
    "IF": "END_IF",
    "CASE": "END_CASE",
    "FOR": "END_FOR",
    "WHILE": "END_WHILE",
    "REPEAT": "END_REPEAT",
    "STRUCT": "END_STRUCT",
    "TYPE": "END_TYPE",
    "CONFIGURATION": "END_CONFIGURATION",
    "RESOURCE": "END_RESOURCE",
}


def open_block(stack: list) -> Token | None:
    """The keyword token of the innermost block still open (its END_ not yet read)."""
    for item in reversed(stack):
        if isinstance(item, Token) and item.type != "IDENT" and item.value.upper() in OPENERS:
            return item
        if isinstance(item, Tree) and item.data == "var_kind":
            return None
    return None


def describe_context(stack: list) -> str:
    """What a missing ';' should end, from the parser's stack: 'the assignment', 'the call', ..."""
    depth = 0
    for i in range(len(stack) - 1, -1, -1):
        item = stack[i]
        if isinstance(item, Token):
            value = item.value.upper()
            if value == ")":
                depth += 1
                continue
            if value == "(" and depth > 0:
                depth -= 1
                if depth == 0 and i > 0 and isinstance(stack[i - 1], Tree) and stack[i - 1].data == "variable":
                    return "the call"
                continue
            if depth:
                continue
            if value == ":=":
                before = stack[i - 1] if i > 0 else None
                if isinstance(before, Tree) and before.data == "variable":
                    return "the assignment"
                if isinstance(before, Token) and before.type == "IDENT":
                    return "the initial value" if i >= 2 and stack[i - 2] != "(" else "the parameter"
                return "the initial value"
            if value in ("RETURN", "EXIT", "CONTINUE", "END_IF", "END_CASE", "END_FOR", "END_WHILE", "END_REPEAT"):
                return value
            if value == ":":
                return "the declaration"
        elif isinstance(item, Tree):
            if item.data == "call":
                return "the call"
            if item.data in ("stmt_list", "var_block"):
                break
    last = stack[-1]
    return f"'{last.value}'" if isinstance(last, Token) else "the statement"

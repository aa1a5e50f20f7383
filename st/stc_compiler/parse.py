# parse.py -- Structured Text source -> the compiler's tree (tree.py): reads the bytes (size, NUL and
# UTF-8 checked), blanks comments and pragmas, parses with st.lark (LALR), limits nesting, builds the
# tree with a place on every node; a syntax error becomes a StError naming what was expected.

from __future__ import annotations

import functools
import os
import re
import sys
from pathlib import Path

from lark import Lark, Token, Tree
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from . import literals
from . import tree as t
from .errors import Place, StError
from .syntax_words import OPENERS, describe_context, describe_expected, open_block, word

GRAMMAR = Path(__file__).resolve().parent.parent / "st.lark"
MAX_SOURCE_BYTES = 4 << 20  # 4 MiB: some 100,000 lines; a generated 10,000-line program is ~400 KB
MAX_DEPTH = 400  # nesting of the syntax tree (expressions and statements); beyond it: an error
_RECURSION_LIMIT = 8 * MAX_DEPTH + 2000  # what the recursive passes over a tree that deep need


@functools.cache
def parser() -> Lark:
    return Lark(GRAMMAR.read_text(), parser="lalr", lexer="basic", propagate_positions=True, maybe_placeholders=True)


def ensure_recursion_limit() -> None:
    """The passes recurse along the tree; MAX_DEPTH bounds the tree, this makes room for it."""
    if sys.getrecursionlimit() < _RECURSION_LIMIT:
        sys.setrecursionlimit(_RECURSION_LIMIT)


# ---- reading ----------------------------------------------------------------------------------


def _too_large(name: str, size: int) -> StError:
    return StError(
        Place(name, 1, 1),
        "too-large",
        f"the file has {size} bytes, more than the limit of {MAX_SOURCE_BYTES} bytes; split it into several files",
    )


def decode(name: str, data: bytes) -> str:
    """The text of a source file, or a StError saying why it cannot be one."""
    if len(data) > MAX_SOURCE_BYTES:
        raise _too_large(name, len(data))
    nul = data.find(b"\0")
    if nul >= 0:
        line = data.count(b"\n", 0, nul) + 1
        col = nul - (data.rfind(b"\n", 0, nul) + 1) + 1
        raise StError(Place(name, line, col), "encoding", "a NUL byte; a source file is text: remove it")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        line = data.count(b"\n", 0, e.start) + 1
        col = len(data[data.rfind(b"\n", 0, e.start) + 1 : e.start].decode("utf-8", "replace")) + 1
        raise StError(Place(name, line, col), "encoding", "bytes that are not UTF-8; save the file as UTF-8") from None
    return text.removeprefix("\ufeff")


def read(path: str) -> str:
    try:
        with open(path, "rb") as f:
            size = os.fstat(f.fileno()).st_size
            if size > MAX_SOURCE_BYTES:
                raise _too_large(path, size)
            data = f.read(MAX_SOURCE_BYTES + 1)
    except OSError as e:
        raise StError(Place(path, 1, 1), "file", f"cannot read the file: {e.strerror}") from None
    return decode(path, data)


# ---- comments and pragmas ---------------------------------------------------------------------

_INTERESTING = re.compile(r"\(\*|\*\)|/\*|//|\{|'|\"")
_STRING_END = {"'": re.compile(r"(\$.|[^'$\n])*'"), '"': re.compile(r'(\$.|[^"$\n])*"')}


def strip_comments(name: str, text: str, pragmas: list[tuple[int, int, str]] | None = None) -> str:
    """The text with (* *) (nested), /* */, // comments and { } pragmas replaced by spaces (line
    ends kept, so places stay right); strings are left alone.  Each pragma's (start, end, text
    inside the braces) is appended to `pragmas` when given."""
    out: list[str] = []
    pos = 0
    n = len(text)
    while True:
        m = _INTERESTING.search(text, pos)
        if not m:
            out.append(text[pos:])
            return "".join(out)
        start, tok = m.start(), m.group()
        out.append(text[pos:start])
        if tok in "'\"":
            s = _STRING_END[tok].match(text, start + 1)
            end = s.end() if s else start + 1  # an unclosed string: the lexer reports it
            out.append(text[start:end])
            pos = end
            continue
        if tok == "*)":
            raise StError(
                _place_of(name, text, start), "syntax", "'*)' closes no comment; remove it or open one with '(*'"
            )
        if tok == "(*":
            end = _nested_end(text, start)
        elif tok == "/*":
            end = text.find("*/", start + 2)
            end = -1 if end < 0 else end + 2
        elif tok == "//":
            end = text.find("\n", start)
            end = n if end < 0 else end
        else:  # a pragma
            end = text.find("}", start)
            end = -1 if end < 0 else end + 1
        if end < 0:
            what = {"(*": "comment '(*'", "/*": "comment '/*'", "{": "pragma '{'"}[tok]
            closer = {"(*": "*)", "/*": "*/", "{": "}"}[tok]
            raise StError(
                _place_of(name, text, start), "syntax", f"the {what} is never closed; close it with '{closer}'"
            )
        if tok == "{" and pragmas is not None:
            pragmas.append((start, end, text[start + 1 : end - 1]))
        out.append(re.sub(r"[^\n]", " ", text[start:end]))
        pos = end


_COMMENT_MARK = re.compile(r"\(\*|\*\)")


def _nested_end(text: str, start: int) -> int:
    depth = 0
    for m in _COMMENT_MARK.finditer(text, start):
        depth += 1 if m.group() == "(*" else -1
        if depth == 0:
            return m.end()
    return -1


def _place_of(name: str, text: str, offset: int) -> Place:
    line = text.count("\n", 0, offset) + 1
    return Place(name, line, offset - (text.rfind("\n", 0, offset) + 1) + 1)


# ---- parsing ----------------------------------------------------------------------------------


def parse_text(name: str, text: str) -> t.Unit:
    """One source file's text -> its Unit; raises StError."""
    size = len(text.encode("utf-8", "surrogatepass"))
    if size > MAX_SOURCE_BYTES:
        raise _too_large(name, size)
    if "\0" in text:
        decode(name, text.encode("utf-8", "surrogatepass"))
    pragmas: list[tuple[int, int, str]] = []
    clean = strip_comments(name, text, pragmas)
    try:
        lark_tree = parser().parse(clean)
    except UnexpectedInput as e:
        raise _syntax_error(name, clean, e) from None
    _check_depth(name, lark_tree)
    ensure_recursion_limit()
    unit = Builder(name).unit(lark_tree)
    _attach_externs(name, clean, pragmas, unit)
    return unit


# ---- {extern 'cpp::name'}: a declaration implemented in C++ (docs/st.md "C++ implementations")

_EXTERN = re.compile(r"\s*extern\b(.*)$", re.S | re.I)
_EXTERN_NAME = re.compile(
    r"\s*'([A-Za-z_][A-Za-z0-9_]*(?:::[A-Za-z_][A-Za-z0-9_]*)*)"
    r"(?:\(\s*([A-Za-z_][A-Za-z0-9_]*(?:\s*,\s*[A-Za-z_][A-Za-z0-9_]*)*)?\s*\))?'\s*$"
)
_EXTERN_TARGET = re.compile(r"\s*(FUNCTION_BLOCK|FUNCTION|TYPE)\b", re.I)


def _attach_externs(name: str, clean: str, pragmas: list[tuple[int, int, str]], unit: t.Unit) -> None:
    """Sets `extern` on the FUNCTION_BLOCK, FUNCTION or TYPE that an {extern '...'} pragma stands
    right before; other pragmas stay ignored (as other compilers' attributes)."""
    for start, end, body in pragmas:
        m = _EXTERN.match(body)
        if not m:
            continue
        place = _place_of(name, clean, start)
        cpp = _EXTERN_NAME.match(m.group(1))
        if not cpp:
            raise StError(
                place,
                "syntax",
                "an extern pragma names one C++ function or type: {extern 'namespace::Name'}, "
                "or for a STRUCT a C++ function of its members: {extern 'namespace::make(a, b)'}",
            )
        target = _EXTERN_TARGET.match(clean, end)
        node = None
        if target:
            at = _place_of(name, clean, target.start(1))
            if target.group(1).upper() == "TYPE":
                node = next((d for d in unit.types if (d.place.line, d.place.col) > (at.line, at.col)), None)
            else:
                node = next((p for p in unit.pous if (p.place.line, p.place.col) == (at.line, at.col)), None)
        if node is None:
            raise StError(
                place,
                "syntax",
                "{extern '...'} must stand right before the FUNCTION_BLOCK, FUNCTION or TYPE it implements; move it there",
            )
        args = cpp.group(0).strip().endswith(")'")
        if args and not isinstance(node, t.TypeDecl):
            raise StError(
                place, "syntax", "only a STRUCT's extern lists arguments; name the C++ struct or function alone"
            )
        node.extern = cpp.group(1)
        if args:
            node.extern_args = [a.strip() for a in (cpp.group(2) or "").split(",") if a.strip()]


def parse_file(path: str) -> t.Unit:
    return parse_text(path, read(path))


def read_source(path: str) -> t.Unit:
    """A source file of a set -> its Unit: a `.xml` file is a PLCopen XML project, imported by
    plcopen/plcopen_import (put on sys.path like glb/ is, and imported only when one is given), any
    other file is ST.  build.front and cli.front read every source through this."""
    if path.lower().endswith(".xml"):
        folder = str(Path(__file__).resolve().parents[2] / "plcopen")
        if folder not in sys.path:
            sys.path.insert(0, folder)
        from plcopen_import.project import read_unit

        return read_unit(path)
    return parse_file(path)


def _check_depth(name: str, root: Tree) -> None:
    stack = [(root, 1)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_DEPTH:
            line, col = _first_place(node)
            raise StError(
                Place(name, line, col),
                "too-deep",
                f"nested deeper than {MAX_DEPTH} levels; split the expression or the statements into smaller ones",
            )
        for c in node.children:
            if isinstance(c, Tree):
                stack.append((c, depth + 1))
            elif isinstance(c, Token) and c.type == "IDENT" and c.value.upper() in keywords():
                raise StError(Place(name, c.line, c.column), "syntax", f"'{c.value}' is a keyword; choose another name")


def _first_place(node: Tree | Token) -> tuple[int, int]:
    if isinstance(node, Token):
        return node.line or 1, node.column or 1
    meta = node.meta
    return (getattr(meta, "line", 1), getattr(meta, "column", 1)) if not meta.empty else (1, 1)


def _syntax_error(name: str, text: str, e: UnexpectedInput) -> StError:
    if isinstance(e, UnexpectedCharacters):
        ch = text[e.pos_in_stream] if e.pos_in_stream < len(text) else ""
        if ch in "'\"":
            message = "the string is not closed on its line; end it with " + ch
        else:
            message = f"unexpected character {ch!r}; it is not part of Structured Text here"
        return StError(Place(name, e.line, e.column), "syntax", message)
    if isinstance(e, UnexpectedEOF):
        return StError(
            _place_of(name, text, len(text)),
            "syntax",
            f"unexpected end of the file; expected {describe_expected(e.expected)}",
        )
    assert isinstance(e, UnexpectedToken)
    tok = e.token
    stack = list(getattr(e.state, "value_stack", []) or [])
    accepted = _accepted(e)
    expected = describe_expected(accepted)
    at_end = tok.type == "$END"
    prev_line = _end_place(stack[-1])[0] if stack else 0
    ends_statement = isinstance(stack[-1], Tree) or stack[-1].value != ";" if stack else False
    if ends_statement and "SEMICOLON" in accepted and (at_end or tok.line > prev_line):
        # `x := 1` and a new line: point just after what the ';' should end
        line, col = _end_place(stack[-1])
        return StError(Place(name, line, col), "syntax", f"expected ';' after {describe_context(stack)}")
    opener = open_block(stack)
    if opener is not None and OPENERS[opener.value.upper()] in {word(n).strip("'") for n in accepted}:
        closer = OPENERS[opener.value.upper()]
        if at_end or (tok.value.upper().startswith("END_") and tok.type != "IDENT"):
            found = "the end of the file" if at_end else f"'{tok.value}'"
            message = f"expected {closer} to close the {opener.value.upper()} of line {opener.line}, found {found}"
            place = _place_of(name, text, len(text)) if at_end else Place(name, tok.line, tok.column)
            return StError(place, "syntax", message)
    if at_end:
        return StError(_place_of(name, text, len(text)), "syntax", f"unexpected end of the file; expected {expected}")
    message = f"expected {expected}, found {_token_words(tok)}"
    if tok.value == "=" and "':='" in {word(n) for n in accepted}:
        message = "expected ':=' to assign (or to pass a parameter), found '='; '=' compares"
    if _is_keyword(tok) and "IDENT" in accepted and "INTEGER" not in accepted:  # where a name, not an expression, goes
        message += f"; '{tok.value}' is a keyword: choose another name"
    return StError(Place(name, tok.line, tok.column), "syntax", message)


def _accepted(e: UnexpectedToken) -> set[str]:
    """The tokens the parser could take at the error (exact, unlike LALR's merged lookahead set)."""
    try:
        return set(e.interactive_parser.accepts()) - {"$END"} or set(e.expected)
    except Exception:  # noqa: BLE001 (only the wording of the message depends on it)
        return set(e.expected or ())


def _semicolon_only(expected: set[str]) -> bool:
    # ';' is what ends the construct; the rest would continue an expression
    return "SEMICOLON" in expected and not ({"END_VAR", "END_STRUCT", "COLON"} & expected)


def _end_place(node: Tree | Token) -> tuple[int, int]:
    if isinstance(node, Token):
        return node.end_line or node.line, node.end_column or node.column
    if node.meta.empty:
        return 1, 1
    return node.meta.end_line, node.meta.end_column


def _is_keyword(tok: Token) -> bool:
    return tok.type != "$END" and tok.value.upper() in keywords()


@functools.cache
def keywords() -> frozenset[str]:
    """The grammar's keywords (upper-case): no name may be spelled as one."""
    return frozenset(
        term.pattern.value.upper()
        for term in parser().terminals
        if term.pattern.type == "str" and re.fullmatch(r"[A-Za-z_]+", term.pattern.value)
    )


def _token_words(tok: Token) -> str:
    if _is_keyword(tok):
        return f"'{tok.value.upper()}'"
    if tok.type == "IDENT":
        return f"the name '{tok.value}'"
    return f"'{tok.value}'"


# ---- lark tree -> tree.py ---------------------------------------------------------------------


class Builder:
    """Builds tree.py nodes from lark's tree, one method per grammar rule."""

    def __init__(self, file: str) -> None:
        self.file = file

    def place(self, node: Tree | Token) -> Place:
        line, col = _first_place(node)
        return Place(self.file, line, col)

    def error(self, node: Tree | Token, code: str, message: str) -> StError:
        return StError(self.place(node), code, message)

    # -- top level

    def unit(self, root: Tree) -> t.Unit:
        unit = t.Unit(Place(self.file, 1, 1))
        for item in root.children:
            kind = item.data
            if kind in ("program", "function_block", "function"):
                unit.pous.append(self.pou(item))
            elif kind == "type_decl":
                unit.types.extend(self.type_def(d) for d in item.children)
            elif kind == "configuration":
                unit.configurations.append(self.configuration(item))
            else:  # a top-level var_block: a global variable list
                decls = self.var_block(item)
                for d in decls:
                    if d.kind != "VAR_GLOBAL":
                        raise StError(d.place, "syntax", "only VAR_GLOBAL may stand outside a POU; put it in one")
                unit.globals.extend(decls)
        return unit

    def pou(self, node: Tree) -> t.Pou:
        kind = node.data.upper()
        name_tok, rest = node.children[0], node.children[1:]
        returns = None
        if kind == "FUNCTION":
            returns, rest = rest[0], rest[1:]
            returns = self.type_spec(returns) if returns is not None else None
        decls: list[t.VarDecl] = []
        for block in rest[:-1]:
            decls.extend(self.var_block(block))
        return t.Pou(self.place(node), kind, str(name_tok), decls, self.stmt_list(rest[-1]), returns)

    def var_block(self, node: Tree) -> list[t.VarDecl]:
        kind_tree, *rest = node.children
        kind = {
            "k_var": "VAR",
            "k_input": "VAR_INPUT",
            "k_output": "VAR_OUTPUT",
            "k_in_out": "VAR_IN_OUT",
            "k_temp": "VAR_TEMP",
            "k_global": "VAR_GLOBAL",
            "k_external": "VAR_EXTERNAL",
        }[kind_tree.data]
        quals = {q.data for q in rest if q.data.startswith("q_")}
        decls: list[t.VarDecl] = []
        for d in rest:
            if d.data == "var_decl":
                decls.extend(self.var_decl(d, kind, quals))
        return decls

    def var_decl(self, node: Tree, kind: str, quals: set[str]) -> list[t.VarDecl]:
        names, location, spec, init = node.children
        loc = str(location.children[0]) if location is not None else None
        spec_node = self.type_spec(spec)
        init_node = self.initializer(init) if init is not None else None
        return [
            t.VarDecl(
                self.place(n),
                str(n),
                kind,
                spec_node,
                init_node,
                constant="q_constant" in quals,
                retain="q_retain" in quals,
                persistent="q_persistent" in quals,
                location=loc,
            )
            for n in names.children
        ]

    def type_def(self, node: Tree) -> t.TypeDecl:
        name, spec, init = node.children
        return t.TypeDecl(
            self.place(name), str(name), self.type_spec(spec), self.initializer(init) if init is not None else None
        )

    def type_spec(self, node: Tree):
        p = self.place(node)
        kind = node.data
        c = node.children
        if kind == "type_ref":
            return t.TypeRef(p, str(c[0]))
        if kind == "string_type":
            return t.StringSpec(p, str(c[0]).upper() == "WSTRING", self.expr(c[1]) if c[1] is not None else None)
        if kind == "array_type":
            ranges = [(self.expr(r.children[0]), self.expr(r.children[1])) for r in c[:-1]]
            return t.ArraySpec(p, ranges, self.type_spec(c[-1]))
        if kind == "subrange_type":
            return t.SubrangeSpec(p, self.type_spec(c[0]), self.expr(c[1]), self.expr(c[2]))
        if kind == "enum_type":
            return t.EnumSpec(
                p,
                [
                    t.EnumValue(
                        self.place(v),
                        str(v.children[0]),
                        self.expr(v.children[1]) if v.children[1] is not None else None,
                    )
                    for v in c
                ],
            )
        if kind == "struct_type":
            members: list[t.VarDecl] = []
            for m in c:
                names, spec, init = m.children
                spec_node = self.type_spec(spec)
                init_node = self.initializer(init) if init is not None else None
                members.extend(t.VarDecl(self.place(n), str(n), "MEMBER", spec_node, init_node) for n in names.children)
            return t.StructSpec(p, members)
        raise self.error(node, "syntax", f"unknown type form {kind}")  # pragma: no cover (grammar and builder agree)

    def initializer(self, node):
        if isinstance(node, Tree) and node.data == "array_init":
            items = []
            for item in node.children:
                if isinstance(item, Tree) and item.data == "repeat_item":
                    count, value = item.children
                    n = literals.integer(str(count))
                    items.append(
                        t.ArrayItem(self.place(item), n, self.initializer(value) if value is not None else None)
                    )
                else:
                    items.append(t.ArrayItem(self.place(item), None, self.initializer(item)))
            return t.ArrayInit(self.place(node), items)
        if isinstance(node, Tree) and node.data == "struct_init":
            fields = [(str(f.children[0]), self.place(f), self.initializer(f.children[1])) for f in node.children]
            return t.StructInit(self.place(node), fields)
        return self.expr(node)

    # -- configuration

    def configuration(self, node: Tree) -> t.Configuration:
        name, *items = node.children
        conf = t.Configuration(self.place(node), str(name), [], [])
        direct = t.Resource(self.place(node), str(name), None, [], [], [])
        for item in items:
            if item.data == "resource":
                conf.resources.append(self.resource(item))
            elif item.data == "var_block":
                conf.vars.extend(self.var_block(item))
            else:
                self.resource_item(direct, item)
        if direct.tasks or direct.programs:
            conf.resources.insert(0, direct)
        return conf

    def resource(self, node: Tree) -> t.Resource:
        name, on, *items = node.children
        res = t.Resource(self.place(node), str(name), str(on) if on is not None else None, [], [], [])
        for item in items:
            self.resource_item(res, item)
        return res

    def resource_item(self, res: t.Resource, item: Tree) -> None:
        if item.data == "var_block":
            res.vars.extend(self.var_block(item))
        elif item.data == "task":
            name, *params = item.children
            res.tasks.append(
                t.Task(
                    self.place(item),
                    str(name),
                    {str(p.children[0]).upper(): (self.place(p), self.expr(p.children[1])) for p in params},
                )
            )
        else:  # program_config
            retain, name, task, type_name, *args = item.children
            res.programs.append(
                t.ProgramConfig(
                    self.place(item),
                    str(name),
                    str(task) if task is not None else None,
                    str(type_name),
                    None if retain is None else retain.data == "q_retain",
                    [self.arg(a) for a in args if a is not None],
                )
            )

    # -- statements

    def stmt_list(self, node: Tree) -> list:
        return [s for s in (self.statement(c) for c in node.children) if s is not None]

    def statement(self, node: Tree):
        p = self.place(node)
        kind = node.data
        c = node.children
        if kind == "assignment":
            return t.Assign(p, self.expr(c[0]), self.expr(c[1]))
        if kind == "call_stmt":
            return t.CallStmt(p, self.expr(c[0]))
        if kind == "if_stmt":
            cond, body, *rest = c
            branches = [(self.expr(cond), self.stmt_list(body))]
            for e in rest[:-1]:
                branches.append((self.expr(e.children[0]), self.stmt_list(e.children[1])))
            return t.If(p, branches, self.stmt_list(rest[-1]) if rest[-1] is not None else None)
        if kind == "case_stmt":
            return self.case(node)
        if kind == "for_stmt":
            var, start, end, step, body = c
            return t.For(
                p,
                t.Name(self.place(var), str(var)),
                self.expr(start),
                self.expr(end),
                self.expr(step) if step is not None else None,
                self.stmt_list(body),
            )
        if kind == "while_stmt":
            return t.While(p, self.expr(c[0]), self.stmt_list(c[1]))
        if kind == "repeat_stmt":
            return t.Repeat(p, self.stmt_list(c[0]), self.expr(c[1]))
        if kind == "exit_stmt":
            return t.Exit(p)
        if kind == "continue_stmt":
            return t.Continue(p)
        if kind == "return_stmt":
            return t.Return(p)
        return None  # an empty statement

    def case(self, node: Tree) -> t.Case:
        selector, *parts = node.children
        orelse = parts.pop()
        branches: list[t.CaseBranch] = []
        for part in parts:
            if part.data == "case_labels":
                labels = [
                    t.CaseLabel(
                        self.place(lab),
                        self.expr(lab.children[0]),
                        self.expr(lab.children[1]) if lab.children[1] is not None else None,
                    )
                    for lab in part.children
                ]
                branches.append(t.CaseBranch(self.place(part), labels, []))
                continue
            stmt = self.statement(part)
            if stmt is None:
                continue
            if not branches:
                raise self.error(
                    part, "syntax", "a statement before the first CASE label; write a label such as `1:` before it"
                )
            branches[-1].body.append(stmt)
        return t.Case(
            self.place(node), self.expr(selector), branches, self.stmt_list(orelse) if orelse is not None else None
        )

    # -- expressions

    def expr(self, node) -> t.Expr:
        if isinstance(node, Token):  # pragma: no cover (every literal has a rule)
            raise self.error(node, "syntax", f"unexpected '{node}'")
        p = self.place(node)
        kind = node.data
        c = node.children
        if kind == "binop":
            op = str(c[1]).upper()
            return t.Binary(p, "AND" if op == "&" else op, self.expr(c[0]), self.expr(c[2]))
        if kind == "unop":
            return t.Unary(p, str(c[0]).upper(), self.expr(c[1]))
        if kind == "variable":
            return self.variable(node)
        if kind == "call":
            return t.Call(p, self.variable(c[0]), [self.arg(a) for a in c[1:] if a is not None])
        if kind == "op_call":
            callee = t.Name(self.place(c[0]), str(c[0]).upper())
            return t.Call(p, callee, [self.arg(a) for a in c[1:] if a is not None])
        return self.literal(node)

    def variable(self, node: Tree) -> t.Expr:
        first, *selectors = node.children
        sp = self.place(first)  # `a.b[1].3` and its parts start where the variable starts
        e: t.Expr = t.Name(sp, str(first))
        for s in selectors:
            if s.data == "field":
                e = t.Member(sp, e, str(s.children[0]))
            elif s.data == "bit":
                e = t.BitAccess(sp, e, literals.integer(str(s.children[0])))
            elif s.data == "index":
                e = t.Index(sp, e, [self.expr(i) for i in s.children])
            else:
                raise self.error(
                    s, "unsupported", "pointers (^) are not supported; use VAR_IN_OUT to pass a variable by reference"
                )
        return e

    def arg(self, node: Tree) -> t.Arg:
        p = self.place(node)
        if node.data == "arg_in":
            return t.Arg(p, str(node.children[0]), self.expr(node.children[1]))
        if node.data == "arg_out":
            neg, name, target = node.children
            return t.Arg(
                p, str(name), self.expr(target) if target is not None else None, output=True, negated=neg is not None
            )
        return t.Arg(p, None, self.expr(node.children[0]))

    def literal(self, node: Tree) -> t.Expr:
        try:
            return literals.build(self.place(node), node)
        except ValueError as e:
            raise self.error(node, "literal", str(e)) from None

# parser.py -- tokens of one .glb file -> FileSyntax.
#
# The grammar (docs/glbc.md has it with examples):
#   file        := { namespace | define | declaration | ';' }
#   namespace   := 'namespace' NAME { ('.' | '::') NAME } END
#   define      := '#' 'define' NAME ['-'] INTEGER  (ends at the end of its line)
#   declaration := [ 'retain' | 'persistent' ] type NAME { '[' size ']' } END   (the qualifier:
#                  top-level declarations only)
#   type        := scalar-words | 'struct' '{' { declaration | define | ';' } '}'
#   size        := INTEGER | NAME-of-a-#define
#   END         := ';' | end of line | end of file | (inside a struct) before '}'
# A line end inside an unfinished declaration is white space (`struct` / `{` on the next line);
# once the declaration is complete it ends it (Figure 11's `short I0 // comment`).

from __future__ import annotations

import re

from . import names
from .errors import GlbError, Loc, Note, Source
from .lexer import EOF, IDENT, NEWLINE, NUMBER, PUNCT, Token, tokenize
from .scalars import COMBINING_WORDS, SINGLE_WORD, combine
from .syntax import Decl, DefineStmt, Dim, FileSyntax, NamespaceStmt, ScalarSpec, StructSpec

MAX_DIM = 16_777_216  # the largest array dimension
MAX_DEFINE = 2**63 - 1  # a #define becomes a C++ `long`
MAX_NESTING = 32  # structs inside structs
QUALIFIERS = ("retain", "persistent")  # kept across restarts by irpd (docs/retain.md)

_DECIMAL = re.compile(r"(0|[1-9][0-9]*)([uU]?(?:ll|LL|l|L)?|(?:ll|LL|l|L)[uU])\Z")
_HEX = re.compile(r"0[xX]([0-9a-fA-F]+)([uU]?(?:ll|LL|l|L)?|(?:ll|LL|l|L)[uU])\Z")
_OCTAL = re.compile(r"0[0-9]+[uUlL]*\Z")

_TYPE_HELP = (
    "a scalar type (int8_t … uint64_t, char, short, int, long, unsigned …, float, double, bool, BOOL) or 'struct'"
)


def parse_integer(tok: Token, what: str) -> int:
    """The value of an integer literal token (decimal or hex, C suffixes allowed)."""
    m = _DECIMAL.match(tok.text)
    if m:
        return int(m.group(1))
    m = _HEX.match(tok.text)
    if m:
        return int(m.group(1), 16)
    if _OCTAL.match(tok.text):
        raise GlbError(
            f"'{tok.text}' would be octal in C, which .glb does not accept: write the {what} in decimal", tok.loc
        )
    raise GlbError(f"expected an integer {what}, found '{tok.text}'", tok.loc)


class Parser:
    def __init__(self, src: Source):
        self.src = src
        self.tokens = tokenize(src)
        self.pos = 0
        self.namespace: NamespaceStmt | None = None
        self.items_before_namespace = None  # where the first global declaration is, if any
        self.items: list[DefineStmt | Decl] = []
        self.depth = 0  # structs open around the current position

    # -- token access ---------------------------------------------------------------------------

    def peek(self, skip_newlines: bool = True) -> Token:
        if skip_newlines:
            while self.tokens[self.pos].kind == NEWLINE:
                self.pos += 1
        return self.tokens[self.pos]

    def take(self, skip_newlines: bool = True) -> Token:
        tok = self.peek(skip_newlines)
        if tok.kind != EOF:
            self.pos += 1
        return tok

    def previous(self) -> Token:
        i = self.pos - 1
        while i > 0 and self.tokens[i].kind == NEWLINE:
            i -= 1
        return self.tokens[max(i, 0)]

    def where(self, tok: Token) -> Loc:
        """Where to report a problem at `tok`: right after the previous token when `tok` is an end
        of line or of file (so that the caret shows where something is missing)."""
        if tok.kind in (NEWLINE, EOF) and self.pos > 0:
            return self.previous().end
        return tok.loc

    def expected(self, what: str, tok: Token) -> GlbError:
        return GlbError(f"expected {what}, found {tok.describe()}", self.where(tok))

    # -- file -----------------------------------------------------------------------------------

    def parse(self) -> FileSyntax:
        first_define: DefineStmt | None = None
        while True:
            tok = self.peek()
            if tok.kind == EOF:
                break
            if tok.is_punct(";"):
                self.take()
            elif tok.is_punct("#"):
                define = self.parse_define()
                first_define = first_define or define
                self.items.append(define)
            elif tok.is_word("namespace"):
                self.parse_namespace()
            else:
                # Before any namespace line: the global namespace (C++ `::name`, path `name`), as the
                # variable `joint` of the paper's Figures 7 and 8 is used.
                if self.namespace is None and self.items_before_namespace is None:
                    self.items_before_namespace = tok.loc
                qualifier = self.parse_qualifier()
                decl = self.parse_declaration(in_struct=False)
                decl.retain = qualifier
                self.items.append(decl)
        return FileSyntax(self.src, self.namespace, self.items)

    def end_of_statement(self, what: str, in_struct: bool) -> None:
        """A declaration or namespace line ends at ';', at the end of its line or file, or before
        the '}' of its struct."""
        tok = self.peek(skip_newlines=False)
        if tok.is_punct(";") or tok.kind == NEWLINE:
            self.pos += 1
        elif tok.kind == EOF or (in_struct and tok.is_punct("}")):
            pass
        else:
            raise GlbError(f"expected ';' or end of line after {what}, found {tok.describe()}", tok.loc)

    def name(self, what: str, field: bool = False) -> Token:
        tok = self.take()
        if tok.kind != IDENT:
            if tok.kind == NUMBER:
                raise GlbError(f"expected {what}, found '{tok.text}' (a name starts with a letter or '_')", tok.loc)
            raise self.expected(what, tok)
        problem = names.problem(tok.text, field=field)
        if problem:
            raise GlbError(problem, tok.loc)
        return tok

    # -- namespace and #define ------------------------------------------------------------------

    def parse_namespace(self) -> None:
        keyword = self.take()
        first = self.name("a namespace name after 'namespace'")
        parts = [first.text]
        while self.peek(skip_newlines=False).kind == PUNCT and self.peek(skip_newlines=False).text in (".", "::"):
            self.take()
            parts.append(self.name("a namespace name part").text)
        dotted = ".".join(parts)
        self.end_of_statement(f"'namespace {dotted}'", in_struct=False)
        if self.items_before_namespace is not None:
            raise GlbError(
                "'namespace' after global declarations: a file's declarations are either all global or all in "
                "its one namespace, declared before them",
                keyword.loc,
                notes=[Note(self.items_before_namespace, "the first global declaration")],
            )
        if self.namespace is not None:
            raise GlbError(
                f"a second namespace line: this file already declared namespace {self.namespace.name}; "
                f"put each namespace in its own .glb file",
                keyword.loc,
                notes=[Note(self.namespace.loc, f"namespace {self.namespace.name} declared here")],
            )
        self.namespace = NamespaceStmt(dotted, first.loc)

    def parse_define(self) -> DefineStmt:
        self.take()  # '#'
        directive = self.take(skip_newlines=False)
        if not directive.is_word("define"):
            if directive.kind == IDENT:
                raise GlbError(f"'#{directive.text}' is not supported: a .glb file knows only #define", directive.loc)
            raise self.expected("'define' after '#'", directive)
        name = self.take(skip_newlines=False)
        if name.kind in (NEWLINE, EOF):
            raise self.expected("a name after '#define'", name)
        self.pos -= 1
        name = self.name("a name after '#define'")
        sign = 1
        tok = self.take(skip_newlines=False)
        if tok.is_punct("-"):
            sign, tok = -1, self.take(skip_newlines=False)
        if tok.kind != NUMBER:
            raise GlbError(
                f"expected an integer value for #define {name.text}, found {tok.describe()}", self.where(tok)
            )
        value = sign * parse_integer(tok, f"value for #define {name.text}")
        if not -MAX_DEFINE - 1 <= value <= MAX_DEFINE:
            raise GlbError(f"#define {name.text} {value} does not fit a C++ long", tok.loc)
        end = self.peek(skip_newlines=False)
        if end.kind not in (NEWLINE, EOF):
            raise GlbError(
                f"expected end of line after '#define {name.text} {tok.text}' "
                f"(a #define takes one integer and no ';'), found {end.describe()}",
                end.loc,
            )
        return DefineStmt(name.text, value, name.loc)

    # -- declarations ---------------------------------------------------------------------------

    def parse_qualifier(self) -> str | None:
        """`retain` or `persistent` before a top-level declaration (docs/retain.md): at most one."""
        tok = self.peek()
        if tok.kind != IDENT or tok.text not in QUALIFIERS:
            return None
        self.take()
        again = self.peek()
        if again.kind == IDENT and again.text in QUALIFIERS:
            raise GlbError(
                f"'{again.text}' after '{tok.text}': a declaration takes one qualifier; "
                "'persistent' already includes what 'retain' keeps",
                again.loc,
            )
        return tok.text

    def parse_declaration(self, in_struct: bool) -> Decl:
        tok = self.peek()
        if in_struct and tok.kind == IDENT and tok.text in QUALIFIERS:
            raise GlbError(
                f"'{tok.text}' qualifies a top-level variable, not a field: write it before the variable's "
                "declaration (the whole variable is kept)",
                tok.loc,
            )
        if tok.is_word("struct"):
            type_ = self.parse_struct()
            after = self.peek(skip_newlines=False)
            if after.kind != IDENT:
                raise GlbError(
                    f"expected the variable's name after '}}' (on the same line), found {after.describe()}",
                    self.where(after),
                )
        elif tok.kind == IDENT and (tok.text in SINGLE_WORD or tok.text in COMBINING_WORDS):
            type_ = self.parse_scalar()
        elif tok.kind == IDENT:
            raise GlbError(f"unknown type '{tok.text}': expected {_TYPE_HELP}", tok.loc)
        else:
            raise GlbError(f"expected a declaration (a type and a name), found {tok.describe()}", tok.loc)
        what = "a field name" if in_struct else "a variable name"
        name = self.name(f"{what} after the type", field=in_struct)
        dims = []
        while self.peek(skip_newlines=False).is_punct("["):
            dims.append(self.parse_dim(name.text))
        self.end_of_statement(f"'{name.text}{''.join(_show_dim(d) for d in dims)}'", in_struct)
        return Decl(type_, name.text, name.loc, dims)

    def parse_scalar(self) -> ScalarSpec:
        first = self.take()
        if first.text in SINGLE_WORD:
            return ScalarSpec(SINGLE_WORD[first.text], first.loc)
        words = [first.text]
        last = first
        while self.peek().kind == IDENT and self.peek().text in COMBINING_WORDS:
            last = self.take()
            words.append(last.text)
        spelled = " ".join(words)
        span = Loc(
            self.src,
            first.loc.line,
            first.loc.col,
            len(spelled) if last.loc.line == first.loc.line else len(first.text),
        )
        nxt = self.peek()
        if nxt.kind == IDENT and nxt.text in ("double", "float"):  # long double, unsigned float
            if nxt.loc.line == first.loc.line:
                span = Loc(self.src, first.loc.line, first.loc.col, nxt.loc.col + len(nxt.text) - first.loc.col)
            raise GlbError(f"unsupported type '{spelled} {nxt.text}': expected {_TYPE_HELP}", span)
        cname = combine(words)
        if cname is None:
            raise GlbError(f"invalid type '{spelled}': expected {_TYPE_HELP}", span)
        return ScalarSpec(cname, span)

    def parse_struct(self) -> StructSpec:
        keyword = self.take()
        if self.depth == MAX_NESTING:
            raise GlbError(f"structs nest more than {MAX_NESTING} deep", keyword.loc)
        brace = self.take()
        if not brace.is_punct("{"):
            hint = " (structs in .glb are anonymous: `struct { … } name;`)" if brace.kind == IDENT else ""
            raise GlbError(f"expected '{{' after 'struct', found {brace.describe()}{hint}", self.where(brace))
        members: list[Decl | DefineStmt] = []
        self.depth += 1
        while True:
            tok = self.peek()
            if tok.is_punct("}"):
                self.take()
                break
            if tok.kind == EOF:
                raise GlbError(
                    f"expected '}}' to close the struct opened at line {keyword.loc.line}, found end of file",
                    self.where(tok),
                    notes=[Note(brace.loc, "the struct opens here")],
                )
            if tok.is_punct(";"):
                self.take()
            elif tok.is_punct("#"):
                members.append(self.parse_define())
            else:
                members.append(self.parse_declaration(in_struct=True))
        self.depth -= 1
        if not any(isinstance(m, Decl) for m in members):
            raise GlbError("a struct needs at least one field", keyword.loc)
        return StructSpec(members, keyword.loc)

    def parse_dim(self, name: str) -> Dim:
        self.take()  # '['
        tok = self.take()
        if tok.is_punct("]"):
            raise GlbError(f"expected the size of array '{name}' between '[' and ']'", tok.loc)
        if tok.is_punct("-"):
            number = self.take()
            if number.kind != NUMBER:
                raise self.expected(f"an integer size for array '{name}'", number)
            value = -parse_integer(number, "array size")
            loc = Loc(self.src, tok.loc.line, tok.loc.col, number.loc.col + len(number.text) - tok.loc.col)
            raise GlbError(f"array size must be at least 1, found {value}", loc)
        if tok.kind == NUMBER:
            value = parse_integer(tok, "array size")
            check_dim(value, tok.loc)
            dim = Dim(tok.loc, value=value)
        elif tok.kind == IDENT:
            dim = Dim(tok.loc, define=tok.text)
        else:
            raise self.expected(f"an integer or a #define name as the size of array '{name}'", tok)
        close = self.take()
        if not close.is_punct("]"):
            raise self.expected(f"']' after the size of array '{name}'", close)
        return dim


def check_dim(value: int, loc: Loc, via: str = "") -> None:
    if value < 1:
        raise GlbError(f"array size must be at least 1, found {value}{via}", loc)
    if value > MAX_DIM:
        raise GlbError(f"array size {value}{via} is too large (at most {MAX_DIM})", loc)


def _show_dim(d: Dim) -> str:
    return f"[{d.value if d.define is None else d.define}]"


def parse_file(src: Source) -> FileSyntax:
    return Parser(src).parse()

# il.py -- an Instruction List body -> tree statements, for the IL that editors still ship (Beremiz's
# and OpenPLC's examples): LD/LDN, ST/STN, S, R, AND/OR/XOR (N), NOT, ADD SUB MUL DIV MOD, GT GE EQ
# NE LE LT, JMP/JMPC/JMPCN to labels, RET/RETC/RETCN and CAL/CALC/CALCN.  The current result is a
# hidden variable per type (`_cr_INT`, `_cr_BOOL`: the type of the operand loaded); labels make the
# body a loop over its segments (`_ilpc`).  Operands are ST expressions (stc's grammar); parenthesised
# operators are refused, naming the line.

from __future__ import annotations

import re

from stc_compiler import tree as t
from stc_compiler.errors import Place, StError

from . import st_text

_COMMENT = re.compile(r"\(\*.*?\*\)", re.S)
_LINE = re.compile(r"^\s*(?:(?P<label>[A-Za-z_]\w*)\s*:)?\s*(?:(?P<op>[A-Za-z]+)\b\s*(?P<arg>.*?))?\s*;?\s*$")
_BINARY = {"AND": "AND", "OR": "OR", "XOR": "XOR", "ADD": "+", "SUB": "-", "MUL": "*", "DIV": "/", "MOD": "MOD"}
_COMPARE = {"GT": ">", "GE": ">=", "EQ": "=", "NE": "<>", "LE": "<=", "LT": "<"}
_INTS = ("SINT", "INT", "DINT", "LINT", "USINT", "UINT", "UDINT", "ULINT", "REAL", "LREAL")
_REALS = ("REAL", "LREAL")
_LITERAL_TYPES = {"bool": "BOOL", "duration": "TIME", "string": "STRING", "int": "INT", "real": "LREAL"}


class _Il:
    def __init__(self, ctx, name: str, file: str, first: int) -> None:
        self.ctx, self.name, self.file, self.first = ctx, name, file, first
        self.type: str | None = None
        self.declared: set[str] = set()
        self.jump_types: dict[str, str | None] = {}

    def place(self, line: int) -> Place:
        """At the file's line; the origin counts the body's lines (`main (IL) line 3`)."""
        return Place(self.file, line, 1, f"{self.name} (IL) line {line - self.first + 1}")

    def error(self, line: int, message: str) -> StError:
        return StError(self.place(line), "plcopen", message)

    def hidden(self, name: str, typ: str, line: int) -> t.Name:
        p = self.place(line)
        if name not in self.declared:
            self.declared.add(name)
            self.ctx.declare(t.VarDecl(p, name, "VAR", t.TypeRef(p, typ)))
        return t.Name(p, name)

    def cr(self, line: int, typ: str | None = None) -> t.Name:
        typ = typ or self.type
        if typ is None:
            raise self.error(line, "no value is loaded yet (start with LD)")
        return self.hidden(f"_cr_{typ}", typ, line)

    def operand(self, line: int, text: str) -> t.Expr:
        if not text:
            raise self.error(line, "the instruction needs an operand")
        p = self.place(line)
        return st_text.expression(self.file, text, line, p.origin)

    def type_of(self, line: int, e: t.Expr) -> str:
        """The IEC type of a loaded operand: a declared variable's, or a literal's."""
        if isinstance(e, t.Literal):
            if e.prefix:
                return e.prefix.upper()
            numeric = _INTS if e.kind == "int" else _REALS if e.kind == "real" else ()
            return self.type if self.type in numeric else _LITERAL_TYPES.get(e.kind, "INT")
        if isinstance(e, t.Name):
            for v in self.ctx.pou.vars:
                if v.name.upper() == e.name.upper() and isinstance(v.spec, t.TypeRef):
                    return v.spec.name.upper()
        raise self.error(
            line,
            "the type of this operand is not known here (a variable of an elementary type, or a literal); write the POU in ST",
        )

    def instruction(self, line: int, op: str, arg: str) -> list:
        p = self.place(line)
        op = op.upper()
        if arg.strip().startswith("("):
            raise self.error(line, f"'{op}(' (a parenthesised operator) is not supported; write the POU in ST")
        neg = op in ("LDN", "STN", "ANDN", "ORN", "XORN")
        base = op[:-1] if neg else op
        if base == "LD":
            value = self.operand(line, arg)
            self.type = self.type_of(line, value)
            return [t.Assign(p, self.cr(line), t.Unary(p, "NOT", value) if neg else value)]
        if base == "ST":
            cur = self.cr(line)
            return [t.Assign(p, self.operand(line, arg), t.Unary(p, "NOT", cur) if neg else cur)]
        if op in ("S", "R"):
            value = t.Literal(p, "bool", op == "S", "TRUE" if op == "S" else "FALSE")
            return [t.If(p, [(self.cr(line), [t.Assign(p, self.operand(line, arg), value)])], None)]
        if op == "NOT":
            return [t.Assign(p, self.cr(line), t.Unary(p, "NOT", self.cr(line)))]
        if base in _BINARY:
            value = self.operand(line, arg)
            value = t.Unary(p, "NOT", value) if neg else value
            return [t.Assign(p, self.cr(line), t.Binary(p, _BINARY[base], self.cr(line), value))]
        if op in _COMPARE:
            value = t.Binary(p, _COMPARE[op], self.cr(line), self.operand(line, arg))
            self.type = "BOOL"
            return [t.Assign(p, self.cr(line), value)]
        if op in ("RET", "RETC", "RETCN"):
            return self.when(line, op[3:], [t.Return(p)])
        if op in ("CAL", "CALC", "CALCN"):
            call = st_text.statements(self.file, f"{arg};", line, p.origin)
            return self.when(line, op[3:], call)
        if op in ("JMP", "JMPC", "JMPCN"):
            return [("jump", arg.strip().upper(), op[3:], line)]
        raise self.error(line, f"'{op}' is not an IL operator this import supports; write the POU in ST")

    def when(self, line: int, cond: str, body: list) -> list:
        if not cond:
            return body
        p = self.place(line)
        c = self.cr(line, "BOOL")
        return [t.If(p, [(t.Unary(p, "NOT", c) if cond == "CN" else c, body)], None)]


def translate(ctx, name: str, lang_el) -> list:
    """The statements of an <IL> body of POU `name`."""
    text, first = st_text.text_of(lang_el)
    il = _Il(ctx, name, ctx.file, first)
    text = _COMMENT.sub(lambda m: "\n" * m.group(0).count("\n"), text)
    segments: list[tuple[str | None, list]] = [(None, [])]
    for n, raw in enumerate(text.split("\n")):
        line = first + n
        m = _LINE.match(raw)
        if m is None:
            raise il.error(line, f"{raw.strip()!r} is not an IL instruction")
        if m.group("label"):
            label = m.group("label").upper()
            if il.type is None:
                il.type = il.jump_types.get(label)
            segments.append((label, []))
        if m.group("op"):
            for s in il.instruction(line, m.group("op"), m.group("arg") or ""):
                if isinstance(s, tuple):
                    il.jump_types[s[1]] = il.type
                segments[-1][1].append(s)
    return _flow(il, segments)


def _flow(il: _Il, segments: list[tuple[str | None, list]]) -> list:
    """Without jumps, the statements in order; with them, a loop over the segments between labels."""
    if not any(isinstance(s, tuple) for _, body in segments for s in body):
        return [s for _, body in segments for s in body]
    index = {label: i for i, (label, _) in enumerate(segments) if label}
    p = il.place(1)
    pc = il.hidden("_ilpc", "INT", 1)

    def num(k: int) -> t.Literal:
        return t.Literal(p, "int", k, str(k))

    branches = []
    for i, (_, body) in enumerate(segments):
        stmts = []
        for s in body:
            if not isinstance(s, tuple):
                stmts.append(s)
                continue
            _, label, cond, line = s
            if label not in index:
                raise il.error(line, f"no label '{label}' in this body")
            go = [t.Assign(il.place(line), t.Name(p, "_ilpc"), num(index[label])), t.Continue(il.place(line))]
            stmts += il.when(line, cond, go)
        stmts.append(t.Assign(p, t.Name(p, "_ilpc"), num(i + 1 if i + 1 < len(segments) else -1)))
        branches.append(t.CaseBranch(p, [t.CaseLabel(p, num(i), None)], stmts))
    loop = t.While(p, t.Binary(p, ">=", t.Name(p, "_ilpc"), num(0)), [t.Case(p, t.Name(p, "_ilpc"), branches, None)])
    return [t.Assign(p, pc, num(0)), loop]

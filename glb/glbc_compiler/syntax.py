# syntax.py -- what the parser makes of one .glb file: its namespace line, #defines and
# declarations in file order, with the position of every name for later error messages.

from __future__ import annotations

from dataclasses import dataclass, field

from .errors import Loc, Source


@dataclass
class NamespaceStmt:
    name: str  # dotted: knu.Robot
    loc: Loc  # the first part


@dataclass
class DefineStmt:
    name: str
    value: int
    loc: Loc  # the name


@dataclass
class Dim:
    """One array dimension: an integer literal (value) or a #define name (define, resolved later)."""

    loc: Loc
    value: int | None = None
    define: str | None = None


@dataclass
class ScalarSpec:
    cname: str  # the C++ spelling: `unsigned long`
    loc: Loc


@dataclass
class StructSpec:
    members: list[Decl | DefineStmt]
    loc: Loc  # the `struct` keyword


@dataclass
class Decl:
    type: ScalarSpec | StructSpec
    name: str
    loc: Loc  # the name
    dims: list[Dim] = field(default_factory=list)
    retain: str | None = None  # a top-level declaration's qualifier: "retain" or "persistent"
    iec_type: str | None = None  # the IEC 61131-3 type it holds (declarations made by stc; .glb text has none)
    internal: bool = False  # the compiler's own (stc's init flags): laid out, kept, never shown to users
    # Top-level declarations of the same group share one lock (stc: a PROGRAM instance's struct and
    # array variables, which its module writes back together; docs/glbc.md "Lock groups").
    lock_group: str | None = None
    # Placed right after the declaration before it, at its own alignment, when that one is packed
    # too (stc: a PROGRAM instance's variables, which its module alone writes: they need no cache
    # line each); else on cache lines of its own.
    packed: bool = False


@dataclass
class FileSyntax:
    source: Source
    namespace: NamespaceStmt | None
    items: list[DefineStmt | Decl]  # in file order

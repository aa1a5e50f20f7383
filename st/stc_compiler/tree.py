# tree.py -- the compiler's tree of a Structured Text source: POUs, declarations, statements and
# expressions, each with its place.  parse.py builds it; check.py fills `type` on every expression,
# `decl` on every name and `target` on every call; code generators read it (see docs/st-compiler.md).

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from .errors import Place


@dataclass(eq=False)
class Node:
    place: Place


# ---- expressions ------------------------------------------------------------------------------


@dataclass(eq=False)
class Expr(Node):
    # set by check.py: the expression's IEC type (types.Type), and its value when constant
    type: Any = field(default=None, init=False, repr=False)
    const: Any = field(default=None, init=False, repr=False)


@dataclass(eq=False)
class Literal(Expr):
    """kind: int, real, bool, string, wstring, duration (ns), date (ns since 1970), tod (ns since
    midnight), dt (ns since 1970) or enum (value = the enumerator's name); prefix: the type named
    before '#' (INT#5, Color#Red) or None."""

    kind: str
    value: Any
    text: str
    prefix: str | None = None


@dataclass(eq=False)
class Name(Expr):
    name: str
    decl: Any = field(default=None, init=False, repr=False)  # VarDecl, EnumValue or POU (set by check.py)


@dataclass(eq=False)
class Member(Expr):
    """`base.name`: a struct field, an FB instance's input/output, a glb namespace's variable."""

    base: Expr
    name: str
    decl: Any = field(default=None, init=False, repr=False)


@dataclass(eq=False)
class Index(Expr):
    base: Expr
    indices: list[Expr]


@dataclass(eq=False)
class BitAccess(Expr):
    base: Expr
    bit: int


@dataclass(eq=False)
class Unary(Expr):
    op: str  # '-', '+', 'NOT'
    operand: Expr


@dataclass(eq=False)
class Binary(Expr):
    op: str  # OR XOR AND = <> < > <= >= + - * / MOD **  ('&' is read as AND)
    left: Expr
    right: Expr


@dataclass(eq=False)
class Arg(Node):
    """One argument: positional (name None), `name := value`, or output `name => target` (NOT negates)."""

    name: str | None
    value: Expr | None
    output: bool = False
    negated: bool = False
    param: Any = field(default=None, init=False, repr=False)  # the parameter it binds (set by check.py)


@dataclass(eq=False)
class Call(Expr):
    """A function call or an FB instance call; check.py sets `target`: a Pou (FUNCTION), a
    stdlib.Function, or the FB instance's VarDecl (then `fb` is its FUNCTION_BLOCK Pou)."""

    callee: Expr
    args: list[Arg]
    target: Any = field(default=None, init=False, repr=False)
    fb: Any = field(default=None, init=False, repr=False)


# ---- types as written and initial values ------------------------------------------------------


@dataclass(eq=False)
class TypeRef(Node):
    name: str


@dataclass(eq=False)
class StringSpec(Node):
    wide: bool
    length: Expr | None


@dataclass(eq=False)
class ArraySpec(Node):
    ranges: list[tuple[Expr, Expr]]
    element: Any


@dataclass(eq=False)
class SubrangeSpec(Node):
    base: TypeRef
    low: Expr
    high: Expr


@dataclass(eq=False)
class EnumValue(Node):
    name: str
    value: Expr | None
    number: int = field(default=0, init=False)  # set by check.py
    enum: Any = field(default=None, init=False, repr=False)  # its types.EnumType


@dataclass(eq=False)
class EnumSpec(Node):
    values: list[EnumValue]


@dataclass(eq=False)
class StructSpec(Node):
    members: list[VarDecl]


@dataclass(eq=False)
class ArrayItem(Node):
    count: int | None  # `3(0)` repeats 0 three times; None: once
    value: Any  # Expr, ArrayInit, StructInit or None (`3()`: default values)


@dataclass(eq=False)
class ArrayInit(Node):
    items: list[ArrayItem]


@dataclass(eq=False)
class StructInit(Node):
    fields: list[tuple[str, Place, Any]]


# ---- declarations -----------------------------------------------------------------------------


@dataclass(eq=False)
class VarDecl(Node):
    """One variable: kind is VAR, VAR_INPUT, VAR_OUTPUT, VAR_IN_OUT, VAR_TEMP, VAR_GLOBAL,
    VAR_EXTERNAL, or MEMBER (a struct field).  location: the text after AT ('%PLC.IN.x')."""

    name: str
    kind: str
    spec: Any
    init: Any = None
    constant: bool = False
    retain: bool = False
    persistent: bool = False
    location: str | None = None
    type: Any = field(default=None, init=False, repr=False)  # types.Type (check.py)
    owner: Any = field(default=None, init=False, repr=False)  # the Pou, TypeDecl, or None for globals
    glb: Any = field(default=None, init=False, repr=False)  # the layout.json variable it is bound to


@dataclass(eq=False)
class TypeDecl(Node):
    name: str
    spec: Any
    init: Any = None
    type: Any = field(default=None, init=False, repr=False)
    # {extern 'cpp::Type'} on a STRUCT: its bytes are the C++ type's; {extern 'cpp::make(a, b)'}: C++ code
    # receives cpp::make(x.a, x.b) (extern_args: the members named)
    extern: str | None = field(default=None, init=False)
    extern_args: list[str] | None = field(default=None, init=False)


# ---- statements -------------------------------------------------------------------------------


@dataclass(eq=False)
class Assign(Node):
    target: Expr
    value: Expr


@dataclass(eq=False)
class CallStmt(Node):
    call: Call


@dataclass(eq=False)
class If(Node):
    branches: list[tuple[Expr, list]]  # IF and every ELSIF: (condition, statements)
    orelse: list | None


@dataclass(eq=False)
class CaseLabel(Node):
    low: Expr
    high: Expr | None  # a range low..high, else None


@dataclass(eq=False)
class CaseBranch(Node):
    labels: list[CaseLabel]
    body: list


@dataclass(eq=False)
class Case(Node):
    selector: Expr
    branches: list[CaseBranch]
    orelse: list | None


@dataclass(eq=False)
class For(Node):
    var: Name
    start: Expr
    end: Expr
    step: Expr | None
    body: list


@dataclass(eq=False)
class While(Node):
    cond: Expr
    body: list


@dataclass(eq=False)
class Repeat(Node):
    body: list
    cond: Expr


@dataclass(eq=False)
class Exit(Node):
    pass


@dataclass(eq=False)
class Continue(Node):
    pass


@dataclass(eq=False)
class Return(Node):
    pass


# ---- program organisation units and configuration ---------------------------------------------


@dataclass(eq=False)
class Pou(Node):
    """kind: PROGRAM, FUNCTION_BLOCK or FUNCTION (then `returns` is its type as written)."""

    kind: str
    name: str
    vars: list[VarDecl]
    body: list
    returns: Any = None
    # {extern 'cpp::Name'}: implemented in C++ (an FB: the struct whose operator() is the body; a
    # FUNCTION: the function called with the inputs in order); the body is empty
    extern: str | None = field(default=None, init=False)
    return_type: Any = field(default=None, init=False, repr=False)  # types.Type (check.py)
    result: VarDecl | None = field(default=None, init=False, repr=False)  # a FUNCTION's own-name variable
    locals: dict[str, VarDecl] = field(default_factory=dict, init=False, repr=False)  # upper-case name -> decl
    uses: list[tuple[Pou, Place]] = field(
        default_factory=list, init=False, repr=False
    )  # FUNCTIONs called, FBs instantiated


@dataclass(eq=False)
class Task(Node):
    name: str
    params: dict[str, tuple[Place, Expr]]  # INTERVAL, PRIORITY, SINGLE (upper-cased keys)


@dataclass(eq=False)
class ProgramConfig(Node):
    """`PROGRAM inst WITH task : Type (args);`"""

    name: str
    task: str | None
    type_name: str
    retain: bool | None
    args: list[Arg]
    pou: Pou | None = field(default=None, init=False, repr=False)  # set by check.py


@dataclass(eq=False)
class Resource(Node):
    name: str
    on: str | None
    vars: list[VarDecl]
    tasks: list[Task]
    programs: list[ProgramConfig]


@dataclass(eq=False)
class Configuration(Node):
    name: str
    vars: list[VarDecl]
    resources: list[Resource]  # tasks/programs written directly in the CONFIGURATION form one of its own


@dataclass(eq=False)
class Unit(Node):
    """One source file."""

    pous: list[Pou] = field(default_factory=list)
    types: list[TypeDecl] = field(default_factory=list)
    globals: list[VarDecl] = field(default_factory=list)
    configurations: list[Configuration] = field(default_factory=list)
    library: bool = False  # st/lib's standard.st or plcopen.st (check.library_units)

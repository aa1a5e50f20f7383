# layout.py -- the parsed files -> one segment layout: names checked per namespace, struct types
# named (`v_t`, `X_f_t`), sizes and offsets as g++ lays them out on x86-64, top-level variables
# on their own 64-byte cache lines (packed ones one after the other), one lock each (the variables of
# a lock group one between them).

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .errors import GlbError, Loc, Note
from .parser import check_dim
from .scalars import SCALARS, Scalar
from .syntax import Decl, DefineStmt, Dim, FileSyntax, StructSpec

CACHE_LINE = 64  # every top-level variable starts on its own cache line(s)
MAX_LEAVES = 200_000  # scalars listed in layout.json's `leaves`
DEFAULT_MAX_SIZE = 16 * 1024 * 1024


GLOBAL = ""  # the namespace of declarations in a file without a namespace line


def describe_namespace(namespace: str) -> str:
    return f"namespace {namespace}" if namespace else "the global namespace"


def qualify(namespace: str, name: str) -> str:
    """`knu.Robot` + `joints` -> `knu.Robot.joints`; in the global namespace just `joints`."""
    return f"{namespace}.{name}" if namespace else name


@dataclass
class StructType:
    namespace: str
    cname: str  # the C++ name of the value type: joints_t
    owner: str  # what it is named after, for messages: "variable 'joints'"
    loc: Loc  # the `struct` keyword
    fields: list[Field] = field(default_factory=list)
    size: int = 0
    align: int = 1
    leaves: int = 0  # scalars in one value

    @property
    def qualname(self) -> str:
        return qualify(self.namespace, self.cname)

    @property
    def ref_name(self) -> str:
        return self.cname + "_ref"


Type = Scalar | StructType


@dataclass
class Field:
    name: str
    type: Type
    dims: list[int]
    offset: int  # within its struct
    size: int  # with every dimension
    loc: Loc
    iec_type: str | None = None  # the IEC type of its elements (declared by stc), else None


@dataclass
class Variable:
    namespace: str
    name: str
    type: Type
    dims: list[int]
    size: int
    loc: Loc
    types: list[StructType]  # the struct types it introduces, nested ones first
    offset: int = 0
    lock: int = 0
    retain: str | None = None  # "retain" or "persistent": irpd saves and restores it (docs/retain.md)
    iec_type: str | None = None  # the IEC type of its elements (declared by stc), else None
    internal: bool = False  # a compiler's own variable (Decl.internal): "internal": true in layout.json
    lock_group: str | None = None  # Decl.lock_group: the variables of a group share their lock
    packed: bool = False  # Decl.packed: right after the variable before it when that one is packed too

    @property
    def path(self) -> str:
        return qualify(self.namespace, self.name)

    @property
    def align(self) -> int:
        return self.type.align


@dataclass
class Define:
    namespace: str
    name: str
    value: int
    loc: Loc


@dataclass
class Block:
    """What one file contributes, in file order: the header emits one namespace block per file."""

    source: str
    namespace: str
    defines: list[Define] = field(default_factory=list)
    types: list[StructType] = field(default_factory=list)
    variables: list[Variable] = field(default_factory=list)


@dataclass
class Layout:
    sources: list[str]
    namespaces: list[str]
    defines: list[Define]
    types: list[StructType]  # nested types before the types that contain them
    variables: list[Variable]
    blocks: list[Block]
    data_size: int = 0
    lock_count: int = 0
    # Set by evolve.place (glbc --previous): the earlier layouts whose space is kept, and what
    # changed against the previous one.
    lineage: list[dict] = field(default_factory=list)
    changes: dict | None = None


@dataclass
class _Symbol:
    kind: str  # variable, define, type
    loc: Loc
    owner: str = ""  # for a type: what it is named after

    def describe(self, name: str) -> str:
        if self.kind == "type":
            return f"the struct type '{name}' that glbc generates for {self.owner}"
        return f"{'#define' if self.kind == 'define' else 'variable'} '{name}'"


def round_up(n: int, to: int) -> int:
    return (n + to - 1) // to * to


class _Builder:
    def __init__(self, max_size: int):
        self.max_size = max_size
        self.symbols: dict[str, dict[str, _Symbol]] = {}  # namespace -> name -> symbol
        self.namespace_locs: dict[str, Loc] = {}
        self.defines: dict[str, dict[str, Define]] = {}
        self.all_defines: list[Define] = []
        self.types: list[StructType] = []
        self.variables: list[Variable] = []
        self.blocks: list[Block] = []
        self.lock_count = 0
        self.last_packed = False  # whether the variable laid out last was a packed one (Decl.packed)
        self.group_locks: dict[str, int] = {}  # a lock group's lock
        self.leaves = 0

    # -- names ----------------------------------------------------------------------------------

    def declare(self, ns: str, name: str, sym: _Symbol) -> None:
        table = self.symbols.setdefault(ns, {})
        old = table.get(name)
        if old is None:
            table[name] = sym
            return
        note = [Note(old.loc, f"{old.describe(name)} is declared here")]
        if sym.kind != "type" and old.kind != "type":
            raise GlbError(
                f"duplicate name '{name}' in {describe_namespace(ns)}: first declared at {old.loc}", sym.loc, notes=note
            )
        raise GlbError(
            f"{sym.describe(name)} clashes with {old.describe(name)} at {old.loc}; rename one of them",
            sym.loc,
            notes=note,
        )

    def define(self, ns: str, stmt: DefineStmt, block: Block) -> None:
        self.declare(ns, stmt.name, _Symbol("define", stmt.loc))
        d = Define(ns, stmt.name, stmt.value, stmt.loc)
        self.defines.setdefault(ns, {})[stmt.name] = d
        self.all_defines.append(d)
        block.defines.append(d)

    def dims(self, ns: str, dims: list[Dim]) -> list[int]:
        out = []
        for d in dims:
            if d.define is None:
                out.append(d.value)
                continue
            found = self.defines.get(ns, {}).get(d.define)
            if found is None:
                raise GlbError(
                    f"'{d.define}' is not a #define of {describe_namespace(ns)} declared before this line: "
                    f"an array size is an integer or a #define name",
                    d.loc,
                )
            check_dim(found.value, d.loc, via=f" (#define {d.define})")
            out.append(found.value)
        return out

    # -- types ----------------------------------------------------------------------------------

    def struct(
        self,
        ns: str,
        spec: StructSpec,
        cname: str,
        owner: str,
        name_loc: Loc,
        block: Block,
        introduced: list[StructType],
    ) -> StructType:
        st = StructType(ns, cname, owner, spec.loc)
        self.declare(ns, cname, _Symbol("type", name_loc, owner))
        self.declare(ns, st.ref_name, _Symbol("type", name_loc, owner))
        seen: dict[str, Loc] = {}
        offset = 0
        for m in spec.members:
            if isinstance(m, DefineStmt):
                self.define(ns, m, block)
                continue
            if m.name in seen:
                raise GlbError(
                    f"duplicate field '{m.name}' in the struct of {owner}: first declared at {seen[m.name]}",
                    m.loc,
                    notes=[Note(seen[m.name], f"field '{m.name}' is declared here")],
                )
            seen[m.name] = m.loc
            dims = self.dims(ns, m.dims)
            if isinstance(m.type, StructSpec):
                t: Type = self.struct(
                    ns, m.type, f"{cname}_{m.name}_t", f"field '{m.name}' of {cname}", m.loc, block, introduced
                )
            else:
                t = SCALARS[m.type.cname]
            count = math.prod(dims)
            offset = round_up(offset, t.align)
            st.fields.append(Field(m.name, t, dims, offset, t.size * count, m.loc, m.iec_type))
            offset += t.size * count
            st.align = max(st.align, t.align)
            st.leaves += _leaves(t) * count
        st.size = round_up(offset, st.align)
        self.types.append(st)
        introduced.append(st)
        block.types.append(st)
        return st

    # -- files ----------------------------------------------------------------------------------

    def file(self, fs: FileSyntax) -> None:
        if fs.namespace is None and not fs.items:
            return  # nothing but comments and blank lines
        ns = fs.namespace.name if fs.namespace else GLOBAL
        if fs.namespace:
            self.namespace_locs.setdefault(ns, fs.namespace.loc)
        self.symbols.setdefault(ns, {})
        block = Block(fs.source.name, ns)
        self.blocks.append(block)
        for item in fs.items:
            if isinstance(item, DefineStmt):
                self.define(ns, item, block)
            else:
                self.variable(ns, item, block)

    def variable(self, ns: str, decl: Decl, block: Block) -> None:
        self.declare(ns, decl.name, _Symbol("variable", decl.loc))
        dims = self.dims(ns, decl.dims)
        introduced: list[StructType] = []
        if isinstance(decl.type, StructSpec):
            t: Type = self.struct(
                ns, decl.type, f"{decl.name}_t", f"variable '{decl.name}'", decl.loc, block, introduced
            )
        else:
            t = SCALARS[decl.type.cname]
        count = math.prod(dims)
        var = Variable(
            ns,
            decl.name,
            t,
            dims,
            t.size * count,
            decl.loc,
            introduced,
            retain=decl.retain,
            iec_type=decl.iec_type,
            internal=decl.internal,
            lock_group=decl.lock_group,
            packed=decl.packed,
        )
        last = self.variables[-1] if self.variables else None
        if last is None:
            var.offset = 0
        elif decl.packed and self.last_packed:
            var.offset = round_up(last.offset + last.size, var.align)
        else:
            var.offset = round_up(last.offset + last.size, CACHE_LINE)
        self.last_packed = decl.packed
        if decl.lock_group is not None and decl.lock_group in self.group_locks:
            var.lock = self.group_locks[decl.lock_group]
        else:
            var.lock = self.lock_count
            self.lock_count += 1
            if decl.lock_group is not None:
                self.group_locks[decl.lock_group] = var.lock
        end = round_up(var.offset + var.size, CACHE_LINE)
        if end > self.max_size:
            raise GlbError(
                f"segment over its limit: variable '{decl.name}' ({var.size} bytes at offset {var.offset}) "
                f"ends at byte {end}, over --max-size {self.max_size}",
                decl.loc,
            )
        self.leaves += _leaves(t) * count
        if self.leaves > MAX_LEAVES:
            raise GlbError(
                f"too many scalars: variable '{decl.name}' brings layout.json's leaves to {self.leaves}, "
                f"over the limit of {MAX_LEAVES}",
                decl.loc,
            )
        self.variables.append(var)
        block.variables.append(var)

    # -- checks across files ----------------------------------------------------------------------

    def check_namespace_parts(self) -> None:
        """`namespace a.b` and a name `b` in namespace `a` would be the same C++ name a::b."""
        for ns, loc in self.namespace_locs.items():
            parts = ns.split(".")
            for k in range(1, len(parts)):
                parent, part = ".".join(parts[:k]), parts[k]
                sym = self.symbols.get(parent, {}).get(part)
                if sym is not None:
                    raise GlbError(
                        f"{sym.describe(part)} of namespace {parent} clashes with namespace {ns} "
                        f"(declared at {loc}): both would be {'::'.join(parts[: k + 1])} in C++",
                        sym.loc,
                        notes=[Note(loc, f"namespace {ns} is declared here")],
                    )

    def check_field_names(self) -> None:
        """A field named like a generated type would change that type's meaning inside the struct."""
        for st in self.types:
            table = self.symbols[st.namespace]
            for f in st.fields:
                sym = table.get(f.name)
                if sym is not None and sym.kind == "type":
                    raise GlbError(
                        f"field '{f.name}' clashes with {sym.describe(f.name)} at {sym.loc}; rename one of them",
                        f.loc,
                        notes=[Note(sym.loc, "the type is named after this declaration")],
                    )


def _leaves(t: Type) -> int:
    return t.leaves if isinstance(t, StructType) else 1


def build(files: list[FileSyntax], max_size: int = DEFAULT_MAX_SIZE) -> Layout:
    b = _Builder(max_size)
    for fs in files:
        b.file(fs)
    b.check_namespace_parts()
    b.check_field_names()
    data_size = round_up(b.variables[-1].offset + b.variables[-1].size, CACHE_LINE) if b.variables else 0
    return Layout(
        [fs.source.name for fs in files],
        list(b.namespace_locs),
        b.all_defines,
        b.types,
        b.variables,
        b.blocks,
        data_size,
        b.lock_count,
    )

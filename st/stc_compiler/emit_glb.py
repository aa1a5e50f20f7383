# emit_glb.py -- the checked program's variables -> glbc declarations, laid out with glbc's Python API
# (glb/glbc_compiler: syntax.Decl -> layout.build -> evolve.place -> generated.h and layout.json):
# one namespace per PROGRAM instance, one per CONFIGURATION / RESOURCE for its VAR_GLOBALs ("GVL" for
# VAR_GLOBAL lists outside one), after the set's own .glb files and against the set's layout (or the
# running one), so that the set's C++ modules and the running variables keep their places.

from __future__ import annotations

import json
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

from . import tree as t
from . import types as ty
from .errors import Place, StError

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "glb"))
from glbc_compiler import cli as glbc_cli  # noqa: E402
from glbc_compiler.emit_header import render as render_header  # noqa: E402
from glbc_compiler.emit_layout import document  # noqa: E402
from glbc_compiler.emit_layout import render as render_layout  # noqa: E402
from glbc_compiler.errors import GlbError, Loc, Source  # noqa: E402
from glbc_compiler.evolve import Previous, place, read_previous  # noqa: E402
from glbc_compiler.layout import DEFAULT_MAX_SIZE, Layout, build  # noqa: E402
from glbc_compiler.parser import parse_file  # noqa: E402
from glbc_compiler.syntax import Decl, Dim, FileSyntax, NamespaceStmt, ScalarSpec, StructSpec  # noqa: E402

GLOBALS_NAMESPACE = "GVL"  # the namespace of VAR_GLOBAL lists written outside a CONFIGURATION
# Per PROGRAM instance: TRUE once its module initialised its variables (start() of the generated
# module); the second one is RETAIN, so that a restart restores the retained values and leaves them.
INIT_FLAG, RETAIN_INIT_FLAG = "_stc_init", "_stc_init_retain"


@dataclass
class Instance:
    """A PROGRAM instance of the set (tasks.py makes them): its name is its module's and its namespace."""

    name: str
    pou: t.Pou
    interval_ns: int
    priority: int  # IEC: 0 is the highest
    place: Place
    task: str = ""


@dataclass
class GlobalsBlock:
    namespace: str
    decls: list[t.VarDecl] = field(default_factory=list)


def stored(v: t.VarDecl) -> bool:
    """Whether a declaration of a PROGRAM, FB or VAR_GLOBAL list is a shared variable of its own: not
    VAR_TEMP, VAR_IN_OUT or VAR_EXTERNAL (they refer to others), not a CONSTANT (compiled in), not an
    AT binding (it is the bound variable)."""
    return (
        v.kind in ("VAR", "VAR_INPUT", "VAR_OUTPUT", "VAR_GLOBAL", "MEMBER")
        and not v.constant
        and v.location is None
        and v.type is not None
    )


def scalar(typ: ty.Type | None) -> bool:
    """Whether a value of this type is a scalar: a top-level one is one atomic load and store (the
    generated code copies it every run), else it is a struct or an array (the kept image, kept.hpp)."""
    b = ty.base(typ) if typ is not None else None
    return isinstance(b, (ty.Elementary, ty.LiteralType, ty.EnumType))


def fb_fields(pou: t.Pou) -> list[t.VarDecl]:
    """An FB instance's fields in shared memory and in its C++ struct: VAR_INPUT, VAR_OUTPUT, VAR."""
    return [v for v in pou.vars if stored(v)]


def globals_blocks(units: list[t.Unit]) -> list[GlobalsBlock]:
    blocks: dict[str, GlobalsBlock] = {}
    for unit in units:
        for g in unit.globals:
            blocks.setdefault(GLOBALS_NAMESPACE, GlobalsBlock(GLOBALS_NAMESPACE)).decls.append(g)
        for conf in unit.configurations:
            for g in conf.vars:
                blocks.setdefault(conf.name, GlobalsBlock(conf.name)).decls.append(g)
            for res in conf.resources:
                for g in res.vars:
                    blocks.setdefault(res.name, GlobalsBlock(res.name)).decls.append(g)
    for b in blocks.values():
        b.decls = [g for g in b.decls if stored(g)]
    return [b for b in blocks.values() if b.decls]


class _Declarer:
    """ST declarations -> glbc Decls (the same structs the .glb parser makes)."""

    def __init__(self) -> None:
        self.sources: dict[str, Source] = {}

    def loc(self, place: Place) -> Loc:
        src = self.sources.get(place.file)
        if src is None:
            try:
                text = Path(place.file).read_text(encoding="utf-8", errors="replace")
            except OSError:
                text = ""
            src = self.sources[place.file] = Source.from_text(place.file, text)
        return Loc(src, place.line, place.col)

    def decl(self, v: t.VarDecl, name: str | None = None, lock_group: str | None = None, packed: bool = False) -> Decl:
        at = self.loc(v.place)
        spec, dims, iec = self.spec(v.type, at)
        d = Decl(
            spec, name or v.name, at, [Dim(at, n) for n in dims], iec_type=iec, lock_group=lock_group, packed=packed
        )
        if v.kind != "MEMBER" and (v.retain or v.persistent):
            d.retain = "persistent" if v.persistent else "retain"
        return d

    def spec(self, typ: ty.Type, at: Loc) -> tuple[ScalarSpec | StructSpec, list[int], str]:
        """(the element's glbc type, the dimensions, the element's IEC type name)."""
        if isinstance(typ, ty.ArrayType):
            spec, inner, iec = self.spec(typ.element, at)
            return spec, [hi - lo + 1 for lo, hi in typ.dims] + inner, iec
        if isinstance(typ, ty.StringType):
            return ScalarSpec("char", at), [typ.length + 1], typ.name
        if isinstance(typ, ty.SubrangeType):
            return ScalarSpec(typ.base.cpp, at), [], typ.base.name
        if isinstance(typ, ty.EnumType):
            return ScalarSpec(typ.cpp, at), [], typ.name
        if isinstance(typ, ty.Elementary):
            return ScalarSpec(typ.cpp, at), [], typ.name
        if isinstance(typ, ty.StructType):
            return StructSpec([self.decl(m) for m in typ.members.values()], at), [], typ.name
        if isinstance(typ, ty.FbType):
            members = [self.decl(m) for m in fb_fields(typ.pou)]
            if not members:  # glbc needs a field; the C++ struct has the same one (emit_cpp.py)
                members = [Decl(ScalarSpec("bool", at), EMPTY_FB_FIELD, at, iec_type="BOOL")]
            return StructSpec(members, at), [], typ.name
        raise StError(Place(at.source.name, at.line, at.col), "unsupported", f"{typ} cannot be a shared variable")


EMPTY_FB_FIELD = "_empty"  # the one field of an FB instance that has no VAR_INPUT, VAR_OUTPUT or VAR


def st_files(instances: list[Instance], blocks: list[GlobalsBlock]) -> list[FileSyntax]:
    """The FileSyntax glbc lays out for the ST variables: one per namespace."""
    d = _Declarer()
    files = []
    for b in blocks:
        at = d.loc(b.decls[0].place)
        files.append(FileSyntax(at.source, NamespaceStmt(b.namespace, at), [d.decl(g) for g in b.decls]))
    for inst in instances:
        at = d.loc(inst.place)
        # its structs and arrays (FB instances among them) share one lock: the instance's module
        # reads them with one sequence check and writes them back under one taking of the lock; and
        # its variables are packed, so that its scalars, copied every run, are a cache line or two
        items = [
            d.decl(v, lock_group=None if scalar(v.type) else inst.name, packed=True) for v in inst.pou.vars if stored(v)
        ]
        items.append(Decl(ScalarSpec("bool", at), INIT_FLAG, at, iec_type="BOOL", internal=True))
        if any(v.retain or v.persistent for v in inst.pou.vars if stored(v)):
            flag = Decl(ScalarSpec("bool", at), RETAIN_INIT_FLAG, at, retain="retain", iec_type="BOOL", internal=True)
            items.append(flag)
        files.append(FileSyntax(at.source, NamespaceStmt(inst.name, at), items))
    return files


def read_glb(files: list[str]) -> list[FileSyntax]:
    """The set's .glb files, parsed by glbc (GlbError on a bad one)."""
    return [parse_file(glbc_cli._read(name)) for name in files]


def glb_only_document(glb: list[FileSyntax]) -> dict:
    """The layout of the .glb files alone (what the checker binds AT paths and qualified access to when
    no --set-layout is given)."""
    return document(build(glb))


@dataclass
class Laid:
    layout: Layout
    doc: dict
    header: str


def lay_out(
    glb: list[FileSyntax],
    st: list[FileSyntax],
    set_layout: str | None,
    running: str | None,
    argv: list[str],
    max_size: int = DEFAULT_MAX_SIZE,
) -> Laid:
    """The set's layout: .glb variables first, then the ST ones; against the running layout when
    given (online change), else against the set's layout (its C++ modules keep fitting).  With both,
    the set's layout must have been laid out against the running one; it joins the lineage."""
    layout = build(glb + st, max_size)
    if set_layout is not None:
        _declared_by_glb(layout, read_previous(set_layout))
    prev: Previous | None = None
    if running is not None:
        prev = read_previous(running)
    elif set_layout is not None:
        prev = read_previous(set_layout)
    if prev is not None:
        place(layout, prev, max_size)
    if running is not None and set_layout is not None:
        _keep_set_layout(layout, read_previous(set_layout))
    doc = document(layout)
    return Laid(layout, doc, render_header(layout, doc["hash"], argv))


def _declared_by_glb(layout: Layout, set_prev: Previous) -> None:
    """Every .glb variable of the set's layout (one without an `iec_type`: stc's own are declared again
    by the program) must be declared by the .glb files given: stc lays the set out again from
    declarations, and the header its modules include is made from them; a layout.json names places,
    not what glbc declared (its comments, #defines, the names of its types).  So a set's .glb files
    come with its .st files; without them its C++ modules would lose their variables."""
    declared = {v.path for v in layout.variables}
    for p in set_prev.variables:
        if p.path not in set_prev.iec and p.path not in declared:
            raise GlbError(
                f"'{p.path}' of the set's layout is declared by none of the .glb files given: give the set's "
                f".glb files (--glb; in an uploaded set, beside its .st files), or, if it was removed from "
                f"them, the layout glbc makes of them now",
                file=set_prev.file,
            )


def _keep_set_layout(layout: Layout, set_prev: Previous) -> None:
    """The set's C++ modules were built against set_prev: every variable of it must be where it was,
    and its hash in the lineage, for irpd to take them (docs/hot-reload.md, layouts::compatible)."""
    from glbc_compiler.emit_layout import type_id

    now = {v.path: v for v in layout.variables}
    for p in set_prev.variables:
        v = now.get(p.path)
        if v is None or (v.offset, v.lock, type_id(v)) != (p.offset, p.lock, p.type_id):
            raise GlbError(
                f"'{p.path}' is not where the set's layout has it: the set's layout was not laid out against "
                f"the running one; build the .glb files with glbc --previous <running layout.json> first",
                file=set_prev.file,
            )
    if all(e["hash"] != set_prev.hash for e in layout.lineage):
        layout.lineage.insert(0, {"hash": set_prev.hash, "variables": [p.entry() for p in set_prev.variables]})


def write(out: str, laid: Laid) -> None:
    os.makedirs(os.path.join(out, "indurop"), exist_ok=True)
    glbc_cli._write(os.path.join(out, "indurop", "generated.h"), laid.header)
    glbc_cli._write(os.path.join(out, "layout.json"), render_layout(laid.layout))


def glb_error(e: GlbError) -> StError:
    """A glbc error as stc reports it (code `layout`), at the ST place when glbc named one."""
    loc = getattr(e, "loc", None)
    if loc is not None:
        return StError(Place(loc.source.name, loc.line, loc.col), "layout", e.message)
    return StError(Place(getattr(e, "file", None) or "layout.json", 1, 1), "layout", e.message)


def load_json(path: str) -> dict:
    with open(path, encoding="utf-8") as f:
        return json.load(f)

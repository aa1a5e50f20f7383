# emit_cpp.py -- the checked tree -> one C++20 translation unit per PROGRAM instance: a thread module
# (start() and run(), docs/modules.md) against st/runtime (irp::st) and glbc's generated.h.  run()
# copies in the shared variables the code touches (the process image), runs the PROGRAM on those
# locals and writes back what changed; every statement carries `#line N "file.st"`.  Expressions and
# statements are in emit_code.py; the standard functions' C++ names come from stdlib.py's table.

from __future__ import annotations

from . import externs
from . import tree as t
from . import types as ty
from .check import Program
from .emit_code import (
    PART_STATEMENTS,
    CodeEmitter,
    _scalar,
    cpp_type,
    image_key,
    literal,
    program_members,
    walk_names,
    written_roots,
)
from .emit_glb import EMPTY_FB_FIELD, INIT_FLAG, RETAIN_INIT_FLAG, Instance, fb_fields, stored
from .errors import StError

RESET_LINE = "#line RESET"  # replaced by the .cpp's own line once the text is complete
# Names the generated code uses unqualified besides the standard functions: the runtime's helpers and
# types (irp::st) and the generated scaffolding.  A POU or type of the same name would hide them.
GENERATED_NAMES = frozenset(
    "Place String ENUM index range loopCheck forStarts forStep cycleTime store copyIn writeBack getBit setBit "
    "NEG programBody fbBody startInstance runInstance Globals Bound global global0 bound bound0 self self0 "
    "initial fresh freshRetained globalInitial safeOutputs start run Kept kept grouped image forget How inPart "
    "KeptImage groupCount inPlace openGroup closeGroup".upper().split()
)
LOCAL_NAMES = frozenset({"SELF", "FB_", "R_", "WRITTEN_"})  # the generated code's own locals in a POU's body


def name_problems(prog: Program) -> list[StError]:
    """POUs, types and locals whose names the generated C++ needs for itself: an error asking to rename."""
    errors = []
    # the functions that keep what a made STRUCT's ns::make returns (externs.Passing.made_helper)
    made = {
        (externs.MADE_PREFIX + d.name).upper()
        for unit in prog.units
        for d in unit.types
        if getattr(d, "extern", None) and getattr(d, "extern_args", None) is not None
    }
    for unit in prog.units:
        for decl in list(unit.pous) + list(unit.types):
            if decl.name.upper() in GENERATED_NAMES or decl.name.upper() in made:
                what = getattr(decl, "kind", "type")
                errors.append(
                    StError(
                        decl.place,
                        "name",
                        f"'{decl.name}' is a name the generated C++ uses (the ST runtime); rename the {what}",
                    )
                )
        bindings = [v for pou in unit.pous for v in pou.vars] + list(unit.globals)
        bindings += [g for conf in unit.configurations for g in conf.vars + [x for r in conf.resources for x in r.vars]]
        for v in bindings:
            if v.location is not None and v.glb is None:
                errors.append(
                    StError(
                        v.place,
                        "binding",
                        f"{v.location} is a shared variable of the set's layout: give stc build the set's .glb files "
                        "(--glb) or its layout (--set-layout)",
                    )
                )
        for pou in unit.pous:
            for v in pou.vars:
                if v.location is not None and pou.kind != "PROGRAM":
                    errors.append(
                        StError(
                            v.place,
                            "unsupported",
                            f"an AT binding belongs in a PROGRAM or a VAR_GLOBAL, not in a {pou.kind}; "
                            "bind it there and pass the value in",
                        )
                    )
                if v.name.upper() in LOCAL_NAMES:
                    errors.append(
                        StError(v.place, "name", f"'{v.name}' is a name the generated C++ uses; rename the variable")
                    )
            if pou.kind == "PROGRAM":
                for v in pou.vars:
                    if v.kind == "VAR_IN_OUT":
                        errors.append(
                            StError(
                                v.place,
                                "unsupported",
                                "a PROGRAM run by a task has nothing to pass by reference: declare it VAR, "
                                "VAR_EXTERNAL or bind it with AT",
                            )
                        )
    return errors


def generate(
    prog: Program, inst: Instance, added: set[str], sources: list[str], layout: list[dict] | None = None
) -> str:
    """The .cpp of one PROGRAM instance.  `added`: the paths of variables the layout added against
    the previous one (online change): start() gives them their initial values even when the other
    variables keep theirs.  `layout`: the set's variables as laid out (layout.json's "variables"):
    an instance they lay out as its C++ struct runs in place (in_place_members)."""
    return _Unit(prog, inst, added, sources, layout).render()


def in_place_members(inst: Instance, layout: list[dict] | None) -> list[tuple[t.VarDecl, dict]] | None:
    """The instance's struct members with their layout entries when the segment lays them out as the
    C++ struct (declaration order, each at its alignment, from an address aligned for all) and its
    structs and arrays share one lock (its group): the program then runs in place (in_place.hpp).
    None when not: an AT binding among them (it lives elsewhere), a variable an online change put
    elsewhere, no layout given."""
    members = program_members(inst.pou)
    if layout is None or not members or any(v.location is not None for v in members):
        return None
    entries = {(e.get("namespace"), e.get("name")): e for e in layout}
    out, base, at = [], None, 0
    for v in members:
        e = entries.get((inst.name, v.name))
        if e is None:
            return None
        if base is None:
            base = e["offset"]
        at = -(-at // e["align"]) * e["align"]
        if e["offset"] != base + at:
            return None
        at += e["size"]
        out.append((v, e))
    if base % max(e["align"] for _, e in out):
        return None
    if len({e["lock"] for v, e in out if not _scalar(v.type)}) > 1:
        return None
    return out


class _Unit:
    def __init__(
        self, prog: Program, inst: Instance, added: set[str], sources: list[str], layout: list[dict] | None
    ) -> None:
        self.prog, self.inst, self.added, self.sources = prog, inst, added, sources
        self.code = CodeEmitter(prog)
        self.pous = self.reached(inst.pou)  # FUNCTIONs and FBs the program uses, callees first
        self.in_place = in_place_members(inst, layout)

    # ---- what the program reaches ----------------------------------------------------------------

    def reached(self, root: t.Pou) -> list[t.Pou]:
        order: list[t.Pou] = []
        seen: set[int] = set()

        def visit(p: t.Pou) -> None:
            if id(p) in seen:
                return
            seen.add(id(p))
            for callee, _ in p.uses:
                visit(callee)
            for v in p.vars:  # FB instances of the declarations, also FBs used only as types
                for fb in _fbs_in(v.type):
                    visit(fb)
            order.append(p)

        visit(root)
        return [p for p in order if p is not root]

    def touched(self) -> tuple[list[t.VarDecl], list[t.VarDecl], list[t.VarDecl]]:
        """(the program's own variables, the VAR_GLOBALs, the .glb variables) its code reaches."""
        own, glob, glb = {}, {}, {}
        used: set[int] = set()  # the program's own declarations its body names
        for pou in [self.inst.pou] + self.pous:
            for n in walk_names(pou.body):
                d = n.decl
                if not isinstance(d, t.VarDecl):
                    continue
                used.add(id(d))
                if d.kind == "GLB":
                    glb[d.glb["path"]] = d
                elif d.kind == "VAR_EXTERNAL" or d.kind == "VAR_GLOBAL":
                    g = self.prog.globals.get(d.name.upper())
                    if g is not None and not g.constant:
                        glob[g.name.upper()] = g
        for v in self.inst.pou.vars:
            if stored(v) or (v.location is not None and v.glb is not None):
                own[v.name.upper()] = v
        self.used = used
        # the variables whose values the code may change (written_roots), by image_key
        self.written = {image_key(self.prog, d) for p in [self.inst.pou] + self.pous for d in written_roots(p.body)}
        glb_scalars_first = sorted(glb.values(), key=lambda d: not _scalar(d.type))
        return list(own.values()), list(glob.values()), glb_scalars_first

    # ---- the file ------------------------------------------------------------------------------

    def render(self) -> str:
        inst, pou = self.inst, self.inst.pou
        own, glob, glb = self.touched()
        self.copies = self.image(own, glob, glb)
        # the kept image's entries the code may write: each statement that may write one marks it
        table = self.table()
        self.code.written_index = {c[5]: i for i, c in enumerate(table) if c[4]}
        functions = []
        for p in self.pous:
            functions += self.code.pou(p) + [""]
        functions += self.code.pou(pou) + [""]
        head = [
            f"// {inst.name}.cpp -- generated by stc from {', '.join(self.sources)}: the PROGRAM instance "
            f"{inst.name} of {pou.name}",
            f"// (every {inst.interval_ns / 1e6:g} ms, priority {inst.priority}).  Do not edit: change the ST "
            "source and run `stc build` again.",
            "#include <indurop/generated.h>",
            "#include <indurop/indurop.h>",
            "#include <indurop/st/st.hpp>",
            *externs.includes(self.pous),
            "",
            "#include <array>",
            "#include <cstddef>",
            "",
            "namespace {",
            "using namespace irp::st;",
            "",
        ]
        body = self.code.type_definitions(self.pous, pou, glob)
        body += self.images(own, glob, glb)
        body += self.code.declarations(self.pous)
        body += self.code.places_text()
        body += functions
        body += self.entry_points(own, glob, glb)
        body += [
            "}  // namespace",
            "",
            "// The module's entry points (docs/modules.md).",
            "void start() { startInstance(); }",
            "void run() { runInstance(); }",
        ]
        lines = head + body
        out = []
        for line in lines:
            if line == RESET_LINE:
                line = f'#line {len(out) + 2} "{inst.name}.cpp"'
            out.append(line)
        return "\n".join(out) + "\n"

    def images(self, own, glob, glb) -> list[str]:
        pou = self.inst.pou
        if self.in_place:
            ns = f"::{self.inst.name}"
            first = f"{ns}::{self.in_place[0][0].name}"
            out = [
                "// The PROGRAM's variables: run() works on them in place in the segment (in_place.hpp), laid out",
                f"// there as {pou.name} is (checked here); the process image below is of the other variables.",
            ]
            for v, e in self.in_place:
                out.append(
                    f"static_assert(offsetof({pou.name}, {v.name}) == {ns}::{v.name}.offset() - {first}.offset() && "
                    f"sizeof({pou.name}::{v.name}) == {e['size']});"
                )
        else:
            out = [
                "// The process image: the locals run() works on, and their snapshots at the copy-in.",
                f"{pou.name} self, self0;",
            ]
        if glob:
            out.append("Globals global, global0;")
        if glb:
            out.append("struct Bound {  // the scalars first: the lines a run copies them to")
            for d in glb:
                out.append(f"    {self.code.glb_type(d)} {_glb_member(d)};")
            out.append("};")
            out.append("Bound bound, bound0;")
        if self.code.written_index:
            n = sum(1 for c in self.copies if not _scalar(c[3]))
            out.append(f"bool written_[{n}];  // image[i] (below) may have been written in this run")
        return out + [""]

    def table(self) -> list[tuple]:
        """The kept image's entries (the structs and arrays of the process image), the instance's own
        first: they are its lock group (emit_glb.py), whose entries kept.hpp's grouped() needs together."""
        own = f"::{self.inst.name}::"
        rest = [c for c in self.copies if not _scalar(c[3])]
        return [c for c in rest if c[0].startswith(own)] + [c for c in rest if not c[0].startswith(own)]

    def image(self, own, glob, glb) -> list[tuple]:
        """The process image: (ref, local, snapshot, type, whether the code may write it, image_key)
        of each variable the code touches."""
        ns = f"::{self.inst.name}"
        # the program's own variables: none when it runs in place, else those the code touches (the
        # others' initial values are written by start())
        copied = [] if self.in_place else [v for v in own if id(v) in self.used]
        copies = []
        for v in copied:
            ref = _glb_ref(v.glb) if v.location is not None else f"{ns}::{v.name}"
            copies.append((ref, f"self.{v.name}", f"self0.{v.name}", v.type))
        for g in glob:
            ref = _glb_ref(g.glb) if g.location is not None else f"::{self.code.global_namespace(g)}::{g.name}"
            copies.append((ref, f"global.{g.name}", f"global0.{g.name}", g.type))
        for d in glb:
            member = _glb_member(d)
            copies.append((_glb_ref(d.glb), f"bound.{member}", f"bound0.{member}", d.type))
        decls = copied + glob + glb
        keys = [image_key(self.prog, d) for d in decls]
        return [(*c, k in self.written, k) for c, k in zip(copies, keys)]

    def entry_points(self, own, glob, glb) -> list[str]:
        inst, pou = self.inst, self.inst.pou
        ns = f"::{inst.name}"
        copies = self.copies
        plain = [v for v in own if v.location is None and not (v.retain or v.persistent)]
        kept = [v for v in own if v.location is None and (v.retain or v.persistent)]
        out = [
            "// start(): the initial values, for the variables that have none yet (a new segment, or added by",
            "// an online change); retained ones only when no retained value was restored.",
            "void startInstance() {",
            f"    static const {pou.name} initial{{}};",
            f"    const bool fresh = !{ns}::{INIT_FLAG}.load();",
        ]
        stores = []
        for v in plain:
            path = f"{inst.name}.{v.name}"
            cond = "fresh" if path not in self.added else "true"
            stores.append(f"    if ({cond}) store({ns}::{v.name}, initial.{v.name});")
        out += in_parts(stores)
        if kept:
            out.append(f"    const bool freshRetained = !{ns}::{RETAIN_INIT_FLAG}.load();")
            for v in kept:
                path = f"{inst.name}.{v.name}"
                cond = "freshRetained" if path not in self.added else "true"
                out.append(f"    if ({cond}) store({ns}::{v.name}, initial.{v.name});")
            out.append(f"    {ns}::{RETAIN_INIT_FLAG}.store(true);")
        if glob:
            out.append("    static const Globals globalInitial{};")
            for g in glob:
                if g.location is None:
                    ns_g = self.code.global_namespace(g)
                    cond = "true" if f"{ns_g}.{g.name}" in self.added else "fresh"
                    out.append(f"    if ({cond}) store(::{ns_g}::{g.name}, globalInitial.{g.name});")
        out += [f"    {ns}::{INIT_FLAG}.store(true);", "}", ""]
        outputs = [v for v in own if v.kind == "VAR_OUTPUT"]
        if outputs:
            out += [
                "// A run that faults: the PROGRAM's outputs (VAR_OUTPUT) go to their safe values, their initial",
                "// values, before irpd disables the module.",
                "void safeOutputs() {",
                f"    static const {pou.name} initial{{}};",
            ]
            for v in outputs:
                ref = _glb_ref(v.glb) if v.location is not None else f"{ns}::{v.name}"
                out.append(f"    store({ref}, initial.{v.name});")
            out += ["}", ""]
        # scalars: one atomic load and store each; structs and arrays: the kept image's table (kept.hpp)
        scalars = [c for c in copies if _scalar(c[3])]
        table = self.table()
        image_args = "image, written_" if self.code.written_index else "image"
        group = None  # in place: the lock of the instance's structs and arrays, held for the run
        if self.in_place:
            group = next((f"{ns}::{v.name}.lockIndex()" for v, _ in self.in_place if not _scalar(v.type)), None)
            out += [
                "// run(): one period, on the PROGRAM's variables in place, the structs and arrays among them with",
                "// their group's lock held (in_place.hpp); the others through the process image.  A fault throws",
                "// past the write-back: the process image writes nothing; what the run wrote in place stays.",
            ]
        else:
            out += ["// run(): one period.  A fault throws past the write-back: a faulting run writes nothing."]
        if table:
            out.append(
                "// the kept image (kept.hpp): the table, its entries' sequences in it"
                + ("; the instance's own first," if not self.in_place else "")
            )
            if not self.in_place:
                out.append("// one lock group")
            out.append("constexpr auto spec0_ = grouped(std::array{")
            for ref, local, snap, _, written, _ in table:
                snap = f", {snap}" if written else ""  # read only: no snapshot, no write-back
                out.append(f"    kept({ref}, {local}{snap}),")
            out.append("});")
            out.append("// the table a run walks: 20 bytes an entry, the groups apart")
            out.append("constinit KeptImage<spec0_.size(), groupCount(spec0_)> image{spec0_};")
        out.append("void runInstance() {")
        if self.in_place:
            out.append(f"    auto &self = inPlace<{pou.name}>({ns}::{self.in_place[0][0].name});")
        # a scalar the code never writes: no snapshot (never written back)
        out += in_parts(
            [
                f"    copyIn({ref}, {local}, {snap});" if written else f"    copyIn({ref}, {local});"
                for ref, local, snap, _, written, _ in scalars
            ]
        )
        if table:
            out.append("    copyIn(image);")
        if group:
            out.append(f"    const uint32_t group_ = openGroup({group});")
        if outputs or table or group:
            out += ["    try {", "        programBody(self);", "    } catch (...) {"]
            if group:
                out.append(f"        closeGroup({group}, group_);")
            if table:
                out.append(f"        forget({image_args});  // the locals hold a partial run")
            if outputs:
                out.append("        safeOutputs();")
            out += ["        throw;", "    }"]
        else:
            out.append("    programBody(self);")
        if group:
            out.append(f"    closeGroup({group}, group_);")
        out += in_parts(
            [f"    writeBack({ref}, {local}, {snap});" for ref, local, snap, _, written, _ in scalars if written]
        )
        if table and self.code.written_index:  # else every entry is read only
            out.append(f"    writeBack({image_args});")
        out += ["}", ""]
        return out


def in_parts(lines: list[str]) -> list[str]:
    """Lines of a function (copy-ins, write-backs, initial values: one a variable) in parts of at most
    PART_STATEMENTS, each a lambda run by the runtime's inPart() (noinline): g++ compiles each part as
    a function of its own, as it does the parts of a long body."""
    if len(lines) <= PART_STATEMENTS:
        return lines
    out = []
    for at in range(0, len(lines), PART_STATEMENTS):
        out += ["    inPart([&] {", *("    " + line for line in lines[at : at + PART_STATEMENTS]), "    });"]
    return out


def _fbs_in(typ) -> list[t.Pou]:
    while isinstance(typ, ty.ArrayType):
        typ = typ.element
    if isinstance(typ, ty.FbType):
        return [typ.pou]
    if isinstance(typ, ty.StructType) and not _is_glb_struct(typ):
        return [fb for m in typ.members.values() for fb in _fbs_in(m.type)]
    return []


def _is_glb_struct(typ) -> bool:
    return any(getattr(m, "glb", None) is not None for m in typ.members.values())


def _glb_ref(entry: dict) -> str:
    ns = entry.get("namespace", "")
    return "::" + "::".join([*ns.split("."), entry["name"]]) if ns else f"::{entry['name']}"


def _glb_member(d: t.VarDecl) -> str:
    return d.glb["path"].replace(".", "_")


__all__ = ["generate", "EMPTY_FB_FIELD", "fb_fields", "cpp_type", "literal"]

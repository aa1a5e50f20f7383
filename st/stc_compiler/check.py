# check.py -- the meaning of a set of ST sources: declarations (types, POUs, globals, configurations),
# names (case-insensitive, C++-safe), initial values, statements and recursion.  Expressions and calls
# are typed by check_expr.py.  Afterwards every expression has `type`, every name `decl`, every call
# `target`; errors are gathered and raised together as StErrors.

from __future__ import annotations

import difflib
import sys
from dataclasses import dataclass, field
from pathlib import Path

from . import externs, stdlib
from . import tree as t
from . import types as ty
from .check_expr import ExprChecker
from .errors import Collector, Place
from .layout import Layout
from .parse import ensure_recursion_limit, parse_text

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "glb"))
from glbc_compiler import names as glb_names  # noqa: E402  (glbc's rules for C++-safe names: one truth)

LOOPS = (t.For, t.While, t.Repeat)


@dataclass
class Program:
    """What check() returns: every declaration by upper-case name, and the sources' units."""

    units: list[t.Unit]
    pous: dict[str, t.Pou] = field(default_factory=dict)
    types: dict[str, t.TypeDecl] = field(default_factory=dict)
    globals: dict[str, t.VarDecl] = field(default_factory=dict)
    enum_values: dict[str, list[t.EnumValue]] = field(default_factory=dict)
    configurations: list[t.Configuration] = field(default_factory=list)
    layout: Layout | None = None


LIBRARY = Path(__file__).resolve().parents[1] / "lib"
STANDARD_LIBRARY = LIBRARY / "standard.st"
LIBRARIES = (STANDARD_LIBRARY, LIBRARY / "plcopen.st", LIBRARY / "sfc.st")


def library_units() -> list[t.Unit]:
    """st/lib/standard.st (TON, CTU, R_TRIG, ...), plcopen.st (the motion blocks, the alarms) and
    sfc.st (an SFC's step type and ACTION_CONTROL), read with every program; parsed anew each time
    because check() fills its tree."""
    units = [parse_text(f.name, f.read_text()) for f in LIBRARIES]
    for u in units:
        u.library = True
    return units


def check(units: list[t.Unit], layout: Layout | None = None, library: bool = True) -> Program:
    """Checks the units together (one set) with the standard library; raises StErrors listing
    every error found."""
    ensure_recursion_limit()  # the passes recurse along trees parse.py let through (MAX_DEPTH)
    errors = Collector()
    prog = Program((library_units() if library else []) + units, layout=layout)
    Checker(prog, errors).run()
    errors.raise_if_any()
    return prog


class Checker(ExprChecker):
    def __init__(self, prog: Program, errors: Collector) -> None:
        super().__init__(prog, errors)
        self._resolving: set[int] = set()

    def run(self) -> None:
        self.declare()
        for decl in self.prog.types.values():
            self.type_decl(decl)
        for g in self.prog.globals.values():
            self.var(g, None)
        for pou in self.prog.pous.values():
            self.pou_vars(pou)
        for pou in self.prog.pous.values():
            if pou.extern:
                self.extern_pou(pou)
            self.scope = pou
            self.block(pou.body, 0)
            self.scope = None
        for decl in self.prog.types.values():
            if decl.extern:
                self.extern_type(decl)
        self.recursion()
        for conf in self.prog.configurations:
            self.configuration(conf)

    def extern_type(self, decl: t.TypeDecl) -> None:
        """{extern 'cpp::Type'} on a STRUCT: the C++ type of its bytes; {extern 'cpp::make(a, b)'}: made
        from its members a, b."""
        self.extern_library(decl.place, decl.extern)
        if not isinstance(decl.type, ty.StructType):
            self.error(
                decl.place, "declaration", f"{{extern '{decl.extern}'}} binds a STRUCT type; '{decl.name}' is none"
            )
            return
        for a in decl.extern_args or []:
            if a.upper() not in decl.type.members:
                self.error(
                    decl.place,
                    "declaration",
                    f"{{extern '{decl.extern}(...)'}} names '{a}', which is no member of {decl.name}; name its members",
                )

    def extern_library(self, place: Place, cpp: str) -> None:
        if externs.library_of(cpp) is None:
            known = ", ".join(f"{ns}::" for ns in externs.LIBRARIES)
            self.error(
                place, "declaration", f"no C++ library the modules link has '{cpp}'; an extern names one in {known}"
            )

    def extern_pou(self, pou: t.Pou) -> None:
        """An FB or FUNCTION implemented in C++ declares its interface only: the C++ is its body."""
        self.extern_library(pou.place, pou.extern)
        if pou.body:
            self.error(
                pou.body[0].place,
                "declaration",
                f"{pou.name} is implemented in C++ ({pou.extern}); remove its statements, or the {{extern}} pragma",
            )
        for v in pou.vars:
            if v.kind in ("VAR_TEMP", "VAR_EXTERNAL"):
                self.error(
                    v.place,
                    "declaration",
                    f"{v.kind} in {pou.name}, implemented in C++ ({pou.extern}): only its interface and memory (VAR) are declared; remove it",
                )

    # ---- names ---------------------------------------------------------------------------------

    def name_ok(self, place: Place, name: str, what: str, field: bool = False) -> None:
        why = glb_names.problem(name, field)
        if why:
            self.error(place, "name", f"{why}; rename the {what}")

    def unique(self, table: dict, key_place: Place, name: str, item, what: str) -> None:
        key = name.upper()
        if key in table:
            first = table[key].place
            where = f"line {first.line}" if first.file == key_place.file else f"{first.file}:{first.line}"
            self.error(key_place, "duplicate", f"'{name}' is declared twice (first at {where}); rename one of them")
            return
        table[key] = item

    def standard_name(self, pou: t.Pou) -> bool:
        """IEC 61131-3 reserves the standard functions' and function blocks' names: a POU of the set
        named like one would hide it from every call (docs/st.md, "Names")."""
        key = pou.name.upper()
        library = self.prog.pous.get(key)
        if stdlib.lookup(key) is not None:
            what = "a standard function"
        elif library is not None and any(p is library for u in self.prog.units if u.library for p in u.pous):
            what = f"a standard {'function block' if library.kind == 'FUNCTION_BLOCK' else library.kind.lower()} (st/lib/{library.place.file})"
        else:
            return False
        self.error(
            pou.place,
            "reserved",
            f"'{pou.name}' is {what}, and IEC 61131-3 reserves its name; rename the {pou.kind} "
            f"(e.g. 'My{pou.name[:1].upper()}{pou.name[1:].lower()}') and its calls",
        )
        return True

    def declare(self) -> None:
        prog = self.prog
        for unit in prog.units:
            for decl in unit.types:
                self.name_ok(decl.place, decl.name, "type")
                if decl.name.upper() in ty.ELEMENTARY or decl.name.upper() in ty.ALIASES:
                    self.error(decl.place, "duplicate", f"'{decl.name}' is an elementary type; choose another name")
                    continue
                self.unique(prog.types, decl.place, decl.name, decl, "type")
            for pou in unit.pous:
                self.name_ok(pou.place, pou.name, pou.kind)
                if pou.name.upper() in prog.types:
                    self.error(pou.place, "duplicate", f"'{pou.name}' is already a type; rename the {pou.kind}")
                    continue
                if not unit.library and self.standard_name(pou):
                    continue
                self.unique(prog.pous, pou.place, pou.name, pou, pou.kind)
            for g in unit.globals:
                self.unique(prog.globals, g.place, g.name, g, "variable")
            for conf in unit.configurations:
                prog.configurations.append(conf)
                for g in conf.vars + [v for r in conf.resources for v in r.vars]:
                    self.unique(prog.globals, g.place, g.name, g, "variable")
        for g in prog.globals.values():
            self.name_ok(g.place, g.name, "variable")
            if g.kind != "VAR_GLOBAL":
                self.error(
                    g.place,
                    "declaration",
                    f"{g.kind} belongs in a POU; a CONFIGURATION or RESOURCE declares VAR_GLOBAL",
                )
        for pou in prog.pous.values():
            local: dict[str, t.VarDecl] = {}
            for v in pou.vars:
                self.name_ok(v.place, v.name, "variable")
                self.unique(local, v.place, v.name, v, "variable")
                v.owner = pou
                self.var_kind_ok(pou, v)
            if pou.kind == "FUNCTION" and pou.returns is not None:
                if pou.name.upper() in local:
                    self.error(
                        local[pou.name.upper()].place,
                        "duplicate",
                        f"'{pou.name}' is the FUNCTION's result; rename the variable",
                    )
                pou.result = t.VarDecl(pou.place, pou.name, "RESULT", pou.returns)
                pou.result.owner = pou
            pou.locals = local

    def var_kind_ok(self, pou: t.Pou, v: t.VarDecl) -> None:
        allowed = {
            "PROGRAM": {"VAR", "VAR_INPUT", "VAR_OUTPUT", "VAR_IN_OUT", "VAR_TEMP", "VAR_EXTERNAL"},
            "FUNCTION_BLOCK": {"VAR", "VAR_INPUT", "VAR_OUTPUT", "VAR_IN_OUT", "VAR_TEMP", "VAR_EXTERNAL"},
            "FUNCTION": {"VAR", "VAR_INPUT", "VAR_OUTPUT", "VAR_IN_OUT", "VAR_TEMP", "VAR_EXTERNAL"},
        }[pou.kind]
        if v.kind not in allowed:
            self.error(
                v.place,
                "declaration",
                f"{v.kind} cannot be declared in a {pou.kind}; declare it in a CONFIGURATION or a VAR_GLOBAL list",
            )
        if pou.kind == "FUNCTION" and (v.retain or v.persistent):
            self.error(
                v.place,
                "declaration",
                "a FUNCTION keeps no state between calls: RETAIN/PERSISTENT do not apply; remove them",
            )
        if v.kind in ("VAR_IN_OUT", "VAR_TEMP", "VAR_EXTERNAL") and v.init is not None and v.kind != "VAR_TEMP":
            self.error(v.place, "declaration", f"a {v.kind} has no initial value of its own; remove ':= ...'")

    # ---- types ---------------------------------------------------------------------------------

    def type_decl(self, decl: t.TypeDecl) -> ty.Type | None:
        if decl.type is not None:
            return decl.type
        if id(decl) in self._resolving:
            self.error(decl.place, "recursion", f"the type '{decl.name}' contains itself; break the cycle")
            return None
        self._resolving.add(id(decl))
        decl.type = self.resolve_spec(decl.spec, decl.name)
        self._resolving.discard(id(decl))
        if decl.type is not None and decl.init is not None:
            self.initial(decl.init, decl.type, decl.place)
        return decl.type

    def alias_init(self, spec):
        """The initial value a derived elementary type gives (TYPE X : INT := 5; END_TYPE, or an alias
        of such a type), for a declaration of type X without its own; None otherwise.  (A derived
        STRUCT, ARRAY, enumeration, subrange or STRING has a type object of its own, which the
        code generator looks its declaration up by.)"""
        seen: set[int] = set()
        while isinstance(spec, t.TypeRef):
            decl = self.prog.types.get(ty.ALIASES.get(spec.name.upper(), spec.name.upper()))
            if decl is None or id(decl) in seen or not isinstance(self.type_decl(decl), ty.Elementary):
                return None
            if decl.init is not None:
                return decl.init
            seen.add(id(decl))
            spec = decl.spec
        return None

    def lookup_type(self, ref: t.TypeRef) -> ty.Type | None:
        key = ty.ALIASES.get(ref.name.upper(), ref.name.upper())
        if key in ty.ELEMENTARY:
            return ty.ELEMENTARY[key]
        if key in self.prog.types:
            return self.type_decl(self.prog.types[key])
        pou = self.prog.pous.get(key)
        if pou is not None:
            if pou.kind == "FUNCTION_BLOCK":
                return ty.FbType(pou)
            self.error(
                ref.place, "type", f"'{ref.name}' is a {pou.kind}, not a type; only a FUNCTION_BLOCK has instances"
            )
            return None
        choices = list(ty.ELEMENTARY) + [d.name for d in self.prog.types.values()]
        choices += [p.name for p in self.prog.pous.values() if p.kind == "FUNCTION_BLOCK"]
        self.error(ref.place, "undeclared", f"unknown type '{ref.name}'{did_you_mean(ref.name, choices)}")
        return None

    def resolve_spec(self, spec, name: str | None = None) -> ty.Type | None:
        if isinstance(spec, t.TypeRef):
            return self.lookup_type(spec)
        if isinstance(spec, t.StringSpec):
            length = ty.DEFAULT_STRING_LENGTH
            if spec.length is not None:
                length = self.constant_int(spec.length, "a STRING length")
                if length is None:
                    return None
                if not 1 <= length <= ty.MAX_STRING_LENGTH:
                    self.error(
                        spec.length.place, "range", f"a STRING length is 1..{ty.MAX_STRING_LENGTH}, not {length}"
                    )
                    return None
            return ty.StringType(length, spec.wide)
        if isinstance(spec, t.ArraySpec):
            dims = []
            for lo_e, hi_e in spec.ranges:
                lo, hi = self.constant_int(lo_e, "an array bound"), self.constant_int(hi_e, "an array bound")
                if lo is None or hi is None:
                    return None
                if hi < lo:
                    self.error(lo_e.place, "range", f"the array range {lo}..{hi} is empty; write the lower bound first")
                    return None
                dims.append((lo, hi))
            element = self.resolve_spec(spec.element)
            return ty.ArrayType(dims, element, self.alias_init(spec.element)) if element is not None else None
        if isinstance(spec, t.SubrangeSpec):
            base = self.resolve_spec(spec.base)
            lo, hi = self.constant_int(spec.low, "a subrange bound"), self.constant_int(spec.high, "a subrange bound")
            if base is None or lo is None or hi is None:
                return None
            if not (isinstance(base, ty.Elementary) and base.kind in ("int", "uint")):
                self.error(spec.place, "type", f"a subrange needs an integer base type, not {base}")
                return None
            if hi < lo or not (ty.fits(base, lo) and ty.fits(base, hi)):
                self.error(spec.low.place, "range", f"the subrange {lo}..{hi} does not fit {base} or is empty")
                return None
            return ty.SubrangeType(name or f"{base}({lo}..{hi})", base, lo, hi)
        if isinstance(spec, t.EnumSpec):
            return self.enum(spec, name or "an inline enumeration")
        if isinstance(spec, t.StructSpec):
            st = ty.StructType(name or "STRUCT")
            for m in spec.members:
                self.name_ok(m.place, m.name, "field", field=True)
                if m.name.upper() in st.members:
                    self.error(m.place, "duplicate", f"the field '{m.name}' is declared twice; rename one")
                    continue
                st.members[m.name.upper()] = m
                self.var(m, None)
            return st
        return None

    def enum(self, spec: t.EnumSpec, name: str) -> ty.EnumType:
        et = ty.EnumType(name)
        number = 0
        for v in spec.values:
            self.name_ok(v.place, v.name, "enumeration value")
            if v.value is not None:
                n = self.constant_int(v.value, "an enumeration value")
                number = n if n is not None else number
            if not ty.fits(ty.INT, number):
                self.error(
                    v.place, "range", f"the enumeration value {number} does not fit INT (enumerations are 16-bit)"
                )
            if v.name.upper() in et.values:
                self.error(v.place, "duplicate", f"'{v.name}' is in the enumeration twice; remove one")
                continue
            v.number, v.enum = number, et
            et.values[v.name.upper()] = v
            self.prog.enum_values.setdefault(v.name.upper(), []).append(v)
            number += 1
        return et

    # ---- variables and initial values ----------------------------------------------------------

    def pou_vars(self, pou: t.Pou) -> None:
        self.scope = pou
        if pou.result is not None:
            pou.return_type = pou.result.type = self.resolve_spec(pou.returns)
            pou.result.init = self.alias_init(pou.returns)  # FUNCTION F : Five starts its result at 5
            if isinstance(pou.return_type, ty.FbType):
                self.error(pou.place, "type", "a FUNCTION cannot return an FB instance; return a STRUCT or use an FB")
        for v in pou.vars:
            self.var(v, pou)
            fb = _instance_of(v.type)
            if fb is not None:
                pou.uses.append((fb, v.place))
        self.scope = None

    def var(self, v: t.VarDecl, pou: t.Pou | None) -> None:
        v.type = self.resolve_spec(v.spec, None)
        if v.type is None:
            return
        if v.init is None and v.location is None and v.kind not in ("VAR_IN_OUT", "VAR_EXTERNAL", "RESULT"):
            v.init = self.alias_init(v.spec)  # TYPE X : INT := 5; a variable of type X starts at 5
        if v.kind == "VAR_EXTERNAL":
            g = self.prog.globals.get(v.name.upper())
            if g is None:
                self.error(
                    v.place,
                    "undeclared",
                    f"no VAR_GLOBAL '{v.name}' for this VAR_EXTERNAL; declare it in a VAR_GLOBAL list",
                )
            elif g.type is not None and not ty.same(g.type, v.type):
                self.error(
                    v.place,
                    "type",
                    f"VAR_EXTERNAL '{v.name}' is {v.type} but the VAR_GLOBAL is {g.type}; declare it {g.type}",
                )
            elif g.constant and not v.constant:
                self.error(
                    v.place, "constant", f"the VAR_GLOBAL '{v.name}' is CONSTANT; declare the VAR_EXTERNAL CONSTANT too"
                )
        if v.constant and v.init is None and v.kind != "VAR_EXTERNAL":
            self.error(v.place, "constant", f"the CONSTANT '{v.name}' needs a value: write ':= ...'")
        if v.location is not None:
            self.binding(v)
        if v.init is not None:
            self.initial(v.init, v.type, v.place)
            if v.constant and isinstance(v.init, t.Expr) and v.init.const is not None:
                v.const = v.init.const  # type: ignore[attr-defined]

    def binding(self, v: t.VarDecl) -> None:
        """`x AT %PLC_ROBOT.PLC_IN.Start : BOOL;`: an existing shared variable of the set's layout."""
        path = v.location[1:]
        if (
            not path
            or path[0] in "IQM"
            and (len(path) < 2 or path[1] in "XBWDL0123456789*")
            and "." not in path[:3].rstrip("XBWDL")
        ):
            self.error(
                v.place,
                "binding",
                f"direct addresses such as {v.location} are not supported; bind to a shared variable: AT %<namespace>.<variable>",
            )
            return
        layout = self.prog.layout
        if layout is None:
            return  # no layout given (stc check without --layout): checked when the set is built
        entry = layout.variable(path)
        if entry is None:
            names = [e["path"] for e in layout.variables.values()]
            self.error(v.place, "binding", f"no shared variable '{path}' in {layout.file}{did_you_mean(path, names)}")
            return
        glb_type = layout.iec_type(entry)
        if glb_type is None or not _same_storage(glb_type, v.type):
            self.error(
                v.place,
                "binding",
                f"'{path}' is {glb_type or entry['type']} ({entry['type']}) in the layout but '{v.name}' is declared {v.type}; declare it {glb_type}",
            )
            return
        v.glb = entry

    def initial(self, init, typ: ty.Type, place: Place) -> None:
        if isinstance(init, t.ArrayInit):
            if not isinstance(typ, ty.ArrayType):
                self.error(init.place, "type", f"an array initialiser [...] for {typ}; give a value of type {typ}")
                return
            total = 1
            for lo, hi in typ.dims:
                total *= hi - lo + 1
            count = 0
            for item in init.items:
                count += item.count if item.count is not None else 1
                if item.value is not None:
                    self.initial(item.value, typ.element, item.place)
            if count > total:
                self.error(
                    init.place,
                    "range",
                    f"{count} initial values for an array of {total} elements; remove {count - total}",
                )
            return
        if isinstance(init, t.StructInit):
            st = ty.base(typ)
            if isinstance(st, ty.FbType):
                members = {v.name.upper(): v for v in st.pou.vars if v.kind in ("VAR_INPUT", "VAR_OUTPUT", "VAR")}
            elif isinstance(st, ty.StructType):
                members = st.members
            else:
                self.error(init.place, "type", f"a structure initialiser (...) for {typ}; give a value of type {typ}")
                return
            for name, fplace, value in init.fields:
                m = members.get(name.upper())
                if m is None:
                    self.error(
                        fplace,
                        "undeclared",
                        f"{typ} has no field '{name}'{did_you_mean(name, [v.name for v in members.values()])}",
                    )
                elif m.type is not None:
                    self.initial(value, m.type, fplace)
            return
        self.expect(init, typ, "initial value", constant=True)

    def constant_int(self, e: t.Expr, what: str) -> int | None:
        typ = self.expr(e)
        if typ is None:
            return None
        if not isinstance(e.const, int) or isinstance(e.const, bool) or ty.kind(typ) not in ("int", "uint", "lit_int"):
            self.error(e.place, "constant", f"{what} must be a constant integer expression (literals, CONSTANTs)")
            return None
        self.settle(e, ty.concrete(typ))
        return e.const

    # ---- statements ----------------------------------------------------------------------------

    def block(self, stmts: list, loops: int) -> None:
        for s in stmts:
            self.statement(s, loops)

    def statement(self, s, loops: int) -> None:
        if isinstance(s, t.Assign):
            target = self.expr(s.target)
            if target is not None and self.assignable(s.target):
                self.expect(s.value, target, "assignment")
            else:
                self.expr(s.value)
        elif isinstance(s, t.CallStmt):
            # A call whose result is dropped is typed as any expression (MUX(0, x, 1); types its
            # inputs INT); an untyped one (MAX(1, 2);) takes its literals' default type.
            s.call.type = self.call(s.call, statement=True)
            self.settle(s.call, ty.concrete(s.call.type))
        elif isinstance(s, t.If):
            for cond, body in s.branches:
                self.condition(cond, "IF")
                self.block(body, loops)
            self.block(s.orelse or [], loops)
        elif isinstance(s, t.Case):
            self.case(s, loops)
        elif isinstance(s, t.For):
            self.for_loop(s, loops)
        elif isinstance(s, t.While):
            self.condition(s.cond, "WHILE")
            self.block(s.body, loops + 1)
        elif isinstance(s, t.Repeat):
            self.block(s.body, loops + 1)
            self.condition(s.cond, "UNTIL")
        elif isinstance(s, (t.Exit, t.Continue)) and loops == 0:
            word = "EXIT" if isinstance(s, t.Exit) else "CONTINUE"
            self.error(s.place, "loop", f"{word} outside a loop; it may stand only inside FOR, WHILE or REPEAT")

    def condition(self, e: t.Expr, what: str) -> None:
        typ = self.expr(e)
        if typ is not None and ty.base(typ) is not ty.BOOL:
            self.error(e.place, "type", f"the {what} condition is {typ}, not BOOL; compare it, e.g. `<> 0`")

    def for_loop(self, s: t.For, loops: int) -> None:
        typ = self.expr(s.var)
        if typ is not None:
            if ty.kind(typ) not in ("int", "uint"):
                self.error(
                    s.var.place,
                    "type",
                    f"the FOR variable '{s.var.name}' is {typ}; it must be an integer type (e.g. DINT)",
                )
            elif self.assignable(s.var):
                for e in (s.start, s.end) + ((s.step,) if s.step is not None else ()):
                    self.expect(e, typ, "FOR bound")
                if s.step is not None and s.step.const == 0:
                    self.error(s.step.place, "range", "BY 0 never ends the loop; give a step other than 0")
        self.block(s.body, loops + 1)

    def case(self, s: t.Case, loops: int) -> None:
        sel = self.expr(s.selector)
        if (
            sel is not None
            and ty.kind(sel) not in ("int", "uint", "lit_int")
            and not isinstance(ty.base(sel), ty.EnumType)
        ):
            self.error(s.selector.place, "type", f"CASE selects on an integer or an enumeration, not {sel}")
            sel = None
        if isinstance(sel, ty.LiteralType):  # CASE MAX(1, 2) OF: the literals' default type
            sel = ty.concrete(sel)
            self.settle(s.selector, sel)
        seen: list[tuple[int, int, t.CaseLabel]] = []
        for branch in s.branches:
            for label in branch.labels:
                lo = self.case_value(label.low, sel)
                hi = self.case_value(label.high, sel) if label.high is not None else lo
                if lo is None or hi is None:
                    continue
                if hi < lo:
                    self.error(label.place, "range", f"the CASE range {lo}..{hi} is empty; write the lower bound first")
                    continue
                for a, b, other in seen:
                    if lo <= b and a <= hi:
                        self.error(
                            label.place,
                            "case-overlap",
                            f"this CASE label overlaps the one on line {other.place.line} ({a}..{b}); each value may have one branch",
                        )
                        break
                seen.append((lo, hi, label))
            self.block(branch.body, loops)
        self.block(s.orelse or [], loops)

    def case_value(self, e: t.Expr, sel: ty.Type | None) -> int | None:
        typ = self.expr(e)
        if typ is None or sel is None:
            return None
        if not ty.converts(typ, sel):
            self.error(
                e.place, "type", f"the CASE label is {typ} but the selector is {sel}; write a label of type {sel}"
            )
            return None
        if not isinstance(e.const, int):
            self.error(
                e.place, "constant", "a CASE label must be a constant (a literal, a CONSTANT or an enumeration value)"
            )
            return None
        self.settle(e, sel)
        return int(e.const)

    # ---- recursion -----------------------------------------------------------------------------

    def recursion(self) -> None:
        """IEC 61131-3 forbids recursion: a cycle of calls (or of FB instances) is an error naming it."""
        state: dict[str, int] = {}
        path: list[tuple[t.Pou, Place]] = []

        def visit(pou: t.Pou) -> None:
            key = pou.name.upper()
            state[key] = 1
            for callee, place in pou.uses:
                ckey = callee.name.upper()
                if state.get(ckey) == 1:
                    names = (
                        [p.name for p, _ in path[[p.name.upper() for p, _ in path].index(ckey) :]]
                        if any(p.name.upper() == ckey for p, _ in path)
                        else []
                    )
                    chain = " -> ".join(names + [pou.name, callee.name]) if names else f"{pou.name} -> {callee.name}"
                    self.error(
                        place, "recursion", f"recursive call chain {chain}; IEC 61131-3 forbids recursion: use a loop"
                    )
                elif ckey not in state:
                    path.append((pou, place))
                    visit(callee)
                    path.pop()
            state[key] = 2

        for pou in self.prog.pous.values():
            if pou.name.upper() not in state:
                visit(pou)

    # ---- configuration -------------------------------------------------------------------------

    def configuration(self, conf: t.Configuration) -> None:
        self.name_ok(conf.place, conf.name, "CONFIGURATION")
        instances: dict[str, t.ProgramConfig] = {}
        for res in conf.resources:
            tasks: dict[str, t.Task] = {}
            for task in res.tasks:
                self.name_ok(task.place, task.name, "TASK")
                self.unique(tasks, task.place, task.name, task, "TASK")
                for key, (pplace, value) in task.params.items():
                    want = {"INTERVAL": ty.TIME, "PRIORITY": ty.ELEMENTARY["UINT"], "SINGLE": ty.BOOL}.get(key)
                    if want is None:
                        self.error(pplace, "task", f"a TASK takes INTERVAL, PRIORITY or SINGLE, not '{key}'")
                    else:
                        self.expect(value, want, f"TASK {key}", constant=key != "SINGLE")
                if "INTERVAL" not in task.params:
                    self.error(
                        task.place,
                        "task",
                        f"TASK {task.name} has no INTERVAL; give it one, e.g. INTERVAL := T#10ms (event tasks are not supported)",
                    )
            for pc in res.programs:
                self.name_ok(pc.place, pc.name, "PROGRAM instance")
                self.unique(instances, pc.place, pc.name, pc, "PROGRAM instance")
                layout = self.prog.layout
                if layout is not None and layout.is_namespace(pc.name):
                    self.error(
                        pc.place,
                        "name",
                        f"'{pc.name}' is already a namespace of the shared variables ({layout.file}); rename the PROGRAM instance",
                    )
                pou = self.prog.pous.get(pc.type_name.upper())
                if pou is None or pou.kind != "PROGRAM":
                    programs = [p.name for p in self.prog.pous.values() if p.kind == "PROGRAM"]
                    self.error(
                        pc.place, "undeclared", f"no PROGRAM '{pc.type_name}'{did_you_mean(pc.type_name, programs)}"
                    )
                    continue
                pc.pou = pou
                if pc.task is None:
                    self.error(
                        pc.place,
                        "task",
                        f"PROGRAM {pc.name} has no task; write `PROGRAM {pc.name} WITH <task> : {pc.type_name};`",
                    )
                elif pc.task.upper() not in tasks:
                    self.error(
                        pc.place,
                        "undeclared",
                        f"no TASK '{pc.task}' in RESOURCE {res.name}{did_you_mean(pc.task, [x.name for x in tasks.values()])}",
                    )
                if pc.args:
                    self.error(
                        pc.args[0].place,
                        "unsupported",
                        "PROGRAM parameters in a configuration are not supported; use VAR_GLOBAL / AT bindings",
                    )


def _instance_of(typ: ty.Type | None) -> t.Pou | None:
    """The FUNCTION_BLOCK an FB instance (or an array of them) is of."""
    while isinstance(typ, ty.ArrayType):
        typ = typ.element
    return typ.pou if isinstance(typ, ty.FbType) else None


def _same_storage(a: ty.Type, b: ty.Type) -> bool:
    """A binding's type matches the layout's when both have the same bytes (WORD and UINT alike)."""
    a, b = ty.base(a), ty.base(b)
    if isinstance(a, ty.ArrayType) or isinstance(b, ty.ArrayType):
        return (
            isinstance(a, ty.ArrayType)
            and isinstance(b, ty.ArrayType)
            and [h - lo for lo, h in a.dims] == [h - lo for lo, h in b.dims]
            and _same_storage(a.element, b.element)
        )
    if isinstance(a, ty.Elementary) and isinstance(b, ty.Elementary):
        timed = ("time", "date", "tod", "dt")
        return a.cpp == b.cpp and (a.kind in timed) == (b.kind in timed)
    return a is b


def did_you_mean(name: str, choices) -> str:
    by_upper = {c.upper(): c for c in choices}
    close = difflib.get_close_matches(name.upper(), list(by_upper), n=1, cutoff=0.6)
    return f"; did you mean '{by_upper[close[0]]}'?" if close else ""

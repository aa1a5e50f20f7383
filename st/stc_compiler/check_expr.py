# check_expr.py -- the types of ST expressions: name lookup (case-insensitive), literals, operators
# with IEC's implicit conversions, constant folding, assignability, and calls of functions, FB
# instances and the standard functions (stdlib.py).  check.py's Checker builds on it.

from __future__ import annotations

import difflib

from . import stdlib
from . import tree as t
from . import types as ty
from .errors import Collector, Place

ARITH = ("+", "-", "*", "/")
COMPARE = ("=", "<>", "<", ">", "<=", ">=")
NUMERIC = ("int", "uint", "real", "lit_int", "lit_real")


class GlbPath(ty.Type):
    """A leading part of a shared variable's path (`PLC_ROBOT`, `PLC_ROBOT.PLC_IN`) while a qualified
    access is resolved against the layout."""

    def __init__(self, path: str) -> None:
        self.name = path


def _time_result(op: str, lk: str, rk: str, lt: ty.Type, rt: ty.Type) -> ty.Type | None:
    """IEC 61131-3 table 30: arithmetic on durations and points in time."""
    lt, rt = ty.base(lt), ty.base(rt)
    if lk == rk == "time" and op in ("+", "-"):
        return ty.common(lt, rt)
    if lk == "time" and rk in NUMERIC and op in ("*", "/"):
        return lt
    if lk in NUMERIC and rk == "time" and op == "*":
        return rt
    if lk in ("tod", "dt") and rk == "time" and op in ("+", "-"):
        return lt
    if lk == rk and lk in ("date", "tod", "dt") and op == "-":
        return ty.LTIME if lt.name.startswith("L") else ty.TIME
    return None


class ExprChecker:
    def __init__(self, prog, errors: Collector) -> None:
        self.prog = prog
        self.errors = errors
        self.scope: t.Pou | None = None
        self._glb_decls: dict[str, t.VarDecl] = {}

    def error(self, place: Place, code: str, message: str) -> None:
        self.errors.add(place, code, message)

    # ---- names ---------------------------------------------------------------------------------

    def find_var(self, name: str) -> t.VarDecl | None:
        key = name.upper()
        pou = self.scope
        if pou is not None:
            local = getattr(pou, "locals", {}).get(key)
            if local is not None:
                return local
            if pou.result is not None and key == pou.name.upper():
                return pou.result
        return self.prog.globals.get(key)

    def visible_names(self) -> list[str]:
        names = [v.name for v in self.prog.globals.values()]
        if self.scope is not None:
            names += [v.name for v in getattr(self.scope, "locals", {}).values()]
        return names + [vs[0].name for vs in self.prog.enum_values.values()]

    def name(self, e: t.Name) -> ty.Type | None:
        decl = self.find_var(e.name)
        key = e.name.upper()
        if decl is not None:
            e.decl = decl
            e.const = getattr(decl, "const", None)
            return decl.type
        values = self.prog.enum_values.get(key)
        if values:
            if len({id(v.enum) for v in values}) > 1:
                names = " or ".join(f"{v.enum.name}#{v.name}" for v in values)
                self.error(e.place, "ambiguous", f"'{e.name}' is a value of several enumerations; write {names}")
                return None
            e.decl, e.const = values[0], values[0].number
            return values[0].enum
        if key in self.prog.pous:
            pou = self.prog.pous[key]
            self.error(e.place, "type", f"'{e.name}' is a {pou.kind}, not a variable; call it: {e.name}(...)")
            return None
        layout = self.prog.layout
        if layout is not None and layout.variable(e.name) is not None:
            return self.glb_variable(e, e.name)
        if layout is not None and layout.is_namespace(e.name):
            return GlbPath(e.name)
        self.error(e.place, "undeclared", f"'{e.name}' is not declared{self.did_you_mean(e.name)}")
        return None

    def did_you_mean(self, name: str, extra: list[str] | None = None) -> str:
        choices = {c.upper(): c for c in self.visible_names() + (extra or [])}
        close = difflib.get_close_matches(name.upper(), list(choices), n=1, cutoff=0.6)
        return f"; did you mean '{choices[close[0]]}'?" if close else "; declare it in a VAR block"

    # ---- expressions ---------------------------------------------------------------------------

    def expr(self, e: t.Expr) -> ty.Type | None:
        """The type of e (None after an error, which is reported); sets e.type and, when constant, e.const."""
        e.type = self._expr(e)
        return e.type

    def value(self, e: t.Expr) -> ty.Type | None:
        """expr() for a value: a namespace of the layout is not one."""
        typ = self.expr(e)
        if isinstance(typ, GlbPath):
            self.error(
                e.place,
                "type",
                f"'{typ.name}' is a namespace of the shared variables, not a variable; name one of its variables",
            )
            return None
        return typ

    def _expr(self, e: t.Expr) -> ty.Type | None:
        if isinstance(e, t.Literal):
            return self.literal(e)
        if isinstance(e, t.Name):
            return self.name(e)
        if isinstance(e, t.Member):
            return self.member(e)
        if isinstance(e, t.Index):
            return self.index(e)
        if isinstance(e, t.BitAccess):
            return self.bit(e)
        if isinstance(e, t.Unary):
            return self.unary(e)
        if isinstance(e, t.Binary):
            return self.binary(e)
        if isinstance(e, t.Call):
            return self.call(e, statement=False)
        return None  # pragma: no cover

    def literal(self, e: t.Literal) -> ty.Type | None:
        e.const = e.value
        if e.kind == "enum":
            enum = self.prog.types.get(e.prefix.upper())
            et = enum.type if enum is not None else None
            if not isinstance(et, ty.EnumType):
                self.error(
                    e.place, "undeclared", f"'{e.prefix}' is not an enumeration type; declare it in TYPE ... END_TYPE"
                )
                return None
            v = et.values.get(e.value.upper())
            if v is None:
                names = [x.name for x in et.values.values()]
                close = difflib.get_close_matches(e.value, names, n=1, cutoff=0.6)
                hint = f"; did you mean {e.prefix}#{close[0]}?" if close else f"; its values are {', '.join(names)}"
                self.error(e.place, "undeclared", f"{e.prefix} has no value '{e.value}'{hint}")
                return None
            e.const = v.number
            return et
        if e.kind in ("duration", "date", "tod", "dt"):
            return ty.ELEMENTARY[e.prefix]
        if e.kind in ("string", "wstring"):
            return ty.StringType(max(1, len(e.value)), e.kind == "wstring")
        if e.prefix is None:
            if e.kind == "bool":
                return ty.BOOL
            return ty.LiteralType(e.kind, e.value)
        prefix = ty.ALIASES.get(e.prefix.upper(), e.prefix.upper())
        typ = ty.ELEMENTARY.get(prefix)
        if typ is None:
            self.error(e.place, "type", f"'{e.prefix}#' names no elementary type; write e.g. INT#5 or REAL#1.5")
            return None
        if e.kind == "bool" or (typ is ty.BOOL and e.kind == "int" and e.value in (0, 1)):
            if typ is not ty.BOOL:
                self.error(e.place, "type", f"{e.text}: TRUE/FALSE are BOOL; write BOOL#{e.value!s}")
            e.const = bool(e.value)
            return ty.BOOL
        if e.kind == "real" and typ.kind != "real":
            self.error(
                e.place, "type", f"{e.text}: a real number cannot be {typ}; write REAL# or LREAL#, or a whole number"
            )
            return None
        if e.kind == "int" and typ.kind in ("int", "uint", "bit") and not ty.fits(typ, e.value):
            lo, hi = ty.value_range(typ)
            self.error(e.place, "range", f"{e.text} does not fit {typ} ({lo}..{hi}); use a wider type")
            return None
        if e.kind == "int" and typ.kind not in ("int", "uint", "bit", "real"):
            self.error(e.place, "type", f"{e.text}: an integer cannot be {typ}")
            return None
        if typ.kind == "real":
            e.const = float(e.value)
        return typ

    def member(self, e: t.Member) -> ty.Type | None:
        base = self.expr(e.base)
        if base is None:
            return None
        key = e.name.upper()
        if isinstance(base, GlbPath):
            return self.glb_member(e, base)
        b = ty.base(base)
        if isinstance(b, ty.FbType):
            m = getattr(b.pou, "locals", {}).get(key)
            if m is None:
                names = [v.name for v in b.pou.vars if v.kind in ("VAR_INPUT", "VAR_OUTPUT")]
                self.error(
                    e.place, "undeclared", f"{b.pou.name} has no input or output '{e.name}'{_close(e.name, names)}"
                )
                return None
            if m.kind not in ("VAR_INPUT", "VAR_OUTPUT", "VAR_IN_OUT"):
                self.error(
                    e.place,
                    "access",
                    f"'{e.name}' is internal to {b.pou.name} ({m.kind}); declare it VAR_OUTPUT to read it from outside",
                )
                return None
            e.decl = m
            return m.type
        if isinstance(b, ty.StructType):
            m = b.members.get(key)
            if m is None:
                self.error(
                    e.place,
                    "undeclared",
                    f"{b.name} has no field '{e.name}'{_close(e.name, [v.name for v in b.members.values()])}",
                )
                return None
            e.decl = m
            return m.type
        self.error(e.place, "type", f"{base} has no fields; '.{e.name}' applies to a STRUCT or an FB instance")
        return None

    def glb_member(self, e: t.Member, base: GlbPath) -> ty.Type | None:
        path = f"{base.name}.{e.name}"
        layout = self.prog.layout
        if layout.variable(path) is not None:
            return self.glb_variable(e, path)
        if layout.is_namespace(path):
            return GlbPath(path)
        names = [v["path"] for v in layout.variables.values() if v["path"].upper().startswith(base.name.upper() + ".")]
        self.error(e.place, "undeclared", f"no shared variable '{path}' in {layout.file}{_close(path, names)}")
        return None

    def glb_variable(self, e: t.Name | t.Member, path: str) -> ty.Type | None:
        """A shared variable of the layout named in full (qualified access): its IEC type."""
        layout = self.prog.layout
        entry = layout.variable(path)
        if entry is not None:
            decl = self._glb_decls.get(path.upper())
            if decl is None:
                decl = t.VarDecl(e.place, entry["path"], "GLB", None)
                decl.type, decl.glb = layout.iec_type(entry), entry
                self._glb_decls[path.upper()] = decl
            if decl.type is None:
                self.error(e.place, "type", f"'{entry['path']}' is {entry['type']}, which ST has no type for")
            e.decl = decl
            return decl.type
        return None  # pragma: no cover (callers look the path up first)

    def index(self, e: t.Index) -> ty.Type | None:
        base = self.value(e.base)
        for i in e.indices:
            it = self.value(i)
            if it is not None and ty.kind(it) not in ("int", "uint", "lit_int"):
                self.error(
                    i.place, "type", f"an array index is an integer, not {it}; convert it, e.g. {it}_TO_DINT(...)"
                )
            elif it is not None:
                self.settle(i, ty.DINT)
        if base is None:
            return None
        b = ty.base(base)
        if not isinstance(b, ty.ArrayType):
            self.error(e.place, "type", f"{base} is not an array; '[...]' applies to an ARRAY")
            return None
        if len(e.indices) != len(b.dims):
            self.error(
                e.place,
                "type",
                f"{len(e.indices)} indices for an array of {len(b.dims)} dimensions; give {len(b.dims)}",
            )
            return None
        for i, (lo, hi) in zip(e.indices, b.dims, strict=True):
            if isinstance(i.const, int) and not lo <= i.const <= hi:
                self.error(i.place, "range", f"the index {i.const} is outside the array's range {lo}..{hi}")
        return b.element

    def bit(self, e: t.BitAccess) -> ty.Type | None:
        base = self.value(e.base)
        if base is None:
            return None
        b = ty.base(base)
        if not isinstance(b, ty.Elementary) or b.kind not in ("bit", "int", "uint"):
            self.error(e.place, "type", f"bit access '.{e.bit}' applies to a bit string or an integer, not {base}")
            return None
        if e.bit >= b.bits:
            self.error(e.place, "range", f"{base} has bits 0..{b.bits - 1}, not {e.bit}")
            return None
        return ty.BOOL

    def unary(self, e: t.Unary) -> ty.Type | None:
        typ = self.value(e.operand)
        if typ is None:
            return None
        k = ty.kind(typ)
        if e.op == "NOT":
            if k not in ("bool", "bit"):
                self.error(
                    e.place, "type", f"NOT applies to BOOL or a bit string, not {typ}; compare it instead, e.g. `= 0`"
                )
                return None
            self.fold_unary(e)
            return ty.base(typ)
        if k not in ("int", "real", "time", "lit_int", "lit_real") and not (e.op == "+" and k == "uint"):
            self.error(e.place, "type", f"unary {e.op} applies to a signed number or a duration, not {typ}")
            return None
        self.fold_unary(e)
        if isinstance(typ, ty.LiteralType):
            low, high = (typ.low, typ.high) if e.op == "+" or typ.low is None else (-typ.high, -typ.low)
            return ty.LiteralType(typ.kind, e.const, low, high)
        return ty.base(typ)

    def binary(self, e: t.Binary) -> ty.Type | None:
        lt, rt = self.value(e.left), self.value(e.right)
        if lt is None or rt is None:
            return None
        op = e.op
        lk, rk = ty.kind(lt), ty.kind(rt)
        c = ty.common(lt, rt)
        if c is None and lk == rk == "string" and op in COMPARE:
            c = ty.STRING
        if op in ("AND", "OR", "XOR"):
            if c is None or ty.kind(c) not in ("bool", "bit", "lit_int"):
                return self.mismatch(e, lt, rt, f"{op} needs two BOOLs or two bit strings, not {lt} and {rt}")
            result = ty.concrete(c)
            self.settle_both(e, result)
            self.fold(e)
            return result
        if op in COMPARE:
            if c is None:
                return self.mismatch(e, lt, rt, f"cannot compare {lt} with {rt}")
            self.settle_both(e, ty.concrete(c))
            self.fold(e)
            return ty.BOOL
        if op == "**":
            if lk not in NUMERIC or rk not in NUMERIC:
                return self.mismatch(e, lt, rt, f"** needs numbers, not {lt} and {rt}")
            result = ty.base(lt) if lk == "real" else ty.LREAL if lk.startswith("lit") else None
            if result is None:
                self.error(
                    e.place, "type", f"** needs a REAL or LREAL base, not {lt}; convert it, e.g. {lt}_TO_LREAL(...)"
                )
                return None
            self.settle(e.left, result)
            self.settle(e.right, ty.concrete(rt))
            return result
        timed = _time_result(op, lk, rk, lt, rt) if "time" in (lk, rk) or lk in ("date", "tod", "dt") else None
        if timed is not None:
            for side, st in ((e.left, lt), (e.right, rt)):
                self.settle(side, ty.concrete(st) if ty.kind(st) != "time" else ty.base(st))
            return timed
        if op in ("/", "MOD") and e.right.const == 0 and e.left.const is None:
            self.error(e.right.place, "division", "division by zero; divide by something other than 0")
            return None
        if op == "MOD" and (c is None or ty.kind(c) not in ("int", "uint", "lit_int")):
            return self.mismatch(e, lt, rt, f"MOD needs two integers, not {lt} and {rt}")
        if c is None or ty.kind(c) not in NUMERIC:
            what = {"+": "add", "-": "subtract", "*": "multiply", "/": "divide", "MOD": "take MOD of"}[op]
            return self.mismatch(e, lt, rt, f"cannot {what} {lt} and {rt}")
        self.fold(e)
        if isinstance(c, ty.LiteralType) and e.const is not None:
            return ty.LiteralType("real" if isinstance(e.const, float) else "int", e.const)
        self.settle_both(e, c)
        return c

    def mismatch(self, e: t.Binary, lt: ty.Type, rt: ty.Type, what: str) -> None:
        conv = stdlib.conversion(str(ty.concrete(rt)), str(ty.concrete(lt))) or stdlib.conversion(
            str(ty.concrete(lt)), str(ty.concrete(rt))
        )
        hint = f"; convert one of them, e.g. {conv}(...)" if conv else "; they have no common type"
        self.error(e.place, "type", f"{what}{hint}")
        return None

    @staticmethod
    def fold_unary(e: t.Unary) -> None:
        """e.const from its operand's: NOT of a BOOL, - or + of a number (the monitor folds read values
        with it too, agent/indurop_agent/sets/st_monitor.py)."""
        c = e.operand.const
        if e.op == "NOT":
            if isinstance(c, bool):
                e.const = not c
        elif isinstance(c, (int, float)) and not isinstance(c, bool):
            e.const = -c if e.op == "-" else c

    def fold(self, e: t.Binary) -> None:
        a, b = e.left.const, e.right.const
        if a is None or b is None or isinstance(a, str) or isinstance(b, str):
            return
        op = e.op
        try:
            if op in COMPARE:
                e.const = {"=": a == b, "<>": a != b, "<": a < b, ">": a > b, "<=": a <= b, ">=": a >= b}[op]
            elif op in ("AND", "OR", "XOR"):
                r = {"AND": a & b, "OR": a | b, "XOR": a ^ b}[op]
                e.const = bool(r) if isinstance(a, bool) else r
            elif op in ("/", "MOD") and b == 0:
                self.error(e.right.place, "division", "division by zero; divide by something other than 0")
            elif op == "/":
                e.const = (
                    a / b if isinstance(a, float) or isinstance(b, float) else int(a / b) if abs(a) < 2**52 else a // b
                )
            elif op == "MOD":
                e.const = a - b * int(a / b)
            elif op in ("+", "-", "*"):
                e.const = {"+": a + b, "-": a - b, "*": a * b}[op]
        except (TypeError, OverflowError):
            e.const = None

    def settle(self, e: t.Expr, typ: ty.Type) -> None:
        """Gives untyped literals under `e` the type their context chose."""
        if isinstance(e.type, ty.LiteralType) and not isinstance(typ, ty.LiteralType):
            untyped, e.type = e.type, ty.base(typ)
            if isinstance(e, t.Call):  # MAX(1, 2): its generic arguments take the type it is given
                self.settle_call(e, typ, untyped)
                return
            for child in (getattr(e, "left", None), getattr(e, "right", None), getattr(e, "operand", None)):
                if child is not None:
                    self.settle(child, typ)

    def settle_call(self, c: t.Call, typ: ty.Type, untyped: ty.LiteralType) -> None:
        for a in c.args:
            p = a.param
            if p is None or p.type != "T" or a.value is None:
                continue
            if not ty.in_family(typ, p.family):
                conv = stdlib.conversion(str(untyped.default()), str(ty.base(typ)))
                fix = f"; convert its result, e.g. {conv}({c.target.name}(...))" if conv else ""
                self.error(a.place, "type", f"{c.target.name}'s {p.name} is {p.family}, not {typ}{fix}")
                return
            self.settle(a.value, typ)

    def settle_both(self, e: t.Binary, typ: ty.Type) -> None:
        self.settle(e.left, typ)
        self.settle(e.right, typ)

    # ---- what an expression may become -------------------------------------------------------

    def expect(self, e: t.Expr, dst: ty.Type, what: str, constant: bool = False) -> bool:
        """Checks that e's value may be stored in `dst` (IEC's implicit conversions); the error names the fix."""
        src = self.value(e)
        if src is None or dst is None:
            return False
        if constant and e.const is None:
            self.error(e.place, "constant", f"the {what} must be a constant (literals, CONSTANTs, enumeration values)")
            return False
        ok = ty.converts(src, dst)
        sk, dk = ty.kind(src), ty.kind(dst)
        if not ok and sk == dk == "string" and src.wide == ty.base(dst).wide:
            ok = True  # a longer string is cut at the target's length (docs/st.md)
        if not ok and isinstance(ty.base(dst), ty.EnumType) and ty.same(src, dst):
            ok = True
        if not ok and dk == "bool" and isinstance(e, t.Literal) and e.kind == "int" and e.prefix is None:
            ok = e.value in (0, 1)  # IEC 61131-3's boolean literals include 1 and 0 (`Lamp := 1;`)
        if ok:
            self.settle(e, dst)
            if isinstance(dst, ty.SubrangeType) and isinstance(e.const, int) and not ty.fits(dst, e.const):
                self.error(e.place, "range", f"{e.const} is outside {dst.name} ({dst.low}..{dst.high})")
                return False
            return True
        if isinstance(src, ty.LiteralType) and src.kind == "int" and dk in ("int", "uint", "bit"):
            lo, hi = ty.value_range(ty.base(dst))
            self.error(e.place, "range", f"{src.misfit(dst)} does not fit {dst} ({lo}..{hi}); use a wider type")
            return False
        s, d = ty.concrete(src), ty.base(dst)
        if isinstance(d, ty.EnumType) and d.values:
            first = next(iter(d.values.values())).name
            self.error(
                e.place, "type", f"cannot assign {s} to the enumeration {d}; give one of its values, e.g. {d}#{first}"
            )
            return False
        conv = stdlib.conversion(str(s), str(d))
        lead = f"cannot assign {s} to {d}" if what == "assignment" else f"the {what} is {d}, not {s}"
        if conv:
            narrowing = ty.kind(s) == ty.kind(d) or (ty.kind(s) in NUMERIC and ty.kind(d) in NUMERIC)
            why = " (it may lose data)" if narrowing else ""
            self.error(e.place, "type", f"{lead}{why}; use {conv}(...)")
        else:
            self.error(e.place, "type", f"{lead}; no conversion between them exists")
        return False

    def assignable(self, e: t.Expr) -> bool:
        """Whether e names a variable this POU may write; else an error saying why not."""
        if isinstance(e, t.Name):
            d = e.decl
            if isinstance(d, t.VarDecl):
                if d.constant:
                    self.error(
                        e.place,
                        "constant",
                        f"'{e.name}' is CONSTANT and cannot be assigned; remove CONSTANT or use another variable",
                    )
                    return False
                return True
            if d is not None:
                self.error(e.place, "assign", f"'{e.name}' is not a variable and cannot be assigned")
            return False
        if isinstance(e, t.Member):
            base = ty.base(e.base.type) if e.base.type is not None else None
            if isinstance(base, ty.FbType) and isinstance(e.decl, t.VarDecl):
                inst = _text(e.base)
                if e.decl.kind == "VAR_INPUT":
                    self.error(
                        e.place,
                        "access",
                        f"'{inst}.{e.name}' is an input of {base.pou.name}; set it through the call: {inst}({e.name} := ...)",
                    )
                    return False
                if e.decl.kind == "VAR_OUTPUT":
                    self.error(
                        e.place,
                        "access",
                        f"'{inst}.{e.name}' is an output of {base.pou.name}; only {base.pou.name} writes it",
                    )
                    return False
            if isinstance(e.decl, t.VarDecl) and e.decl.kind == "GLB":
                return True
            if isinstance(e.decl, t.VarDecl) and e.decl.constant:
                self.error(e.place, "constant", f"'{e.name}' is CONSTANT and cannot be assigned")
                return False
            return self.assignable(e.base)
        if isinstance(e, (t.Index, t.BitAccess)):
            return self.assignable(e.base)
        self.error(e.place, "assign", "only a variable can be assigned; this is an expression")
        return False

    # ---- calls ---------------------------------------------------------------------------------

    def call(self, c: t.Call, statement: bool) -> ty.Type | None:
        from .check_call import check_call

        return check_call(self, c, statement)


def _close(name: str, names: list[str]) -> str:
    by = {n.upper(): n for n in names}
    close = difflib.get_close_matches(name.upper(), list(by), n=1, cutoff=0.6)
    return f"; did you mean '{by[close[0]]}'?" if close else ""


def _text(e: t.Expr) -> str:
    if isinstance(e, t.Name):
        return e.name
    if isinstance(e, t.Member):
        return f"{_text(e.base)}.{e.name}"
    if isinstance(e, t.Index):
        return f"{_text(e.base)}[...]"
    return "..."

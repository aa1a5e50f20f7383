# emit_code.py -- C++ for the POUs of a checked ST program (emit_cpp.py assembles the file): the types
# (STRUCTs and FB instances as plain structs with their initial values), FUNCTIONs as C++ functions,
# FUNCTION_BLOCKs and the PROGRAM as functions on their struct, statements with `#line` and the write
# flags of the process image's structs and arrays they may write (`written_[i] = true;`, which run()'s
# write-back reads), expressions on irp::st (integer arithmetic that wraps, faults that name the ST
# place, the standard functions).

from __future__ import annotations

from . import externs, stdlib
from . import tree as t
from . import types as ty
from .check_expr import _text
from .emit_glb import EMPTY_FB_FIELD, fb_fields, globals_blocks, scalar, stored

# A POU body of more statements (nested ones counted) is split at its top-level statements into C++
# functions of at most about this many (a single larger statement keeps a function of its own): g++'s
# optimiser takes time that grows faster than a function's size, so a 10,000-line program compiles
# in pieces of a bounded size.
PART_STATEMENTS = 200

# The runtime spells the points in time of 64-bit ns once: the L-forms are the same values.
RUNTIME_NAME = {"LDATE": "DATE", "LTOD": "TOD", "LDT": "DT", "TIME_OF_DAY": "TOD", "DATE_AND_TIME": "DT"}
RUNTIME_NAME |= {"WSTRING": "STRING"}


def rt_name(name: str) -> str:
    return RUNTIME_NAME.get(name, name)


def cpp_type(typ) -> str:
    typ = ty.base(typ) if isinstance(typ, ty.SubrangeType) else typ
    if isinstance(typ, ty.Elementary):
        return rt_name(typ.name)
    if isinstance(typ, ty.StringType):
        return f"String<{typ.length}>"
    if isinstance(typ, ty.ArrayType):
        out = cpp_type(typ.element)
        for lo, hi in reversed(typ.dims):
            out = f"std::array<{out}, {hi - lo + 1}>"
        return out
    if isinstance(typ, ty.EnumType):
        return "ENUM"
    if isinstance(typ, ty.FbType):
        return typ.pou.name
    if isinstance(typ, ty.StructType):
        return getattr(typ, "cpp_name", typ.name)
    if isinstance(typ, ty.LiteralType):
        return cpp_type(typ.default())
    raise ValueError(f"no C++ type for {typ}")


def literal(value, typ) -> str:
    """A constant value as C++ for a place of type typ."""
    b = ty.base(typ) if typ is not None else None
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f"String<{max(1, len(value.encode('utf-8')))}>({c_string(value)})"
    if isinstance(value, float) or (isinstance(b, ty.Elementary) and b.kind == "real"):
        text = repr(float(value))
        if text in ("inf", "-inf", "nan"):
            text = {"inf": "HUGE_VAL", "-inf": "-HUGE_VAL", "nan": "NAN"}[text]
        elif "e" not in text and "." not in text:
            text += ".0"
        return text + ("f" if isinstance(b, ty.Elementary) and b.name == "REAL" and text[-1].isdigit() else "")
    value = int(value)
    if value == -(1 << 63):
        return "(-9223372036854775807LL - 1)"
    if value >= 1 << 63:
        return f"{value}ULL"
    if value >= 1 << 31 or value < -(1 << 31):
        return f"{value}LL"
    return str(value)


def c_string(text: str) -> str:
    out = []
    for byte in text.encode("utf-8"):
        c = chr(byte)
        if c in '"\\?':
            out.append("\\" + c)
        elif 32 <= byte < 127:
            out.append(c)
        else:
            out.append(f"\\{byte:03o}")
    return '"' + "".join(out) + '"'


def walk_names(stmts):
    """Every Name and Member node in statements (expressions, arguments, targets), recursively."""
    stack = list(stmts)
    while stack:
        n = stack.pop()
        if n is None:
            continue
        if isinstance(n, (list, tuple)):
            stack.extend(n)
            continue
        if isinstance(n, (t.Name, t.Member)):
            yield n
        if isinstance(n, t.Node):
            for value in vars(n).values():
                if isinstance(value, (t.Node, list, tuple)) and value is not n:
                    if isinstance(value, t.Pou) or isinstance(value, t.VarDecl):
                        continue
                    stack.append(value)


def program_members(pou: t.Pou) -> list[t.VarDecl]:
    """The members of a PROGRAM's C++ struct, in their order: its shared variables and its AT bindings
    (VAR, VAR_INPUT, VAR_OUTPUT), not its constants (static members) nor VAR_TEMP."""
    return [
        v for v in pou.vars if stored(v) or (v.location is not None and v.kind in ("VAR", "VAR_INPUT", "VAR_OUTPUT"))
    ]


class CodeEmitter:
    def __init__(self, prog) -> None:
        self.prog = prog
        self.places: dict[str, str] = {}  # constant name -> its definition
        self.scope: t.Pou | None = None
        self.temp = 0
        self.in_part = False  # emitting a part of a split body: RETURN ends the POU through the caller
        self.written_index: dict = {}  # image_key -> the kept image's entry a statement marks written_[i]
        self.marked: set[int] = set()  # the entries marked by statements that ran before the one emitted
        self.glb_structs: dict[int, str] = {}
        self.made_emitted: set[str] = set()  # the made structs whose function is in the file (externs.Passing)
        if prog.layout is not None:
            for name, st in prog.layout._structs.items():
                st.cpp_name = "::" + name.replace(".", "::")
        self.namespaces: dict[int, str] = {}
        for block in globals_blocks(prog.units):
            for g in block.decls:
                self.namespaces[id(g)] = block.namespace
        self.enum_decls = {id(d.type): d for d in prog.types.values() if isinstance(d.type, ty.EnumType)}
        # a named type's own initial value (TYPE Color : (...) := Green;); not for an alias of an
        # elementary type, whose type object is the elementary type itself
        self.type_decls = {
            id(d.type): d for d in prog.types.values() if d.type is not None and not isinstance(d.type, ty.Elementary)
        }

    # ---- places (faults) -------------------------------------------------------------------------

    def place(self, node: t.Node) -> str:
        p = node.place
        pou = self.scope
        who = f"{pou.kind} {pou.name}" if pou is not None else "?"
        name = f"k{pou.name if pou else ''}_{p.line}_{p.col}"
        if name not in self.places:
            self.places[name] = f'constexpr Place {name}{{{c_string(p.file)}, {p.line}, {p.col}, "{who}"}};'
        return name

    def places_text(self) -> list[str]:
        if not self.places:
            return []
        return ["// The ST places a run-time fault names."] + list(self.places.values()) + [""]

    def global_namespace(self, g: t.VarDecl) -> str:
        return self.namespaces[id(g)]

    def glb_type(self, d: t.VarDecl) -> str:
        return cpp_type(d.type)

    # ---- types -----------------------------------------------------------------------------------

    def type_definitions(self, pous: list[t.Pou], program: t.Pou, glob: list[t.VarDecl]) -> list[str]:
        out: list[str] = []
        done: set[int] = set()

        def need(typ) -> None:
            while isinstance(typ, ty.ArrayType):
                typ = typ.element
            if isinstance(typ, ty.FbType):
                emit_fb(typ.pou)
            elif isinstance(typ, ty.StructType) and not hasattr(typ, "cpp_name") and id(typ) not in done:
                done.add(id(typ))
                for m in typ.members.values():
                    need(m.type)
                decl = self.type_decls.get(id(typ))
                alias = externs.MAY_ALIAS if decl is not None and decl.extern else ""  # passed in place (externs.py)
                out.append(f"struct {alias}{typ.name} {{")
                out.extend(f"    {self.member(m)}" for m in typ.members.values())
                out.extend(["};", ""])

        def emit_fb(pou: t.Pou) -> None:
            if id(pou) in done:
                return
            done.add(id(pou))
            fields = fb_fields(pou)
            for v in pou.vars:
                need(v.type)
            alias = externs.MAY_ALIAS if pou.extern else ""  # externs.fb_body() runs it as the C++ block
            head = f"struct {alias}{pou.name} {{  // FUNCTION_BLOCK {pou.name}: an instance's data, as in shared memory"
            out.append(head)
            out.extend(f"    {self.member(v)}" for v in fields)
            if not fields:
                out.append(f"    BOOL {EMPTY_FB_FIELD}{{}};")
            out.extend(f"    {self.constant(v, static=True)}" for v in pou.vars if v.constant)
            out.extend(["};", ""])

        for p in pous:
            for v in p.vars:
                need(v.type)
            if p.return_type is not None:
                need(p.return_type)
            if p.kind == "FUNCTION_BLOCK":
                emit_fb(p)
        for v in program.vars:
            need(v.type)
        for g in glob:
            need(g.type)
        out.append(f"struct {program.name} {{  // PROGRAM {program.name}: its variables")
        members = {id(v) for v in program_members(program)}
        for v in program.vars:
            if id(v) in members:
                out.append(f"    {self.member(v)}")
            elif v.constant:
                out.append(f"    {self.constant(v, static=True)}")
        out += ["};", ""]
        if glob:
            out.append("struct Globals {  // the VAR_GLOBALs the program uses")
            out.extend(f"    {self.member(g)}" for g in glob)
            out += ["};", ""]
        constants = [g for g in self.prog.globals.values() if g.constant]
        if constants:
            out.append("// global CONSTANTs")
            out.extend(self.constant(g, static=False) for g in constants)
            out.append("")
        return out

    def member(self, v: t.VarDecl) -> str:
        return f"{cpp_type(v.type)} {v.name}{{{self.initial(v.init, v.type)}}};"

    def constant(self, v: t.VarDecl, static: bool) -> str:
        return f"{'static ' if static else ''}constexpr {cpp_type(v.type)} {v.name}{{{self.initial(v.init, v.type)}}};"

    def initial(self, init, typ) -> str:
        """The brace contents of a declaration's initial value ('' = the type's default)."""
        if init is None:
            return self.default(typ)
        if isinstance(init, t.ArrayInit):
            items = []
            for item in init.items:
                value = self.value_of(item.value, typ.element) if item.value is not None else self.zero(typ.element)
                items += [value] * (item.count if item.count is not None else 1)
            return ", ".join(items)
        return self.value_of(init, typ) if not isinstance(init, t.StructInit) else self.struct_init(init, typ)

    def value_of(self, init, typ) -> str:
        if isinstance(init, (t.ArrayInit, t.StructInit)):
            return f"{cpp_type(typ)}{{{self.initial(init, typ)}}}"
        return self.conv(init, typ)

    def struct_init(self, init: t.StructInit, typ) -> str:
        b = ty.base(typ)
        order = [v.name for v in fb_fields(b.pou)] if isinstance(b, ty.FbType) else [m.name for m in b.members.values()]
        members = {v.name.upper(): v for v in fb_fields(b.pou)} if isinstance(b, ty.FbType) else dict(b.members)
        given = {name.upper(): value for name, _, value in init.fields}
        parts = []
        for name in order:
            if name.upper() in given:
                parts.append(f".{name} = {self.value_of(given[name.upper()], members[name.upper()].type)}")
        return ", ".join(parts)

    def default(self, typ) -> str:
        b = ty.base(typ)
        if isinstance(typ, ty.SubrangeType) and not typ.low <= 0 <= typ.high:
            return literal(typ.low, typ.base)
        decl = self.type_decls.get(id(typ))
        if decl is not None and decl.init is not None:
            return self.initial(decl.init, typ)
        if isinstance(typ, ty.ArrayType):  # every element at its type's initial value, if it has one
            one = (
                self.initial(typ.element_init, typ.element)
                if typ.element_init is not None
                else self.default(typ.element)
            )
            if not one:
                return ""
            if not isinstance(typ.element, ty.ArrayType) and "," in one or isinstance(typ.element, ty.StructType):
                one = f"{cpp_type(typ.element)}{{{one}}}"
            count = 1
            for lo, hi in typ.dims:
                count *= hi - lo + 1
            return ", ".join([one] * count)
        if isinstance(b, ty.EnumType) and b.values:
            first = next(iter(b.values.values()))
            return f"{first.number} /* {first.name} */"
        return ""

    def zero(self, typ) -> str:
        return f"{cpp_type(typ)}{{{self.default(typ)}}}"

    # ---- POUs ------------------------------------------------------------------------------------

    def declarations(self, pous: list[t.Pou]) -> list[str]:
        out = [self.signature(p) + ";" for p in pous]
        return out + [""] if out else []

    def signature(self, p: t.Pou) -> str:
        if p.kind == "FUNCTION":
            params = []
            for v in p.vars:
                if v.kind == "VAR_INPUT":
                    params.append(f"{cpp_type(v.type)} {v.name}")
                elif v.kind in ("VAR_IN_OUT", "VAR_OUTPUT"):
                    params.append(f"{cpp_type(v.type)} &{v.name}")
            result = cpp_type(p.return_type) if p.return_type is not None else "void"
            return f"{result} {p.name}({', '.join(params)})"
        inouts = [f", {cpp_type(v.type)} &{v.name}" for v in p.vars if v.kind == "VAR_IN_OUT"]
        name = "fbBody" if p.kind == "FUNCTION_BLOCK" else "programBody"
        return f"void {name}({p.name} &self{''.join(inouts)})"

    def pou(self, p: t.Pou) -> list[str]:
        if p.extern:
            return self.extern_pou(p)
        self.scope = p
        self.marked = set()
        out = [f"// {p.kind} {p.name} ({p.place.file}:{p.place.line})", self.signature(p) + " {"]
        for v in p.vars:
            local = v.kind == "VAR_TEMP" or (p.kind == "FUNCTION" and v.kind == "VAR")
            if v.constant and p.kind == "FUNCTION":
                out.append(f"    {self.constant(v, static=True)}")
            elif local:
                out.append(f"    {self.member(v)}")
        if p.kind == "FUNCTION" and p.return_type is not None:
            init = self.initial(p.result.init if p.result is not None else None, p.return_type)
            out.append(f"    {cpp_type(p.return_type)} {p.name}{{{init}}};")
        parts = split_body(p.body)
        done = f"return {p.name};" if p.kind == "FUNCTION" and p.return_type is not None else "return;"
        before = []
        if len(parts) == 1:
            out += _indent(self.block(p.body))
        else:
            for k, part in enumerate(parts, 1):
                name, params, args = self.part_signature(p, k)
                before += self.part(p, part, k, len(parts), name, params)
                out.append(f"    if ({name}({args})) {done}")
        if p.kind == "FUNCTION" and p.return_type is not None:
            out.append(f"    return {p.name};")
        out += ["}", "#line RESET"]
        self.scope = None
        return before + out

    def part_signature(self, p: t.Pou, k: int) -> tuple[str, str, str]:
        """The name of part k of p's split body, its parameters and the arguments p passes: everything
        p's statements name besides the instance's fields, by reference (p's parameters, locals, result)."""
        if p.kind == "FUNCTION":
            names = [(cpp_type(v.type), v.name) for v in p.vars if not v.constant]
            if p.return_type is not None:
                names.append((cpp_type(p.return_type), p.name))
            name = f"{p.name}{k}_"
        else:
            names = [(p.name, "self")]
            names += [(cpp_type(v.type), v.name) for v in p.vars if v.kind in ("VAR_IN_OUT", "VAR_TEMP")]
            name = f"{'fbBody' if p.kind == 'FUNCTION_BLOCK' else 'programBody'}{k}_"
        params = ", ".join(f"{typ} &{n}" for typ, n in names)
        return name, params, ", ".join(n for _, n in names)

    def part(self, p: t.Pou, stmts: list, k: int, count: int, name: str, params: str) -> list[str]:
        """Part k of p's split body: its statements in a function of their own, true when a RETURN ran."""
        first = stmts[0].place
        out = [
            f"// {p.kind} {p.name}, part {k} of {count} (from {first.file}:{first.line}): true when it RETURNed",
            f"[[gnu::noinline]] bool {name}({params}) {{",
        ]
        if p.kind == "FUNCTION":
            out += [f"    {self.constant(v, static=True)}" for v in p.vars if v.constant]
        self.in_part = True
        self.marked = set()
        out += _indent(self.block(stmts))
        self.in_part = False
        return out + ["    return false;", "}", "#line RESET"]

    def extern_pou(self, p: t.Pou) -> list[str]:
        """An FB or FUNCTION implemented in C++ ({extern '...'}, externs.py)."""
        decl_of_type = lambda typ: self.type_decls.get(id(typ))  # noqa: E731
        if p.kind == "FUNCTION_BLOCK":
            out = externs.fb_body(p, fb_fields(p), self.signature(p), decl_of_type, self.made_emitted)
        else:
            out = []
            enums = any(isinstance(ty.base(v.type), ty.EnumType) for v in p.vars)
            if enums and not getattr(self, "_extern_enum", False):
                self._extern_enum = True
                out += externs.EXTERN_ENUM
            out += externs.function_body(p, self.signature(p), decl_of_type, self.made_emitted)
        return out + ["#line RESET"]

    # ---- statements --------------------------------------------------------------------------------

    def block(self, stmts: list) -> list[str]:
        """Statements, each after its `#line`, at indentation 0 (nested() and pou() indent them)."""
        out = []
        outer, self.marked = self.marked, set(self.marked)
        for s in stmts:
            out.append(f'#line {s.place.line} "{s.place.file}"')
            out += self.marks(s)
            out += self.statement(s)
        self.marked = outer
        return out

    def marks(self, s) -> list[str]:
        """`written_[i] = true;` for each struct or array of the kept image the statement may write:
        run()'s write-back compares only those with their snapshots (kept.hpp).  Not again where an
        earlier statement of the same or an enclosing block marked it (it ran before this one)."""
        found = {self.written_index.get(image_key(self.prog, d)) for d in statement_writes(s)}
        new = sorted(i for i in found if i is not None and i not in self.marked)
        self.marked.update(new)
        return [f"written_[{i}] = true;" for i in new]

    def nested(self, stmts: list) -> list[str]:
        return _indent(self.block(stmts))

    def statement(self, s) -> list[str]:
        if isinstance(s, t.Assign):
            return self.assign(s.target, s.value, s)
        if isinstance(s, t.CallStmt):
            return self.call_statement(s.call)
        if isinstance(s, t.If):
            out = []
            for i, (cond, body) in enumerate(s.branches):
                out.append(f"{'if' if i == 0 else '} else if'} ({_bare(self.expr(cond))}) {{")
                out += self.nested(body)
            if s.orelse:
                out.append("} else {")
                out += self.nested(s.orelse)
            return out + ["}"]
        if isinstance(s, t.Case):
            return self.case(s)
        if isinstance(s, t.For):
            return self.for_loop(s)
        if isinstance(s, t.While):
            guard = f"loopCheck({self.place(s)});"
            return [f"while ({_bare(self.expr(s.cond))}) {{", f"    {guard}"] + self.nested(s.body) + ["}"]
        if isinstance(s, t.Repeat):
            guard = f"loopCheck({self.place(s)});"
            return ["do {", f"    {guard}"] + self.nested(s.body) + [f"}} while (!({self.expr(s.cond)}));"]
        if isinstance(s, t.Exit):
            return ["break;"]
        if isinstance(s, t.Continue):
            return ["continue;"]
        if isinstance(s, t.Return):
            if self.in_part:
                return ["return true;"]
            p = self.scope
            return [f"return {p.name};" if p.kind == "FUNCTION" and p.return_type is not None else "return;"]
        raise ValueError(f"no C++ for {type(s).__name__}")

    def fresh(self, stem: str) -> str:
        self.temp += 1
        return f"{stem}{self.temp}_"

    def case(self, s: t.Case) -> list[str]:
        sel = self.fresh("sel")
        typ = ty.concrete(s.selector.type)
        out = ["{  // CASE", f"    const {cpp_type(typ)} {sel} = {self.expr(s.selector)};"]
        first = True
        for branch in s.branches:
            tests = []
            for label in branch.labels:
                lo = literal(label.low.const, typ)
                if label.high is None:
                    tests.append(f"{sel} == {lo}")
                else:
                    tests.append(f"({sel} >= {lo} && {sel} <= {literal(label.high.const, typ)})")
            out.append(f"    {'if' if first else '} else if'} ({_bare(' || '.join(tests))}) {{")
            first = False
            out += _indent(self.nested(branch.body))
        if s.orelse:
            if first:
                out.append("    {")
            else:
                out.append("    } else {")
            out += _indent(self.nested(s.orelse))
        if not first or s.orelse:
            out.append("    }")
        return out + ["}"]

    def for_loop(self, s: t.For) -> list[str]:
        typ = s.var.type
        var = self.lvalue(s.var)
        end, step = self.fresh("end"), self.fresh("by")
        step_code = self.conv(s.step, typ) if s.step is not None else "1"
        out = [
            f"{{  // FOR {s.var.name}",
            f"    {var} = {self.conv(s.start, typ)};",
            f"    const {cpp_type(typ)} {end} = {self.conv(s.end, typ)};",
            f"    const {cpp_type(typ)} {step} = {step_code};",
            f"    if (forStarts({var}, {end}, {step})) do {{",
            f"        loopCheck({self.place(s)});",
        ]
        out += _indent(self.nested(s.body))
        out.append(f"    }} while (forStep({var}, {end}, {step}));")
        return out + ["}"]

    def assign(self, target: t.Expr, value: t.Expr, s) -> list[str]:
        if isinstance(target, t.BitAccess):
            return [f"setBit<{target.bit}>({self.lvalue(target.base)}, {self.conv(value, ty.BOOL)});"]
        if isinstance(ty.base(target.type), ty.ArrayType) and isinstance(value, (t.Name, t.Member, t.Index)):
            # a .glb array (a C array in generated.h) and an ST one (std::array) have the same bytes
            lv, rv = self.lvalue(target), self.expr(value)
            return [f"static_assert(sizeof({lv}) == sizeof({rv}));", f"std::memcpy(&{lv}, &{rv}, sizeof({lv}));"]
        return [f"{self.lvalue(target)} = {self.ranged(value, target.type, s)};"]

    def ranged(self, value: t.Expr, typ, node: t.Node) -> str:
        """value converted to typ; checked against a subrange (a fault naming node's place)."""
        code = self.conv(value, typ)
        if isinstance(typ, ty.SubrangeType) and not (
            isinstance(value.const, int) and typ.low <= value.const <= typ.high
        ):
            code = f"range({self.place(node)}, {code}, {typ.low}, {typ.high})"
        return code

    def call_statement(self, c: t.Call) -> list[str]:
        if c.fb is None:
            return [f"{self.expr(c)};"]
        fb = c.fb
        inst = self.lvalue(c.callee)
        out = []
        if isinstance(c.callee, t.Index):
            out.append(f"auto &fb_ = {inst};")
            inst = "fb_"
        inouts = {}
        outputs = []
        for a in c.args:
            p = a.param
            if p is None:
                continue
            if p.kind == "VAR_INPUT" and a.value is not None:
                out.append(f"{inst}.{p.name} = {self.ranged(a.value, p.type, a)};")
            elif p.kind == "VAR_IN_OUT":
                inouts[p.name.upper()] = self.lvalue(a.value)
            elif p.kind == "VAR_OUTPUT" and a.value is not None:
                get = f"{inst}.{p.name}"
                if a.negated:
                    get = f"!{get}"
                elif cpp_type(p.type) != cpp_type(a.value.type):
                    get = f"{cpp_type(a.value.type)}({get})"
                outputs.append(f"{self.lvalue(a.value)} = {get};")
        args = "".join(f", {inouts[v.name.upper()]}" for v in fb.vars if v.kind == "VAR_IN_OUT")
        out.append(f"fbBody({inst}{args});")
        out += outputs
        if len(out) == 1:
            return out
        return ["{  // " + _text(c.callee) + "(...)"] + _indent(out) + ["}"]

    # ---- expressions -------------------------------------------------------------------------------

    def conv(self, e: t.Expr, dst, cast: bool = False) -> str:
        """e's value as a dst: IEC's implicit widening made explicit; a literal typed for dst."""
        src = e.type
        if isinstance(ty.base(dst), ty.EnumType) and e.const is not None:
            return self.expr(e)  # the value with its name in a comment
        if e.const is not None and not isinstance(e.const, str) and _scalar(dst):
            code = literal(e.const, dst)
            if isinstance(ty.base(dst), ty.Elementary) and ty.base(dst).kind == "time" and isinstance(e, t.Literal):
                code += f" /* {e.text} */"
            return f"{cpp_type(dst)}({code})" if cast else code
        code = self.expr(e)
        if dst is None or not _scalar(dst) or not _scalar(src):
            return code
        if cpp_type(src) != cpp_type(dst) or cast and isinstance(src, ty.LiteralType):
            return f"{cpp_type(dst)}({code})"
        return code

    def expr(self, e: t.Expr) -> str:
        if e.const is not None and _scalar(e.type):
            if isinstance(e, t.Name) and isinstance(e.decl, t.EnumValue):
                return f"{e.const} /* {e.decl.name} */"
            if isinstance(e, t.Literal) and e.kind == "enum":
                return f"{e.const} /* {e.text} */"
            return literal(e.const, e.type)
        if isinstance(e, t.Literal):
            return literal(e.value, e.type)
        if isinstance(e, (t.Name, t.Member, t.Index)):
            return self.lvalue(e)
        if isinstance(e, t.BitAccess):
            return f"getBit<{e.bit}>({self.expr(e.base)})"
        if isinstance(e, t.Unary):
            return self.unary(e)
        if isinstance(e, t.Binary):
            return self.binary(e)
        if isinstance(e, t.Call):
            return self.call(e)
        raise ValueError(f"no C++ for {type(e).__name__}")

    def lvalue(self, e: t.Expr) -> str:
        if isinstance(e, t.Name):
            d = e.decl
            if d.kind == "RESULT":
                return d.name
            if d.kind == "GLB":
                return f"bound.{d.glb['path'].replace('.', '_')}"
            if d.kind in ("VAR_EXTERNAL", "VAR_GLOBAL"):
                g = self.prog.globals.get(d.name.upper(), d)
                return g.name if g.constant else f"global.{g.name}"
            p = self.scope
            if d.kind in ("VAR_TEMP", "VAR_IN_OUT") or (p is not None and p.kind == "FUNCTION"):
                return d.name
            return f"self.{d.name}"
        if isinstance(e, t.Member):
            if isinstance(e.decl, t.VarDecl) and e.decl.kind == "GLB":
                return f"bound.{e.decl.glb['path'].replace('.', '_')}"
            # the member as declared: ST is case-insensitive, C++ is not (cld.OUT of `Out : INT`)
            name = e.decl.name if isinstance(e.decl, t.VarDecl) else e.name
            return f"{self.lvalue(e.base)}.{name}"
        if isinstance(e, t.Index):
            arr = ty.base(e.base.type)
            out = self.lvalue(e.base)
            for i, (lo, hi) in zip(e.indices, arr.dims, strict=True):
                if isinstance(i.const, int):
                    out += f"[{i.const - lo}]"
                else:
                    out += f"[index({self.place(i)}, {self.expr(i)}, {lo}, {hi})]"
            return out
        if isinstance(e, t.Call):
            return self.call(e)
        raise ValueError(f"{type(e).__name__} is not a variable")

    def unary(self, e: t.Unary) -> str:
        k = ty.kind(e.type)
        if e.op == "NOT":
            return f"!{self.paren(e.operand)}" if k == "bool" else f"NOT({self.conv(e.operand, e.type)})"
        if e.op == "+":
            return self.expr(e.operand)
        if k in ("int", "time"):
            return f"NEG({self.conv(e.operand, e.type)})"
        return f"-{self.paren(e.operand)}"

    def paren(self, e: t.Expr) -> str:
        code = self.expr(e)
        return f"({code})" if isinstance(e, (t.Binary, t.Unary)) and e.const is None else code

    def binary(self, e: t.Binary) -> str:
        op = e.op
        lt, rt = e.left.type, e.right.type
        lk, rk = ty.kind(lt), ty.kind(rt)
        if op in ("=", "<>", "<", ">", "<=", ">="):
            common = ty.concrete(ty.common(lt, rt) or (ty.STRING if lk == rk == "string" else lt))
            cop = {"=": "==", "<>": "!="}.get(op, op)
            return f"({self.conv(e.left, common)} {cop} {self.conv(e.right, common)})"
        if op in ("AND", "OR", "XOR"):
            if ty.kind(e.type) == "bool":
                cop = {"AND": "&&", "OR": "||", "XOR": "!="}[op]
                return f"({self.conv(e.left, ty.BOOL)} {cop} {self.conv(e.right, ty.BOOL)})"
            return f"{op}({self.conv(e.left, e.type, cast=True)}, {self.conv(e.right, e.type)})"
        if op == "**":
            return f"EXPT({self.conv(e.left, e.type, cast=True)}, {self.expr(e.right)})"
        if "time" in (lk, rk) or lk in ("date", "tod", "dt"):
            return self.time_binary(e, lk, rk)
        typ = e.type
        real = ty.kind(typ) == "real"
        if op == "/" or op == "MOD":
            fn = "DIV" if op == "/" else "MOD"
            if real:
                return f"({self.conv(e.left, typ)} / {self.conv(e.right, typ)})"
            return f"{fn}({self.place(e)}, {self.conv(e.left, typ, cast=True)}, {self.conv(e.right, typ)})"
        if real:
            return f"({self.conv(e.left, typ)} {op} {self.conv(e.right, typ)})"
        fn = {"+": "ADD", "-": "SUB", "*": "MUL"}[op]
        return f"{fn}({self.conv(e.left, typ, cast=True)}, {self.conv(e.right, typ)})"

    def time_binary(self, e: t.Binary, lk: str, rk: str) -> str:
        op = e.op
        left, right = self.expr(e.left), self.expr(e.right)
        long = ty.base(e.type).name.startswith("L") if isinstance(ty.base(e.type), ty.Elementary) else False
        if lk == rk == "time":
            return f"{'ADD' if op == '+' else 'SUB'}_{'LTIME' if long else 'TIME'}({left}, {right})"
        if lk == "time" and op == "*":
            return f"MUL_{'LTIME' if long else 'TIME'}({left}, {self.conv(e.right, ty.concrete(e.right.type))})"
        if rk == "time" and op == "*":
            return f"MUL_{'LTIME' if long else 'TIME'}({right}, {self.conv(e.left, ty.concrete(e.left.type))})"
        if lk == "time" and op == "/":
            num = self.conv(e.right, ty.concrete(e.right.type))
            return f"DIV_{'LTIME' if long else 'TIME'}({self.place(e)}, {left}, {num})"
        kinds = {"tod": "TOD", "dt": "DT", "date": "DATE"}
        if rk == "time":
            return f"{'ADD' if op == '+' else 'SUB'}_{kinds[lk]}_TIME({left}, {right})"
        return f"SUB_{kinds[lk]}_{kinds[rk]}({left}, {right})"

    # ---- calls -------------------------------------------------------------------------------------

    def call(self, c: t.Call) -> str:
        target = c.target
        if isinstance(target, t.Pou):
            return self.function_call(c, target)
        if isinstance(target, stdlib.Function):
            return self.std_call(c, target)
        raise ValueError("an FB call is a statement")

    def function_call(self, c: t.Call, f: t.Pou) -> str:
        by_param = {id(a.param): a for a in c.args if a.param is not None}
        args, after, temps = [], [], []
        for v in f.vars:
            a = by_param.get(id(v))
            if v.kind == "VAR_INPUT":
                args.append(
                    self.ranged(a.value, v.type, a)
                    if a is not None
                    else f"{cpp_type(v.type)}{{{self.initial(v.init, v.type)}}}"
                )
            elif v.kind == "VAR_IN_OUT":
                args.append(self.lvalue(a.value))
            elif v.kind == "VAR_OUTPUT":
                tmp = self.fresh("out")
                temps.append(f"{cpp_type(v.type)} {tmp}{{}}; ")
                args.append(tmp)
                if a is not None and a.value is not None:
                    get = f"!{tmp}" if a.negated else tmp
                    after.append(f"{self.lvalue(a.value)} = {get}; ")
        call = f"{f.name}({', '.join(args)})"
        if not temps:
            return call
        if f.return_type is None:
            return f"[&] {{ {''.join(temps)}{call}; {''.join(after)}}}()"
        return f"[&] {{ {''.join(temps)}auto r_ = {call}; {''.join(after)}return r_; }}()"

    def std_call(self, c: t.Call, fn: stdlib.Function) -> str:
        args = [a for a in c.args]
        if fn.kind == "intrinsic":
            return "cycleTime()"
        if fn.kind == "conversion":
            return self.conversion(fn, args[0].value)
        generic = None
        if fn.result == "T":
            generic = ty.concrete(c.type)
        elif any(a.param is not None and a.param.type == "T" for a in args):
            for a in args:
                if a.param is not None and a.param.type == "T":
                    generic = a.value.type if generic is None else (ty.common(generic, a.value.type) or generic)
            generic = ty.concrete(generic) if generic is not None else None
        parts = []
        for a in args:
            p = a.param
            if p is not None and p.type == "T" and generic is not None:
                parts.append(self.conv(a.value, generic, cast=True))
            elif p is not None and p.type in ty.ELEMENTARY:
                parts.append(self.conv(a.value, ty.ELEMENTARY[p.type]))
            else:
                parts.append(
                    self.conv(a.value, ty.concrete(a.value.type), cast=isinstance(a.value.type, ty.LiteralType))
                )
        name = fn.name
        if name in ("DIV", "MOD", "MUX") and not (name == "DIV" and ty.kind(generic) == "real"):
            parts.insert(0, self.place(c))
        if name == "DIV" and ty.kind(generic) == "real":
            return f"({parts[0]} / {parts[1]})"
        return f"{name}({', '.join(parts)})"

    def conversion(self, fn: stdlib.Function, arg: t.Expr) -> str:
        name = fn.name
        src_t = ty.concrete(arg.type)
        value = self.conv(arg, src_t, cast=isinstance(arg.type, ty.LiteralType))
        if name == "TRUNC":
            return f"TRUNC({value})"
        if "_TRUNC_" in name:
            return f"TRUNC_{name.split('_TRUNC_')[1]}({value})"
        if name.startswith("TO_"):
            src, dst = rt_name(_type_name(src_t)), rt_name(name[3:])
        else:
            src_name, dst_name = name.split("_TO_")
            src, dst = rt_name(src_name), rt_name(dst_name)
        if src == dst:
            return value
        return f"{src}_TO_{dst}({value})"


def _statements(stmts) -> int:
    """Statements in stmts, nested ones counted."""
    n = 0
    for s in stmts or []:
        n += 1
        if isinstance(s, t.If):
            n += sum(_statements(body) for _, body in s.branches) + _statements(s.orelse)
        elif isinstance(s, t.Case):
            n += sum(_statements(b.body) for b in s.branches) + _statements(s.orelse)
        elif isinstance(s, (t.For, t.While, t.Repeat)):
            n += _statements(s.body)
    return n


def split_body(stmts: list) -> list[list]:
    """A body cut at top-level statements into parts of at most PART_STATEMENTS statements (nested ones
    counted; a larger statement is a part alone); one part when the whole body fits."""
    parts: list[list] = [[]]
    size = 0
    for s in stmts:
        n = _statements([s])
        if parts[-1] and size + n > PART_STATEMENTS:
            parts.append([])
            size = 0
        parts[-1].append(s)
        size += n
    return parts


def _bare(code: str) -> str:
    """`(a == b)` -> `a == b` where the parentheses enclose the whole (an if's own make them redundant)."""
    if not (code.startswith("(") and code.endswith(")")):
        return code
    depth = 0
    for i, c in enumerate(code):
        depth += {"(": 1, ")": -1}.get(c, 0)
        if depth == 0 and i < len(code) - 1:
            return code
    return code[1:-1]


def _indent(lines: list[str]) -> list[str]:
    return [line if line.startswith("#") else "    " + line for line in lines]


def _type_name(typ) -> str:
    b = ty.base(typ)
    if isinstance(b, ty.StringType):
        return "STRING"
    return b.name


_scalar = scalar  # emit_glb's: a value of one atomic load and store


def written_roots(stmts) -> list[t.VarDecl]:
    """The variables whose values statements may change: the root variable of every assignment's and
    FOR's target, of an FB call's instance and outputs (=>), of what a call passes to VAR_IN_OUT or
    VAR_OUTPUT (a FUNCTION's or an FB's).  A variable none of the code reaches this way is read only:
    run() copies it in and never writes it back."""
    targets = []
    stack = list(stmts)
    while stack:
        n = stack.pop()
        if isinstance(n, (list, tuple)):
            stack.extend(n)
            continue
        if not isinstance(n, t.Node) or isinstance(n, (t.Pou, t.VarDecl)):
            continue
        if isinstance(n, t.Assign):
            targets.append(n.target)
        elif isinstance(n, t.For):
            targets.append(n.var)
        elif isinstance(n, t.Call):
            if n.fb is not None:
                targets.append(n.callee)
            for a in n.args:
                p = getattr(a, "param", None)
                if a.value is not None and getattr(p, "kind", None) in ("VAR_IN_OUT", "VAR_OUTPUT"):
                    targets.append(a.value)
        stack.extend(v for v in vars(n).values() if isinstance(v, (t.Node, list, tuple)) and v is not n)
    roots = []
    for e in targets:
        while not isinstance(e, t.Name):
            if isinstance(e, t.Member) and isinstance(e.decl, t.VarDecl) and e.decl.kind == "GLB":
                break  # a .glb variable reached through its namespace: the member is the variable
            e = e.base
        if isinstance(e.decl, t.VarDecl):
            roots.append(e.decl)
    return roots


def statement_writes(s) -> list[t.VarDecl]:
    """The variables one statement may write itself, without the statements nested in it (they
    mark their own): an assignment's or FOR's target, an FB call's instance, and what a call in the
    statement's expressions (an IF's conditions, a CASE's selector, ...) passes to VAR_IN_OUT or
    VAR_OUTPUT."""
    if isinstance(s, (t.Assign, t.CallStmt)):
        return written_roots([s])
    if isinstance(s, t.If):
        return written_roots([cond for cond, _ in s.branches])
    if isinstance(s, t.Case):
        return written_roots([s.selector])
    if isinstance(s, t.For):
        return [s.var.decl, *written_roots([e for e in (s.start, s.end, s.step) if e is not None])]
    if isinstance(s, (t.While, t.Repeat)):
        return written_roots([s.cond])
    return []


def image_key(prog, d: t.VarDecl):
    """One key per shared variable of the process image, whichever declaration names it: a .glb
    variable by its path, a VAR_GLOBAL (also through VAR_EXTERNAL) by its name, else the declaration."""
    if d.kind == "GLB":
        return ("glb", d.glb["path"])
    if d.kind in ("VAR_EXTERNAL", "VAR_GLOBAL") and d.name.upper() in prog.globals:
        return ("global", d.name.upper())
    return id(d)

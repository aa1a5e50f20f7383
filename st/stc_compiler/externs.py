# externs.py -- declarations implemented in C++ ({extern 'ns::Name'}, st/lib/plcopen.st): which C++
# libraries may implement them (one table for the checker and the code generator), and the C++ that
# binds them: an extern FUNCTION_BLOCK's instance is the C++ struct's bytes (static_asserts prove
# offsets and sizes) and its call runs the struct's operator(); an extern FUNCTION calls the C++
# function; a STRUCT marked extern reaches C++ as factory(member, member, ...).

from __future__ import annotations

from dataclasses import dataclass

from . import tree as t
from . import types as ty


@dataclass(frozen=True)
class Library:
    header: str  # included by the generated C++
    link: str | None  # the static library linked into the module (None: libindurop itself)
    include_dir: str  # its headers' folder in the source tree (the installed SDK has them in include/)
    build_dir: str  # where a build folder of this tree has the library


# The C++ namespaces an {extern} may name, and what a module then needs.
LIBRARIES = {
    "plcopen": Library(
        "indurop/plcopen/plcopen.h", "indurop_plcopen", "rtcore/modules/plcopen/include", "rtcore/modules/plcopen"
    ),
    "irp": Library("indurop/indurop.h", None, "rtcore/include", "rtcore"),
}


def library_of(cpp: str) -> Library | None:
    return LIBRARIES.get(cpp.split("::", 1)[0]) if "::" in cpp else None


def used(pous: list[t.Pou]) -> list[Library]:
    """The libraries of the extern POUs a program reaches, once each."""
    out: list[Library] = []
    for p in pous:
        lib = library_of(p.extern) if p.extern else None
        if lib is not None and lib not in out:
            out.append(lib)
    return out


def includes(pous: list[t.Pou]) -> list[str]:
    libs = used(pous)
    if not libs:
        return []
    return [f"#include <{lib.header}>" for lib in libs] + ["#include <cstddef>", "#include <cstring>"]


class Passing:
    """How ST lvalues reach an extern C++ call: a STRUCT of a C++ type's bytes ({extern 'ns::T'}) in
    place, as that type (its ST struct is declared may_alias, as an extern FB's is), a STRUCT made by
    a function ({extern 'ns::make(a, b)'}) as what ns::make(its members, passed the same way) returns,
    anything else as it is.  What ns::make returns is kept by made_helper()'s function, one for the
    module, and made again only for another variable: it is a view of the variable's members (a
    function of its address), and the cell's PLCopen blocks, called on one group 13 times a period,
    made it 13 times (about 400 instructions a period)."""

    def __init__(self, decl_of_type, emitted: set[str]) -> None:
        self.decl_of_type = decl_of_type
        self.asserts: list[str] = []
        self.helpers: dict[str, list[str]] = {}  # the made structs' functions (made_helper), by name
        self.emitted = emitted  # the module's made structs whose function is already in the file

    def helper_lines(self) -> list[str]:
        """The made structs' functions this POU needs that the file does not have yet."""
        out = []
        for name, lines in self.helpers.items():
            if name not in self.emitted:
                self.emitted.add(name)
                out += lines
        return out

    def arg(self, code: str, typ) -> str:
        decl = self.decl_of_type(typ)
        if decl is None or not decl.extern:
            return code
        if decl.extern_args is not None:
            if decl.name not in self.helpers:
                self.helpers[decl.name] = []  # a member of its own type would recurse
                self.helpers[decl.name] = self.made_helper(decl, typ)
            return f"{MADE_PREFIX}{decl.name}({code})"
        self.asserts += layout_asserts(
            decl.name, decl.extern, [(m.name, m.type) for m in ty.base(typ).members.values()]
        )
        return f"reinterpret_cast<{decl.extern} &>({code})"

    def made_helper(self, decl, typ) -> list[str]:
        """`auto &madeT(T &x)`: ns::make(x's members) kept in a static with the address it was made for,
        made again when called for another variable (the same address is the same members)."""
        members = ty.base(typ).members
        made = ", ".join(self.arg(f"x.{members[a.upper()].name}", members[a.upper()].type) for a in decl.extern_args)
        return [
            f"// {decl.name} reaches C++ as {decl.extern}({', '.join(decl.extern_args)}): a view of the variable's",
            "// members, kept from one call and run to the next and made again only for another variable.",
            f"auto &{MADE_PREFIX}{decl.name}({decl.name} &x) {{",
            f"    using Made = decltype({decl.extern}({made}));",
            "    static constinit struct {",
            "        const void *of;",
            "        Made made;",
            "    } cache{};",
            "    if (cache.of != &x) {",
            f"        cache.made = {decl.extern}({made});",
            "        cache.of = &x;",
            "    }",
            "    return cache.made;",
            "}",
        ]


MADE_PREFIX = "made"  # the function that keeps what a made STRUCT's ns::make returns (Passing.made_helper)


# The attribute of the ST struct of an extern FUNCTION_BLOCK: fb_body() runs the C++ block on the
# instance's bytes in place, as the C++ type, which GCC's may_alias makes defined (a copy of the block
# in and out of every call costs a store-buffer stall: narrow stores read back by wide loads).
MAY_ALIAS = "[[gnu::may_alias]] "


def layout_asserts(name: str, cpp: str, fields: list[tuple[str, object]]) -> list[str]:
    """static_asserts that the ST type `name` (its fields in order) has the bytes of the C++ `cpp`."""
    out = [f'static_assert(sizeof({name}) == sizeof({cpp}), "{name}: the ST fields are not {cpp}\'s");']
    for field_name, typ in fields:
        for path in [field_name] + _paths(typ, field_name + "."):
            out.append(f'static_assert(offsetof({name}, {path}) == offsetof({cpp}, {path}), "{name}.{path}");')
    return out


def _paths(typ, prefix: str) -> list[str]:
    """The member paths of a stored type (nested structs too), for offsetof."""
    typ = ty.base(typ)
    out = []
    if isinstance(typ, ty.StructType):
        for m in typ.members.values():
            out.append(prefix + m.name)
            out += _paths(m.type, prefix + m.name + ".")
    return out


def fb_body(pou: t.Pou, fields: list[t.VarDecl], signature: str, decl_of_type, emitted: set[str]) -> list[str]:
    """The C++ of an extern FUNCTION_BLOCK: the layout proof, then fbBody() running the C++ block on the
    instance's bytes in place (Passing)."""
    cpp, name = pou.extern, pou.name
    out = [f"// FUNCTION_BLOCK {name} ({pou.place.file}:{pou.place.line}) is the C++ {cpp}: an instance is its bytes."]
    out += layout_asserts(name, cpp, [(v.name, v.type) for v in fields])
    passing = Passing(decl_of_type, emitted)
    args = ", ".join(passing.arg(v.name, v.type) for v in pou.vars if v.kind == "VAR_IN_OUT")
    body = [f"reinterpret_cast<{cpp} &>(self)({args});"]
    return (
        out
        + _unique(passing.asserts)
        + passing.helper_lines()
        + [signature + " {"]
        + [f"    {b}" for b in body]
        + ["}"]
    )


def function_body(pou: t.Pou, signature: str, decl_of_type, emitted: set[str]) -> list[str]:
    """The C++ of an extern FUNCTION: the C++ function called with the inputs in order (a STRING as
    its text, an enumeration converted to the C++ enum the parameter has)."""
    passing = Passing(decl_of_type, emitted)
    args = []
    for v in pou.vars:
        if v.kind not in ("VAR_INPUT", "VAR_IN_OUT"):
            continue
        b = ty.base(v.type)
        if isinstance(b, ty.StringType):
            args.append(f"{v.name}.data")
        elif isinstance(b, ty.EnumType):
            args.append(f"ExternEnum{{{v.name}}}")
        else:
            args.append(passing.arg(v.name, v.type))
    call = f"{pou.extern}({', '.join(args)})"
    if pou.return_type is not None:
        body = [f"const auto result = {call};", "return result;"]
    else:
        body = [f"{call};"]
    head = [f"// FUNCTION {pou.name} ({pou.place.file}:{pou.place.line}) is the C++ {pou.extern}."]
    return (
        head
        + _unique(passing.asserts)
        + passing.helper_lines()
        + [signature + " {"]
        + [f"    {b}" for b in body]
        + ["}"]
    )


def _unique(lines: list[str]) -> list[str]:
    return list(dict.fromkeys(lines))


# An ST enumeration (ENUM, int16_t) passed where the C++ function takes an enum of the same values.
EXTERN_ENUM = [
    "struct ExternEnum {",
    "    ENUM value;",
    "    template <class E>",
    "        requires std::is_enum_v<E>",
    "    constexpr operator E() const noexcept { return static_cast<E>(value); }",
    "};",
    "",
]

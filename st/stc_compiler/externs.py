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
    anything else as it is.  The reference ns::make returns is made on the stack at every call: a
    static made once would cost its cache lines in a run that starts with cold caches, more than
    the stores of making it again."""

    def __init__(self, decl_of_type) -> None:
        self.decl_of_type = decl_of_type
        self.before: list[str] = []
        self.after: list[str] = []
        self.asserts: list[str] = []
        self.count = 0

    def arg(self, code: str, typ) -> str:
        decl = self.decl_of_type(typ)
        if decl is None or not decl.extern:
            return code
        if decl.extern_args is not None:
            members = ty.base(typ).members
            made = ", ".join(
                self.arg(f"{code}.{members[a.upper()].name}", members[a.upper()].type) for a in decl.extern_args
            )
            self.count += 1
            self.before.append(f"auto cpp{self.count} = {decl.extern}({made});")
            return f"cpp{self.count}"
        self.asserts += layout_asserts(
            decl.name, decl.extern, [(m.name, m.type) for m in ty.base(typ).members.values()]
        )
        return f"reinterpret_cast<{decl.extern} &>({code})"


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


def fb_body(pou: t.Pou, fields: list[t.VarDecl], signature: str, decl_of_type) -> list[str]:
    """The C++ of an extern FUNCTION_BLOCK: the layout proof, then fbBody() running the C++ block on the
    instance's bytes in place (Passing)."""
    cpp, name = pou.extern, pou.name
    out = [f"// FUNCTION_BLOCK {name} ({pou.place.file}:{pou.place.line}) is the C++ {cpp}: an instance is its bytes."]
    out += layout_asserts(name, cpp, [(v.name, v.type) for v in fields])
    passing = Passing(decl_of_type)
    args = ", ".join(passing.arg(v.name, v.type) for v in pou.vars if v.kind == "VAR_IN_OUT")
    body = passing.before + [f"reinterpret_cast<{cpp} &>(self)({args});"] + passing.after
    return out + _unique(passing.asserts) + [signature + " {"] + [f"    {b}" for b in body] + ["}"]


def function_body(pou: t.Pou, signature: str, decl_of_type) -> list[str]:
    """The C++ of an extern FUNCTION: the C++ function called with the inputs in order (a STRING as
    its text, an enumeration converted to the C++ enum the parameter has)."""
    passing = Passing(decl_of_type)
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
    body = passing.before
    if pou.return_type is not None:
        body += [f"const auto result = {call};", *passing.after, "return result;"]
    else:
        body += [f"{call};", *passing.after]
    head = [f"// FUNCTION {pou.name} ({pou.place.file}:{pou.place.line}) is the C++ {pou.extern}."]
    return head + _unique(passing.asserts) + [signature + " {"] + [f"    {b}" for b in body] + ["}"]


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

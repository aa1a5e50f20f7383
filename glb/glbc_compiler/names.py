# names.py -- which identifiers a .glb may use as a namespace part, variable, field or #define:
# C++ identifiers that are not keywords, not type names and that the generated header can use.

from __future__ import annotations

import re

from .scalars import TYPE_WORDS

IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")

# C++20 keywords and alternative tokens.
CPP_KEYWORDS = frozenset(
    """
alignas alignof and and_eq asm auto bitand bitor bool break case catch char char8_t char16_t
char32_t class compl concept const consteval constexpr constinit const_cast continue co_await
co_return co_yield decltype default delete do double dynamic_cast else enum explicit export
extern false float for friend goto if inline int long mutable namespace new noexcept not not_eq
nullptr operator or or_eq private protected public register reinterpret_cast requires return
short signed sizeof static static_assert static_cast struct switch template this thread_local
throw true try typedef typeid typename union unsigned using virtual void volatile wchar_t while
xor xor_eq
""".split()
)

# Names that are macros in the standard headers the generated header includes, or that the
# generated code itself relies on (`std`, `irp` are namespaces it refers to).
RESERVED = frozenset(
    """
std irp assert errno offsetof NULL EOF stdin stdout stderr
""".split()
)

# Field names that would break the reference class glbc derives from irp::shared::StructRef,
# or hide the whole-struct operations (`x.load()`, `x.update(fn)`) that generic code calls.
RESERVED_FIELDS = frozenset({"StructRef", "RefBase", "value_type", "load", "update"})


def problem(name: str, field: bool = False) -> str | None:
    """Why `name` cannot be used, or None when it can."""
    if not IDENTIFIER.match(name):
        return f"'{name}' is not a valid name (a letter or '_', then letters, digits or '_')"
    if name in CPP_KEYWORDS:
        return f"'{name}' is a C++ keyword and cannot be used as a name"
    if name in TYPE_WORDS:
        return f"'{name}' is a type name and cannot be used as a name"
    if "__" in name or (name.startswith("_") and len(name) > 1 and name[1].isupper()):
        return f"'{name}' is reserved in C++ (names containing '__' or starting with '_' and a capital letter)"
    if name.startswith(("INDUROP_", "indurop_")):
        return f"'{name}' is reserved for the generated header (names starting with INDUROP_ or indurop_)"
    if name in RESERVED:
        return f"'{name}' is reserved (a macro or namespace the generated header relies on)"
    if field and name in RESERVED_FIELDS:
        return f"'{name}' is reserved as a field name (the generated reference class uses it)"
    return None

# layout.py -- a set's existing shared variables as ST sees them: reads glbc's layout.json (docs/glbc.md)
# and gives each variable (and struct field) an IEC type, for `AT %path` bindings and qualified access.

from __future__ import annotations

import json
from dataclasses import dataclass, field

from . import types as ty
from .errors import Place, StError

# A scalar's IEC type when layout.json gives no `iec_type`, from its `scalars` entry (kind, size):
# the signed and unsigned integers (not the bit strings), REAL, LREAL, BOOL.
_IEC_OF_SCALAR = {
    ("bool", 1): "BOOL",
    ("signed", 1): "SINT",
    ("signed", 2): "INT",
    ("signed", 4): "DINT",
    ("signed", 8): "LINT",
    ("unsigned", 1): "USINT",
    ("unsigned", 2): "UINT",
    ("unsigned", 4): "UDINT",
    ("unsigned", 8): "ULINT",
    ("float", 4): "REAL",
    ("float", 8): "LREAL",
}


@dataclass
class Layout:
    file: str
    variables: dict[str, dict] = field(default_factory=dict)  # upper-case path -> layout.json variable
    types: dict[str, dict] = field(default_factory=dict)  # struct type name -> its entry
    scalars: dict[str, dict] = field(default_factory=dict)  # C++ scalar spelling -> size, align, kind
    prefixes: set[str] = field(default_factory=set)  # upper-case namespace paths and their leading parts
    _structs: dict[str, ty.StructType] = field(default_factory=dict)

    def variable(self, path: str) -> dict | None:
        return self.variables.get(path.upper())

    def is_namespace(self, path: str) -> bool:
        return path.upper() in self.prefixes

    def iec_type(self, entry: dict) -> ty.Type | None:
        """The IEC type of a layout variable or field (arrays included), or None if ST has none for it."""
        element = self.scalar_or_struct(entry.get("iec_type"), entry["type"])
        if element is None:
            return None
        dims = entry.get("dims") or []
        return ty.ArrayType([(0, n - 1) for n in dims], element) if dims else element

    def scalar_or_struct(self, iec: str | None, cpp: str) -> ty.Type | None:
        if iec and iec.upper() in ty.ELEMENTARY:
            return ty.ELEMENTARY[iec.upper()]
        scalar = self.scalars.get(cpp)
        if scalar is not None:
            name = _IEC_OF_SCALAR.get((scalar.get("kind"), scalar.get("size")))
            return ty.ELEMENTARY[name] if name else None
        if cpp in self.types:
            return self._struct(cpp)
        return None

    def _struct(self, name: str) -> ty.StructType:
        from . import tree as t  # the fields are declarations like an ST struct's

        if name not in self._structs:
            st = ty.StructType(name.rsplit(".", 1)[-1])
            self._structs[name] = st
            for f in self.types[name].get("fields", []):
                decl = t.VarDecl(Place(self.file, 1, 1), f["name"], "MEMBER", None)
                decl.type = self.iec_type(f)
                decl.glb = f
                if decl.type is not None:
                    st.members[f["name"].upper()] = decl
        return self._structs[name]


def from_document(doc: dict, path: str) -> Layout:
    """A layout.json document (already read, or made by glbc in memory) as a Layout."""
    layout = Layout(path, types=dict(doc.get("types", {})), scalars=dict(doc.get("scalars", {})))
    for var in doc["variables"]:
        layout.variables[var["path"].upper()] = var
        parts = var["path"].split(".")
        for i in range(1, len(parts)):
            layout.prefixes.add(".".join(parts[:i]).upper())
    return layout


def load(path: str) -> Layout:
    """layout.json -> Layout; a StError naming the file when it is not one."""
    try:
        with open(path, encoding="utf-8") as f:
            doc = json.load(f)
        return from_document(doc, path)
    except OSError as e:
        raise StError(Place(path, 1, 1), "layout", f"cannot read the layout: {e.strerror}") from None
    except (ValueError, KeyError, TypeError, AttributeError) as e:
        raise StError(
            Place(path, 1, 1), "layout", f"not a glbc layout.json ({e}); give the layout.json glbc wrote"
        ) from None

"""st_check.py -- the Programs page's Structured Text, checked in the agent's own process with the
compiler that builds the sets (st/stc_compiler, found beside the `stc` the agent runs): the POUs of
a set's .st files, and the check of an edited file in its set (its other .st files as stored, the
set's own .glb variables as its layout) answering every error with its place and the symbols the
editor completes and hovers with.  No process per keystroke: the grammar is loaded once, each
parsed file (st/lib's too) is kept pickled by its text and unpickled for a check, which fills the
tree it checks (docs/programming.md)."""

from __future__ import annotations

import functools
import hashlib
import importlib
import json
import pickle
import sys
import threading
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

PARSED_KEPT = 64  # parsed files kept (by name and text); a set's files and the editor's versions of one
PARAM_KINDS = ("VAR_INPUT", "VAR_OUTPUT", "VAR_IN_OUT")
_LOCK = threading.Lock()  # one check at a time: they share the compiler's module state


class CompilerMissing(Exception):
    """The ST compiler's package is not beside the configured stc."""


@functools.cache
def compiler(stc: Path) -> SimpleNamespace:
    """stc_compiler's modules, imported from the folder of `stc` (st/ of the source tree, or
    share/indurop/st of the package)."""
    folder = str(Path(stc).resolve().parent)
    if not (Path(folder) / "stc_compiler").is_dir():
        raise CompilerMissing(f"the ST compiler's package is not beside {stc}; install indurop's st/ or set `stc`")
    if folder not in sys.path:
        sys.path.insert(0, folder)
    names = ("parse", "check", "check_expr", "tree", "errors", "layout", "emit_glb", "tasks", "stdlib", "build")
    return SimpleNamespace(**{n: importlib.import_module(f"stc_compiler.{n}") for n in names})


class Parsed:
    """Parsed units kept pickled by (name, text): a check unpickles a fresh tree to fill."""

    def __init__(self, stc: Path) -> None:
        self.c = compiler(stc)
        self._kept: OrderedDict[tuple[str, str], bytes | Exception] = OrderedDict()
        self._library = pickle.dumps(self.c.check.library_units())

    def library(self) -> list:
        return pickle.loads(self._library)

    def unit(self, name: str, text: str, keep: bool = True):
        """The file's tree (a fresh copy), or raises its StError (a syntax error, bad bytes).
        `keep` False: parsed and not kept (the text being typed: each check's is new)."""
        if not keep:
            return self.c.parse.parse_text(name, text)
        key = (name, hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest())
        kept = self._kept.get(key)
        if kept is None:
            try:
                kept = pickle.dumps(self.c.parse.parse_text(name, text))
            except self.c.errors.StError as e:
                kept = e
            self._kept[key] = kept
            while len(self._kept) > PARSED_KEPT:
                self._kept.popitem(last=False)
        self._kept.move_to_end(key)
        if isinstance(kept, Exception):
            raise kept
        return pickle.loads(kept)


@functools.cache
def parsed(stc: Path) -> Parsed:
    return Parsed(stc)


@dataclass
class SetSources:
    """A set's .st files by path (text), and its layout document (or None)."""

    files: dict[str, str]
    layout: dict | None


def outline(stc: Path, name: str, text: str) -> dict:
    """A file's POUs and configurations with their lines, or its first error."""
    p = parsed(stc)
    try:
        with _LOCK:
            unit = p.unit(name, text)
    except p.c.errors.StError as e:
        return {"path": name, "pous": [], "error": e.as_json()}
    pous = [{"name": u.name, "kind": u.kind, "line": u.place.line} for u in unit.pous]
    pous += [{"name": c.name, "kind": "CONFIGURATION", "line": c.place.line} for c in unit.configurations]
    return {"path": name, "pous": sorted(pous, key=lambda x: x["line"]), "error": None}


def check(stc: Path, sources: SetSources, path: str, text: str) -> dict:
    """The set's sources with `path` as `text`, checked together: {errors, symbols}.  Each error is
    {file, line, column, code, message} (file: its path in the set); a file that cannot be read
    (a syntax error) gives its error only, as `stc check` does.  What the checker could still type
    goes into the symbols, so completion works on a file with errors."""
    p = parsed(stc)
    with _LOCK:
        errors, prog = program(p, sources, path, text)
        symbols = _symbols(p.c, prog)
    errors.sort(key=lambda e: (e.file != path, e.file, e.line, e.col))
    return {"errors": [e.as_json() for e in errors], "symbols": symbols}


def program(p: Parsed, sources: SetSources, path: str, text: str) -> tuple[list, object]:
    """(errors, the checked Program) of the set's sources with `path` as `text`; call it with _LOCK
    held (the checker's tree is fresh: what it holds may be read after)."""
    c = p.c
    errors: list = []
    units = []
    c.parse.ensure_recursion_limit()
    for name, body in sorted({**sources.files, path: text}.items()):
        try:
            units.append(p.unit(name, body, keep=name != path))
        except c.errors.StError as e:
            errors.append(e)
    collector = c.errors.Collector()
    prog = c.check.Program(p.library() + units, layout=_layout(c, sources.layout))
    try:
        c.check.Checker(prog, collector).run()
    except RecursionError:
        errors.append(c.errors.StError(c.errors.Place(path, 1, 1), "too-deep", "the program nests too deeply"))
    if not errors:  # as stc check: with a file unread, what the others miss of it is no error
        errors = collector.errors
    return errors, prog


def _layout(c, doc: dict | None):
    """The set's .glb variables as the checker sees them (the ST variables of its last build left
    out, as `stc build` does with --set-layout)."""
    if not doc:
        return None
    try:
        return c.build.without_st(c.layout.from_document(json.loads(json.dumps(doc)), "layout.json"))
    except (KeyError, TypeError, ValueError, AttributeError):
        return None


def _type(v) -> str | None:
    return str(v.type) if getattr(v, "type", None) is not None else None


def _symbols(c, prog) -> dict:
    """POUs with their variables (IEC type, shared-variable path), globals, FB types with their
    inputs and outputs, functions (the set's, st/lib's and the standard ones)."""
    paths = _paths(c, prog)
    pous, fbs, functions = [], [], []
    for pou in sorted(prog.pous.values(), key=lambda x: x.name.upper()):
        library = _is_library(prog, pou)
        params = [{"name": v.name, "kind": v.kind, "type": _type(v)} for v in pou.vars if v.kind in PARAM_KINDS]
        if pou.kind == "FUNCTION_BLOCK":
            fbs.append({"name": pou.name, "library": library, "params": params})
        elif pou.kind == "FUNCTION":
            result = str(pou.return_type) if pou.return_type is not None else None
            functions.append(
                {"name": pou.name, "kind": "library" if library else "user", "result": result, "params": params}
            )
        if library:
            continue
        pous.append(
            {
                "name": pou.name,
                "kind": pou.kind,
                "file": pou.place.file,
                "line": pou.place.line,
                "vars": [
                    {
                        "name": v.name,
                        "kind": v.kind,
                        "type": _type(v),
                        "line": v.place.line,
                        "constant": v.constant,
                        "paths": paths.get(id(v), []),
                    }
                    for v in pou.vars
                ],
            }
        )
    globals_ = [
        {"name": g.name, "type": _type(g), "file": g.place.file, "line": g.place.line, "paths": paths.get(id(g), [])}
        for g in prog.globals.values()
    ]
    return {"pous": pous, "globals": globals_, "fb_types": fbs, "functions": functions + _standard(c)}


def _is_library(prog, pou) -> bool:
    return any(u.library and pou in u.pous for u in prog.units)


def _paths(c, prog) -> dict[int, list[str]]:
    """Each declaration's shared-variable paths: a PROGRAM's variables once per instance
    (`Main.count`), a VAR_GLOBAL in its namespace (`Plant.level`, `GVL.x`), an AT binding the
    variable it binds, a VAR_EXTERNAL its VAR_GLOBAL's."""
    out: dict[int, list[str]] = {}
    try:
        instances = c.tasks.instances(prog)
    except c.errors.StError:
        instances = []
    for inst in instances:
        for v in inst.pou.vars:
            if c.emit_glb.stored(v):
                out.setdefault(id(v), []).append(f"{inst.name}.{v.name}")
    for block in c.emit_glb.globals_blocks(prog.units):
        for g in block.decls:
            out.setdefault(id(g), []).append(f"{block.namespace}.{g.name}")
    for pou in prog.pous.values():
        for v in pou.vars:
            if v.location:
                out[id(v)] = [v.location.lstrip("%")]
            elif v.kind == "VAR_EXTERNAL":  # the VAR_GLOBAL it names: its shared variable
                g = prog.globals.get(v.name.upper())
                if g is not None and id(g) in out:
                    out[id(v)] = out[id(g)]
    return out


@functools.cache
def _standard_table(stdlib) -> tuple:
    return tuple(stdlib.described())


def _standard(c) -> list[dict]:
    return list(_standard_table(c.stdlib))

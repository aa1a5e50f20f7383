# build.py -- `stc build`: the checked program -> OUT/layout.json and OUT/indurop/generated.h (emit_glb.py),
# <Instance>.cpp in OUT or --cpp-dir (emit_cpp.py), OUT/module.xml (tasks.py) and, unless --no-compile, OUT/<Instance>.so
# compiled in parallel with the flags and the SDK of the project's modules (sdk.py).

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

from . import emit_glb, sdk, tasks
from .check import Program, check
from .emit_cpp import generate, name_problems
from .errors import StError, StErrors
from .layout import from_document
from .layout import load as load_layout
from .parse import read_source


@dataclass
class Options:
    out: str
    sources: list[str]
    glb: list[str]
    set_layout: str | None = None
    previous: str | None = None
    module_xml: str | None = None
    compile: bool = True
    sdk: str | None = None
    cxx: str | None = None
    jobs: int = 0
    cpp_dir: str | None = None  # where <Instance>.cpp go; None: OUT


def front(opts: Options) -> tuple[Program, list]:
    """The .glb files and the ST sources, parsed and checked; StErrors listing every error."""
    errors: list[StError] = []
    glb, layout = [], None
    try:
        glb = emit_glb.read_glb(opts.glb)
        if opts.set_layout is not None:
            layout = without_st(load_layout(opts.set_layout))
        elif glb:
            layout = from_document(emit_glb.glb_only_document(glb), opts.glb[0])
    except emit_glb.GlbError as e:
        errors.append(emit_glb.glb_error(e))
    except StError as e:
        errors.append(e)
    units = []
    for f in opts.sources:
        try:
            units.append(read_source(f))
        except StError as e:
            errors.append(e)
        except StErrors as e:  # a PLCopen XML project: an error per POU
            errors.extend(e.errors)
    if errors:
        raise StErrors(errors)
    return check(units, layout), glb


def build(opts: Options, argv: list[str]) -> list[str]:
    """Writes every output; returns the paths of the modules compiled.  Raises StErrors."""
    prog, glb = front(opts)
    problems = name_problems(prog)
    if problems:
        raise StErrors(problems)
    insts = tasks.instances(prog)
    if not insts:
        raise StError(_first_place(prog, opts), "task", "no PROGRAM to run; write a PROGRAM (and a CONFIGURATION)")
    try:
        st = emit_glb.st_files(insts, emit_glb.globals_blocks(prog.units))
        laid = emit_glb.lay_out(glb, st, opts.set_layout, opts.previous, ["stc", *argv])
        os.makedirs(opts.out, exist_ok=True)
        emit_glb.write(opts.out, laid)
    except emit_glb.GlbError as e:
        raise StErrors([emit_glb.glb_error(e)]) from None
    added = set((laid.doc.get("changes") or {}).get("added", []))
    added |= {m["path"] for m in (laid.doc.get("changes") or {}).get("moved", [])}
    sources = [os.path.basename(s) for s in opts.sources]
    cpps = []
    if opts.cpp_dir is not None:
        os.makedirs(opts.cpp_dir, exist_ok=True)
    for inst in insts:
        path = os.path.join(opts.cpp_dir or opts.out, f"{inst.name}.cpp")
        emit_glb.glbc_cli._write(path, generate(prog, inst, added, sources, laid.doc.get("variables")))
        cpps.append((inst, path))
    xml = tasks.module_xml(insts, opts.out, opts.module_xml)
    emit_glb.glbc_cli._write(os.path.join(opts.out, "module.xml"), xml)
    if not opts.compile:
        return []
    kit = sdk.find(opts.sdk, opts.cxx)
    jobs = opts.jobs or min(len(cpps), os.cpu_count() or 1)
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        results = list(pool.map(lambda ic: sdk.compile_module(kit, ic[1], opts.out, ic[0].name), cpps))
    errors = [e for r in results for e in r]
    if errors:
        raise StErrors(errors)
    return [os.path.join(opts.out, f"{i.name}.so") for i, _ in cpps]


def without_st(layout):
    """The set's layout as the checker sees it: its .glb variables.  Variables stc declared (they have an
    `iec_type`) are the previous build's ST variables, declared again now: a set rebuilt in place."""
    for key in [k for k, v in layout.variables.items() if v.get("iec_type")]:
        del layout.variables[key]
    layout.prefixes = {p for v in layout.variables.values() for p in _prefixes(v["path"])}
    return layout


def _prefixes(path: str) -> list[str]:
    parts = path.split(".")
    return [".".join(parts[:i]).upper() for i in range(1, len(parts))]


def _first_place(prog: Program, opts: Options):
    from .errors import Place

    return Place(opts.sources[0] if opts.sources else "stc", 1, 1)

"""plc_monitor.py -- the live view's values (docs/programming.md "The live view"): for a graphical POU
of a set's PLCopen XML file, the value leaving each element, taken from ONE truth, the translation:
plcopen_import.project.unit_of(file, root, flows) fills flows[(body, localId, output)] with the stc
tree expression of that value (LD: the power after a contact, a coil, a block's ENO; FBD: a block's
output, a variable).  Here those
expressions are checked in the POU's scope (names resolved, as the compiler resolves them), the
shared variables they read are read in one pass over the segment, and each is folded with the ST
compiler's own folding (st_monitor.Analysis.evaluate), exactly as the ST monitor folds IF conditions.
The variables the elements name (a contact's, a coil's, a variable's expression, an SFC step's X and
T) are read in the same pass.

    found = analyse(stc, (set_id, "plc.xml", "main"), sources, "plc.xml", xml_bytes, "main")
    answer = found.snapshot(segment, forced)

A PROGRAM's values are its first instance's; a FUNCTION_BLOCK's those of its first instance in the
running programs (`plc_task_instance.CounterSFC0`); a FUNCTION has no instance to read, so its flows
are answered with the reason."""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path

from . import plc_diagram, st_check, st_monitor

KEPT = 8  # analyses kept (by set, file and POU)
MAX_DEPTH = 8  # FB instances nested in FB instances, looked through to find a FUNCTION_BLOCK's
VARIABLE_KINDS = ("contact", "coil", "inVariable", "outVariable", "inOutVariable")
_kept = st_monitor.Kept(KEPT)


@dataclass
class Flow:
    id: int
    pin: str | None
    expr: object
    paths: list[str]
    reason: str | None = None  # why it is never evaluated (no instance, a check error)
    type: str | None = None  # its IEC type, once checked
    constant: bool = False  # the compiler folded it to a constant


@dataclass
class Shown:
    """A variable an element names: a leaf (contact, coil, variable) or a step's X and T."""

    id: int
    path: str
    step: bool = False


@dataclass
class Analysis:
    base: st_monitor.Analysis
    instance: str | None
    flows: list[Flow] = field(default_factory=list)
    shown: list[Shown] = field(default_factory=list)

    def snapshot(self, seg, forced: dict) -> dict:
        """Every flow's value and every element's variable from one read of the segment."""
        wanted = [p for f in self.flows for p in f.paths if p in seg.leaves]
        for s in self.shown:
            wanted += [f"{s.path}.X", f"{s.path}.T"] if s.step else [s.path]
        read, _ = seg.read_many([p for p in dict.fromkeys(wanted) if p in seg.leaves])
        values = {leaf["path"]: (leaf, v) for leaf, v in read}
        return {
            "layout_hash": seg.hash,
            "instance": self.instance,
            "flows": [self._flow(f, values) for f in self.flows],
            "elements": [x for s in self.shown if (x := self._shown(s, values, forced)) is not None],
            "errors": [],
        }

    def _flow(self, f: Flow, values: dict) -> dict:
        out = {"id": f.id, "pin": f.pin, "type": f.type, "constant": f.constant}
        if f.reason is not None:
            return {**out, "value": None, "reason": f.reason}
        try:
            return {**out, "value": self.base.evaluate(f.expr, self.instance, values)}
        except st_monitor.NotEvaluated as e:
            return {**out, "value": None, "reason": str(e)}

    @staticmethod
    def _shown(s: Shown, values: dict, forced: dict) -> dict | None:
        if s.step:
            x, tm = values.get(f"{s.path}.X"), values.get(f"{s.path}.T")
            if x is None:
                return None
            active = bool(x[1])
            ms = _ms(tm[0], tm[1]) if tm is not None else None
            return {"id": s.id, "path": s.path, "type": "STEP", "value": active, "active": active, "time_ms": ms}
        if s.path not in values:
            return None
        leaf, v = values[s.path]
        return {"id": s.id, "path": s.path, "type": leaf["type"], "value": v, "forced": s.path in forced}


def _ms(leaf: dict, v) -> float | None:
    """A TIME leaf's value in milliseconds (the segment keeps a TIME as nanoseconds)."""
    return v / 1e6 if isinstance(v, (int, float)) else None


def kept(key: tuple) -> Analysis | None:
    """The analysis kept by `key` (analyse's), or None."""
    return _kept.peek(key)


def analyse(stc: Path, key: tuple, sources: st_check.SetSources, path: str, data: bytes, pou_name: str) -> Analysis:
    """The flows and shown variables of POU `pou_name` of the set's PLCopen file `path` (kept by
    `key`: a stored set never changes)."""
    return _kept.get(key, lambda: _analyse(stc, sources, path, data, pou_name))


def _analyse(stc: Path, sources: st_check.SetSources, path: str, data: bytes, pou_name: str) -> Analysis:
    imp = plc_diagram.importer(stc)
    from plcopen_import import project  # on sys.path once importer() ran

    p = st_check.parsed(stc)
    c = p.c
    with st_check._LOCK:
        try:
            flows: dict = {}
            unit = project.unit_of(path, imp.read.read(path, data), flows)
        except (c.errors.StError, c.errors.StErrors) as e:
            raise plc_diagram.DiagramError(f"the file does not translate: {e}") from None
        units = []
        for name, text in sorted(sources.files.items()):
            try:
                units.append(p.unit(name, text))
            except c.errors.StError:
                pass  # as stc check: a file unread leaves what it declares unknown
        prog = c.check.Program(p.library() + units + [unit], layout=st_check._layout(c, sources.layout))
        collector = c.errors.Collector()
        c.check.Checker(prog, collector).run()
        return _analysis(c, prog, unit, flows, pou_name, imp, path, data)


def _analysis(c, prog, unit, all_flows: dict, pou_name: str, imp, path: str, data: bytes) -> Analysis:
    project = plc_diagram.Project(path, imp.read.read(path, data), imp)
    diagram = plc_diagram.diagram(project, pou_name)  # NoSuchPou names the POUs it has
    pou = next(x for x in unit.pous if x.name.upper() == pou_name.upper())
    paths = st_check._paths(c, prog)
    instance = _instance(c, prog, pou)
    for v in pou.vars:  # a VAR_EXTERNAL of a global CONSTANT is its value (its shared variable: _paths)
        g = prog.globals.get(v.name.upper()) if v.kind == "VAR_EXTERNAL" else None
        if g is not None and id(v) not in paths and getattr(g, "const", None) is not None:
            v.const = g.const
    if instance is not None and pou.kind == "FUNCTION_BLOCK":  # its variables under the instance found
        for v in pou.vars:
            if c.emit_glb.stored(v):
                paths[id(v)] = [f"{instance}.{v.name}"]
    found = Analysis(st_monitor.Analysis(c, paths=paths), instance)
    checker = c.check.Checker(prog, c.errors.Collector())
    checker.scope = pou
    flows = {(k[1], k[2]): e for k, e in all_flows.items() if k[0].upper() == pou.name.upper()}
    for el in diagram["elements"]:
        for pin in dict.fromkeys(out["name"] for out in el["outputs"] or [{"name": None}]):
            expr = flows.get((el["id"], pin))
            if expr is not None:
                found.flows.append(_flow(c, checker, el["id"], pin, copy.deepcopy(expr), instance, paths))
        if instance is not None and el["kind"] in VARIABLE_KINDS and el["label"]:
            shown = _variable(c, checker, imp, path, el, instance, paths)
            if shown is not None:
                found.shown.append(Shown(el["id"], shown))
        if instance is not None and el["kind"] == "step" and el["label"]:
            found.shown.append(Shown(el["id"], f"{instance}.{el['label']}", step=True))
    return found


def _instance(c, prog, pou) -> str | None:
    """Where POU `pou`'s values are: a PROGRAM's first instance (`instance0`); a FUNCTION_BLOCK's first
    instance met walking the PROGRAM instances' variables (`plc_task_instance.CounterSFC0`); None for a
    FUNCTION (no instance) or an FB no program instantiates."""
    try:
        instances = c.tasks.instances(prog)
    except c.errors.StError:
        return None
    if pou.kind == "PROGRAM":
        return next((i.name for i in instances if i.pou is pou), None)
    todo = [(i.name, i.pou, 0) for i in instances]
    while todo:
        path, owner, depth = todo.pop(0)
        for v in owner.vars:
            fb = getattr(v.type, "pou", None)
            if fb is None or not c.emit_glb.stored(v) or depth > MAX_DEPTH:
                continue
            if fb is pou:
                return f"{path}.{v.name}"
            todo.append((f"{path}.{v.name}", fb, depth + 1))
    return None


def _flow(c, checker, id_: int, pin: str | None, expr, instance: str | None, paths: dict) -> Flow:
    if instance is None:
        return Flow(id_, pin, expr, [], "a FUNCTION, or an FB no running program instantiates, has no instance to read")
    errors_before = len(checker.errors.errors)
    checker.expr(expr)
    if len(checker.errors.errors) > errors_before:
        return Flow(id_, pin, expr, [], checker.errors.errors[-1].message)
    reads: list[str] = []
    st_monitor.reads(c, expr, instance, paths, reads)
    typ = str(expr.type) if getattr(expr, "type", None) is not None else None
    return Flow(id_, pin, expr, list(dict.fromkeys(reads)), type=typ, constant=expr.const is not None)


def _variable(c, checker, imp, path: str, el: dict, instance: str, paths: dict) -> str | None:
    """The shared variable an element's variable or expression names, or None (an expression, a
    VAR_TEMP, a constant)."""
    try:
        expr = imp.st_text.expression(path, el["label"], 1)
    except (c.errors.StError, c.errors.StErrors):
        return None
    errors_before = len(checker.errors.errors)
    checker.expr(expr)
    if len(checker.errors.errors) > errors_before:
        return None
    return st_monitor.path_of(c, expr, instance, paths)

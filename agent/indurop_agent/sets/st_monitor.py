"""st_monitor.py -- monitoring in the ST editor (docs/programming.md "Monitoring"): where each variable
of a .st file's PROGRAM bodies is, the shared variable it is (`main.Step`, `PLC_ROBOT.I0`, an FB
instance `main.Power` as a group), and the conditions of IF/ELSIF/WHILE/REPEAT and CASE selectors;
then, for the lines shown, their values from one pass over the shared memory, each condition
evaluated on them with the ST compiler's own folding (check_expr.ExprChecker.fold, fold_unary): one
truth of the operators' semantics.

    found = analyse(stc, sources, "main.st")       # once per set and file: the checked tree, kept
    answer = found.snapshot(segment, forced, 10, 60, expand=["main.Power"])

A condition is not evaluated when it calls a function or an FB (a call may change state: the
monitor never runs code), or names what is not in shared memory (a VAR_TEMP, a VAR_IN_OUT)."""

from __future__ import annotations

import re
import threading
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace

from ..irpd.variables import VariableError
from . import st_check

KEPT = 8  # analyses kept (by set and file)
KEYWORD_AFTER = {"IF": "THEN", "ELSIF": "THEN", "WHILE": "DO", "CASE": "OF", "UNTIL": "END_REPEAT"}


class Kept:
    """Analyses kept by key (a stored set never changes), the least recently used dropped past `size`;
    made outside the lock (a make takes st_check's own)."""

    def __init__(self, size: int) -> None:
        self.size = size
        self.found: OrderedDict[tuple, object] = OrderedDict()
        self.lock = threading.Lock()

    def peek(self, key: tuple):
        """What is kept by `key`, or None."""
        with self.lock:
            if key in self.found:
                self.found.move_to_end(key)
                return self.found[key]
        return None

    def get(self, key: tuple, make):
        found = self.peek(key)
        if found is not None:
            return found
        made = make()
        with self.lock:
            self.found[key] = made
            while len(self.found) > self.size:
                self.found.popitem(last=False)
        return made


_kept = Kept(KEPT)


class NotEvaluated(Exception):
    """Why a condition has no value: its message says it."""


@dataclass
class Occurrence:
    line: int
    column: int
    end_column: int
    path: str
    type: str | None


@dataclass
class Condition:
    line: int
    column: int
    end_line: int
    end_column: int
    what: str
    expr: object
    instance: str
    paths: list[str]  # the shared variables it reads


@dataclass
class Analysis:
    c: SimpleNamespace
    occurrences: list[Occurrence] = field(default_factory=list)
    conditions: list[Condition] = field(default_factory=list)
    paths: dict = field(default_factory=dict)  # id(decl) -> [shared-variable paths], st_check._paths

    def snapshot(self, seg, forced: dict, first: int, last: int, expand: list[str]) -> dict:
        """The occurrences and conditions of lines first..last with their values, and the fields
        of the groups in `expand`: every value from one read of the segment (Segment.read_many).
        Every field of the API's MonitorAnswer is given (the route writes the answer as it is)."""
        occurrences = [o for o in self.occurrences if first <= o.line <= last]
        conditions = [x for x in self.conditions if x.line <= last and x.end_line >= first]
        groups, errors = {}, []
        for g in expand:
            try:
                groups[g] = [leaf["path"] for leaf in seg.select(g)]
            except VariableError as e:  # named in the answer
                errors.append({"path": g, "message": str(e)})
        wanted = [o.path for o in occurrences if o.path in seg.leaves]
        wanted += [p for x in conditions for p in x.paths if p in seg.leaves]
        wanted += [p for paths in groups.values() for p in paths]
        read, _ = seg.read_many(list(dict.fromkeys(wanted)))
        values = {leaf["path"]: (leaf, v) for leaf, v in read}
        return {
            "layout_hash": seg.hash,
            "occurrences": [self._occurrence(o, seg, values, forced) for o in occurrences if self._known(o, seg)],
            "conditions": [self._condition(x, values) for x in conditions],
            "fields": {
                g: [_leaf_value(p, values, forced) for p in paths if p in values] for g, paths in groups.items()
            },
            "errors": errors,
        }

    @staticmethod
    def _known(o: Occurrence, seg) -> bool:
        return o.path in seg.leaves or bool(seg.group(o.path))

    @staticmethod
    def _occurrence(o: Occurrence, seg, values: dict, forced: dict) -> dict:
        out = {"line": o.line, "column": o.column, "end_column": o.end_column, "path": o.path, "type": o.type}
        if o.path not in seg.leaves:
            return {**out, "group": True, "value": None, "forced": False}
        value = values[o.path][1] if o.path in values else None
        return {**out, "group": False, "value": value, "forced": o.path in forced}

    def _condition(self, x: Condition, values: dict) -> dict:
        out = {"line": x.line, "column": x.column, "end_line": x.end_line, "end_column": x.end_column, "what": x.what}
        try:
            return {**out, "value": self.evaluate(x.expr, x.instance, values), "reason": None}
        except NotEvaluated as e:
            return {**out, "value": None, "reason": str(e)}

    def evaluate(self, e, instance: str, values: dict):
        """e's value with the variables' values read, folded as the compiler folds constants."""
        t = self.c.tree
        if e.const is not None:
            return e.const
        if isinstance(e, (t.Name, t.Member, t.Index)):
            path = path_of(self.c, e, instance, self.paths)
            if path is not None and path in values:
                return values[path][1]
            decl = getattr(e, "decl", None)
            kind = getattr(decl, "kind", None)
            if path is None and kind in ("VAR_TEMP", "VAR_IN_OUT", "VAR_EXTERNAL"):
                raise NotEvaluated(f"'{decl.name}' is {kind}: it is not kept in shared memory")
            raise NotEvaluated(f"'{_name(e)}' is not a shared variable the agent can read")
        if isinstance(e, t.Unary):
            shadow = SimpleNamespace(op=e.op, operand=SimpleNamespace(const=self.evaluate(e.operand, instance, values)))
            shadow.const = None
            self.c.check_expr.ExprChecker.fold_unary(shadow)
            return _folded(shadow, e)
        if isinstance(e, t.Binary):
            a = self.evaluate(e.left, instance, values)
            b = self.evaluate(e.right, instance, values)
            return self._fold(e.op, a, b, e.right.place, e)
        if isinstance(e, t.Call) and _operator(e) is not None:  # ADD(a, b), AND(a, b, c), NOT(a), MOVE(a)
            op = _operator(e)
            args = [self.evaluate(a.value, instance, values) for a in _in_order(e.args)]
            if op == "MOVE" and len(args) == 1:
                return args[0]
            if op == "NOT" and len(args) == 1:
                return self.evaluate(t.Unary(e.place, "NOT", SimpleNamespace(const=args[0])), instance, values)
            if len(args) < 2:
                raise NotEvaluated(f"{e.callee.name} with {len(args)} input(s)")
            out = args[0]
            for b in args[1:]:
                out = self._fold(op, out, b, e.place, e)
            return out
        if isinstance(e, t.Call):
            raise NotEvaluated(
                f"it calls {_name(e.callee)}: a function or an FB may change state, and the monitor never runs code"
            )
        raise NotEvaluated("the monitor does not evaluate this expression")

    def _fold(self, op: str, a, b, place, e):
        shadow = SimpleNamespace(
            op=op, left=SimpleNamespace(const=a), right=SimpleNamespace(const=b, place=place), const=None
        )
        folder = self.c.check_expr.ExprChecker(None, self.c.errors.Collector())
        folder.fold(shadow)
        if folder.errors.errors:
            raise NotEvaluated(folder.errors.errors[0].message)
        return _folded(shadow, e)


# the standard functions that are the ST operators (IEC 61131-3 table of arithmetic, bit-string and
# comparison functions: ADD is +, ...): a call of one is folded as the operator is
OPERATORS = {"ADD": "+", "SUB": "-", "MUL": "*", "DIV": "/", "MOD": "MOD", "AND": "AND", "OR": "OR", "XOR": "XOR"}
OPERATORS |= {"GT": ">", "GE": ">=", "EQ": "=", "LE": "<=", "LT": "<", "NE": "<>", "NOT": "NOT", "MOVE": "MOVE"}


def _operator(e) -> str | None:
    """The operator a call of a standard operator function (ADD, AND, EQ, NOT, MOVE ...) is, with its
    inputs only (no EN/ENO, no output), else None."""
    target = getattr(e, "target", None)
    if getattr(target, "kind", None) != "operator" or any(a.output or a.value is None for a in e.args):
        return None
    if any(a.name is not None and a.name.upper() in ("EN", "ENO") for a in e.args):
        return None
    return OPERATORS.get(target.name.upper())


def _in_order(args: list) -> list:
    """Inputs IN1, IN2, ... in their order whether given by name (in any order) or by position."""
    if all(a.name is None for a in args):
        return args
    return sorted(args, key=lambda a: int("".join(ch for ch in (a.name or "") if ch.isdigit()) or 0))


def _folded(shadow, e):
    if shadow.const is None:
        raise NotEvaluated(f"{e.op} of these values has no value the compiler folds")
    return shadow.const


def _leaf_value(path: str, values: dict, forced: dict) -> dict:
    leaf, v = values[path]
    return {"path": path, "type": leaf["type"], "value": v, "forced": path in forced}


def _name(e) -> str:
    if hasattr(e, "name"):
        return e.name
    base = getattr(e, "base", None)
    return _name(base) if base is not None else "?"


def path_of(c, e, instance: str, paths: dict) -> str | None:
    """The shared variable (leaf or group) a Name, a member access or an index with a constant names
    in PROGRAM instance `instance`, or None (a VAR_TEMP, a constant, an index computed at run time)."""
    t = c.tree
    if isinstance(e, t.Name):
        decl = e.decl
        if not isinstance(decl, t.VarDecl):
            return None
        if decl.kind == "GLB":
            return decl.glb["path"]
        if id(decl) in paths and decl.kind != "MEMBER":
            found = paths[id(decl)]
            mine = [p for p in found if p.startswith(instance + ".")]
            return (mine or found)[0]
        return None
    if isinstance(e, t.Member):
        decl = e.decl
        if isinstance(decl, t.VarDecl) and decl.kind == "GLB":
            return decl.glb["path"]
        base = path_of(c, e.base, instance, paths)
        return f"{base}.{decl.name if decl is not None else e.name}" if base is not None else None
    if isinstance(e, t.Index):
        base = path_of(c, e.base, instance, paths)
        if base is None or len(e.indices) != 1 or not isinstance(e.indices[0].const, int):
            return None
        return f"{base}[{e.indices[0].const}]"
    return None


def kept(key: tuple) -> Analysis | None:
    """The analysis kept by `key` (analyse's), or None: a refresh of the monitor needs nothing else
    of the set."""
    return _kept.peek(key)


def analyse(stc: Path, key: tuple, sources: st_check.SetSources, path: str) -> Analysis:
    """The occurrences and conditions of `path` in the set (kept by `key`, e.g. (set id, path): a
    stored set never changes)."""
    return _kept.get(key, lambda: _analyse(stc, sources, path))


def _analyse(stc: Path, sources: st_check.SetSources, path: str) -> Analysis:
    p = st_check.parsed(stc)
    c = p.c
    with st_check._LOCK:
        _, prog = st_check.program(p, sources, path, sources.files[path])
        try:
            instances = c.tasks.instances(prog)
        except c.errors.StError:
            instances = []
        found = Analysis(c, paths=st_check._paths(c, prog))
        lines = sources.files[path].split("\n")
        for inst in instances:
            if inst.pou.place.file == path and not any(i.pou is inst.pou for i in instances[: instances.index(inst)]):
                _Walker(found, inst.name, lines).statements(inst.pou.body)
    found.occurrences.sort(key=lambda o: (o.line, o.column))
    found.conditions.sort(key=lambda x: (x.line, x.column))
    return found


class _Walker:
    """Collects a PROGRAM body's variable occurrences and conditions into an Analysis."""

    def __init__(self, found: Analysis, instance: str, lines: list[str]) -> None:
        self.found, self.instance, self.lines = found, instance, lines
        self.t = found.c.tree

    def statements(self, body: list | None) -> None:
        t = self.t
        for s in body or []:
            if isinstance(s, t.Assign):
                self.expr(s.target)
                self.expr(s.value)
            elif isinstance(s, t.CallStmt):
                self.expr(s.call)
            elif isinstance(s, t.If):
                for n, (cond, stmts) in enumerate(s.branches):
                    self.condition("IF" if n == 0 else "ELSIF", cond)
                    self.statements(stmts)
                self.statements(s.orelse)
            elif isinstance(s, t.Case):
                self.condition("CASE", s.selector)
                for b in s.branches:
                    self.statements(b.body)
                self.statements(s.orelse)
            elif isinstance(s, t.For):
                for e in (s.var, s.start, s.end, s.step):
                    if e is not None:
                        self.expr(e)
                self.statements(s.body)
            elif isinstance(s, t.While):
                self.condition("WHILE", s.cond)
                self.statements(s.body)
            elif isinstance(s, t.Repeat):
                self.statements(s.body)
                self.condition("UNTIL", s.cond)

    def condition(self, what: str, e) -> None:
        self.expr(e)
        line, col = e.place.line, e.place.col
        end_line, end_col = self.end_before(KEYWORD_AFTER[what], line, col)
        reads = []
        self.reads(e, reads)
        self.found.conditions.append(Condition(line, col, end_line, end_col, what, e, self.instance, reads))

    def reads(self, e, out: list) -> None:
        reads(self.found.c, e, self.instance, self.found.paths, out)

    def expr(self, e) -> None:
        t = self.t
        path = path_of(self.found.c, e, self.instance, self.found.paths)
        if path is not None and e.place.file and e.place.line <= len(self.lines):
            typ = str(e.type) if e.type is not None else None
            end = self.end_of(e)
            if end is not None:
                self.found.occurrences.append(Occurrence(e.place.line, e.place.col, end, path, typ))
            if isinstance(e, t.Index):
                for i in e.indices:
                    self.expr(i)
            return
        for child in _children(t, e):
            self.expr(child)

    def end_of(self, e) -> int | None:
        """The 1-based column just after a name, a member access or an index on its line."""
        t = self.t
        text = self.lines[e.place.line - 1]
        if isinstance(e, t.Name):
            at = e.place.col - 1 + len(e.name)
            return at + 1 if text[e.place.col - 1 : at].upper() == e.name.upper() else None
        if isinstance(e, (t.Member, t.Index)):
            base = self.end_of(e.base)
            if base is None:
                return None
            if isinstance(e, t.Member):
                m = re.compile(r"\s*\.\s*" + re.escape(e.name), re.I).match(text, base - 1)
            else:
                m = re.compile(r"\s*\[[^\]]*\]").match(text, base - 1)
            return m.end() + 1 if m else None
        return None

    def end_before(self, keyword: str, line: int, col: int) -> tuple[int, int]:
        """Where a condition starting at line:col ends: before the keyword that follows it."""
        pattern = re.compile(rf"\b{keyword}\b", re.I)
        for n in range(line - 1, min(len(self.lines), line + 20)):
            text = self.lines[n]
            m = pattern.search(text, col - 1 if n == line - 1 else 0)
            if m:
                head = text[: m.start()].rstrip().rstrip(";").rstrip()
                if head.strip() or n == line - 1:
                    return n + 1, len(head) + 1
                return n, len(self.lines[n - 1].rstrip().rstrip(";")) + 1  # the keyword opens its line
        return line, len(self.lines[line - 1]) + 1


def reads(c, e, instance: str, paths: dict, out: list) -> None:
    """Adds to `out` the shared variables expression `e` reads in PROGRAM instance `instance`."""
    path = path_of(c, e, instance, paths)
    if path is not None:
        out.append(path)
        return
    for child in _children(c.tree, e):
        reads(c, child, instance, paths, out)


def _children(t, e) -> list:
    if isinstance(e, t.Member):
        return [e.base]
    if isinstance(e, t.Index):
        return [e.base, *e.indices]
    if isinstance(e, t.BitAccess):
        return [e.base]
    if isinstance(e, t.Unary):
        return [e.operand]
    if isinstance(e, t.Binary):
        return [e.left, e.right]
    if isinstance(e, t.Call):
        return [e.callee, *(a.value for a in e.args if a.value is not None)]
    return []

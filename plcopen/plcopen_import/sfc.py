# sfc.py -- an SFC body (PLCopen XML) -> ST compiler tree statements and hidden variables, with
# matiec's order in each period: the transitions are tested on the steps active at its start, then
# the steps are updated, then the actions of the steps now active run.  A step is a variable named as
# the step, of type SFC_STEP (X, T); each action has an ACTION_CONTROL (st/lib/sfc.st: the qualifiers'
# logic, written once in ST).  docs/plcopen-xml.md "SFC" describes what is supported.

from __future__ import annotations

import copy
from dataclasses import dataclass, field

from lxml import etree
from stc_compiler import tree as t
from stc_compiler.errors import Place, StError, StErrors

from . import st_text
from .graph import Body, Element
from .read import local, q

QUALIFIERS = ("N", "R", "S", "L", "D", "P", "P1", "P0", "SD", "DS", "SL")
TIMED = ("L", "D", "SD", "DS", "SL")
STEP_TYPE = "SFC_STEP"
CONTROL_TYPE = "ACTION_CONTROL"
# the elements of the chart itself; the others (contacts, blocks, variables, rails) are LD/FBD
# networks whose value a transition's condition is connected to
CHART = {
    "step",
    "transition",
    "selectionDivergence",
    "selectionConvergence",
    "simultaneousDivergence",
    "simultaneousConvergence",
    "jumpStep",
    "actionBlock",
    "macroStep",
}


@dataclass
class Action:
    """One action of the chart: named (the POU's <actions>), inline, or a BOOL variable."""

    key: str  # upper-case name, or the inline action's own key
    control: str  # its ACTION_CONTROL variable
    place: Place
    statements: list | None  # the body; None: a BOOL variable action
    variable: str | None = None
    inputs: dict[str, list[Element]] = field(default_factory=dict)  # qualifier -> steps
    duration: tuple[str, t.Expr, Element] | None = None  # (text, expression, step that gave it)


class Chart:
    def __init__(self, ctx, pou_el: etree._Element, body: Body) -> None:
        self.ctx = ctx
        self.pou_el = pou_el
        self.body = body
        self.file = body.file
        self.steps: dict[str, Element] = {}  # upper-case name -> step
        self.down: dict[int, list[Element]] = {}  # localId -> the elements connected below it
        self.actions: dict[str, Action] = {}
        self.named: dict[str, tuple[list, list[t.Expr]]] = {}  # named transitions: body, when to run it
        for e in body.elements.values():
            for pin in e.inputs:
                if pin.name == "condition":
                    continue
                for link in pin.links:
                    self.down.setdefault(link.ref, []).append(e)

    # ---- places and nodes --------------------------------------------------------------------

    def at(self, e: Element | None, where: str = "") -> Place:
        return self.body.origin(e, where)

    def where(self, e: Element) -> str:
        if e.kind == "step":
            return f"step '{e.attr('name')}'"
        return ""

    def error(self, e: Element | None, message: str) -> StError:
        return StError(self.at(e, self.where(e) if e is not None else ""), "plcopen", message)

    # ---- the graph ---------------------------------------------------------------------------

    def read_steps(self) -> None:
        for e in self.body.elements.values():
            if e.kind == "macroStep":
                raise self.error(e, "macro steps are not supported; draw the steps of the macro step in the chart")
            if e.kind != "step":
                continue
            name = e.attr("name") or ""
            if not name:
                raise self.error(e, "a step without a name; give it one")
            first = self.steps.get(name.upper())
            if first is not None:
                raise self.error(e, f"step '{name}' is named twice (also localId {first.id}); rename one")
            self.steps[name.upper()] = e
        if not any(self.initial(s) for s in self.steps.values()):
            raise StError(self.at(None), "plcopen", "the chart has no initial step; mark one step initialStep=\"true\"")

    @staticmethod
    def initial(step: Element) -> bool:
        return step.attr("initialStep") in ("true", "1")  # xsd:boolean

    def sources(self, e: Element) -> list[Element]:
        return [self.body.source(link, e) for pin in e.inputs if pin.name != "condition" for link in pin.links]

    def before(self, e: Element, tr: Element, seen: frozenset = frozenset()) -> list[Element]:
        """The steps a transition follows (through a selection divergence or a simultaneous convergence)."""
        if e.kind == "step":
            return [e]
        if e.kind in ("selectionDivergence", "simultaneousConvergence") and e.id not in seen:
            out: list[Element] = []
            for s in self.sources(e):
                out += [x for x in self.before(s, tr, seen | {e.id}) if x not in out]
            return out
        raise self.error(tr, f"a transition follows a {e.kind} (localId {e.id}); it must follow a step or a divergence")

    def after(self, e: Element, tr: Element, seen: frozenset = frozenset()) -> list[Element]:
        """The steps a transition leads to (through convergences, simultaneous divergences, jumps)."""
        out: list[Element] = []
        for d in self.down.get(e.id, []):
            if d.id in seen:
                raise self.error(tr, f"the {d.kind} localId {d.id} is connected in a loop without a step")
            if d.kind == "step":
                found = [d]
            elif d.kind == "jumpStep":
                target = d.attr("targetName") or ""
                step = self.steps.get(target.upper())
                if step is None:
                    raise self.error(d, f"the jump to '{target}': no step has that name")
                found = [step]
            elif d.kind in ("selectionConvergence", "simultaneousDivergence"):
                found = self.after(d, tr, seen | {d.id})
            elif d.kind in CHART:
                raise self.error(tr, f"a {d.kind} (localId {d.id}) follows a transition; a step must")
            else:
                continue
            out += [x for x in found if x not in out]
        return out

    def transitions(self) -> list[tuple[Element, list[Element], list[Element]]]:
        out = []
        for e in self.body.elements.values():
            if e.kind != "transition":
                continue
            pre: list[Element] = []
            for s in self.sources(e):
                pre += [x for x in self.before(s, e) if x not in pre]
            if not pre:
                raise self.error(e, "a transition that follows no step; connect it below a step")
            post = self.after(e, e)
            if not post:
                raise self.error(e, "a transition that leads to no step; connect a step or a jump below it")
            out.append((e, pre, post))
        return out

    def check_reachable(self, trs) -> None:
        """Item 6: a step no sequence of transitions reaches from the initial steps is an error."""
        reached = {s.id for s in self.steps.values() if self.initial(s)}
        changed = True
        while changed:
            changed = False
            for _, pre, post in trs:
                if all(p.id in reached for p in pre):
                    for s in post:
                        if s.id not in reached:
                            reached.add(s.id)
                            changed = True
        unreached = [s for s in self.steps.values() if s.id not in reached]
        if unreached:
            starts = ", ".join(f"'{s.attr('name')}'" for s in self.steps.values() if self.initial(s))
            errors = [
                self.error(s, f"step '{s.attr('name')}' is unreachable: no transition leads to it from {starts}")
                for s in unreached
            ]
            raise StErrors(errors) if len(errors) > 1 else errors[0]

    # ---- conditions --------------------------------------------------------------------------

    def condition(self, tr: Element, where: str, active: t.Expr) -> tuple[list, t.Expr]:
        """(statements to run first, the condition) of a transition whose steps are `active`."""
        cond = tr.el.find(q("condition"))
        place = self.at(tr, where)
        if cond is None or len(cond) == 0:
            raise StError(place, "plcopen", "a transition without a condition; give one")
        kind = local(cond[0])
        if kind == "inline":
            st = cond[0].find(q("ST"))
            if st is None:
                raise StError(
                    place, "plcopen", "an inline condition that is not ST; write it in ST or as a named transition"
                )
            text, line = st_text.text_of(st)
            return [], st_text.expression(self.file, text, line, place.origin)
        if kind == "reference":
            return [], self.named_transition(cond[0].get("name") or "", place, active)
        if kind == "connectionPointIn":
            pin = next((p for p in tr.inputs if p.name == "condition"), None)
            value = self.ctx.connection_expr(self.body, tr, pin) if pin is not None else None
            if value is None:
                raise StError(place, "plcopen", "the condition is connected to nothing; connect it or write it")
            return self.ctx.net(self.body).take(), value  # the calls of the blocks it goes through
        raise StError(place, "plcopen", f"a condition given as <{kind}> is not supported")

    def named_transition(self, name: str, place: Place, active: t.Expr) -> t.Expr:
        """A transition of the POU's <transitions>: a BOOL variable of its name, which its body (run
        once a period, when the steps of a transition that names it are active) assigns; else a BOOL
        variable of the POU of that name."""
        key = name.upper()
        if key not in self.named:
            decl = next(
                (
                    d
                    for d in self.pou_el.iterfind(f"{q('transitions')}/{q('transition')}")
                    if (d.get("name") or "").upper() == key
                ),
                None,
            )
            if decl is None:
                return t.Name(place, name)
            self.declare(place, name, t.TypeRef(place, "BOOL"))
            self.named[key] = (self.ctx.body_statements(decl.find(q("body")), f"{self.body.pou}.{name}"), [])
        self.named[key][1].append(active)
        return t.Name(place, name)

    # ---- actions -----------------------------------------------------------------------------

    def read_actions(self) -> list[Action]:
        order: list[Action] = []
        named = {a.get("name", "").upper(): a for a in self.pou_el.findall(f"{q('actions')}/{q('action')}")}
        for block in (e for e in self.body.elements.values() if e.kind == "actionBlock"):
            sources = self.sources(block)
            if len(sources) != 1 or sources[0].kind != "step":
                raise self.error(block, "an action block must be connected to one step")
            step = sources[0]
            where = self.where(step)
            for n, a in enumerate(block.el.findall(q("action")), 1):
                qualifier = a.get("qualifier") or "N"
                place = self.at(block, f"{where}, action {n}")
                if qualifier not in QUALIFIERS:
                    raise StError(
                        place,
                        "plcopen",
                        f"the action qualifier {qualifier} is not supported ({' '.join(QUALIFIERS)} are)",
                    )
                action = self.action_of(a, block, n, named, place)
                if action.key not in self.actions:
                    self.actions[action.key] = action
                    order.append(action)
                action = self.actions[action.key]
                action.inputs.setdefault(qualifier, []).append(step)
                if qualifier in TIMED:
                    self.duration(action, a, step, place)
        return order

    def action_of(self, a, block: Element, n: int, named: dict, place: Place) -> Action:
        ref = a.find(q("reference"))
        if ref is not None:
            name = ref.get("name") or ""
            key = name.upper()
            if key in self.actions:
                return self.actions[key]
            decl = named.get(key)
            if decl is not None:
                body = self.ctx.body_statements(decl.find(q("body")), f"{self.body.pou}.{name}")
                return Action(key, f"_act{name}", place, body)
            control = f"_act{name}" if name.isidentifier() else f"_act{block.id}_{n}"  # `out.lamp`
            return Action(key, control, place, None, variable=name)
        inline = a.find(q("inline"))
        if inline is None:
            raise StError(place, "plcopen", "an action with neither a reference nor an inline body")
        st = inline.find(q("ST"))
        if st is not None:
            text, line = st_text.text_of(st)
            statements = st_text.statements(self.file, text, line, place.origin)
        else:
            statements = self.ctx.body_statements(inline, f"{self.body.pou}.action{block.id}_{n}")
        return Action(f"_{block.id}_{n}", f"_act{block.id}_{n}", place, statements)

    def duration(self, action: Action, a, step: Element, place: Place) -> None:
        text = (a.get("duration") or "").strip()
        if not text:
            raise StError(place, "plcopen", f"the qualifier {a.get('qualifier')} needs a duration, e.g. T#2s")
        if action.duration is None:
            action.duration = (text, st_text.expression(self.file, text, a.sourceline or 1, place.origin), step)
        elif action.duration[0].upper() != text.upper():
            other = action.duration[2].attr("name")
            raise StError(
                place,
                "plcopen",
                f"the action is given two durations ({action.duration[0]} in step '{other}', {text} here); "
                "ACTION_CONTROL has one: give both the same, or make two actions",
            )

    # ---- declarations and statements ---------------------------------------------------------

    def declare(self, place: Place, name: str, spec, init=None) -> None:
        self.ctx.declare(t.VarDecl(place, name, "VAR", spec, init))

    def translate(self) -> list:
        holder = self.body.el.getparent()
        holder = holder.getparent() if holder is not None else None
        if holder is not None and local(holder) in ("action", "transition", "inline"):
            raise StError(
                self.at(None),
                "plcopen",
                f"an SFC as the body of an {local(holder)} is not supported; draw its steps in the POU's chart",
            )
        self.read_steps()
        trs = self.transitions()
        self.check_reachable(trs)
        actions = self.read_actions()
        out: list = []
        here = self.at(None)
        self.declare(here, "_sfctick", t.TypeRef(here, "LTIME"))
        self.declare(here, "_sfcdt", t.TypeRef(here, "TIME"))
        for s in self.steps.values():
            p = self.at(s, self.where(s))
            init = t.StructInit(p, [("X", p, true(p))]) if self.initial(s) else None
            self.declare(p, s.attr("name"), t.TypeRef(p, STEP_TYPE), init)
        out += self.clock(here)
        out += self.fire_tests(trs)
        out += self.step_updates(trs)
        for action in actions:
            out += self.action_statements(action)
        return out

    def clock(self, p: Place) -> list:
        """step.T of every active step grows by the time since the last period (their due times)."""

        def now():
            return t.Call(p, name(p, "__CYCLE_TIME_NS"), [])

        never = t.Binary(p, "=", name(p, "_sfctick"), t.Literal(p, "duration", 0, "LTIME#0s", "LTIME"))
        since = t.Binary(p, "-", now(), name(p, "_sfctick"))
        out = [
            t.If(p, [(never, [t.Assign(p, name(p, "_sfctick"), now())])], None),
            t.Assign(p, name(p, "_sfcdt"), t.Call(p, name(p, "LTIME_TO_TIME"), [t.Arg(p, None, since)])),
            t.Assign(p, name(p, "_sfctick"), now()),
        ]
        for s in self.steps.values():
            sp = self.at(s, self.where(s))
            grown = t.Binary(sp, "+", member(sp, s, "T"), name(sp, "_sfcdt"))
            out.append(t.If(sp, [(member(sp, s, "X"), [t.Assign(sp, member(sp, s, "T"), grown)])], None))
        return out

    def fire_tests(self, trs) -> list:
        """Each transition's flag `_fire<localId>`: its steps were active and its condition held;
        then, of transitions that share a step, the leftmost that fires takes it."""
        tests: list = []
        for tr, pre, post in trs:
            where = f"transition {'+'.join(s.attr('name') for s in pre)} -> {'+'.join(s.attr('name') for s in post)}"
            p = self.at(tr, where)
            fire = f"_fire{tr.id}"
            self.declare(p, fire, t.TypeRef(p, "BOOL"))
            active = all_of(p, [member(p, s, "X") for s in pre])
            first, cond = self.condition(tr, where, active)
            tests.append(t.Assign(p, name(p, fire), false(p)))
            tests.append(t.If(p, [(copy.deepcopy(active), [*first, t.Assign(p, name(p, fire), cond)])], None))
        out: list = [
            t.If(body[0].place if body else self.at(None), [(any_of(self.at(None), guards), body)], None)
            for body, guards in self.named.values()
            if body
        ]
        out += tests
        ordered = sorted(trs, key=lambda x: (x[0].x, x[0].y, x[0].id))
        for i, (tr, pre, _) in enumerate(ordered):
            rivals = [o for o, opre, _ in ordered[:i] if any(s in opre for s in pre)]
            if rivals:
                p = self.at(tr)
                taken = any_of(p, [name(p, f"_fire{o.id}") for o in rivals])
                out.append(t.If(p, [(taken, [t.Assign(p, name(p, f"_fire{tr.id}"), false(p))])], None))
        return out

    def step_updates(self, trs) -> list:
        """The steps before a firing transition are left, then the steps after it entered (T#0s)."""
        out: list = []
        for tr, pre, _ in trs:
            p = self.at(tr)
            out.append(
                t.If(p, [(name(p, f"_fire{tr.id}"), [t.Assign(p, member(p, s, "X"), false(p)) for s in pre])], None)
            )
        for tr, _, post in trs:
            p = self.at(tr)
            body = []
            for s in post:
                body += [t.Assign(p, member(p, s, "X"), true(p)), t.Assign(p, member(p, s, "T"), zero_time(p))]
            out.append(t.If(p, [(name(p, f"_fire{tr.id}"), body)], None))
        return out

    def action_statements(self, action: Action) -> list:
        p = action.place
        init = []
        for edge, qualifier in (("P_M", "P"), ("P1_M", "P1"), ("P0_M", "P0")):
            if any(self.initial(s) for s in action.inputs.get(qualifier, [])):
                init.append((edge, p, true(p)))
        self.declare(p, action.control, t.TypeRef(p, CONTROL_TYPE), t.StructInit(p, init) if init else None)
        args = [t.Arg(p, qual, any_of(p, [member(p, s, "X") for s in steps])) for qual, steps in action.inputs.items()]
        if action.duration is not None:
            args.append(t.Arg(p, "T", action.duration[1]))

        def output(pin: str) -> t.Member:
            return t.Member(p, name(p, action.control), pin)

        out: list = [t.CallStmt(p, t.Call(p, name(p, action.control), args))]
        if action.statements is None:
            target = st_text.expression(self.file, action.variable, p.line, p.origin)
            write = t.Assign(p, target, output("Q"))
            out.append(t.If(p, [(output("A"), [write])], None))
        else:
            out.append(t.If(p, [(output("Q"), action.statements)], None))
        return out


# ---- small node makers -------------------------------------------------------------------------


def name(p: Place, text: str) -> t.Name:
    return t.Name(p, text)


def member(p: Place, step: Element, field_name: str) -> t.Member:
    return t.Member(p, t.Name(p, step.attr("name")), field_name)


def true(p: Place) -> t.Literal:
    return t.Literal(p, "bool", True, "TRUE")


def false(p: Place) -> t.Literal:
    return t.Literal(p, "bool", False, "FALSE")


def zero_time(p: Place) -> t.Literal:
    return t.Literal(p, "duration", 0, "T#0s", "TIME")


def all_of(p: Place, xs: list[t.Expr]) -> t.Expr:
    out = xs[0]
    for x in xs[1:]:
        out = t.Binary(p, "AND", out, x)
    return out


def any_of(p: Place, xs: list[t.Expr]) -> t.Expr:
    out = xs[0]
    for x in xs[1:]:
        out = t.Binary(p, "OR", out, x)
    return out


def translate(ctx, pou_el: etree._Element, body: Body) -> list:
    """The statements of an SFC body; its steps, transition flags and action controls are declared
    through ctx.declare."""
    return Chart(ctx, pou_el, body).translate()

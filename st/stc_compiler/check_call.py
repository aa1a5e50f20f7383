# check_call.py -- calls: a FUNCTION of the set, an FB instance, or a standard function (stdlib.py):
# binds every argument to its parameter (formal `x := v`, `q => v`, or informal by position), checks
# direction and type, resolves the generic parameters (ANY_NUM, ...) and records the call's target.

from __future__ import annotations

from . import stdlib
from . import tree as t
from . import types as ty
from .check_expr import _close, _text


def check_call(ck, c: t.Call, statement: bool) -> ty.Type | None:
    callee = c.callee
    if isinstance(callee, t.Name):
        key = callee.name.upper()
        decl = ck.find_var(key)
        if decl is not None and decl.kind == "RESULT":
            decl = None  # `F(...)` inside FUNCTION F calls it (recursion() refuses that), F := assigns
        if decl is None:
            pou = ck.prog.pous.get(key)
            if pou is not None:
                callee.decl = pou  # a function's name has no type of its own; the call has its result's
                return _pou_call(ck, c, pou, statement)
            fn = stdlib.lookup(key)
            if fn is not None:
                callee.decl = fn
                return _std_call(ck, c, fn)
            for a in c.args:
                if a.value is not None:
                    ck.expr(a.value)
            extra = [p.name for p in ck.prog.pous.values() if p.kind == "FUNCTION"] + list(stdlib.FUNCTIONS)
            ck.error(
                callee.place,
                "undeclared",
                f"no function or FB instance '{callee.name}'{ck.did_you_mean(callee.name, extra)}",
            )
            return None
    typ = ck.value(callee)
    if typ is None:
        return None
    fb = ty.base(typ)
    if not isinstance(fb, ty.FbType):
        ck.error(
            callee.place, "type", f"'{_text(callee)}' is {typ}, not an FB instance or a function; it cannot be called"
        )
        return None
    return _fb_call(ck, c, fb.pou, statement)


def _pou_call(ck, c: t.Call, pou: t.Pou, statement: bool) -> ty.Type | None:
    if pou.kind == "FUNCTION_BLOCK":
        ck.error(
            c.place,
            "call",
            f"{pou.name} is a FUNCTION_BLOCK type; declare an instance (`t : {pou.name};`) and call it: t(...)",
        )
        return None
    if pou.kind == "PROGRAM":
        ck.error(
            c.place,
            "call",
            f"{pou.name} is a PROGRAM; a TASK runs it (PROGRAM inst WITH task : {pou.name}), it is not called",
        )
        return None
    c.target = pou
    if ck.scope is not None:
        ck.scope.uses.append((pou, c.place))
    _bind(ck, c, pou, function=True)
    if pou.result is None and not statement:
        ck.error(
            c.place, "call", f"FUNCTION {pou.name} returns no value; call it as a statement or give it a result type"
        )
        return None
    return pou.return_type


def _fb_call(ck, c: t.Call, pou: t.Pou, statement: bool) -> ty.Type | None:
    c.target = c.callee.decl if isinstance(c.callee, (t.Name, t.Member)) else None
    c.fb = pou
    _bind(ck, c, pou, function=False)
    if not statement:
        ck.error(
            c.place,
            "call",
            f"an FB call is a statement of its own; call {_text(c.callee)}(...); then read its outputs ({_text(c.callee)}.<output>)",
        )
    return None


def _bind(ck, c: t.Call, pou: t.Pou, function: bool) -> None:
    """Binds the arguments of a call of a FUNCTION or an FB instance to the POU's parameters."""
    params = [v for v in pou.vars if v.kind in ("VAR_INPUT", "VAR_IN_OUT", "VAR_OUTPUT")]
    by_name = {v.name.upper(): v for v in params}
    positional = [v for v in params if v.kind in ("VAR_INPUT", "VAR_IN_OUT")]
    named = [a for a in c.args if a.name is not None]
    if named and len(named) != len(c.args):
        ck.error(
            c.args[0].place,
            "call",
            f"mix of formal (x := v) and informal arguments in the call of {pou.name}; name every argument",
        )
    given: dict[str, t.Arg] = {}
    for i, a in enumerate(c.args):
        if a.name is None:
            if i >= len(positional):
                ck.error(
                    a.place,
                    "call",
                    f"{pou.name} takes {len(positional)} arguments, not {len(c.args)}; remove the extra ones",
                )
                ck.expr(a.value)
                continue
            p = positional[i]
        else:
            p = by_name.get(a.name.upper())
            if p is None:
                ck.error(a.place, "parameter", _unknown_parameter(pou, a.name, params))
                if a.value is not None:
                    ck.expr(a.value)
                continue
        if p.name.upper() in given:
            ck.error(a.place, "parameter", f"'{p.name}' is given twice; give it once")
            continue
        given[p.name.upper()] = a
        a.param = p
        _arg(ck, a, p, pou)
    if not named and function and len(c.args) < len(positional):
        ck.error(
            c.place,
            "call",
            f"{pou.name} takes {len(positional)} arguments, not {len(c.args)}; give them all, or name them (x := v)",
        )
    for p in params:
        if p.kind == "VAR_IN_OUT" and p.name.upper() not in given:
            ck.error(
                c.place,
                "parameter",
                f"the VAR_IN_OUT '{p.name}' of {pou.name} must be given in every call: {p.name} := <variable>",
            )


def _unknown_parameter(pou: t.Pou, name: str, params: list[t.VarDecl]) -> str:
    if pou.extern:  # e.g. PLCopen's Deceleration, Jerk, BufferMode, which the C++ blocks do not have
        return (
            f"{pou.name} has no parameter '{name}': its implementation, the C++ {pou.extern}, has none; "
            f"remove it (the parameters are {', '.join(v.name for v in params)})"
        )
    return f"{pou.name} has no parameter '{name}'{_close(name, [v.name for v in params])}"


def _arg(ck, a: t.Arg, p: t.VarDecl, pou: t.Pou) -> None:
    if p.kind == "VAR_OUTPUT":
        if not a.output:
            ck.error(
                a.place, "direction", f"'{p.name}' is an output of {pou.name}; read it with {p.name} => <variable>"
            )
            if a.value is not None:
                ck.expr(a.value)
            return
        if a.value is None:
            return
        target = ck.value(a.value)
        if target is not None and ck.assignable(a.value) and p.type is not None:
            if not ty.converts(p.type, target):
                conv = stdlib.conversion(str(p.type), str(target))
                fix = (
                    f"; assign it to a {p.type} variable or convert with {conv}"
                    if conv
                    else f"; assign it to a {p.type} variable"
                )
                ck.error(a.place, "type", f"the output {p.name} is {p.type}, the variable is {target}{fix}")
        return
    if a.output:
        ck.error(a.place, "direction", f"'{p.name}' is an input of {pou.name}; pass it with {p.name} := <value>")
        if a.value is not None:
            ck.expr(a.value)
        return
    if p.type is None or a.value is None:
        return
    if p.kind == "VAR_IN_OUT":
        typ = ck.value(a.value)
        if typ is not None and (not isinstance(a.value, (t.Name, t.Member, t.Index)) or not ck.assignable(a.value)):
            ck.error(a.place, "parameter", f"the VAR_IN_OUT '{p.name}' needs a variable, not an expression")
        elif typ is not None and not ty.same(typ, p.type):
            ck.error(a.place, "type", f"the VAR_IN_OUT '{p.name}' is {p.type}; pass a {p.type} variable, not {typ}")
        return
    ck.expect(a.value, p.type, f"parameter {p.name}")


# ---- standard functions ------------------------------------------------------------------------


def _std_call(ck, c: t.Call, fn: stdlib.Function) -> ty.Type | None:
    c.target = fn
    params = list(fn.params)
    args = c.args
    if any(a.output for a in args):
        ck.error(args[0].place, "direction", f"{fn.name} has no outputs; pass its inputs only")
        return None
    count = len(args)
    if fn.extensible:
        if count < len(params):
            ck.error(c.place, "call", f"{fn.name} takes at least {len(params)} arguments, not {count}")
            return None
        last = params[-1]
        stem = last.name.rstrip("0123456789")
        first = int(last.name[len(stem) :]) - (len(params) - 1) if fn.name == "MUX" else 1
        if fn.name == "MUX":
            params = [params[0]] + [stdlib.Param(f"{stem}{i}", last.type, last.family) for i in range(count - 1)]
        else:
            params = params[:-1] + [
                stdlib.Param(f"{stem}{i + first}", last.type, last.family) for i in range(len(params) - 1, count)
            ]
    elif count != len(params):
        names = ", ".join(p.name for p in params)
        ck.error(
            c.place,
            "call",
            f"{fn.name} takes {len(params)} argument{'s' if len(params) != 1 else ''} ({names}), not {count}",
        )
        for a in args:
            if a.value is not None:
                ck.expr(a.value)
        return None
    bound: list[tuple[t.Arg, stdlib.Param]] = []
    if any(a.name is not None for a in args):
        by_name = {p.name.upper(): p for p in params}
        for a in args:
            p = by_name.pop(a.name.upper(), None) if a.name is not None else None
            if p is None:
                ck.error(
                    a.place,
                    "parameter",
                    f"{fn.name} has no parameter '{a.name}' (or it is given twice); its parameters are {', '.join(x.name for x in params)}",
                )
                return None
            bound.append((a, p))
    else:
        bound = list(zip(args, params, strict=True))
    types = {id(a): ck.value(a.value) for a, _ in bound}
    if any(v is None for v in types.values()):
        return None
    generic: ty.Type | None = None
    for a, p in bound:
        if p.type == "T":
            at = types[id(a)]
            previous = generic
            generic = at if generic is None else (ty.common(generic, at) or _enum_same(generic, at))
            if generic is None and _literal_misfit(ck, a, previous, at, bound, types):
                return None
            if generic is None:
                ck.error(
                    a.place,
                    "type",
                    f"the arguments of {fn.name} have no common type ({', '.join(str(types[id(x)]) for x, q in bound if q.type == 'T')}); convert them to one type",
                )
                return None
    if isinstance(generic, ty.LiteralType) and generic.kind == "int":
        if next(p.family for _, p in bound if p.type == "T") == "ANY_REAL":
            generic = ty.LiteralType("real", None, generic.low, generic.high)
    # Only literals (MAX(1, 2)): the call stays untyped, like a literal, until its context (the
    # assignment's target, the other operand) types it and its literals with it (settle()).
    untyped = isinstance(generic, ty.LiteralType)
    for a, p in bound:
        at = types[id(a)]
        if p.type == "T":
            if not ty.in_family(generic, p.family) and not (
                p.family == "ANY_MAGNITUDE" and ty.in_family(generic, "ANY_NUM")
            ):
                ck.error(
                    a.place,
                    "type",
                    f"{fn.name}'s {p.name} is {p.family}, not {generic}{_family_fix(generic, p.family)}",
                )
                return None
            if not untyped:
                ck.expect(a.value, generic, f"parameter {p.name}")
        elif p.type.startswith("ANY"):
            if not ty.in_family(at, p.type):
                ck.error(a.place, "type", f"{fn.name}'s {p.name} is {p.type}, not {at}{_family_fix(at, p.type)}")
                return None
            ck.settle(
                a.value, ty.concrete(at) if p.type != "ANY_REAL" or not isinstance(at, ty.LiteralType) else ty.LREAL
            )
        elif p.type in ("STRING", "WSTRING"):
            if ty.kind(at) != "string":
                conv = stdlib.conversion(str(ty.concrete(at)), "STRING")
                ck.error(
                    a.place,
                    "type",
                    f"{fn.name}'s {p.name} is a STRING, not {at}" + (f"; use {conv}(...)" if conv else ""),
                )
                return None
        else:
            ck.expect(a.value, ty.ELEMENTARY[p.type], f"parameter {p.name}")
        a.param = p
    if fn.result == "T":
        return generic
    if fn.result in ("STRING", "WSTRING"):
        return ty.STRING if fn.result == "STRING" else ty.WSTRING
    return ty.ELEMENTARY[fn.result]


def _literal_misfit(ck, a: t.Arg, previous, at, bound, types) -> bool:
    """An error when an untyped integer literal among a call's generic arguments does not fit the
    type of the others (MAX(i, 70000) with i an INT); True when reported."""
    for lit, other in ((at, previous), (previous, at)):
        if isinstance(lit, ty.LiteralType) and lit.kind == "int" and ty.kind(other) in ("int", "uint", "bit"):
            value = lit.misfit(other)
            if value is not None:
                place = a.place if lit is at else next(x for x, q in bound if types[id(x)] is lit).place
                lo, hi = ty.value_range(ty.base(other))
                ck.error(
                    place,
                    "range",
                    f"{value} does not fit {other} ({lo}..{hi}), the type of the other arguments; use a wider type",
                )
                return True
    return False


def _enum_same(a: ty.Type, b: ty.Type) -> ty.Type | None:
    return a if ty.same(a, b) or (ty.kind(a) == ty.kind(b) == "string") else None


# The type a conversion into a generic family suggests (SQRT(i): "use INT_TO_LREAL(...)").
_FAMILY_EXAMPLE = {
    "ANY_REAL": "LREAL",
    "ANY_INT": "DINT",
    "ANY_NUM": "LREAL",
    "ANY_BIT": "DWORD",
    "ANY_MAGNITUDE": "LREAL",
}


def _family_fix(at: ty.Type, family: str) -> str:
    conv = stdlib.conversion(str(ty.concrete(at)), _FAMILY_EXAMPLE.get(family, ""))
    return f"; use {conv}(...)" if conv else ""

# as_st.py -- generate.py's rungs written as the Structured Text they mean (IEC 61131-3 LD: contacts
# in series AND, a coil assigns or sets/resets with the power at it, a block runs with its inputs and
# its outputs go to their variables, rungs top to bottom): a cross-check of the drawing's logic that
# does not need the PLCopen importer (tests/python/cell/test_plc_robot_ld.py builds and runs it).

from __future__ import annotations

from ladder import Block, Coil, Contact, Rung


def power(contacts: list[Contact]) -> str:
    terms = [f"NOT {c.var}" if c.negated else c.var for c in contacts]
    return " AND ".join(terms) or "TRUE"


def coil(c: Coil, value: str) -> str:
    if c.storage == "set":
        return f"IF {value} THEN {c.var} := TRUE; END_IF;"
    if c.storage == "reset":
        return f"IF {value} THEN {c.var} := FALSE; END_IF;"
    return f"{c.var} := {value};"


def block(b: Block) -> list[str]:
    args = [f"{pin} := {power(v) if isinstance(v, list) else v}" for pin, v in (b.inputs | b.in_outs).items()]
    if b.instance:  # a function block: called, then its outputs read
        lines = [f"{b.instance}({', '.join(args)});"]
        result = {pin: f"{b.instance}.{pin}" for pin in b.outputs}
    else:  # a function: its one result
        lines = []
        result = {pin: f"{b.type}({', '.join(args)})" for pin in b.outputs}
    for pin, target in b.outputs.items():
        lines.append(coil(target, result[pin]) if isinstance(target, Coil) else f"{target} := {result[pin]};")
    return lines


def body(rungs: list[Rung]) -> str:
    lines = []
    for r in rungs:
        if r.comment:
            lines.append(f"(* {r.comment} *)")
        if r.block is not None:
            lines += block(r.block)
        else:
            lines += [coil(c, power(r.contacts)) for c in r.coils]
    return "\n".join(lines) + "\n"

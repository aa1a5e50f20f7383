# plcopen_xml.py -- PLCopen XML written by the importer's tests: a project around POUs, and the LD/FBD
# elements of a body (one per call, placed on a grid so that rows give the evaluation order), so that
# a test states the diagram it draws in a few lines.

from __future__ import annotations

HEAD = """<?xml version="1.0" encoding="utf-8"?>
<project xmlns="http://www.plcopen.org/xml/tc6_0201" xmlns:xhtml="http://www.w3.org/1999/xhtml">
  <fileHeader companyName="indurop tests" productName="plcopen" productVersion="1" creationDateTime="2026-12-07T12:00:00"/>
  <contentHeader name="test">
    <coordinateInfo>
      <fbd><scaling x="10" y="10"/></fbd>
      <ld><scaling x="10" y="10"/></ld>
      <sfc><scaling x="10" y="10"/></sfc>
    </coordinateInfo>
  </contentHeader>
"""


def var(name: str, typ: str, init: str | None = None, address: str | None = None) -> str:
    t = f"<{typ}/>" if not typ.startswith("<") else typ
    at = f' address="{address}"' if address else ""
    value = f'<initialValue><simpleValue value="{init}"/></initialValue>' if init is not None else ""
    return f'<variable name="{name}"{at}><type>{t}</type>{value}</variable>'


def section(kind: str, *variables: str, **attrs: str) -> str:
    a = "".join(f' {k}="{v}"' for k, v in attrs.items())
    return f"<{kind}{a}>{''.join(variables)}</{kind}>"


def pou(name: str, kind: str, interface: str, lang: str, body: str) -> str:
    return f'<pou name="{name}" pouType="{kind}"><interface>{interface}</interface><body><{lang}>{body}</{lang}></body></pou>'


def project(*pous: str, data_types: str = "", instances: str = "") -> bytes:
    inst = (
        f"<instances><configurations>{instances}</configurations></instances>"
        if instances
        else ("<instances><configurations/></instances>")
    )
    text = f"{HEAD}<types><dataTypes>{data_types}</dataTypes><pous>{''.join(pous)}</pous></types>{inst}</project>\n"
    return text.encode()


def config(program: str, interval: str = "T#10ms") -> str:
    return (
        '<configuration name="Config0"><resource name="Res0">'
        f'<task name="task0" priority="1" interval="{interval}"><pouInstance name="instance0" typeName="{program}"/></task>'
        "</resource></configuration>"
    )


def _pos(x: float, y: float) -> str:
    return f'<position x="{x}" y="{y}"/>'


def _links(refs) -> str:
    """refs: a localId, (localId, formalParameter), or a list of them (a branch: OR)."""
    if refs is None:
        return "<connectionPointIn/>"
    if not isinstance(refs, list):
        refs = [refs]
    out = []
    for r in refs:
        ref, formal = r if isinstance(r, tuple) else (r, None)
        f = f' formalParameter="{formal}"' if formal else ""
        out.append(f'<connection refLocalId="{ref}"{f}/>')
    return f"<connectionPointIn>{''.join(out)}</connectionPointIn>"


def rail(lid: int, x: float = 0, y: float = 0) -> str:
    return f'<leftPowerRail localId="{lid}" width="10" height="1000">{_pos(x, y)}<connectionPointOut formalParameter=""/></leftPowerRail>'


def _ld_element(tag: str, lid: int, variable: str, ref, x: float, y: float, **attrs) -> str:
    """A contact or coil: attrs such as negated=True, edge="rising", storage="set" (None: left out)."""
    a = "".join(f' {k}="{str(v).lower()}"' for k, v in attrs.items() if v)
    return (
        f'<{tag} localId="{lid}"{a} width="20" height="20">{_pos(x, y)}{_links(ref)}'
        f"<connectionPointOut/><variable>{variable}</variable></{tag}>"
    )


def contact(lid: int, variable: str, ref, x: float, y: float, negated: bool = False, edge: str | None = None) -> str:
    return _ld_element("contact", lid, variable, ref, x, y, negated=negated, edge=edge)


def coil(
    lid: int,
    variable: str,
    ref,
    x: float,
    y: float,
    negated: bool = False,
    storage: str | None = None,
    edge: str | None = None,
) -> str:
    return _ld_element("coil", lid, variable, ref, x, y, negated=negated, storage=storage, edge=edge)


def block(
    lid: int,
    type_name: str,
    inputs: dict,
    outputs: list[str],
    x: float,
    y: float,
    instance: str | None = None,
    order: int = 0,
) -> str:
    """inputs: formalParameter -> refs (see _links); outputs: formalParameters."""
    i = f' instanceName="{instance}"' if instance else ""
    o = f' executionOrderId="{order}"' if order else ""
    ins = "".join(f'<variable formalParameter="{k}">{_links(v)}</variable>' for k, v in inputs.items())
    outs = "".join(f'<variable formalParameter="{k}"><connectionPointOut/></variable>' for k in outputs)
    return (
        f'<block localId="{lid}" typeName="{type_name}"{i}{o} width="60" height="60">{_pos(x, y)}'
        f"<inputVariables>{ins}</inputVariables><inOutVariables/><outputVariables>{outs}</outputVariables></block>"
    )


def in_var(lid: int, expression: str, x: float, y: float) -> str:
    return f'<inVariable localId="{lid}" width="20" height="20">{_pos(x, y)}<connectionPointOut/><expression>{expression}</expression></inVariable>'


def out_var(lid: int, expression: str, ref, x: float, y: float, order: int = 0, negated: bool = False) -> str:
    o = f' executionOrderId="{order}"' if order else ""
    o += ' negated="true"' if negated else ""
    return f'<outVariable localId="{lid}"{o} width="20" height="20">{_pos(x, y)}{_links(ref)}<expression>{expression}</expression></outVariable>'


def jump(lid: int, label: str, ref, x: float, y: float) -> str:
    return f'<jump localId="{lid}" label="{label}" width="20" height="20">{_pos(x, y)}{_links(ref)}</jump>'


def label(lid: int, name: str, x: float, y: float) -> str:
    return f'<label localId="{lid}" label="{name}" width="20" height="20">{_pos(x, y)}</label>'


def ret(lid: int, ref, x: float, y: float) -> str:
    return f'<return localId="{lid}" width="20" height="20">{_pos(x, y)}{_links(ref)}</return>'


def connector(lid: int, name: str, ref, x: float, y: float) -> str:
    return f'<connector localId="{lid}" name="{name}" width="20" height="20">{_pos(x, y)}{_links(ref)}</connector>'


def continuation(lid: int, name: str, x: float, y: float) -> str:
    return f'<continuation localId="{lid}" name="{name}" width="20" height="20">{_pos(x, y)}<connectionPointOut/></continuation>'


def blocks_in_a_cycle(variable: str) -> str:
    """An FBD body whose ADD and MUL feed each other with no variable between them (refused)."""
    return "".join(
        [
            in_var(1, variable, 0, 0),
            block(2, "ADD", {"IN1": 1, "IN2": (3, "OUT")}, ["OUT"], 100, 0),
            block(3, "MUL", {"IN1": (2, "OUT"), "IN2": 1}, ["OUT"], 200, 0),
            out_var(4, variable, (3, "OUT"), 300, 0),
        ]
    )

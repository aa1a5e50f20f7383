# sfc_xml.py -- SFC charts written by the importer's tests as PLCopen XML (TC6 v2.01): steps,
# transitions (inline ST, named, or connected), action blocks, jumps, divergences and convergences,
# and a POU with its named actions and transitions, so that a test states its chart in a few lines;
# and run_recorded(), a chart run in irpd by an ST harness that records what it saw, cycle by cycle.
# The project around it and the LD/FBD elements are plcopen_xml.py's.

from __future__ import annotations

from live_processes import wait_until
from plcopen_live import Running
from plcopen_xml import _links, _pos


def _st(text: str) -> str:
    return f"<ST><xhtml:p><![CDATA[{text}]]></xhtml:p></ST>"


def step(lid: int, name: str, ref=None, x: float = 0, y: float = 0, initial: bool = False) -> str:
    init = ' initialStep="true"' if initial else ""
    cpi = _links(ref) if ref is not None else ""
    return (
        f'<step localId="{lid}" name="{name}"{init} width="60" height="30">{_pos(x, y)}{cpi}'
        '<connectionPointOut formalParameter=""/><connectionPointOutAction formalParameter=""/></step>'
    )


def transition(lid: int, ref, x: float, y: float, st: str | None = None, named: str | None = None, wire=None) -> str:
    """A transition below `ref` whose condition is inline ST `st`, the POU's transition `named`, or
    the value connected to it from `wire` (an LD/FBD element of the chart)."""
    if st is not None:
        cond = f'<inline name="">{_st(st)}</inline>'
    elif named is not None:
        cond = f'<reference name="{named}"/>'
    else:
        cond = _links(wire)
    return (
        f'<transition localId="{lid}" width="20" height="2">{_pos(x, y)}{_links(ref)}'
        f"<connectionPointOut/><condition>{cond}</condition></transition>"
    )


def actions(lid: int, ref: int, x: float, y: float, *items: tuple) -> str:
    """An action block beside step `ref`; items: (qualifier, name or ST text ending in ';'[, duration])."""
    out = []
    for qualifier, what, *duration in items:
        d = f' duration="{duration[0]}"' if duration else ""
        body = f"<inline>{_st(what)}</inline>" if what.endswith(";") else f'<reference name="{what}"/>'
        out.append(f'<action localId="0" qualifier="{qualifier}"{d}><relPosition x="0" y="0"/>{body}</action>')
    return (
        f'<actionBlock localId="{lid}" width="200" height="100">{_pos(x, y)}{_links(ref)}{"".join(out)}</actionBlock>'
    )


def jump(lid: int, target: str, ref, x: float, y: float) -> str:
    return (
        f'<jumpStep localId="{lid}" targetName="{target}" width="10" height="10">{_pos(x, y)}{_links(ref)}</jumpStep>'
    )


def divergence(kind: str, lid: int, ref, x: float, y: float, branches: int = 2) -> str:
    """kind: selection or simultaneous."""
    outs = '<connectionPointOut formalParameter=""/>' * branches
    tag = f"{kind}Divergence"
    return f'<{tag} localId="{lid}" width="200" height="2">{_pos(x, y)}{_links(ref)}{outs}</{tag}>'


def convergence(kind: str, lid: int, refs: list, x: float, y: float) -> str:
    ins = "".join(_links(r) for r in refs)
    tag = f"{kind}Convergence"
    return f'<{tag} localId="{lid}" width="200" height="2">{_pos(x, y)}{ins}<connectionPointOut/></{tag}>'


def two_steps(first: str, second: str, there: dict, back: dict) -> list[str]:
    """The smallest loop (localIds 1-5): `first` (initial) -> transition (there: transition()'s
    condition keywords, e.g. {"st": "go"}) -> `second` -> transition (back) -> a jump to `first`."""
    return [
        step(1, first, initial=True),
        transition(2, 1, 0, 50, **there),
        step(3, second, 2, 0, 100),
        transition(4, 3, 0, 150, **back),
        jump(5, first, 4, 0, 200),
    ]


def pou(name: str, kind: str, interface: str, body: str, acts: dict | None = None, trans: dict | None = None) -> str:
    """A POU with an SFC body; acts and trans: name -> the body of its named actions and transitions,
    ST text or a drawn body (`<LD>...</LD>`)."""

    def drawn(text: str) -> str:
        return f"<body>{text if text.startswith('<') else _st(text)}</body>"

    a = "".join(f'<action name="{n}">{drawn(t)}</action>' for n, t in (acts or {}).items())
    tr = "".join(f'<transition name="{n}">{drawn(t)}</transition>' for n, t in (trans or {}).items())
    return (
        f'<pou name="{name}" pouType="{kind}"><interface>{interface}</interface>'
        f"<actions>{a}</actions><transitions>{tr}</transitions><body><SFC>{body}</SFC></body></pou>"
    )


def run_recorded(tmp_path, project: bytes, harness: str, cycles: int, *arrays: str) -> list[list]:
    """Builds the project with the harness (an ST PROGRAM `Harness`, instance0, that counts its cycles
    in `n` and stops after `cycles`), runs it in irpd until it has, and returns each array's values."""
    xml = tmp_path / "chart.xml"
    xml.write_bytes(project)
    run = Running(tmp_path, {"chart.xml": xml, "harness.st": harness})
    try:
        wait_until(lambda: run.value("instance0.n") > cycles, 60)
        return [list(run.values(f"instance0.{a}").values()) for a in arrays]
    finally:
        run.close()

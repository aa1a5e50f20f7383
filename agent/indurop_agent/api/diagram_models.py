"""diagram_models.py -- the live view's API models (routes/diagrams.py, docs/programming.md "The live
view"): a graphical POU of a set's PLCopen XML file as the browser draws it (GET /programs/diagram)
and its live values (POST /programs/diagram/monitor)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from .monitor_models import PathError


class DiagramPin(BaseModel):
    name: str | None = Field(
        description="the block parameter (formalParameter); 'condition' for a transition's; null: the element's only pin"
    )
    x: float = Field(description="where the pin is, in the file's coordinates")
    y: float
    negated: bool = False
    edge: str = Field("none", description="rising / falling on a block input")


class DiagramWire(BaseModel):
    from_id: int = Field(description="the localId the value comes from")
    from_pin: str | None = Field(description="its output parameter (a block's), null for an element's only output")
    to_id: int = Field(description="the localId it goes to")
    to_pin: str | None = Field(description="the input it feeds (a block's parameter), null for the only input")
    points: list[list[float]] = Field(
        description="the polyline as the file draws it ([x, y] each), from the input back to the output"
    )


class DiagramAction(BaseModel):
    qualifier: str = Field(description="N, S, R, P, P0, P1, L, D, SD, DS, SL")
    duration: str | None = None
    indicator: str | None = None
    name: str | None = Field(None, description="a named action or a variable (reference)")
    text: str | None = Field(None, description="an inline ST action")


class DiagramElement(BaseModel):
    id: int = Field(description="localId")
    kind: str = Field(
        description="the element's tag: leftPowerRail, rightPowerRail, contact, coil, block, inVariable, outVariable, "
        "inOutVariable, connector, continuation, jump, label, return, step, transition, actionBlock, "
        "selectionDivergence, selectionConvergence, simultaneousDivergence, simultaneousConvergence, jumpStep, comment"
    )
    x: float
    y: float
    width: float
    height: float
    label: str | None = Field(
        description="a contact's or coil's variable, a variable's expression, a block's type, a step's name, "
        "a connector's name, a jump's target, a comment's text"
    )
    instance: str | None = Field(description="a function block's instance name")
    negated: bool
    edge: str = Field(description="none, rising or falling (a contact's or coil's P / N)")
    storage: str = Field(description="none, set or reset (a coil's S / R)")
    initial: bool = Field(description="an SFC step that is initial")
    order: int = Field(description="executionOrderId (0: none)")
    inputs: list[DiagramPin]
    outputs: list[DiagramPin]
    actions: list[DiagramAction] = Field(description="an action block's actions")
    condition: str | None = Field(description="a transition's inline ST condition or named transition")


class Diagram(BaseModel):
    set_id: str
    path: str = Field(description="the PLCopen XML file in the set")
    pou: str
    kind: str = Field(description="PROGRAM, FUNCTION_BLOCK or FUNCTION")
    language: str | None = Field(description="LD, FBD or SFC (drawn); ST or IL: `text` holds the body")
    width: float = Field(description="the drawing's extent in the file's coordinates")
    height: float
    elements: list[DiagramElement]
    wires: list[DiagramWire]
    text: str | None = Field(None, description="an ST or IL body's text")


class DiagramMonitorRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    set: str | None = Field(None, description="the set (default: the active one); values are the running ones")
    path: str = Field(description="the PLCopen XML file, e.g. plc.xml", min_length=1, max_length=255)
    pou: str = Field(description="the POU shown", min_length=1, max_length=255)


class FlowValue(BaseModel):
    id: int = Field(description="the localId the value leaves")
    pin: str | None = Field(description="its output (a block's parameter), null for the only one")
    type: str | None = Field(None, description="its IEC type (BOOL: power or a boolean; TIME: nanoseconds)")
    constant: bool = Field(False, description="a constant (a literal drawn as a variable): it never changes")
    value: bool | int | float | None = Field(
        description="the value leaving it now (LD: the power); null when not evaluated"
    )
    reason: str | None = Field(None, description="why it is not evaluated")


class ElementValue(BaseModel):
    id: int = Field(description="the localId of a contact, coil, variable, block or step")
    path: str = Field(description="the shared variable it shows (a step: its X flag's struct)")
    type: str | None = None
    value: bool | int | float | None = None
    forced: bool = False
    active: bool | None = Field(None, description="a step: active now (its X)")
    time_ms: float | None = Field(None, description="a step: how long it has been active (its T)")


class DiagramMonitorAnswer(BaseModel):
    set_id: str
    layout_hash: str
    instance: str | None = Field(description="the PROGRAM instance whose values these are (null: not a PROGRAM)")
    flows: list[FlowValue] = Field(description="the value leaving each element's output, from the translation")
    elements: list[ElementValue] = Field(description="the variables the elements show")
    errors: list[PathError]

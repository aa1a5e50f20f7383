"""capture_models.py -- the shapes of the captures' API (docs/recorder.md "Triggered captures"): a
capture's request (variables, trigger, pre- and post-trigger lengths, repeat), its state, its
shots and their rows, and the limits.  OpenAPI and the web UI's schema.d.ts are generated from
them; their bounds come from capture_limits.py."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from . import capture_limits as L

Number = Annotated[float, Field(allow_inf_nan=False)]
Path = Annotated[str, Field(min_length=1, max_length=231, description="a scalar shared variable, e.g. SIG.wave[4]")]
Severity = Literal["low", "medium", "high", "critical"]


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class EdgeCondition(Strict):
    """The variable crosses `threshold`: rising (the row before < threshold <= this row), falling
    (the row before >= threshold > this row) or either."""

    kind: Literal["edge"]
    variable: Path
    direction: Literal["rising", "falling", "either"] = "rising"
    threshold: Number = 0.0


class LevelCondition(Strict):
    """The variable is above, below or equal to `value` (within `tolerance`), for `hold_rows` rows
    in a row."""

    kind: Literal["level"]
    variable: Path
    compare: Literal["above", "below", "equal"]
    value: Number
    tolerance: Number = Field(0.0, ge=0, description="for equal: |x - value| <= tolerance")
    hold_rows: int = Field(
        1, ge=1, le=L.MAX_HOLD_ROWS, description="rows it must hold; the last one is the trigger row"
    )


class WindowCondition(Strict):
    """The variable is inside [low, high] or outside it, for `hold_rows` rows in a row."""

    kind: Literal["window"]
    variable: Path
    where: Literal["inside", "outside"] = "inside"
    low: Number
    high: Number
    hold_rows: int = Field(1, ge=1, le=L.MAX_HOLD_ROWS)

    @model_validator(mode="after")
    def ordered(self):
        if self.low > self.high:
            raise ValueError(f"the window's low ({self.low}) is above its high ({self.high})")
        return self


Condition = Annotated[EdgeCondition | LevelCondition | WindowCondition, Field(discriminator="kind")]


class ConditionTrigger(Strict):
    """Conditions on variables, combined row by row; the trigger row is the first row at which the
    combination holds (its seq is exact)."""

    kind: Literal["condition"]
    combine: Literal["and", "or"] = "and"
    conditions: list[Condition] = Field(min_length=1, max_length=L.MAX_CONDITIONS)


class AlarmTrigger(Strict):
    """An alarm raised: any (neither key nor severity), one (`key`, e.g. main/8), or of at least a severity."""

    kind: Literal["alarm"]
    key: str | None = Field(None, min_length=1, max_length=300)
    severity: Severity | None = Field(None, description="this severity or higher")


class FaultTrigger(Strict):
    """irpd's events `fault` (a module threw and was disabled) and `stopped` (a fault stopped the set)."""

    kind: Literal["fault"]


class SwapTrigger(Strict):
    """irpd's event `swap`: a hot swap (an online change, an activation) took over."""

    kind: Literal["swap"]


class ManualTrigger(Strict):
    """POST /captures/{id}/trigger (which also forces a capture of any other trigger)."""

    kind: Literal["manual"]


Trigger = Annotated[
    ConditionTrigger | AlarmTrigger | FaultTrigger | SwapTrigger | ManualTrigger, Field(discriminator="kind")
]


class Length(Strict):
    """A length in rows (basic periods) or in seconds (rounded up to rows at the basic period in force
    when it is armed): exactly one of the two."""

    rows: int | None = Field(None, ge=0, le=L.MAX_LENGTH_ROWS)
    seconds: Number | None = Field(None, ge=0, le=L.MAX_LENGTH_S)

    @model_validator(mode="after")
    def one(self):
        if (self.rows is None) == (self.seconds is None):
            raise ValueError('give the length as {"rows": n} or as {"seconds": s}, one of the two')
        return self


class CaptureRequest(Strict):
    """A capture to arm."""

    name: str = Field("", max_length=L.MAX_NAME_CHARS, description="for people; need not be unique")
    variables: list[Path] = Field(
        min_length=1,
        max_length=L.MAX_CHANNELS,
        description="the variables captured; the trigger's are added after them (at most "
        f"{L.MAX_CHANNELS} channels in all)",
    )
    trigger: Trigger
    pre: Length = Field(description=f"rows before the trigger row (at most the rings' capacity, {L.DEFAULT_RING_ROWS})")
    post: Length = Field(description="rows after the trigger row")
    repeat: int = Field(
        1, ge=0, le=L.MAX_REPEAT, description="shots to take, re-armed after each (1: single; 0: until disarmed)"
    )

    @model_validator(mode="after")
    def distinct(self):
        twice = sorted({v for v in self.variables if self.variables.count(v) > 1})
        if twice:
            raise ValueError(f"listed twice in variables: {', '.join(twice)}")
        return self


class Channel(BaseModel):
    path: str
    type: str | None = Field(description="the layout's type (double, uint32_t, bool, ...)")
    iec_type: str | None = Field(
        None,
        description="the IEC 61131-3 type of a Structured Text variable (layout.json's iec_type); null for .glb ones",
    )


class ShotSummary(BaseModel):
    shot: int = Field(description="its number in the capture (1, 2, ...)")
    trigger_seq: int = Field(description="the seq of the trigger row")
    first_seq: int
    last_seq: int
    pre_rows: int = Field(description="rows held before the trigger row")
    post_rows: int = Field(description="rows held after it")
    rows: int
    drops: int = Field(description="rows of first_seq..last_seq after the capture's first row that it did not get")
    cause: str = Field(description="condition, alarm, fault, swap or manual")
    trigger_time_ns: int = Field(description="CLOCK_REALTIME: when the condition was found, or the event's time")
    notes: list[str] = []


class CapturePublic(BaseModel):
    id: str
    name: str
    state: Literal["idle", "armed", "triggered", "done"]
    request: CaptureRequest
    channels: list[Channel] = Field(description="the variables, then the trigger's: the columns of its shots")
    pre_rows: int
    post_rows: int
    basic_period_ns: int | None
    pre_filled: int = Field(description="rows of the pre-trigger buffer held (armed: filling until pre_rows)")
    shots_taken: int = Field(description="since it was last armed")
    lost_rows: int = Field(description="rows it did not get while armed (overwritten before they were read)")
    created: str
    armed_at: str | None
    by: str | None = Field(description="who armed it last")
    message: str | None = Field(
        None,
        description="what happened to it last: why it is not armed, or that it was armed again after irpd restarted",
    )
    shots: list[ShotSummary] = Field(description="the shots kept, oldest first")


class CaptureList(BaseModel):
    captures: list[CapturePublic]


class ShotRows(BaseModel):
    """One shot's rows as columns (the plot panel's shape): seq[k], t_ns[k] and columns[c][k] are row k."""

    capture: str
    summary: ShotSummary
    channels: list[Channel]
    basic_period_ns: int
    seq: list[int]
    t_ns: list[int] = Field(description="due times, CLOCK_MONOTONIC ns")
    columns: list[list[float | None]] = Field(description="one list per channel; null where NaN")
    every: int = Field(description="every n-th row (1: all)")


class CaptureLimits(BaseModel):
    max_channels: int
    max_conditions: int
    max_pre_rows: int = Field(description="the running rings' capacity (the default when irpd does not answer)")
    ring_rows: int | None = Field(description="the running rings' capacity; null when irpd does not answer")
    max_post_rows: int
    max_hold_rows: int
    max_capture_bytes: int
    max_total_bytes: int
    max_armed: int
    max_captures: int
    max_shots_kept: int
    max_repeat: int
    event_lag_s: float
    max_name_chars: int

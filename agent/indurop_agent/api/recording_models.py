"""recording_models.py -- the shapes of the recorder's routes (api/routes/recordings.py,
docs/recorder.md): what a start asks for, and what a recording or capture looks like in answers."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from ..irpd.trace import MAX_CHANNELS
from ..recorder.manager import MAX_DECIMATION
from ..recorder.recording import CAUSES, STATES
from ..recorder.store import NAME_RULE

MAX_DURATION_S = 31 * 24 * 3600.0
PATH_MAX = 231  # bytes of a traced variable's path (docs/trace-and-stream.md)
UNIT_MAX = 32


class VariableWanted(BaseModel):
    model_config = ConfigDict(extra="forbid")
    path: str = Field(min_length=1, max_length=PATH_MAX, description="a scalar leaf of the running layout")
    unit: str = Field("", max_length=UNIT_MAX, description="its unit, written into the file (the layout has none)")


class StopCondition(BaseModel):
    """When a recording ends by itself (neither: when it is stopped)."""

    model_config = ConfigDict(extra="forbid")
    duration_s: float | None = Field(
        None, gt=0, le=MAX_DURATION_S, description="seconds of rows (due time from the first row), then it stops"
    )
    max_bytes: int | None = Field(
        None, gt=0, description="stops once its files hold this many bytes (checked each second; at most the quota)"
    )


class RecordingStart(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str = Field(max_length=200, description=f"the recording's name: {NAME_RULE}")
    variables: list[str | VariableWanted] = Field(
        min_length=1,
        max_length=MAX_CHANNELS,
        description="paths of scalar shared variables, or {path, unit}; irpd traces at most "
        f"{MAX_CHANNELS} channels for all its owners together",
    )
    decimation: int = Field(1, ge=1, le=MAX_DECIMATION, description="every n-th row (seq divisible by n); 1: every row")
    stop: StopCondition = Field(default_factory=StopCondition)


class RecordingVariable(BaseModel):
    path: str
    type: str = Field(description="the layout's type, e.g. double, uint32_t")
    iec_type: str | None = Field(
        None,
        description="the IEC 61131-3 type of a Structured Text variable (layout.json's iec_type); null for .glb ones",
    )
    unit: str
    field: str | None = Field(None, description="its field in the MCAP rows' JSON")


class RecordingPart(BaseModel):
    file: str = Field(description="the part's MCAP file")
    size: int | None
    rows: int | None
    drops: int | None
    first_seq: int | None
    last_seq: int | None
    first_time: str | None
    last_time: str | None
    irpd_pid: int | None
    closed: bool = Field(description="complete (summary and footer written); false: being written, or cut by a crash")
    recovered: str | None = Field(None, description="a crash cut it: why its reading stopped before it was completed")


class RecordingGap(BaseModel):
    part: int = Field(description="the part (0-based) whose first rows follow the gap")
    last_seq: int | None = Field(description="the last row written before the gap")
    first_seq: int = Field(description="the first row after it")
    missing: int | None = Field(
        description="rows the recording would have held in it (null: irpd restarted, seq began again)"
    )
    reason: str


class ShotOf(BaseModel):
    capture: str = Field(description="the capture's id (GET /captures/{capture})")
    shot: int
    trigger_seq: int = Field(description="the trace row that triggered it")
    cause: str = Field(description="what triggered it, in words")


class RecordingPublic(BaseModel):
    name: str
    kind: Literal["recording", "capture"]
    state: str = Field(
        description=f"a recording: {', '.join(STATES)}; damaged: its entry.json cannot be read; a capture: its own states"
    )
    cause: str | None = Field(None, description=f"why it ended: {', '.join(CAUSES)}")
    reason: str | None = Field(None, description="why it ended, in words")
    created: str
    created_by: str | None = None
    ended: str | None = None
    variables: list[RecordingVariable]
    decimation: int | None = None
    stop: StopCondition | None = None
    rows: int
    drops: int = Field(description="rows overwritten in the trace rings before they were read (noted in the file)")
    gaps: list[RecordingGap]
    parts: list[RecordingPart]
    size: int = Field(description="bytes of its files")
    duration_s: float | None = Field(description="from its first row's due time to its last's")
    first_time: str | None
    last_time: str | None
    basic_period_ns: int | None = None
    joint_states: list[str] = Field(description="the joints of its /joint_states channel (none: no such channel)")
    download: str = Field(description="where to download it (an .mcap, or a .zip of its parts)")
    shot: ShotOf | None = Field(None, description="a capture's shot: which capture and shot, and its trigger row")


class ChannelUse(BaseModel):
    limit: int = Field(description="channels irpd traces at most, for all its owners")
    traced: int
    owners: dict[str, int] = Field(description="channels each owner asks for (agent: the stream, dds, recorder)")


class RecordingList(BaseModel):
    recordings: list[RecordingPublic] = Field(description="oldest first")
    quota_bytes: int
    used_bytes: int
    disk_free_bytes: int
    min_free_bytes: int = Field(description="recordings stop when the disk has less free")
    channels: ChannelUse | None = Field(description="the trace rings' channels (null: irpd unreachable)")

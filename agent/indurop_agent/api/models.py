"""models.py -- the fixed shapes the API answers with (sets, swap reports, events), so that the
OpenAPI description says what comes back.  Shapes that come straight from irpd and may grow
(status, modules, stats) stay plain JSON."""
from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field


class Who(BaseModel):
    id: str | None = Field(description="the token's id (first 12 hex digits of its hash); null for the agent itself")
    name: str
    role: str | None


class SetFile(BaseModel):
    path: str = Field(description="relative to the set's root, e.g. lib/cntr1.so")
    sha256: str
    size: int
    kind: str = Field(description="module_xml, config, thread_module, library, executable, layout, json, glb, "
                                  "urdf, mesh, header or text")


class Validation(BaseModel):
    valid: bool | None = Field(description="irpd's `check` verdict; null when irpd could not check the set")
    errors: list[str] = []
    warnings: list[str] = []
    schedule: dict | None = Field(None, description="the slot table irpd would run, as GET /schedule")


class SetPublic(BaseModel):
    id: str = Field(description="16 hex digits derived from the files' paths and contents")
    created: str
    by: Who | None
    files: list[SetFile]
    validation: Validation
    active: bool = False


class SetSummary(BaseModel):
    id: str
    created: str
    by: Who | None
    files: int
    valid: bool | None
    active: bool


class ActiveSet(SetPublic):
    since: str = Field(description="when it became active")
    action: str = Field(description="how: activate, rollback or restore")
    rollback_to: str | None = Field(description="the set POST /sets/rollback would activate")


class SwapReport(BaseModel):
    """irpd's report of a hot swap (control protocol v2)."""

    model_config = ConfigDict(extra="allow")
    set: str | None = None
    set_id: str | None = None
    generation: int | None = None
    swap_cycle: int | None = Field(None, description="global basic-period count at which the new table took over")
    swap_at_ns: int | None = None
    kept: list[str] = []
    started: list[str] = []
    stopped: list[str] = []
    missed_periods: int | None = Field(None, description="dispatcher periods missed around the swap; the goal is 0")
    request_to_swap_ns: int | None = None
    total_ns: int | None = None


class PatchReport(SwapReport):
    reports: list[SwapReport] = Field(description="one per field applied, in the order period_ns, priority, enabled")


class Event(BaseModel):
    model_config = ConfigDict(extra="allow")
    source: str = Field(description="irpd or agent")
    seq: int
    time: str
    time_ns: int
    kind: str
    module: str | None = None
    message: str


class EventsPage(BaseModel):
    events: list[Event] = Field(description="both sources merged by time")
    next: int = Field(description="irpd's cursor: pass it as ?since= next time")
    agent_next: int = Field(description="the agent's cursor: pass it as ?agent_since= next time")
    dropped: int = Field(description="events lost (pushed out of either ring) before the cursors")
    irpd: str = Field(description="ok, or why irpd's events are missing from this page")

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
    kind: str = Field(description="module_xml, config, thread_module, library, executable, layout, json, robot "
                                  "(robot.json), glb, urdf, mesh, header or text")


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


# --- what the web UI needs beyond the figures irpd gives (host load, histograms, batch changes,
# the 3D view); documented in docs/api.md.

class ProcessLoad(BaseModel):
    pid: int
    cpu: float = Field(description="CPU time used since the previous sample, as a fraction of one CPU (0..n)")
    rss_bytes: int
    threads: int


class CpuLoad(BaseModel):
    cpu: int
    busy: float = Field(description="fraction of the last sampling interval not idle (0..1)")


class HostLoad(BaseModel):
    cpus: list[CpuLoad]
    load_avg: list[float] = Field(description="1, 5 and 15 minute load averages")
    interval_s: float = Field(description="the sampling interval the figures cover")
    irpd: ProcessLoad | None = Field(description="null when irpd does not answer")
    agent: ProcessLoad
    agent_uptime_s: float


class Bucket(BaseModel):
    """One non-empty bucket: values in [low_ns, low_ns + width_ns)."""

    low_ns: float
    width_ns: float
    count: int


class Histogram(BaseModel):
    count: int
    min: float
    max: float
    buckets: list[Bucket] = Field(description="the non-empty buckets, ascending; jitter may have negative ones")


class HistogramRecord(BaseModel):
    name: str
    kind: str = Field(description="dispatcher or module")
    executor: str
    runs: int
    overruns: int
    missed: int
    skipped: int
    errors: int
    jitter_ns: Histogram
    latency_ns: Histogram
    exec_ns: Histogram


class Histograms(BaseModel):
    cycles: int = Field(description="basic periods dispatched so far; the figures are cumulative since start")
    time_ns: int = Field(description="CLOCK_MONOTONIC when read")
    records: list[HistogramRecord]


class ModuleChange(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str
    period_ns: int | None = Field(None, gt=0)
    priority: int | None = Field(None, ge=0, le=1_000_000)
    enabled: bool | None = None


class ModuleChanges(BaseModel):
    model_config = ConfigDict(extra="forbid")
    changes: list[ModuleChange] = Field(min_length=1, max_length=256)
    dry_run: bool = Field(False, description="true: check and show the new slot table, change nothing")


class ChangesReport(BaseModel):
    dry_run: bool
    before: dict = Field(description="the slot table running now, as GET /schedule")
    after: dict = Field(description="the slot table with the changes, as GET /schedule")
    utilization: float = Field(description="estimated busy fraction of the busiest executor with the changes "
                                           "(measured exec p99 of each module over its period)")
    warnings: list[str] = []
    report: SwapReport | None = Field(None, description="irpd's swap report (null for a dry run)")


class JointMap(BaseModel):
    joint: str = Field(description="a movable joint of the URDF")
    variable: str | None = Field(description="the scalar shared variable giving its position; null: held at 0")
    scale: float = 1.0
    offset: float = 0.0


class RobotJoint(JointMap):
    type: str = Field(description="revolute, continuous or prismatic")
    lower: float | None
    upper: float | None


class RobotView(BaseModel):
    available: bool = Field(description="false: no robot in the running set, or the viewer could not start")
    detail: str | None = Field(None, description="why not available")
    viewer: str = Field(description="viser or meshcat (the agent's --viewer)")
    viewer_url: str | None = Field(description="where the embedded 3D view is served (relative to the agent)")
    urdf: str | None = Field(description="the URDF file of the running set")
    joints: list[RobotJoint]
    set_id: str | None = Field(None, description="the running set's id in the store (null: irpd runs a folder the "
                                                 "store does not hold yet; PUT /robot/joints imports it)")


class JointMapUpdate(BaseModel):
    model_config = ConfigDict(extra="forbid")
    joints: list[JointMap] = Field(min_length=1, max_length=64)

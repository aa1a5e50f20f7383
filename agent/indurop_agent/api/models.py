"""models.py -- the shapes the API answers with, so that the OpenAPI description (and the web UI's
generated client) says what comes back: the agent's own (sets, events, host load, errors) and
irpd's answers (status, schedule, modules, stats, histograms, swap reports).  irpd's shapes list
the fields irpd sends and let any others through (extra="allow"), so a newer irpd's additions
reach the client."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictInt

from .. import protocol


class Who(BaseModel):
    id: str | None = Field(description="the token's id (first 12 hex digits of its hash); null for the agent itself")
    name: str
    role: str | None


class SetFile(BaseModel):
    path: str = Field(description="relative to the set's root, e.g. lib/cntr1.so")
    sha256: str
    size: int
    kind: str = Field(
        description="module_xml, config, thread_module, library, executable, layout, json, robot "
        "(robot.json), glb, urdf, mesh, header or text"
    )


class ErrorBody(BaseModel):
    """An error answer: what to fix, and for a refused upload or activation where, when known."""

    detail: str
    file: str | None = Field(None, description="the file of the set it is about, relative to the set's root")
    line: int | None = Field(None, description="from 1")
    column: int | None = Field(None, description="from 1")
    module: str | None = Field(None, description="the module (or executor) it is about")
    field: str | None = Field(None, description="the module.xml element: period, executor, property.restart, ...")


class Problem(BaseModel):
    """One of irpd's validation errors with where it points (the place irpd gives as fields)."""

    message: str
    file: str | None = Field(None, description="relative to the set's root, e.g. module.xml")
    line: int | None = None
    column: int | None = None
    module: str | None = Field(None, description="the module (or executor) it is about")
    field: str | None = Field(None, description="the module.xml element: period, executor, property.restart, ...")


class IrpdShape(BaseModel):
    """An answer from irpd: the fields listed are always there; others a newer irpd adds pass through."""

    model_config = ConfigDict(extra="allow")


class ScheduleSlot(IrpdShape):
    index: int
    offset_ns: int = Field(description="index * basic period")
    modules: list[str] = Field(description="the modules run in this slot, in run order (priority, then file order)")


class ScheduledModule(IrpdShape):
    name: str
    moduletype: str = Field(description="thread or process")
    operationtype: str = Field(description="periodic, sporadic or non-real")
    period_ns: int = Field(description="0 for sporadic and non-real modules")
    deadline_ns: int = Field(description="0 = the period")
    priority: int = Field(description="lowest value = highest priority")
    executor: str
    enabled: bool | None = Field(None, description="false: taken out of dispatch (absent in a stored set's check)")


class Schedule(IrpdShape):
    """The slot table (the paper's Table 3): irpd's `schedule`."""

    basic_period_ns: int = Field(description="GCD of the periods")
    macro_period_ns: int = Field(description="LCM of the periods")
    slots: list[ScheduleSlot]
    modules: list[ScheduledModule] = Field(description="every module of the set, in module.xml order")


class MovedVariable(BaseModel):
    model_config = ConfigDict(populate_by_name=True)
    path: str
    from_: int = Field(alias="from", description="its offset in the running layout")
    to: int = Field(description="its offset in the new one (its type changed)")


class VariableChanges(BaseModel):
    """What a set's layout changes in the running shared variables (docs/hot-reload.md)."""

    layout: str | None = Field(None, description="the new layout's hash")
    added: list[str] = Field([], description="variables the running layout does not have (zeroed before the swap)")
    removed: list[str] = Field(
        [], description="variables the new layout does not have (their room stays a hole until irpd restarts)"
    )
    moved: list[MovedVariable] = Field([], description="variables whose type changed: a new place, zeroed")
    replaced: list[str] = Field(
        [],
        description="running modules built against a layout that has a changed "
        "variable elsewhere: they are loaded anew, not kept",
    )


class RestartNeed(BaseModel):
    model_config = ConfigDict(extra="allow")
    reason: str = Field(description="why irpd cannot take the set online")
    expected_downtime_ns: int | None = Field(
        None,
        description="what the restart is expected to cost: from the last "
        "period of the running set to the first of the new one",
    )


class Validation(BaseModel):
    valid: bool | None = Field(description="irpd's `check` verdict; null when irpd could not check the set")
    errors: list[str] = []
    problems: list[Problem] = Field(
        [], description="`errors` again, each with the file, line and column it names (where it names one)"
    )
    warnings: list[str] = []
    schedule: Schedule | None = Field(None, description="the slot table irpd would run, as GET /schedule")
    online: bool | None = Field(
        None,
        description="whether irpd can take the set by a hot swap (checked against what "
        "ran when it was checked); false: only a restart can run it",
    )
    restart: RestartNeed | None = Field(None, description="when online is false: why, and the expected downtime")
    variables: VariableChanges | None = Field(None, description="the shared variables it adds, removes and moves")


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
    action: str = Field(description="how: activate, restart (activated by a restart of irpd), rollback or restore")
    rollback_to: str | None = Field(description="the set POST /sets/rollback would activate")


class ActivateRequest(BaseModel):
    """How to put a set into irpd (docs/set-store.md, activation modes)."""

    model_config = ConfigDict(extra="forbid")
    mode: Literal["online", "restart", "auto"] = Field(
        "online",
        description="online: a hot swap, refused (409) for a set irpd can run only after a restart; "
        "restart: irpd stops and starts again (same pid) on the set; auto: restart only when "
        "irpd cannot take the set online",
    )


class SwapReport(BaseModel):
    """irpd's report of a hot swap (control protocol v2), or of a managed restart (mode restart)."""

    model_config = ConfigDict(extra="allow")
    mode: Literal["online", "restart"] = Field("online", description="how the set went in: a hot swap or a restart")
    downtime_ns: int | None = Field(
        None,
        description="restart: from the old set's last period to the new one's "
        "first, as irpd measured it; null for a hot swap",
    )
    set: str | None = None
    set_id: str | None = None
    generation: int | None = None
    swap_cycle: int | None = Field(None, description="global basic-period count at which the new table took over")
    swap_at_ns: int | None = None
    basic_period_ns: int | None = None
    macro_period_ns: int | None = None
    kept: list[str] = []
    started: list[str] = []
    stopped: list[str] = []
    missed_periods: int | None = Field(None, description="dispatcher periods missed around the swap; the goal is 0")
    variables: VariableChanges | None = Field(None, description="the shared variables the swap added, removed, moved")
    request_to_swap_ns: int | None = None
    total_ns: int | None = None


class SharedMemory(IrpdShape):
    stats: str = Field(description="the stats block's shm name")
    variables: str | None = Field(description="the shared variables' shm name; null: the set has none")
    trace: str | None = Field(None, description="the trace rings' shm name")


class Status(IrpdShape):
    """irpd's `status`."""

    set: str = Field(description="the running module.xml")
    set_id: str | None = Field(description="the stored set's id given at activation; null otherwise")
    generation: int = Field(description="1 + hot swaps since irpd started")
    running: bool
    realtime: bool = Field(description="false: the dispatchers run SCHED_OTHER; periods are not guaranteed")
    pid: int = Field(description="irpd's process id")
    basic_period_ns: int
    macro_period_ns: int
    min_basic_period_ns: int | None = Field(
        None, description="the shortest basic period irpd accepts (a set or change below it is refused)"
    )
    uptime_ns: int
    cycles: int = Field(description="basic periods dispatched")
    modules: int = Field(description="how many modules the set has")
    overruns: int
    missed: int
    skipped: int
    caught_up: int
    events: int = Field(description="the last event's seq")
    stopped_by_fault: str | None = Field(
        None, description="null, or why a fault stopped the set (an overrun with on_overrun=stop): docs/faults.md"
    )
    last_crash: dict[str, Any] | None = Field(
        None,
        description="the crash record irpd took in at start (signal, "
        "module, executor, set, time, cause: fault, abort, "
        "watchdog or signal, sender_pid...), or null: "
        "docs/supervision.md",
    )
    left_out_after_crash: list[dict[str, Any]] = Field([], description="modules a crash left out ({module, set})")
    last_restart: dict[str, Any] | None = Field(
        None,
        description="the managed restart this irpd came from "
        "({from_set_id, set_id, downtime_ns, requested_ns, fell_back, error}), "
        "or null",
    )
    shared_memory: SharedMemory


class Figures(BaseModel):
    """A distribution summarized (ns): min, max, mean and percentiles, from the histograms."""

    model_config = ConfigDict(extra="allow")
    count: int
    min: float
    max: float
    mean: float
    p50: float
    p99: float
    p999: float


class TimingRecord(IrpdShape):
    """A dispatcher's or a module's figures (irpd's stats record)."""

    name: str
    executor: str
    kind: str = Field(description="dispatcher or module")
    period_ns: int = Field(description="the module's period, or the basic period for a dispatcher")
    runs: int
    jitter_ns: Figures = Field(description="Eq. (1): planned start minus actual start (may be negative)")
    latency_ns: Figures = Field(description="start (wake-up for a dispatcher) minus its planned time")
    exec_ns: Figures = Field(description="execution time")
    overruns: int
    missed: int
    skipped: int
    errors: int
    caught_up: int | None = Field(None, description="dispatchers only")
    state: str | None = Field(None, description="modules only: loaded, running, disabled, skipped, stopped, exited")
    priority: int | None = Field(None, description="modules only")
    budget_ns: int | None = Field(None, description="modules only; 0 = none")


class Stats(IrpdShape):
    """irpd's `stats`: every dispatcher and module record."""

    cycles: int
    executors: list[TimingRecord] = Field(description="the dispatchers' records, the main one first")
    modules: list[TimingRecord]


class ModuleInfo(TimingRecord):
    """One module of the running set: its figures, its module.xml entry and its state."""

    state: str = Field(description="loaded, running, disabled, skipped, stopped or exited")
    priority: int
    budget_ns: int
    moduletype: str
    operationtype: str
    deadline_ns: int
    enabled: bool
    file: str
    sha256: str
    properties: dict[str, str]


class Health(BaseModel):
    agent: str = Field(description="ok")
    version: str
    irpd: str = Field(description="ok or unreachable")
    running: bool | None = Field(None, description="irpd's dispatchers run (when irpd answers)")
    detail: str | None = Field(None, description="why irpd is unreachable")


class VariableInfo(BaseModel):
    path: str
    type: str
    size: int


class VariableList(BaseModel):
    layout_hash: str
    variables: list[VariableInfo]


class VariableWritten(BaseModel):
    path: str
    value: StrictBool | StrictInt | float = Field(description="as irpd stored it (checked against the type)")


class VariableValue(VariableWritten):
    layout_hash: str = Field(description="the layout the value was read with")


class LeafValue(BaseModel):
    path: str = Field(description="the leaf's full path, e.g. PLC_ROBOT.IO_STATUS.errors[0]")
    type: str = Field(description="its scalar type, as GET /variables gives it")
    value: StrictBool | StrictInt | float


class GroupValue(BaseModel):
    """The answer for a group's path (a namespace, a struct, an array or one of its elements)."""

    path: str = Field(description="the group asked for, e.g. PLC_ROBOT.IO_STATUS or joint[1]")
    values: list[LeafValue] = Field(
        description="every leaf under it, in layout order; the leaves of one variable are read together, from one write"
    )
    layout_hash: str = Field(description="the layout the values were read with")


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
    model_config = ConfigDict(extra="allow")
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
    model_config = ConfigDict(extra="allow")
    cycles: int = Field(description="basic periods dispatched so far; the figures are cumulative since start")
    time_ns: int = Field(description="CLOCK_MONOTONIC when read")
    records: list[HistogramRecord]


class ModuleChange(protocol.ModuleValues):
    """One module's new values (irpd's `change` entry, with the module as `name`): the types and
    ranges are protocol/control.json's; irpd checks the rest (a module named twice, one it lacks)."""

    name: protocol.Module


class ModuleChanges(BaseModel):
    model_config = ConfigDict(extra="forbid")
    changes: list[ModuleChange] = Field(min_length=1, max_length=protocol.MAX_CHANGES)
    dry_run: bool = Field(False, description="true: check and show the new slot table, change nothing")


class ChangesReport(BaseModel):
    dry_run: bool
    before: Schedule = Field(description="the slot table running before the changes, as GET /schedule")
    after: Schedule = Field(description="the slot table with the changes, as GET /schedule")
    utilization: float = Field(
        description="estimated busy fraction of the busiest executor with the changes "
        "(measured exec p99 of each module, or its <budget> when larger, "
        "over its period); irpd refuses above 1"
    )
    executors: dict[str, float] = Field({}, description="the same estimate per executor (main and every <executor>)")
    warnings: list[str] = Field(
        [],
        description="what may not be meant: a new basic or macro period, modules "
        "sharing a priority on one executor, an executor above 80 %, a "
        "module whose file changed and is loaded anew",
    )
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
    set_id: str | None = Field(
        None,
        description="the running set's id in the store (null: irpd runs a folder the "
        "store does not hold yet; PUT /robot/joints imports it)",
    )


class JointMapUpdate(BaseModel):
    model_config = ConfigDict(extra="forbid")
    joints: list[JointMap] = Field(min_length=1, max_length=64)

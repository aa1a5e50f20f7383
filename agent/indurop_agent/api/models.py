"""models.py -- the shapes the API answers with, so that the OpenAPI description (and the web UI's
generated client) says what comes back: the agent's own (sets, events, host load, errors), and
what the agent makes of irpd's answers where it passes on more or other than irpd sent (an
activation's report, histograms with their buckets as objects, a change's report).  irpd's
answers themselves are the models protocol.py generates from protocol/control.json (Status,
Schedule, ModuleInfo, Stats, ...): they list the fields irpd sends and let any others through
(extra="allow"), so a newer irpd's additions reach the client."""

from __future__ import annotations

from typing import Annotated, Any, Literal, get_origin

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, StrictBool, StrictInt, create_model, model_validator

from ..access.sessions import CSRF_HEADER
from ..access.users import NAME_PATTERN, PASSWORD_MAX, PASSWORD_MIN, name_problem
from ..irpd import protocol

Role = Literal["viewer", "operator", "admin"]


class Who(BaseModel):
    id: str | None = Field(
        description="the token's id (first 12 hex digits of its hash) or the session's handle; null for the agent itself"
    )
    name: str = Field(description="the token's name, or the signed-in user's")
    role: str | None
    user: str | None = Field(None, description="the user behind it (a session's, a token's owner); null: the appliance")
    via: Literal["token", "session", "opcua"] | None = Field(
        None, description="how the request was signed in (opcua: a session of the OPC UA server, docs/opcua.md)"
    )


class SetFile(BaseModel):
    path: str = Field(description="relative to the set's root, e.g. lib/cntr1.so")
    sha256: str
    size: int
    kind: str = Field(
        description="module_xml, config, thread_module, library, executable, layout, json, robot "
        "(robot.json), bridge (dds.json), glb, urdf, mesh, header, text, st (Structured Text source) or "
        "plcopen (a PLCopen XML project, docs/plcopen-xml.md)"
    )


class Problem(protocol.Place):
    """One of irpd's validation errors, or of the ST compiler's, with where it points (the file
    relative to the set's root)."""

    message: str
    file: str | None = Field(None, description="relative to the set's root, e.g. module.xml, main.st")
    code: str | None = Field(
        None, description="the ST compiler's error code (docs/st.md, Errors): `type`, `syntax`, ..."
    )
    origin: str | None = Field(
        None,
        description="for an error in a PLCopen XML file's drawn body: the element, e.g. "
        "`main (LD) rung 4, contact localId 17` (docs/plcopen-xml.md)",
    )


class ErrorBody(protocol.Place):
    """An error answer: what to fix, and for a refused upload or activation where, when known (the
    place irpd gives, with the file relative to the set's root)."""

    detail: str
    file: str | None = Field(None, description="the file of the set it is about, relative to the set's root")
    problems: list[Problem] | None = Field(
        None,
        description="every error when there are several (an upload's ST compile errors); the place above is the first's",
    )


RestartNeed = protocol.RestartNeed


class Validation(BaseModel):
    valid: bool | None = Field(description="irpd's `check` verdict; null when irpd could not check the set")
    errors: list[str] = []
    problems: list[Problem] = Field(
        [], description="`errors` again, each with its place: file, line, column, module and field (those known)"
    )
    warnings: list[str] = []
    schedule: protocol.Schedule | None = Field(None, description="the slot table irpd would run, as GET /schedule")
    online: bool | None = Field(
        None,
        description="whether irpd can take the set by a hot swap (checked against what "
        "ran when it was checked); false: only a restart can run it",
    )
    restart: RestartNeed | None = Field(None, description="when online is false: why, and the expected downtime")
    variables: protocol.VariableChanges | None = Field(
        None, description="the shared variables it adds, removes and moves"
    )
    modules: protocol.ModuleFates | None = Field(
        None,
        description="what activating it online would do to the running modules: kept, started, stopped, "
        "and replaced (the running instance stops, a new one starts afresh); null when it cannot go online",
    )


class DerivedFrom(BaseModel):
    """A set made from another with one file changed (POST /programs/apply)."""

    set_id: str = Field(description="the set it was made from")
    path: str = Field(description="the file that changed, e.g. main.st")


class SetPublic(BaseModel):
    id: str = Field(description="16 hex digits derived from the files' paths and contents")
    created: str
    by: Who | None
    files: list[SetFile]
    validation: Validation
    active: bool = False
    derived_from: DerivedFrom | None = Field(
        None, description="the set this one was made from by an edit, and the file"
    )


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


def _each_optional(model: type[BaseModel]) -> dict[str, Any]:
    """`model`'s fields as create_model takes them, each optional: an empty list, or null, when absent."""
    fields = {}
    for name, f in model.model_fields.items():
        listed = get_origin(f.annotation) is list
        fields[name] = (
            f.annotation if listed else f.annotation | None,
            Field([] if listed else None, alias=f.alias, description=f.description),
        )
    return fields


SwapReport = create_model(
    "SwapReport",
    __base__=protocol.IrpdShape,
    __doc__="irpd's report of a hot swap (the control protocol's swap_report), or of a managed restart "
    "(mode restart): a restart's report has what irpd's status tells after it (set, set_id, generation, "
    "the periods) and downtime_ns, its other fields empty or null.",
    mode=(Literal["online", "restart"], Field("online", description="how the set went in: a hot swap or a restart")),
    downtime_ns=(
        int | None,
        Field(
            None,
            description="restart: from the old set's last period to the new one's first, as irpd measured it; "
            "null for a hot swap",
        ),
    ),
    **_each_optional(protocol.SwapReport),
)


class Health(BaseModel):
    agent: str = Field(description="ok")
    version: str
    irpd: str = Field(description="ok or unreachable")
    running: bool | None = Field(None, description="irpd's dispatchers run (when irpd answers)")
    detail: str | None = Field(None, description="why irpd is unreachable")


class VariableInfo(BaseModel):
    path: str
    type: str = Field(description="the C++ scalar type (layout.json's)")
    size: int
    iec_type: str | None = Field(
        None,
        description="the IEC 61131-3 type of a Structured Text variable (TIME, STRING[20], INT ...); null for .glb ones",
    )
    forced: bool = Field(False, description="irpd holds it forced (docs/forcing.md; GET /forces says by whom)")


class VariableList(BaseModel):
    layout_hash: str
    variables: list[VariableInfo]


class VariableValue(protocol.VariableWritten):
    layout_hash: str = Field(description="the layout the value was read with")
    forced: bool = Field(False, description="irpd holds it forced: `value` is the forced value")


class LeafValue(BaseModel):
    path: str = Field(description="the leaf's full path, e.g. PLC_ROBOT.IO_STATUS.errors[0]")
    type: str = Field(description="its scalar type, as GET /variables gives it")
    value: StrictBool | StrictInt | float | None = Field(
        description="null: a float that is not finite (NaN, infinity), which JSON has no number for"
    )
    forced: bool = Field(False, description="irpd holds it forced")


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


class Histogram(protocol.Histogram):
    """irpd's histogram with each bucket an object (irpd sends [low, width, count])."""

    buckets: list[Bucket] = Field(description="the non-empty buckets, ascending; jitter may have negative ones")


class HistogramRecord(protocol.HistogramRecord):
    jitter_ns: Histogram
    latency_ns: Histogram
    exec_ns: Histogram


class Histograms(protocol.Histograms):
    """irpd's `histograms`, each bucket an object."""

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
    before: protocol.Schedule = Field(description="the slot table running before the changes, as GET /schedule")
    after: protocol.Schedule = Field(description="the slot table with the changes, as GET /schedule")
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


# --- alarms (docs/alarms.md): the agent's alarm manager, agent/indurop_agent/alarms/.

Severity = Literal["low", "medium", "high", "critical"]
AlarmState = Literal["normal", "active_unacknowledged", "active_acknowledged", "cleared_unacknowledged", "shelved"]
AlarmEvent = Literal["raise", "clear", "acknowledge", "confirm", "shelve", "unshelve", "shelve_expired", "flood"]
SHELVE_MAX_MINUTES = 7 * 24 * 60
SHELVE_REASON_MAX = 200


class AlarmPublic(BaseModel):
    key: str = Field(description="<module>/<id>: PLC/8, iodispat/101, cntr1/overruns, agent/irpd_unreachable")
    module: str = Field(description="the module that raised it; irpd and agent for the platform's own")
    id: str = Field(description="1 .. 1023 for a module's alarms; a word for the system alarms the agent raises")
    origin: Literal["module", "system"] = Field(
        description="module: from irpd's alarm segment; system: raised by the agent from irpd's events and status"
    )
    state: AlarmState = Field(description="shelved over any other")
    condition: AlarmState = Field(description="the state without the shelf")
    severity: Severity
    text: str = Field(description="the declared text (module.xml <alarm>, irp::declareAlarm)")
    detail: str = Field(description="the last raise's detail text")
    value: float = Field(description="the number that came with the last raise (an error count, an error code)")
    flags: list[str] = Field(description="undeclared (the id was not declared), truncated (the detail was cut)")
    active: bool
    acknowledged: bool
    raises: int = Field(description="raises since it was last normal")
    changed: str | None = Field(description="the last transition (ISO 8601 UTC)")
    changed_ns: int
    raised: str | None
    cleared: str | None
    acknowledged_at: str | None
    acknowledged_by: Who | None
    confirmed: bool = Field(
        True,
        description="confirmed after its acknowledgement (OPC UA's Confirm, POST .../confirm); false from a raise on",
    )
    confirmed_at: str | None = None
    confirmed_by: Who | None = None
    shelved_at: str | None
    shelved_until: str | None
    shelved_by: Who | None
    shelve_reason: str | None


class AlarmCounts(BaseModel):
    active: int = Field(description="active alarms, not shelved")
    unacknowledged: int = Field(description="alarms not acknowledged (active or cleared), not shelved")
    shelved: int
    highest: Severity | None = Field(description="the highest severity of the alarms counted above")


class AlarmSourceCounters(BaseModel):
    source: int
    module: str
    generation: int
    recorded: int
    rate_dropped: int = Field(description="transitions over the rate limit: not recorded, the bitmap still changed")
    undeclared: int
    bad_ids: int
    truncated: int
    collided: int = Field(0, description="records not written: their ring slot was taken; the bitmap still changed")


class AlarmSegmentStatus(BaseModel):
    name: str | None = Field(description="the alarm segment's shm name, as irpd's status names it")
    error: str | None = Field(description="why it is not read, or null")
    lost: int = Field(0, description="records overwritten before the agent read them (then it reconciles)")
    abandoned: int = Field(0, description="records skipped: their writer stopped in the middle")
    suppressed: int = Field(0, description="transitions not recorded one by one in the history: floods")
    capacity: int | None = None
    rate_limit: int | None = None
    declarations: str | None = Field(None, description="ok, or why irpd's texts and severities were not read")
    sources: list[AlarmSourceCounters] = []


class AlarmList(BaseModel):
    alarms: list[AlarmPublic] = Field(
        description="every alarm that is not normal, or shelved: unacknowledged first, then by severity, newest first"
    )
    counts: AlarmCounts
    newest: AlarmPublic | None = Field(description="the alarm raised last among those not shelved")
    segment: AlarmSegmentStatus


class AlarmTransition(BaseModel):
    seq: int = Field(description="increasing for good: ?after= gives the newer ones")
    time: str
    time_ns: int
    key: str
    module: str
    id: str
    event: AlarmEvent
    state: AlarmState | Literal[""] = Field(description="the alarm's state after it (empty for a flood row)")
    severity: Severity | Literal[""]
    text: str
    detail: str
    value: float
    who: Who | None = Field(description="who acknowledged, confirmed, shelved or unshelved it")
    note: str = Field(
        description="why, when the agent made the transition (reconciliation, irpd restarted, ...); an OPC UA "
        "Acknowledge's or Confirm's comment"
    )
    flags: list[str]
    count: int = Field(description="1; for a flood row, the transitions it stands for")


class AlarmHistory(BaseModel):
    transitions: list[AlarmTransition] = Field(description="newest first")
    total: int = Field(description="how many match the filters")
    offset: int
    limit: int


class AckAll(BaseModel):
    model_config = ConfigDict(extra="forbid")
    module: str | None = Field(None, description="only this module's alarms")


class AckAnswer(BaseModel):
    acknowledged: list[str] = Field(description="the keys acknowledged")
    counts: AlarmCounts


class ShelveRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    minutes: float = Field(gt=0, le=SHELVE_MAX_MINUTES, description="how long; it comes back when the time is up")
    reason: str = Field(min_length=1, max_length=SHELVE_REASON_MAX, description="why, for the history")


# ---- users and sessions (docs/administration.md) ----------------------------------------------------
def _user_name(value: str) -> str:
    problem = name_problem(value)
    if problem:
        raise ValueError(problem)
    return value


UserName = Annotated[
    str,
    AfterValidator(_user_name),
    Field(json_schema_extra={"pattern": NAME_PATTERN, "minLength": 2, "maxLength": 32}),
]
NewPassword = Annotated[
    str,
    Field(
        max_length=PASSWORD_MAX,
        description=f"{PASSWORD_MIN} to {PASSWORD_MAX} characters, no control characters, not containing the user "
        "name (in any case), not the present password",
        json_schema_extra={"minLength": PASSWORD_MIN},
    ),
]


class SignIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str = Field(min_length=1, max_length=256, description="the user name")
    password: str = Field(min_length=1, max_length=PASSWORD_MAX)


class SessionState(BaseModel):
    """The browser's session (GET /session, and the answer to a sign-in)."""

    signed_in: bool
    first_run: bool = Field(
        description="no user exists yet: the first admin is created with the admin token the agent wrote at its "
        "first start (POST /users, or `irpctl user add NAME --role admin`)"
    )
    name: str | None = None
    role: Role | None = None
    csrf_token: str | None = Field(
        None, description=f"send it in the {CSRF_HEADER} header with every change (POST, PUT, PATCH, DELETE)"
    )
    csrf_header: str = CSRF_HEADER
    idle_timeout_s: float = Field(description="a session without a request of its user for this long ends")
    expires: str | None = Field(None, description="when the session ends whatever happens (ISO 8601, UTC)")


class UserCreate(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: UserName
    role: Role
    password: NewPassword


class UserUpdate(BaseModel):
    """An admin's change of a user: the role, or disabled (which revokes their tokens and ends their
    sessions) or enabled again."""

    model_config = ConfigDict(extra="forbid")
    role: Role | None = None
    disabled: StrictBool | None = None

    @model_validator(mode="after")
    def _something(self):
        if self.role is None and self.disabled is None:
            raise ValueError('give "role", "disabled" or both')
        return self


class PasswordChange(BaseModel):
    """A new password: a user's own (with `current_password`), or an admin's reset of another's."""

    model_config = ConfigDict(extra="forbid")
    password: NewPassword
    current_password: str | None = Field(
        None, max_length=PASSWORD_MAX, description="the present password: needed to change one's own"
    )


class UserPublic(BaseModel):
    name: str
    role: Role
    disabled: bool
    created: str
    created_by: str | None = Field(description="who created the user (a user's name, or the token's)")
    last_sign_in: str | None
    password_changed: str
    tokens: int = Field(description="the user's tokens (GET /users/{name}/tokens)")
    sessions: int = Field(description="the user's live browser sessions")


# ---- the System page (routes/system.py, docs/administration.md) ---------------------------------
class AgentInfo(BaseModel):
    version: str
    pid: int
    started: str = Field(description="when this agent process started (UTC)")
    uptime_s: float
    python: str
    supervisor: str | None = Field(
        description="what starts the agent again after POST /system/restart/agent: systemd, demo, or null (nothing: "
        "the restart is refused)"
    )
    scheme: Literal["http", "https"]
    host: str
    port: int


class IrpdInfo(BaseModel):
    reachable: bool
    detail: str | None = Field(None, description="why irpd does not answer")
    version: str | None = Field(None, description="irpd's version, from its control socket's hello")
    protocol: int | None = Field(None, description="the control protocol's version irpd speaks")
    pid: int | None = None
    uptime_s: float | None = Field(None, description="since irpd's process (or its last managed restart) started")
    set_id: str | None = None
    running: bool | None = None


class DiskPart(BaseModel):
    name: str = Field(description="an entry of the data folder: blobs, sets, audit.jsonl, alarms.sqlite3, ...")
    bytes: int


class DataFolder(BaseModel):
    path: str
    used_bytes: int = Field(description="allocated on disk, each file once (a set's tree shares its blobs' inodes)")
    parts: list[DiskPart] = Field(description="by entry of the data folder, largest first")
    complete: bool = Field(description="false: the folder has more files than are counted")
    filesystem_bytes: int
    free_bytes: int


class TlsCertificate(BaseModel):
    path: str = Field(description="the PEM file served")
    error: str | None = Field(None, description="why it cannot be read (the other fields are then absent)")
    fingerprint_sha256: str | None = Field(None, description="as browsers show it: AB:CD:... (32 bytes)")
    subject: str | None = None
    issuer: str | None = None
    self_signed: bool | None = None
    names: list[str] = Field([], description="the host names and addresses it is valid for")
    not_before: str | None = None
    not_after: str | None = None
    days_left: int | None = Field(None, description="until not_after; negative once expired")


class LogSources(BaseModel):
    irpd: str | None = Field(description="where irpd's log is read from (a file, or the journal's unit); null: nowhere")
    agent: str | None


class SystemInfo(BaseModel):
    agent: AgentInfo
    irpd: IrpdInfo
    data: DataFolder
    tls: TlsCertificate | None = Field(description="the certificate served; null when the agent serves plain HTTP")
    logs: LogSources
    restore_pending: bool = Field(description="a restore is staged and is applied when the agent starts again")


class IrpdRestartReport(BaseModel):
    """irpd's managed restart onto the active set (docs/hot-reload.md): the same process, outputs
    driven to safe values first."""

    model_config = ConfigDict(extra="allow")
    mode: Literal["restart"] = "restart"
    set_id: str | None = Field(description="the set irpd runs after it")
    pid: int | None = Field(description="irpd's pid, the same before and after")
    downtime_ns: int | None = Field(description="from the last period before to the first after, as irpd measured it")
    generation: int | None = None
    expected_downtime_ns: int | None = None


class AgentRestart(BaseModel):
    restarting: bool
    supervisor: str = Field(description="what starts it again: systemd or demo")
    detail: str


class LogLine(BaseModel):
    log: Literal["irpd", "agent"]
    time: str | None = Field(description="UTC, ISO 8601; null when the source gives none")
    message: str = Field(description="the line as written (cut after 8192 characters, saying so)")
    pid: int | None = Field(None, description="the writing process (journal only)")
    priority: int | None = Field(None, description="syslog priority 0 (emergency) .. 7 (debug) (journal only)")


class LogPage(BaseModel):
    log: Literal["irpd", "agent"]
    source: str = Field(description="where it was read: a file, or the journal's unit")
    lines: list[LogLine] = Field(description="oldest first: the last `lines` lines that match")
    truncated: bool = Field(description="the file is larger than what was scanned: older lines are not searched")


class BackupArchive(BaseModel):
    created: str | None
    agent_version: str | None
    host: str | None
    with_secrets: bool
    files: int
    bytes: int = Field(description="the unpacked size")


class RestoreSets(BaseModel):
    added: list[str] = Field(description="in the backup, not stored here: added")
    present: list[str] = Field(description="in the backup and stored here already (same content): kept")
    kept: list[str] = Field(description="stored here only: kept (a restore deletes no set)")


class BeforeAfterSet(BaseModel):
    now: str | None
    after: str | None


class BeforeAfterCount(BaseModel):
    now: int | None = Field(description="null: there is no such file here")
    after: int | None


class RestoreFile(BaseModel):
    path: str = Field(description="in the data folder")
    action: Literal["add", "replace", "remove"] = Field(
        description="remove: a file the restore moves aside without a replacement (an OPC UA client certificate "
        "the backup's trust list lacks)"
    )
    what: str


class RestorePlan(BaseModel):
    """What a restore does (its dry run), or did stage (then the agent restarts to apply it)."""

    dry_run: bool
    archive: BackupArchive
    sets: RestoreSets
    active_set: BeforeAfterSet
    tokens: BeforeAfterCount
    users: BeforeAfterCount
    audit_lines: BeforeAfterCount
    files: list[RestoreFile] = Field(description="the data folder's files the backup adds or replaces")
    warnings: list[str]
    restarting: bool = Field(
        False, description="the restore is staged and the agent restarts now to apply it (false: at its next start)"
    )


class TlsUpload(BaseModel):
    model_config = ConfigDict(extra="forbid")
    certificate: str = Field(
        min_length=1, description="PEM: the server's certificate first, then any intermediate ones"
    )
    key: str = Field(min_length=1, description="PEM: its private key, not encrypted")


class TlsInstalled(BaseModel):
    certificate: TlsCertificate
    restarting: bool = Field(description="the agent restarts now to serve it (false: at its next start)")


class PruneRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    keep_last: StrictInt = Field(ge=0, le=1_000_000, description="how many of the newest sets to keep")
    dry_run: StrictBool = Field(False, description="true: only say what would be deleted")


class PrunedSet(BaseModel):
    id: str
    created: str
    by: Who | None
    files: int


class PrunedBlob(BaseModel):
    sha256: str
    size: int


class PruneReport(BaseModel):
    deleted: list[PrunedSet] = Field(description="the sets deleted (or, in a dry run, that would be)")
    kept: list[str] = Field(description="the sets kept: the newest keep_last, the active set and the rollback target")
    blobs: list[PrunedBlob] = Field(description="the stored files no kept set uses, deleted with them")
    bytes: int = Field(description="what the deleted blobs held")
    dry_run: bool

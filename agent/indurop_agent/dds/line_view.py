"""line_view.py -- the view of the line that the DDS bridge hands to its agent (docs/dds.md "The
line"): a JSON file the bridge replaces every announcement period, its shape (LineFile), and what
the agent makes of it for GET /line and irpctl line (LineView: each controller's state and link,
and whether the bridge is there at all).  No DDS here: the agent owns no participant."""

from __future__ import annotations

import json
import os
import tempfile
import time
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, Field, ValidationError

FORMAT = 1
# The file is older than this many of its own periods (and at least STALE_MIN_S): the bridge is
# not writing it any more (stopped, killed, stuck).
STALE_PERIODS = 3
STALE_MIN_S = 5.0
SEVERITIES = ("low", "medium", "high", "critical")
State = Literal["ok", "warning", "fault", "lost"]


class LineAlarm(BaseModel):
    source: str = Field(description="the module that raised it, or irpd")
    id: int
    severity: str = Field(description="low, medium, high or critical")
    text: str


class LineEntry(BaseModel):
    """One controller as the bridge last heard it (the file's entries)."""

    name: str = Field(description="the controller's name on the domain (its bridge's --name)")
    agent_url: str = Field(description="its agent, where its web UI is; empty when it did not say")
    version: str
    set_name: str = Field(description="the running module.xml, as folder/file")
    set_id: str = Field(description="the stored set's id; empty when irpd was not started from the store")
    layout_hash: str = Field(description="the shared-variable layout's hash; empty when unknown")
    health: Literal["running", "stopped", "fault", "irpd_unreachable"]
    health_detail: str = Field(description="why: the fault's reason, irpd's error; empty when running")
    basic_period_ns: int
    jitter_p99_ns: int | None = Field(
        description="the main dispatcher's wake-up jitter: its wake-up latency (woke - due), 99th percentile "
        "over the last 10 s; null when unknown"
    )
    alarms_active: int
    alarms: list[LineAlarm] = Field(description="the most severe active alarms, at most 5")
    uptime_ns: int = Field(description="irpd's")
    period_s: float = Field(description="how often it announces itself")
    lease_s: float = Field(description="its liveliness lease: lost when nothing keeps it alive for this long")
    alive: bool = Field(description="false: its announcements stopped (no writer left, or silent for a lease)")
    last_seen: float = Field(description="when its last announcement arrived (Unix time, this controller's clock)")
    lost_since: float | None = Field(None, description="when it was found lost (Unix time); null while alive")
    lost_reason: str = ""
    duplicate: bool = Field(False, description="more than one controller announces this name")


class LineFile(BaseModel):
    """What the bridge writes (line_file): every controller it sees on the domain, itself included."""

    format: int
    written: float = Field(description="Unix time")
    period_s: float
    name: str = Field(description="the name this bridge announces")
    domain_id: int
    interface: str
    ignored: int = Field(0, description="announcements not listed: not a controller's name, or more names than 256")
    controllers: list[LineEntry]


class LineController(LineEntry):
    state: State = Field(
        description="ok; warning (set stopped, alarms active, name announced twice); "
        "fault (irpd faulted or unreachable, a critical alarm); lost (its announcements stopped)"
    )
    reasons: list[str] = Field(description="why it is not ok, in words")
    this: bool = Field(description="this agent's own controller")
    age_s: float = Field(description="seconds since its last announcement arrived")


class LineView(BaseModel):
    """GET /line: the controllers this controller's DDS bridge sees on its domain."""

    bridge: Literal["ok", "off", "stale", "unreadable"] = Field(
        description="ok; off (no view: the bridge does not run or has no line file); stale (the bridge "
        "stopped writing it); unreadable (not a view this agent reads)"
    )
    message: str = Field(description="what the bridge state means, in words; empty when ok")
    this: str | None = Field(description="the name this controller announces")
    domain_id: int | None
    interface: str | None
    age_s: float | None = Field(description="seconds since the bridge wrote the view")
    period_s: float | None
    ignored: int = Field(0, description="announcements the bridge did not list (a bad name, or over 256 names)")
    controllers: list[LineController] = Field(description="sorted by name; empty unless bridge is ok")


def state_of(e: LineEntry) -> tuple[State, list[str]]:
    """A controller's state on the line, and the reasons for it."""
    if not e.alive:
        return "lost", [e.lost_reason or "its announcements stopped"]
    faults, warnings = [], []
    if e.health == "fault":
        faults.append(f"faulted: {e.health_detail}" if e.health_detail else "faulted")
    elif e.health == "irpd_unreachable":
        faults.append(f"irpd unreachable: {e.health_detail}" if e.health_detail else "irpd unreachable")
    elif e.health == "stopped":
        warnings.append("the set is not running")
    critical = [a for a in e.alarms if a.severity == "critical"]
    if critical:
        faults.append(f"critical alarm {critical[0].source}/{critical[0].id}: {critical[0].text}")
    if e.alarms_active and not critical:
        top = max((a.severity for a in e.alarms), key=_rank, default="")
        warnings.append(f"{e.alarms_active} alarm(s) active" + (f", the highest {top}" if top else ""))
    if e.duplicate:
        warnings.append(f"more than one controller announces the name {e.name!r}")
    if faults:
        return "fault", faults + warnings
    return ("warning", warnings) if warnings else ("ok", [])


def _rank(severity: str) -> int:
    return SEVERITIES.index(severity) if severity in SEVERITIES else -1


def write_view(path: Path, view: LineFile) -> None:
    """Replaces `path` with `view`: a temporary file beside it, renamed over it (a reader sees the old
    view or the new one).  Not fsync'ed: it is rewritten every period and means nothing after a boot."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    try:
        os.fchmod(fd, 0o640)
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(view.model_dump_json())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def read_view(path: Path, now: float | None = None) -> LineView:
    """The line as `path` holds it, each controller with its state; says so when the bridge is off."""
    now = time.time() if now is None else now
    empty = {"this": None, "domain_id": None, "interface": None, "age_s": None, "period_s": None, "controllers": []}
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        return LineView(
            bridge="off",
            message=f"the DDS bridge is not running: it has not written the line's view ({path}). Start it "
            "(indurop-dds-bridge.service, or packaging/demo.sh) with --line-file to see the line.",
            **empty,
        )
    except OSError as e:
        return LineView(bridge="unreadable", message=f"the line's view {path} cannot be read: {e}", **empty)
    try:
        view = LineFile.model_validate(json.loads(raw))
    except (ValueError, ValidationError) as e:
        return LineView(
            bridge="unreadable",
            message=f"the line's view {path} is not one this agent reads (a bridge of another version?): "
            f"{str(e).splitlines()[0]}",
            **empty,
        )
    age = max(0.0, now - view.written)
    head = {
        "this": view.name,
        "domain_id": view.domain_id,
        "interface": view.interface,
        "age_s": round(age, 3),
        "period_s": view.period_s,
        "ignored": view.ignored,
    }
    if view.format != FORMAT:
        return LineView(
            bridge="unreadable",
            message=f"the line's view {path} has format {view.format}; this agent reads {FORMAT}",
            **{**head, "controllers": []},
        )
    if age > max(STALE_PERIODS * view.period_s, STALE_MIN_S):
        return LineView(
            bridge="stale",
            message=f"the DDS bridge last wrote the line's view {age:.0f} s ago: it is not running (stopped or "
            "killed) or is stuck; the line is not known",
            **{**head, "controllers": []},
        )
    controllers = []
    for e in sorted(view.controllers, key=lambda c: c.name):
        state, reasons = state_of(e)
        controllers.append(
            LineController(
                **e.model_dump(),
                state=state,
                reasons=reasons,
                this=e.name == view.name,
                age_s=round(max(0.0, now - e.last_seen), 3),
            )
        )
    return LineView(bridge="ok", message="", **head, controllers=controllers)

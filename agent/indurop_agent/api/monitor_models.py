"""monitor_models.py -- the shapes of live values read many at a time: POST /variables/read (the Watch
page, the bench), POST /programs/monitor (the values inline in the ST editor and the conditions it
shows) and the watch lists kept with a set (docs/programming.md "Monitoring" and "Watch lists")."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from ..recorder.store import NAME_RULE
from .models import LeafValue, Who

MAX_READ_PATHS = 1000  # paths one POST /variables/read or one watch list may name
MAX_EXPANDED = 32  # FB instances / structs one monitor request may expand
MAX_WATCHES = 100  # watch lists per set
MAX_WATCH_BYTES = 256 << 10  # one watch list's file


class ReadRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    paths: list[str] = Field(
        max_length=MAX_READ_PATHS, description=f"leaf paths, at most {MAX_READ_PATHS}, e.g. PLC_ROBOT.I0"
    )


class PathError(BaseModel):
    path: str
    message: str = Field(description="why it was not read: no such variable (the nearest names), a group, a type")


class ReadAnswer(BaseModel):
    """The values of one pass over the shared memory: the leaves of one variable are from one write."""

    layout_hash: str = Field(description="the layout the values were read with")
    values: list[LeafValue] = Field(description="the paths read, in the order asked")
    errors: list[PathError] = Field(description="the paths that were not read, and why")


class MonitorRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    set: str | None = Field(None, description="the set (default: the active one); values are the running ones")
    path: str = Field(description="the .st file, e.g. main.st")
    from_line: int = Field(1, ge=1, description="the first line shown (1-based)")
    to_line: int = Field(1_000_000, ge=1, description="the last line shown")
    expand: list[str] = Field(
        [], max_length=MAX_EXPANDED, description="FB instances or structs (their paths) whose fields to read too"
    )


class Occurrence(BaseModel):
    line: int
    column: int = Field(description="1-based column where the name starts")
    end_column: int = Field(description="1-based column just after the name: where its value is shown")
    path: str = Field(description="the shared variable (a leaf), or the FB instance or struct (a group)")
    group: bool = Field(False, description="an FB instance or a struct: expandable to its fields")
    type: str | None = Field(None, description="its IEC type")
    value: bool | int | float | None = Field(None, description="a leaf's value (null: a group, or unreadable)")
    forced: bool = False


class Condition(BaseModel):
    line: int
    column: int = Field(description="where the condition (or CASE selector) starts")
    end_column: int = Field(description="just after it ends, when it ends on the same line; else its line's end")
    end_line: int
    what: str = Field(description="IF, ELSIF, WHILE, UNTIL or CASE")
    value: bool | int | float | None = Field(None, description="its value now; null when not evaluated")
    reason: str | None = Field(None, description="why it is not evaluated")


class MonitorAnswer(BaseModel):
    set_id: str
    layout_hash: str
    occurrences: list[Occurrence] = Field(description="every variable in the lines asked, with its value")
    conditions: list[Condition] = Field(description="IF/ELSIF/WHILE/UNTIL conditions and CASE selectors")
    fields: dict[str, list[LeafValue]] = Field(description="for each path in `expand`: its leaves")
    errors: list[PathError] = Field(description="an `expand` path that is not a group, or could not be read")


class WatchList(BaseModel):
    """A watch list: the variables to watch, in order."""

    model_config = ConfigDict(extra="forbid")
    paths: list[str] = Field(max_length=MAX_READ_PATHS, description="leaf paths (a variable, an FB instance's field)")


class WatchSaved(BaseModel):
    name: str = Field(description=NAME_RULE)
    set_id: str
    saved: str = Field(description="when it was saved (UTC)")
    by: Who | None
    size: int
    config: WatchList | None = Field(description="null when its file cannot be read (then `error` says why)")
    error: str | None = None


class WatchLists(BaseModel):
    set_id: str
    watches: list[WatchSaved] = Field(description="by name")
    max_configs: int
    max_bytes: int

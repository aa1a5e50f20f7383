"""scope_models.py -- the shapes of the trace configurations kept with a set (api/routes/scopes.py,
docs/recorder.md "Trace configurations"): a capture request, the very model POST /captures takes,
and what the Scope page needs to show it again.  OpenAPI and the web UI's schema.d.ts come from
them."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from ..recorder.capture_limits import MAX_CHANNELS
from ..recorder.capture_models import CaptureRequest, Path
from ..recorder.store import NAME_RULE
from .models import Who

MAX_CONFIGS = 100  # configurations per set
MAX_CONFIG_BYTES = 256 << 10  # one configuration's file


class ScopeConfig(BaseModel):
    """A trace configuration: the capture to arm and how the Scope page plots its shots."""

    model_config = ConfigDict(extra="forbid")
    capture: CaptureRequest = Field(description="what POST /captures takes: arm it as it is")
    plotted: list[Path] | None = Field(
        None,
        max_length=MAX_CHANNELS,
        description="the channels the plot shows, when not all of the capture's (null: all)",
    )
    mode: Literal["time", "xy"] = Field("time", description="the plot's mode")
    xy: list[Path | None] | None = Field(
        None, min_length=2, max_length=2, description="the x–y mode's variables: [x, y] (null: not chosen)"
    )


class ScopeSaved(BaseModel):
    """A configuration as it is kept: its name, when and by whom it was saved, and itself."""

    name: str = Field(description=NAME_RULE)
    set_id: str
    saved: str = Field(description="when it was saved (UTC)")
    by: Who | None = Field(description="who saved it")
    size: int = Field(description="bytes of its file")
    config: ScopeConfig | None = Field(description="null when its file cannot be read (then `error` says why)")
    error: str | None = Field(None, description="why its file is not a configuration (it was altered by hand)")


class ScopeList(BaseModel):
    set_id: str
    scopes: list[ScopeSaved] = Field(description="by name")
    max_configs: int = Field(description="configurations a set may hold")
    max_bytes: int = Field(description="bytes one configuration's file may hold")

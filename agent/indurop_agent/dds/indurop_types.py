"""indurop's own DDS types, as cyclonedds IdlStruct classes.

Generated from protocol/dds/**/*.idl by python3 protocol/dds/generate.py; do not edit.
"""

from dataclasses import dataclass, field

import cyclonedds.idl.annotations as annotate
from cyclonedds.idl import IdlStruct
from cyclonedds.idl import types

__all__ = [
    "LineAlarm",
    "LineController",
    "SharedVariable",
]


@dataclass
class LineAlarm(IdlStruct, typename="indurop::dds::LineAlarm"):
    """indurop::dds::LineAlarm (indurop/dds/LineAlarm.idl)."""

    source: str = ""
    id: types.uint32 = 0
    severity: str = ""
    text: str = ""


@dataclass
class LineController(IdlStruct, typename="indurop::dds::LineController"):
    """indurop::dds::LineController (indurop/dds/LineController.idl)."""

    name: str = ""
    agent_url: str = ""
    version: str = ""
    set_name: str = ""
    set_id: str = ""
    layout_hash: str = ""
    health: str = ""
    health_detail: str = ""
    basic_period_ns: types.uint64 = 0
    jitter_p99_ns: types.int64 = 0
    alarms_active: types.uint32 = 0
    alarms: types.sequence[LineAlarm] = field(default_factory=list)
    uptime_ns: types.uint64 = 0
    period_ms: types.uint32 = 0
    lease_ms: types.uint32 = 0
    seq: types.uint32 = 0
    annotate.key("name")


@dataclass
class SharedVariable(IdlStruct, typename="indurop::dds::SharedVariable"):
    """indurop::dds::SharedVariable (indurop/dds/SharedVariable.idl)."""

    controller: str = ""
    path: str = ""
    seq: types.uint64 = 0
    stamp_ns: types.int64 = 0
    every: types.uint32 = 0
    type: str = ""
    values: types.sequence[types.float64] = field(default_factory=list)
    annotate.key("controller")
    annotate.key("path")

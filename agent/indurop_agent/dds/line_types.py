"""indurop's own types on the DDS domain, as cyclonedds IdlStruct classes.

Generated from protocol/dds/*.idl by python3 protocol/dds/generate.py; do not edit.
"""

from dataclasses import dataclass, field

from cyclonedds.idl import IdlStruct
from cyclonedds.idl import types
from cyclonedds.idl.annotations import key

__all__ = [
    "Alarm",
    "Controller",
]


@dataclass
class Alarm(IdlStruct, typename="indurop::line::Alarm"):
    """indurop::line::Alarm (line.idl)."""

    source: str = ""
    id: types.uint32 = 0
    severity: str = ""
    text: str = ""


@dataclass
class Controller(IdlStruct, typename="indurop::line::Controller"):
    """indurop::line::Controller (line.idl)."""

    name: str = ""
    key("name")
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
    alarms: types.sequence[Alarm] = field(default_factory=list)
    uptime_ns: types.uint64 = 0
    period_ms: types.uint32 = 0
    lease_ms: types.uint32 = 0
    seq: types.uint32 = 0

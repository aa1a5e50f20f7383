"""indurop's own DDS types, as cyclonedds IdlStruct classes.

Generated from protocol/dds/**/*.idl by python3 protocol/dds/generate.py; do not edit.
"""

from dataclasses import dataclass, field

import cyclonedds.idl.annotations as annotate
from cyclonedds.idl import IdlStruct
from cyclonedds.idl import types

__all__ = [
    "SharedVariable",
]


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

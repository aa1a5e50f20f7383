"""ROS 2 message types on the DDS wire, as cyclonedds IdlStruct classes.

Generated from protocol/ros2/**/*.idl by python3 protocol/dds/generate.py; do not edit.
"""

from dataclasses import dataclass, field

from cyclonedds.idl import IdlStruct
from cyclonedds.idl import types

__all__ = [
    "Time",
    "Header",
    "KeyValue",
    "DiagnosticStatus",
    "DiagnosticArray",
    "JointState",
    "Bool",
    "MultiArrayDimension",
    "MultiArrayLayout",
    "Float32MultiArray",
    "Float32",
    "Float64MultiArray",
    "Float64",
    "Int16",
    "Int32MultiArray",
    "Int32",
    "Int64MultiArray",
    "Int64",
    "Int8",
    "UInt16",
    "UInt32",
    "UInt64",
    "UInt8MultiArray",
    "UInt8",
]


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    """builtin_interfaces::msg::dds_::Time_ (builtin_interfaces/msg/Time.idl)."""

    sec: types.int32 = 0
    nanosec: types.uint32 = 0


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    """std_msgs::msg::dds_::Header_ (std_msgs/msg/Header.idl)."""

    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class KeyValue(IdlStruct, typename="diagnostic_msgs::msg::dds_::KeyValue_"):
    """diagnostic_msgs::msg::dds_::KeyValue_ (diagnostic_msgs/msg/KeyValue.idl)."""

    key: str = ""
    value: str = ""


@dataclass
class DiagnosticStatus(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticStatus_"):
    """diagnostic_msgs::msg::dds_::DiagnosticStatus_ (diagnostic_msgs/msg/DiagnosticStatus.idl)."""

    level: types.byte = 0
    name: str = ""
    message: str = ""
    hardware_id: str = ""
    values: types.sequence[KeyValue] = field(default_factory=list)


@dataclass
class DiagnosticArray(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticArray_"):
    """diagnostic_msgs::msg::dds_::DiagnosticArray_ (diagnostic_msgs/msg/DiagnosticArray.idl)."""

    header: Header = field(default_factory=Header)
    status: types.sequence[DiagnosticStatus] = field(default_factory=list)


@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    """sensor_msgs::msg::dds_::JointState_ (sensor_msgs/msg/JointState.idl)."""

    header: Header = field(default_factory=Header)
    name: types.sequence[str] = field(default_factory=list)
    position: types.sequence[types.float64] = field(default_factory=list)
    velocity: types.sequence[types.float64] = field(default_factory=list)
    effort: types.sequence[types.float64] = field(default_factory=list)


@dataclass
class Bool(IdlStruct, typename="std_msgs::msg::dds_::Bool_"):
    """std_msgs::msg::dds_::Bool_ (std_msgs/msg/Bool.idl)."""

    data: bool = False


@dataclass
class MultiArrayDimension(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayDimension_"):
    """std_msgs::msg::dds_::MultiArrayDimension_ (std_msgs/msg/MultiArrayDimension.idl)."""

    label: str = ""
    size: types.uint32 = 0
    stride: types.uint32 = 0


@dataclass
class MultiArrayLayout(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayLayout_"):
    """std_msgs::msg::dds_::MultiArrayLayout_ (std_msgs/msg/MultiArrayLayout.idl)."""

    dim: types.sequence[MultiArrayDimension] = field(default_factory=list)
    data_offset: types.uint32 = 0


@dataclass
class Float32MultiArray(IdlStruct, typename="std_msgs::msg::dds_::Float32MultiArray_"):
    """std_msgs::msg::dds_::Float32MultiArray_ (std_msgs/msg/Float32MultiArray.idl)."""

    layout: MultiArrayLayout = field(default_factory=MultiArrayLayout)
    data: types.sequence[types.float32] = field(default_factory=list)


@dataclass
class Float32(IdlStruct, typename="std_msgs::msg::dds_::Float32_"):
    """std_msgs::msg::dds_::Float32_ (std_msgs/msg/Float32.idl)."""

    data: types.float32 = 0.0


@dataclass
class Float64MultiArray(IdlStruct, typename="std_msgs::msg::dds_::Float64MultiArray_"):
    """std_msgs::msg::dds_::Float64MultiArray_ (std_msgs/msg/Float64MultiArray.idl)."""

    layout: MultiArrayLayout = field(default_factory=MultiArrayLayout)
    data: types.sequence[types.float64] = field(default_factory=list)


@dataclass
class Float64(IdlStruct, typename="std_msgs::msg::dds_::Float64_"):
    """std_msgs::msg::dds_::Float64_ (std_msgs/msg/Float64.idl)."""

    data: types.float64 = 0.0


@dataclass
class Int16(IdlStruct, typename="std_msgs::msg::dds_::Int16_"):
    """std_msgs::msg::dds_::Int16_ (std_msgs/msg/Int16.idl)."""

    data: types.int16 = 0


@dataclass
class Int32MultiArray(IdlStruct, typename="std_msgs::msg::dds_::Int32MultiArray_"):
    """std_msgs::msg::dds_::Int32MultiArray_ (std_msgs/msg/Int32MultiArray.idl)."""

    layout: MultiArrayLayout = field(default_factory=MultiArrayLayout)
    data: types.sequence[types.int32] = field(default_factory=list)


@dataclass
class Int32(IdlStruct, typename="std_msgs::msg::dds_::Int32_"):
    """std_msgs::msg::dds_::Int32_ (std_msgs/msg/Int32.idl)."""

    data: types.int32 = 0


@dataclass
class Int64MultiArray(IdlStruct, typename="std_msgs::msg::dds_::Int64MultiArray_"):
    """std_msgs::msg::dds_::Int64MultiArray_ (std_msgs/msg/Int64MultiArray.idl)."""

    layout: MultiArrayLayout = field(default_factory=MultiArrayLayout)
    data: types.sequence[types.int64] = field(default_factory=list)


@dataclass
class Int64(IdlStruct, typename="std_msgs::msg::dds_::Int64_"):
    """std_msgs::msg::dds_::Int64_ (std_msgs/msg/Int64.idl)."""

    data: types.int64 = 0


@dataclass
class Int8(IdlStruct, typename="std_msgs::msg::dds_::Int8_"):
    """std_msgs::msg::dds_::Int8_ (std_msgs/msg/Int8.idl)."""

    data: types.int8 = 0


@dataclass
class UInt16(IdlStruct, typename="std_msgs::msg::dds_::UInt16_"):
    """std_msgs::msg::dds_::UInt16_ (std_msgs/msg/UInt16.idl)."""

    data: types.uint16 = 0


@dataclass
class UInt32(IdlStruct, typename="std_msgs::msg::dds_::UInt32_"):
    """std_msgs::msg::dds_::UInt32_ (std_msgs/msg/UInt32.idl)."""

    data: types.uint32 = 0


@dataclass
class UInt64(IdlStruct, typename="std_msgs::msg::dds_::UInt64_"):
    """std_msgs::msg::dds_::UInt64_ (std_msgs/msg/UInt64.idl)."""

    data: types.uint64 = 0


@dataclass
class UInt8MultiArray(IdlStruct, typename="std_msgs::msg::dds_::UInt8MultiArray_"):
    """std_msgs::msg::dds_::UInt8MultiArray_ (std_msgs/msg/UInt8MultiArray.idl)."""

    layout: MultiArrayLayout = field(default_factory=MultiArrayLayout)
    data: types.sequence[types.uint8] = field(default_factory=list)


@dataclass
class UInt8(IdlStruct, typename="std_msgs::msg::dds_::UInt8_"):
    """std_msgs::msg::dds_::UInt8_ (std_msgs/msg/UInt8.idl)."""

    data: types.uint8 = 0

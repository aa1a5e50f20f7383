"""mapping.py -- robot.json, the part of a set that says which URDF is its robot and which shared
variable drives each joint: {"urdf": "indurop6.urdf", "joints": [{"joint": "joint_1", "variable":
"PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[0]", "scale": 1, "offset": 0}, ...]}, and an optional
"description" in words.  A joint's position
is value · scale + offset (rad or m); a movable joint the file does not name, or one whose
variable is null, stays at 0.  Checked three ways: its own shape, against the URDF (the joints
exist and move) and against the running layout (the variables exist and are scalars)."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

from ..irpd.variables import number_problem
from .urdf import Urdf

ROBOT_JSON = "robot.json"
MAX_JOINTS = 64


class MappingError(Exception):
    """A robot.json (or a joint map sent to the API) that cannot be used; says which entry and why."""


@dataclass
class JointMapping:
    joint: str
    variable: str | None
    scale: float = 1.0
    offset: float = 0.0

    def as_dict(self) -> dict:
        return {"joint": self.joint, "variable": self.variable, "scale": self.scale, "offset": self.offset}


@dataclass
class RobotConfig:
    urdf: str  # the URDF's path in the set, relative to its root
    joints: list[JointMapping]
    description: str | None = None  # what the file is for, in words (kept when the map changes)

    def dump(self) -> bytes:
        """robot.json's text, one joint a line: the same map always gives the same bytes (and so
        the same set id)."""
        head = [f' "description": {json.dumps(self.description)},'] if self.description else []
        rows = ",\n".join(f"  {json.dumps(j.as_dict())}" for j in self.joints)
        return "\n".join(
            ["{", *head, f' "urdf": {json.dumps(self.urdf)},', ' "joints": [', rows, " ]", "}", ""]
        ).encode()

    def positions(self, values: dict[str, float]) -> dict[str, float]:
        """Joint positions from variable values (a joint whose variable has no value: 0)."""
        out = {}
        for j in self.joints:
            v = values.get(j.variable) if j.variable else None
            out[j.joint] = float(v) * j.scale + j.offset if v is not None else 0.0
        return out


def _number(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise MappingError(f"{where} must be a finite number, not {json.dumps(value)}")
    return float(value)


def check_urdf_path(urdf, shown: str) -> str:
    if not isinstance(urdf, str) or not urdf:
        raise MappingError(f"{shown}: \"urdf\" must name the set's URDF file, e.g. \"indurop6.urdf\"")
    parts = [p for p in urdf.split("/") if p not in ("", ".")]
    if urdf.startswith("/") or "\\" in urdf or ".." in parts or not parts:
        raise MappingError(f"{shown}: \"urdf\" {json.dumps(urdf)} must be a path inside the set, relative to its root")
    if not urdf.lower().endswith(".urdf"):
        raise MappingError(f"{shown}: \"urdf\" {json.dumps(urdf)} is not a .urdf file")
    return "/".join(parts)


def joints_from(items, shown: str) -> list[JointMapping]:
    """The joint entries of robot.json or of PUT /robot/joints, checked for shape and duplicates."""
    if not isinstance(items, list) or not items:
        raise MappingError(f"{shown}: \"joints\" must be a non-empty list of {{joint, variable, scale, offset}}")
    if len(items) > MAX_JOINTS:
        raise MappingError(f"{shown}: more than {MAX_JOINTS} joints")
    out, seen = [], set()
    for i, item in enumerate(items):
        where = f"{shown}: joints[{i}]"
        if isinstance(item, JointMapping):
            item = item.as_dict()
        if not isinstance(item, dict):
            raise MappingError(f"{where} must be an object {{joint, variable, scale, offset}}")
        unknown = set(item) - {"joint", "variable", "scale", "offset"}
        if unknown:
            raise MappingError(
                f"{where}: unknown keys {', '.join(sorted(unknown))}; the keys are joint, variable, scale, offset"
            )
        joint, variable = item.get("joint"), item.get("variable")
        if not isinstance(joint, str) or not joint:
            raise MappingError(f"{where}.joint must be a joint name of the URDF")
        if joint in seen:
            raise MappingError(f"{where}.joint {json.dumps(joint)} is mapped twice")
        seen.add(joint)
        if variable is not None and (not isinstance(variable, str) or not variable):
            raise MappingError(f"{where}.variable must be a shared variable's path or null")
        out.append(
            JointMapping(
                joint,
                variable,
                _number(item.get("scale", 1.0), f"{where}.scale"),
                _number(item.get("offset", 0.0), f"{where}.offset"),
            )
        )
    return out


def parse_config(data: bytes | str, shown: str = ROBOT_JSON) -> RobotConfig:
    """robot.json's content, checked for shape; MappingError says what to fix."""
    try:
        body = json.loads(data)
    except (ValueError, RecursionError) as e:
        raise MappingError(f"{shown} is not valid JSON: {e}") from None
    if not isinstance(body, dict):
        raise MappingError(f"{shown} must be an object {{\"urdf\": ..., \"joints\": [...]}}")
    unknown = set(body) - {"description", "urdf", "joints"}
    if unknown:
        raise MappingError(
            f"{shown}: unknown keys {', '.join(sorted(unknown))}; the keys are description, urdf, joints"
        )
    description = body.get("description")
    if description is not None and not isinstance(description, str):
        raise MappingError(f"{shown}: \"description\" must be a string")
    return RobotConfig(check_urdf_path(body.get("urdf"), shown), joints_from(body.get("joints"), shown), description)


def check_against_urdf(joints: list[JointMapping], urdf: Urdf, shown: str, urdf_name: str) -> None:
    """Every mapped joint is a movable joint of the URDF."""
    movable = [j.name for j in urdf.movable_joints()]
    for i, m in enumerate(joints):
        if m.joint not in movable:
            what = "a fixed joint" if m.joint in urdf.joints else "not a joint"
            raise MappingError(
                f"{shown}: joints[{i}].joint {json.dumps(m.joint)} is {what} of {urdf_name}; "
                f"its movable joints are {', '.join(movable)}"
            )


def check_variables(joints: list[JointMapping], leaves: dict, scalars: dict, shown: str) -> None:
    for i, m in enumerate(joints):
        if m.variable is not None:
            problem = number_problem(m.variable, leaves, scalars)
            if problem:
                raise MappingError(f"{shown}: joints[{i}].variable: {problem}")


def complete(joints: list[JointMapping], urdf: Urdf) -> list[JointMapping]:
    """The map in the URDF's joint order with every movable joint (unmapped ones: variable null)."""
    by_joint = {m.joint: m for m in joints}
    return [by_joint.get(j.name, JointMapping(j.name, None)) for j in urdf.movable_joints()]

"""urdf.py -- the part of a URDF the 3D view needs: links, joints (type, origin, axis, limits),
each link's visuals (box, cylinder, sphere, mesh file) with their colours, and forward kinematics
(the world pose of every link for given joint positions), in numpy.

A joint's frame is URDF's: T_parent_child(q) = T_origin · motion(axis, q), a rotation about the
axis (revolute, continuous) or a translation along it (prismatic); fixed, floating and planar
joints do not move here.  The file is parsed without DTDs or entities (defusedxml)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from defusedxml import ElementTree as SafeET

MOVABLE = ("revolute", "continuous", "prismatic")


class UrdfError(Exception):
    """A URDF the view cannot use; the message names the file and what is wrong."""


@dataclass
class Joint:
    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray  # 4x4, the child frame in the parent's at q = 0
    axis: np.ndarray  # unit vector in the joint frame
    lower: float | None
    upper: float | None

    @property
    def movable(self) -> bool:
        return self.type in MOVABLE

    def motion(self, q: float) -> np.ndarray:
        """The joint's own motion at position q (rad or m)."""
        if self.type in ("revolute", "continuous"):
            return homogeneous(rotation(self.axis, q), np.zeros(3))
        if self.type == "prismatic":
            return homogeneous(np.eye(3), self.axis * q)
        return np.eye(4)


@dataclass
class Visual:
    link: str
    origin: np.ndarray  # 4x4 in the link frame
    shape: str  # box, cylinder, sphere or mesh
    size: tuple[float, ...]  # box: x y z; cylinder: radius, length; sphere: radius; mesh: scale x y z
    rgba: tuple[float, float, float, float]
    filename: str | None = None  # mesh: as written in the URDF


@dataclass
class Urdf:
    name: str
    path: Path | None
    links: list[str]
    joints: dict[str, Joint]
    root: str
    visuals: list[Visual] = field(default_factory=list)

    def movable_joints(self) -> list[Joint]:
        return [j for j in self.joints.values() if j.movable]

    def fk(self, q: dict[str, float] | None = None) -> dict[str, np.ndarray]:
        """The world pose (4x4) of every link for joint positions `q` (missing joints: 0)."""
        q = q or {}
        children: dict[str, list[Joint]] = {}
        for j in self.joints.values():
            children.setdefault(j.parent, []).append(j)
        poses = {self.root: np.eye(4)}
        stack = [self.root]
        while stack:
            parent = stack.pop()
            for j in children.get(parent, []):
                poses[j.child] = poses[parent] @ j.origin @ j.motion(float(q.get(j.name, 0.0)))
                stack.append(j.child)
        return poses


# ---- small geometry -------------------------------------------------------------------------------
def homogeneous(r: np.ndarray, p: np.ndarray) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = r
    t[:3, 3] = p
    return t


def rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues: the rotation by `angle` about the unit vector `axis`."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF's fixed-axis angles: R = Rz(yaw) · Ry(pitch) · Rx(roll)."""
    x = rotation(np.array([1.0, 0, 0]), roll)
    y = rotation(np.array([0, 1.0, 0]), pitch)
    z = rotation(np.array([0, 0, 1.0]), yaw)
    return z @ y @ x


# ---- parsing --------------------------------------------------------------------------------------
def _numbers(text: str | None, count: int, default: str, where: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in (text if text is not None else default).split())
    except ValueError:
        raise UrdfError(f"{where}: {text!r} is not {count} numbers") from None
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise UrdfError(f"{where}: {text!r} is not {count} finite numbers")
    return values


def _origin(node, where: str) -> np.ndarray:
    o = node.find("origin") if node is not None else None
    if o is None:
        return np.eye(4)
    xyz = _numbers(o.get("xyz"), 3, "0 0 0", f"{where} <origin xyz>")
    rpy = _numbers(o.get("rpy"), 3, "0 0 0", f"{where} <origin rpy>")
    return homogeneous(rpy_matrix(*rpy), np.array(xyz))


def _rgba(material, named: dict[str, tuple], where: str) -> tuple[float, float, float, float]:
    grey = (0.6, 0.6, 0.6, 1.0)
    if material is None:
        return grey
    color = material.find("color")
    if color is not None:
        return _numbers(color.get("rgba"), 4, "0.6 0.6 0.6 1", f"{where} <color rgba>")  # type: ignore[return-value]
    return named.get(material.get("name", ""), grey)


def parse(source: Path | str | bytes, shown: str | None = None) -> Urdf:
    """A URDF from a file (Path) or its text; UrdfError names `shown` (or the file) and the problem."""
    path = source if isinstance(source, Path) else None
    shown = shown or (str(path) if path else "URDF text")
    try:
        if path is not None:
            root = SafeET.parse(path, forbid_dtd=True).getroot()
        else:
            root = SafeET.fromstring(source, forbid_dtd=True)
    except OSError as e:
        raise UrdfError(f"{shown}: cannot read it ({e.strerror or e})") from None
    except Exception as e:  # noqa: BLE001 -- ParseError and defusedxml's refusals alike
        raise UrdfError(f"{shown}: not a URDF the view can read: {e}") from None
    if root.tag != "robot":
        raise UrdfError(f"{shown}: the top-level element is <{root.tag}>, expected <robot>")
    named = {}
    for m in root.findall("material"):
        c = m.find("color")
        if m.get("name") and c is not None:
            named[m.get("name")] = _numbers(c.get("rgba"), 4, "0.6 0.6 0.6 1", f"{shown}: material {m.get('name')!r}")

    links, visuals = [], []
    for link in root.findall("link"):
        name = link.get("name")
        if not name:
            raise UrdfError(f"{shown}: a <link> without a name")
        if name in links:
            raise UrdfError(f"{shown}: link {name!r} twice")
        links.append(name)
        for i, v in enumerate(link.findall("visual")):
            where = f"{shown}: link {name!r} visual {i}"
            geometry = v.find("geometry")
            shape = next(iter(geometry), None) if geometry is not None else None
            if shape is None:
                raise UrdfError(f"{where}: no <geometry>")
            rgba = _rgba(v.find("material"), named, where)
            origin = _origin(v, where)
            if shape.tag == "box":
                size = _numbers(shape.get("size"), 3, "", f"{where} <box size>")
            elif shape.tag == "cylinder":
                size = (
                    _numbers(shape.get("radius"), 1, "", f"{where} <cylinder radius>")[0],
                    _numbers(shape.get("length"), 1, "", f"{where} <cylinder length>")[0],
                )
            elif shape.tag == "sphere":
                size = _numbers(shape.get("radius"), 1, "", f"{where} <sphere radius>")
            elif shape.tag == "mesh":
                if not shape.get("filename"):
                    raise UrdfError(f"{where}: <mesh> without a filename")
                size = _numbers(shape.get("scale"), 3, "1 1 1", f"{where} <mesh scale>")
                visuals.append(Visual(name, origin, "mesh", size, rgba, shape.get("filename")))
                continue
            else:
                raise UrdfError(f"{where}: unknown geometry <{shape.tag}>")
            visuals.append(Visual(name, origin, shape.tag, size, rgba))

    joints: dict[str, Joint] = {}
    for j in root.findall("joint"):
        name, kind = j.get("name"), j.get("type")
        where = f"{shown}: joint {name!r}"
        if not name:
            raise UrdfError(f"{shown}: a <joint> without a name")
        if name in joints:
            raise UrdfError(f"{shown}: joint {name!r} twice")
        if kind not in (*MOVABLE, "fixed", "floating", "planar"):
            raise UrdfError(f"{where}: unknown type {kind!r}")
        parent, child = j.find("parent"), j.find("child")
        parent = parent.get("link") if parent is not None else None
        child = child.get("link") if child is not None else None
        for role, link in (("parent", parent), ("child", child)):
            if link not in links:
                raise UrdfError(f"{where}: its {role} link {link!r} is not a <link> of the file")
        axis = np.array(
            _numbers(
                j.find("axis").get("xyz") if j.find("axis") is not None else None, 3, "1 0 0", f"{where} <axis xyz>"
            )
        )
        if kind in MOVABLE:
            norm = float(np.linalg.norm(axis))
            if norm == 0:
                raise UrdfError(f"{where}: the axis is zero")
            axis = axis / norm
        lower = upper = None
        limit = j.find("limit")
        if kind in ("revolute", "prismatic"):
            if limit is None:
                raise UrdfError(f"{where}: a {kind} joint needs <limit lower upper>")
            lower = _numbers(limit.get("lower"), 1, "0", f"{where} <limit lower>")[0]
            upper = _numbers(limit.get("upper"), 1, "0", f"{where} <limit upper>")[0]
        joints[name] = Joint(name, kind, parent, child, _origin(j, where), axis, lower, upper)

    if not links:
        raise UrdfError(f"{shown}: no <link>")
    children: set[str] = set()
    for j in joints.values():
        if j.child in children:
            raise UrdfError(f"{shown}: link {j.child!r} is the child of two joints; each link has one parent")
        children.add(j.child)
    roots = [link for link in links if link not in children]
    if len(roots) != 1:
        raise UrdfError(f"{shown}: the links must form one tree; roots found: {', '.join(roots) or 'none'}")
    urdf = Urdf(root.get("name") or "robot", path, links, joints, roots[0], visuals)
    if len(urdf.fk()) != len(links):
        raise UrdfError(f"{shown}: the joints form a loop; each link can have one parent joint")
    return urdf

"""urdf.py -- the URDF of the 3D view, read with yourdfpy (what viser's ViserUrdf draws with): the
links, the joints (type, limits), each link's visuals (box, cylinder, sphere, mesh file) with their
colours, and the world pose of every link for given joint positions (yourdfpy's forward kinematics:
update_cfg, then get_transform across each joint, composed from the root outwards: trimesh's
get_transform from the root to a deep link chooses its product's order with numpy's multi_dot,
O(depth³) -- 24 ms a pose set for a 30-link chain, against 1.3 ms this way).

A URDF the view cannot use -- malformed, hostile, or not one tree of links -- is refused with a
UrdfError naming the file and what is wrong, never an exception from inside yourdfpy:
  1. the text is parsed with defusedxml first (no DTD, no entities), and every element yourdfpy
     reads is checked for what yourdfpy needs (names, parent and child, one known geometry, the
     numbers of each attribute);
  2. yourdfpy reads the text (its model only), and the model is checked for what the view needs:
     unique names, joints of known types between links of the file, limits, non-zero axes, one tree;
  3. yourdfpy builds its scene graph (load_meshes=False: primitives only, mesh files are never
     opened here; the viewers find them themselves).
A movable joint's axis is normalised (yourdfpy would move a prismatic joint by q·axis), as urdfdom
does.  yourdfpy is imported on first use: it pulls trimesh, which the agent's start does not need."""
from __future__ import annotations

import io
import math
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from defusedxml import ElementTree as SafeET

if TYPE_CHECKING:  # pragma: no cover
    import yourdfpy

MOVABLE = ("revolute", "continuous", "prismatic")
TYPES = (*MOVABLE, "fixed", "floating", "planar")
GREY = (0.6, 0.6, 0.6, 1.0)

# What yourdfpy reads from the elements of a <link>, a <joint> and a <material>, checked first so
# that a wrong file is refused naming the element, not with a KeyError or ValueError from yourdfpy.
REQUIRED = {"parent": ("link",), "child": ("link",), "box": ("size",), "cylinder": ("radius", "length"),
            "sphere": ("radius",), "mesh": ("filename",)}
CHILDREN = {"joint": ("parent", "child"), "visual": ("geometry",), "collision": ("geometry",)}
GEOMETRIES = ("box", "cylinder", "sphere", "mesh")
NUMBERS = {  # element -> attribute -> how many numbers it may hold
    "origin": {"xyz": (3,), "rpy": (3,)}, "axis": {"xyz": (3,)}, "color": {"rgba": (4,)},
    "box": {"size": (3,)}, "cylinder": {"radius": (1,), "length": (1,)}, "sphere": {"radius": (1,)},
    "mesh": {"scale": (1, 3)}, "mass": {"value": (1,)},
    "inertia": dict.fromkeys(("ixx", "ixy", "ixz", "iyy", "iyz", "izz"), (1,)),
    "limit": dict.fromkeys(("lower", "upper", "effort", "velocity"), (1,)),
    "mimic": dict.fromkeys(("multiplier", "offset"), (1,)),
    "calibration": dict.fromkeys(("rising", "falling"), (1,)),
    "safety_controller": dict.fromkeys(("soft_lower_limit", "soft_upper_limit", "k_position", "k_velocity"), (1,)),
}


class UrdfError(Exception):
    """A URDF the view cannot use; the message names the file and what is wrong."""


@dataclass(frozen=True)
class Joint:
    name: str
    type: str
    parent: str
    child: str
    lower: float | None          # revolute, prismatic: <limit> (rad or m); others None
    upper: float | None
    mimic: str | None = None     # the joint this one follows (<mimic>): it does not move on its own

    @property
    def movable(self) -> bool:
        return self.type in MOVABLE and self.mimic is None


@dataclass
class Visual:
    link: str
    origin: np.ndarray          # 4x4 in the link frame
    shape: str                  # box, cylinder, sphere or mesh
    size: tuple[float, ...]     # box: x y z; cylinder: radius, length; sphere: radius; mesh: scale x y z
    rgba: tuple[float, float, float, float]
    filename: str | None = None  # mesh: as written in the URDF


@dataclass(eq=False)
class Urdf:
    name: str
    path: Path | None
    links: list[str]
    joints: dict[str, Joint]
    root: str
    visuals: list[Visual]
    model: yourdfpy.URDF = field(repr=False)  # with its scene graph: the forward kinematics
    edges: list[tuple[str, str]] = field(repr=False)  # (parent, child) of every joint, parents first
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def movable_joints(self) -> list[Joint]:
        return [j for j in self.joints.values() if j.movable]

    def fk(self, q: dict[str, float] | None = None) -> dict[str, np.ndarray]:
        """The world pose (4x4) of every link for joint positions `q` (missing joints: 0)."""
        q = q or {}
        with self._lock:  # update_cfg changes the model's state
            self.model.update_cfg({j.name: float(q.get(j.name, 0.0)) for j in self.movable_joints()})
            poses = {self.root: np.eye(4)}
            for parent, child in self.edges:
                poses[child] = poses[parent] @ self.model.get_transform(child, parent)
            return poses


# ---- checking the text before yourdfpy reads it ----------------------------------------------------
def _numbers(text: str, counts: tuple[int, ...], where: str) -> None:
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        values = []
    if len(values) not in counts or not all(math.isfinite(v) for v in values):
        what = "a finite number" if counts == (1,) else f"{' or '.join(map(str, counts))} finite numbers"
        raise UrdfError(f"{where}{text!r} is not {what}")


def _check_element(el, where: str) -> None:
    """`where`: the message's start, "<file>: " or "<file>: link 'a': "."""
    for attr in REQUIRED.get(el.tag, ()):
        if not el.get(attr):
            raise UrdfError(f"{where}a <{el.tag}> without a {attr}")
    for child in CHILDREN.get(el.tag, ()):
        if el.find(child) is None:
            raise UrdfError(f"{where}a <{el.tag}> without <{child}>")
    if el.tag == "geometry":
        shapes = [c.tag for c in el]
        if len(shapes) != 1:
            raise UrdfError(f"{where}<geometry> holds {len(shapes)} shapes; it holds one of {', '.join(GEOMETRIES)}")
        if shapes[0] not in GEOMETRIES:
            raise UrdfError(f"{where}unknown geometry <{shapes[0]}>; the geometries are {', '.join(GEOMETRIES)}")
    for attr, counts in NUMBERS.get(el.tag, {}).items():
        if el.get(attr) is not None:
            _numbers(el.get(attr), counts, f"{where}<{el.tag} {attr}> ")


def _check_text(text: bytes, shown: str) -> None:
    try:
        root = SafeET.fromstring(text, forbid_dtd=True)
    except Exception as e:  # noqa: BLE001 -- ParseError and defusedxml's refusals alike
        raise UrdfError(f"{shown}: not a URDF the view can read: {e}") from None
    if root.tag != "robot":
        raise UrdfError(f"{shown}: the top-level element is <{root.tag}>, expected <robot>")
    if not root.get("name"):
        raise UrdfError(f"{shown}: the <robot> has no name")
    for top in root:
        if top.tag not in ("link", "joint", "material"):
            continue  # <transmission>, <gazebo>, ...: yourdfpy leaves them
        if top.tag != "material" and not top.get("name"):
            raise UrdfError(f"{shown}: a <{top.tag}> without a name")
        for el in top.iter():
            _check_element(el, f"{shown}: {top.tag} {top.get('name')!r}: ")


# ---- checking yourdfpy's model ------------------------------------------------------------------
def _check_model(robot, shown: str) -> tuple[list[str], str, list[tuple[str, str]]]:
    """The links in file order, the root and the joints' (parent, child) from the root outwards;
    normalises the movable joints' axes."""
    links = [link.name for link in robot.links]
    if not links:
        raise UrdfError(f"{shown}: no <link>")
    for names, what in ((links, "link"), ([j.name for j in robot.joints], "joint")):
        seen: set[str] = set()
        for name in names:
            if name in seen:
                raise UrdfError(f"{shown}: {what} {name!r} twice")
            seen.add(name)
    known, joints = set(links), {j.name for j in robot.joints}
    children: dict[str, list[str]] = {}
    has_parent: set[str] = set()
    for j in robot.joints:
        where = f"{shown}: joint {j.name!r}"
        if j.type not in TYPES:
            raise UrdfError(f"{where}: unknown type {j.type!r}; the types are {', '.join(TYPES)}")
        for role, link in (("parent", j.parent), ("child", j.child)):
            if link not in known:
                raise UrdfError(f"{where}: its {role} link {link!r} is not a <link> of the file")
        if j.type in MOVABLE:
            norm = float(np.linalg.norm(j.axis))
            if norm == 0:
                raise UrdfError(f"{where}: the axis is zero")
            j.axis = j.axis / norm
        if j.type in ("revolute", "prismatic") and j.limit is None:
            raise UrdfError(f"{where}: a {j.type} joint needs <limit lower upper>")
        if j.mimic is not None and j.mimic.joint not in joints:
            raise UrdfError(f"{where}: <mimic joint> {j.mimic.joint!r} is not a <joint> of the file")
        if j.child in has_parent:
            raise UrdfError(f"{shown}: link {j.child!r} is the child of two joints; each link has one parent")
        has_parent.add(j.child)
        children.setdefault(j.parent, []).append(j.child)
    roots = [link for link in links if link not in has_parent]
    if len(roots) != 1:
        raise UrdfError(f"{shown}: the links must form one tree; roots found: {', '.join(roots) or 'none'}")
    edges, stack = [], [roots[0]]
    while stack:
        parent = stack.pop()
        for child in children.get(parent, []):
            edges.append((parent, child))
            stack.append(child)
    if len(edges) != len(links) - 1:
        raise UrdfError(f"{shown}: the joints form a loop; each link can have one parent joint")
    return links, roots[0], edges


def _joint(j) -> Joint:
    lower = upper = None
    if j.type in ("revolute", "prismatic"):  # URDF's defaults: 0
        lower = j.limit.lower if j.limit.lower is not None else 0.0
        upper = j.limit.upper if j.limit.upper is not None else 0.0
    return Joint(j.name, j.type, j.parent, j.child, lower, upper, j.mimic.joint if j.mimic else None)


def _visual(link: str, v, materials: dict) -> Visual:
    origin = v.origin if v.origin is not None else np.eye(4)
    color = None
    if v.material is not None:
        color = v.material.color
        if color is None and v.material.name in materials:
            color = materials[v.material.name].color
    rgba = tuple(float(c) for c in color.rgba) if color is not None else GREY
    g = v.geometry
    if g.box is not None:
        return Visual(link, origin, "box", tuple(float(s) for s in g.box.size), rgba)
    if g.cylinder is not None:
        return Visual(link, origin, "cylinder", (g.cylinder.radius, g.cylinder.length), rgba)
    if g.sphere is not None:
        return Visual(link, origin, "sphere", (g.sphere.radius,), rgba)
    scale = g.mesh.scale
    size = (1.0,) * 3 if scale is None else (float(scale),) * 3 if np.ndim(scale) == 0 else tuple(map(float, scale))
    return Visual(link, origin, "mesh", size, rgba, g.mesh.filename)


def parse(source: Path | bytes, shown: str | None = None) -> Urdf:
    """A URDF from a file (Path) or its text; UrdfError names `shown` (or the file) and the problem."""
    import yourdfpy

    path = source if isinstance(source, Path) else None
    shown = shown or (str(path) if path else "URDF text")
    try:
        text = path.read_bytes() if path is not None else source
    except OSError as e:
        raise UrdfError(f"{shown}: cannot read it ({e.strerror or e})") from None
    _check_text(text, shown)
    try:
        robot = yourdfpy.URDF.load(io.BytesIO(text), build_scene_graph=False, load_meshes=False).robot
    except Exception as e:  # noqa: BLE001 -- whatever the checks above did not foresee
        raise UrdfError(f"{shown}: yourdfpy cannot read it: {type(e).__name__}: {e}") from None
    links, root, edges = _check_model(robot, shown)
    try:
        model = yourdfpy.URDF(robot=robot, build_scene_graph=True, load_meshes=False)
    except Exception as e:  # noqa: BLE001
        raise UrdfError(f"{shown}: yourdfpy cannot build its scene: {type(e).__name__}: {e}") from None
    materials = {m.name: m for m in robot.materials if m.name}
    visuals = [_visual(link.name, v, materials) for link in robot.links for v in link.visuals]
    return Urdf(robot.name, path, links, {j.name: _joint(j) for j in robot.joints}, root, visuals, model, edges)

"""test_fk_numpy.py -- the robot's forward kinematics computed independently of KDL: numpy
composes the URDF's joint origins (xyz, rpy) and axis rotations read with xml.etree, and the
result is compared with the C++ library's (tests/cpp/kinematics_fk, built with the C++ tests) for
hand-picked and random joint values, on config/robots/indurop6.urdf and on a variant with tilted
joint frames and oblique axes that exercises every part of the URDF -> KDL conversion."""

from __future__ import annotations

import os
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[3]
BUILD = Path(os.environ.get("INDUROP_BUILD", ROOT / "build"))
FK_TOOL = BUILD / "tests" / "cpp" / "kinematics_fk"
URDF = ROOT / "config" / "robots" / "indurop6.urdf"


# ---- FK with numpy, from the URDF text ------------------------------------------------------------


def rot_x(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def rot_axis(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues: the rotation by `angle` about the unit vector `axis`."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)


def homogeneous(r: np.ndarray, p: np.ndarray) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = r
    t[:3, 3] = p
    return t


def numbers(text: str | None, default: str) -> np.ndarray:
    return np.array([float(v) for v in (text or default).split()])


class UrdfChain:
    """The joints from `base` to `tip`, as the URDF states them."""

    def __init__(self, urdf: Path, base: str = "base_link", tip: str = "tool0"):
        root = ET.parse(urdf).getroot()
        by_child = {j.find("child").get("link"): j for j in root.findall("joint")}
        joints = []
        link = tip
        while link != base:
            joint = by_child[link]
            joints.append(joint)
            link = joint.find("parent").get("link")
        self.joints = []
        for j in reversed(joints):
            origin = j.find("origin")
            xyz = numbers(origin.get("xyz") if origin is not None else None, "0 0 0")
            rpy = numbers(origin.get("rpy") if origin is not None else None, "0 0 0")
            axis_el = j.find("axis")
            axis = numbers(axis_el.get("xyz") if axis_el is not None else None, "1 0 0")
            limit = j.find("limit")
            self.joints.append(
                {
                    "name": j.get("name"),
                    "type": j.get("type"),
                    # URDF: rpy are fixed-axis roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll)
                    "origin": homogeneous(rot_z(rpy[2]) @ rot_y(rpy[1]) @ rot_x(rpy[0]), xyz),
                    "axis": axis / np.linalg.norm(axis),
                    "lower": float(limit.get("lower")) if limit is not None else None,
                    "upper": float(limit.get("upper")) if limit is not None else None,
                }
            )
        self.movable = [j for j in self.joints if j["type"] != "fixed"]

    def fk(self, q) -> np.ndarray:
        t = np.eye(4)
        values = iter(q)
        for j in self.joints:
            t = t @ j["origin"]
            if j["type"] in ("revolute", "continuous"):
                t = t @ homogeneous(rot_axis(j["axis"], next(values)), np.zeros(3))
            elif j["type"] == "prismatic":
                t = t @ homogeneous(np.eye(3), j["axis"] * next(values))
        return t

    def random_q(self, rng: np.random.Generator) -> np.ndarray:
        return np.array([rng.uniform(j["lower"], j["upper"]) for j in self.movable])


# ---- the C++ side -----------------------------------------------------------------------------------


def cpp_fk(urdf: Path, qs: list) -> list[np.ndarray]:
    assert FK_TOOL.exists(), f"{FK_TOOL} is missing: build first (bash packaging/build.sh)"
    text = "".join(" ".join(repr(float(v)) for v in q) + "\n" for q in qs)
    out = subprocess.run([str(FK_TOOL), str(urdf)], input=text, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stdout + out.stderr
    lines = out.stdout.splitlines()
    assert len(lines) == len(qs)
    return [np.array([float(v) for v in line.split()]).reshape(4, 4) for line in lines]


HAND_PICKED = [
    [0, 0, 0, 0, 0, 0],
    [np.pi / 2, 0, 0, 0, 0, 0],
    [0, np.pi / 2, 0, 0, 0, 0],
    [0, 0, -np.pi / 2, 0, 0, 0],
    [0, 0, 0, np.pi / 2, 0, 0],
    [0, 0, 0, 0, np.pi / 2, 0],
    [0, 0, 0, 0, 0, np.pi / 2],
    [0.3, -0.4, 0.5, -0.6, 0.7, -0.8],
]


def test_numpy_fk_agrees_with_the_hand_worked_zero_pose():
    """The independent side is itself right: tool0 at (0.63, 0, 0.885), its z along +x."""
    t = UrdfChain(URDF).fk([0] * 6)
    np.testing.assert_allclose(t[:3, 3], [0.63, 0, 0.885], atol=1e-12)
    np.testing.assert_allclose(t[:3, :3], rot_y(np.pi / 2), atol=1e-12)
    t = UrdfChain(URDF).fk([0, 0, 0, 0, np.pi / 2, 0])  # wrist bent down: tool z along -z
    np.testing.assert_allclose(t[:3, 3], [0.55, 0, 0.805], atol=1e-12)
    np.testing.assert_allclose(t[:3, 2], [0, 0, -1], atol=1e-12)


def test_cpp_fk_matches_numpy_on_hand_picked_and_random_joint_values():
    chain = UrdfChain(URDF)
    rng = np.random.default_rng(2024)
    qs = HAND_PICKED + [chain.random_q(rng) for _ in range(300)]
    for q, t in zip(qs, cpp_fk(URDF, qs)):
        expected = chain.fk(q)
        np.testing.assert_allclose(t, expected, atol=1e-12, err_msg=f"q = {list(q)}")


def test_cpp_fk_matches_numpy_with_tilted_frames_and_oblique_axes(tmp_path):
    """Every joint origin gets a non-zero rpy and every axis an oblique, non-unit direction: the
    conversion must place each axis in its joint's frame and normalize it."""
    tree = ET.parse(URDF)
    rng = np.random.default_rng(7)
    for joint in tree.getroot().findall("joint"):
        origin = joint.find("origin")
        origin.set("rpy", " ".join(f"{v:.6f}" for v in rng.uniform(-1.2, 1.2, 3)))
        axis = joint.find("axis")
        if axis is not None:
            axis.set("xyz", " ".join(f"{v:.6f}" for v in rng.uniform(-2, 2, 3)))
    variant = tmp_path / "tilted.urdf"
    tree.write(variant)
    chain = UrdfChain(variant)
    qs = HAND_PICKED + [chain.random_q(rng) for _ in range(200)]
    for q, t in zip(qs, cpp_fk(variant, qs)):
        np.testing.assert_allclose(t, chain.fk(q), atol=1e-12, err_msg=f"q = {list(q)}")
    # ... and differs from the original robot, so the test would see a converter ignoring them.
    assert not np.allclose(cpp_fk(variant, [[0.3] * 6])[0], UrdfChain(URDF).fk([0.3] * 6), atol=1e-3)


def test_cpp_tool_refuses_a_broken_urdf(tmp_path):
    broken = tmp_path / "broken.urdf"
    broken.write_text(URDF.read_text().replace('<link name="link_3">', '<link name="link_x">'))
    out = subprocess.run([str(FK_TOOL), str(broken)], input="", capture_output=True, text=True, timeout=60)
    assert out.returncode == 1
    assert out.stdout.startswith(f"error: {broken}: urdfdom refused it:"), out.stdout

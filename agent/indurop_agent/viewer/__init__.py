"""viewer -- the 3D view of the running set's robot (docs/robot-view.md): the URDF and its forward
kinematics (urdf.py), the set's robot.json (mapping.py), two viewer backends behind one interface
(base.py: viser_view.py, meshcat_view.py), the task that keeps the view live (live.py) and the
tickets that let the browser's iframe through the agent's proxy (ticket.py)."""

from __future__ import annotations

from ..config import VIEWERS
from .base import Viewer, ViewerError

__all__ = ["VIEWERS", "Viewer", "ViewerError", "make_viewer"]


def make_viewer(kind: str) -> Viewer:
    """A viewer of this kind, not started yet."""
    if kind == "viser":
        from .viser_view import ViserViewer

        return ViserViewer()
    if kind == "meshcat":
        from .meshcat_view import MeshcatViewer

        return MeshcatViewer()
    raise ViewerError(f"unknown viewer {kind!r}; the viewers are {', '.join(VIEWERS)}")

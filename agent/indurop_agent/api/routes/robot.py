"""robot.py -- the 3D view of the running set's robot: where the viewer is, the URDF, and the
mapping from shared variables to joints (part of the set: robot.json)."""
from __future__ import annotations

from fastapi import APIRouter, Request
from fastapi.responses import Response

from ..deps import AdminDep, ViewerDep
from ..models import JointMapUpdate, RobotView

router = APIRouter(tags=["robot"])


@router.get("/robot")
def robot(request: Request, _: ViewerDep) -> RobotView:
    raise NotImplementedError


@router.get("/robot/urdf", response_class=Response,
            responses={200: {"content": {"application/xml": {}}}, 404: {"description": "no robot in the running set"}})
def robot_urdf(request: Request, _: ViewerDep) -> Response:
    raise NotImplementedError


@router.put("/robot/joints")
def put_joints(body: JointMapUpdate, request: Request, who: AdminDep) -> RobotView:
    """Stores a new mapping as a new version of the running set (history and rollback as for any
    set) and applies it to the view at once."""
    raise NotImplementedError

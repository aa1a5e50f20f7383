"""robot.py -- the 3D view of the running set's robot: where the viewer is, the URDF, and the
mapping from shared variables to joints (part of the set: robot.json); and the reverse proxy that
serves the viewer's page and WebSocket under /api/v1/robot/viewer/ (docs/robot-view.md).

The proxy's callers are iframes: they show a ticket once (?ticket=, from GET /robot's viewer_url),
which is traded for an HttpOnly cookie scoped to the viewer's path, then load the page and open
the WebSocket with that cookie.  The viewer's own server listens on 127.0.0.1 only."""

from __future__ import annotations

import asyncio
from urllib.parse import urlencode, urlsplit

import httpx
import websockets
from fastapi import APIRouter, HTTPException, Request, WebSocket
from fastapi.responses import RedirectResponse, Response
from websockets.asyncio.client import connect

from ...irpd.client import IrpdRefused, IrpdUnavailable
from ...sets.store import StoreError
from ...viewer.base import ViewerError
from ...viewer.live import View
from ...viewer.mapping import MappingError, RobotConfig, check_against_urdf, check_variables, complete, joints_from
from ...viewer.sets import running_set, with_robot_json
from ...viewer.ticket import TicketError
from ..deps import AdminDep, ViewerDep, ask, audited
from ..models import JointMapUpdate, RobotJoint, RobotView
from .variables import segment

router = APIRouter(tags=["robot"])

COOKIE = "indurop_viewer"
VIEWER = "/robot/viewer"
MAX_MESSAGE_BYTES = 64 << 20  # viser sends a whole mesh in one message
PAGE_HEADERS = {"Cache-Control": "no-store"}  # the security headers: headers.py (VIEWER)
CLOSE_UNAUTHENTICATED, CLOSE_FORBIDDEN, CLOSE_NO_VIEWER = 4401, 4403, 4404


def _public(request: Request, view: View, who) -> RobotView:
    settings = request.app.state.settings
    joints = []
    if view.urdf is not None:
        for m in view.joints:
            j = view.urdf.joints[m.joint]
            joints.append(
                RobotJoint(
                    joint=m.joint,
                    variable=m.variable,
                    scale=m.scale,
                    offset=m.offset,
                    type=j.type,
                    lower=j.lower,
                    upper=j.upper,
                )
            )
    url = None
    if view.available:
        ticket = request.app.state.tickets.issue(who)
        url = f"{request.url.path.rsplit('/robot', 1)[0]}{VIEWER}/?ticket={ticket}"
    return RobotView(
        available=view.available,
        detail=view.detail,
        viewer=settings.viewer,
        viewer_url=url,
        urdf=view.config.urdf if view.config else None,
        joints=joints,
        set_id=view.set_id,
    )


@router.get("/robot")
def robot(request: Request, who: ViewerDep) -> RobotView:
    """The running set's robot: its joints with their variables and limits, and the viewer's URL
    (with a ticket valid for viewer_ticket_s; load it in an iframe)."""
    return _public(request, request.app.state.robot.current(), who)


@router.get(
    "/robot/urdf",
    response_class=Response,
    responses={200: {"content": {"application/xml": {}}}, 404: {"description": "no robot in the running set"}},
)
def robot_urdf(request: Request, _: ViewerDep) -> Response:
    view = request.app.state.robot.current()
    if view.urdf is None or view.urdf.path is None:
        raise HTTPException(404, view.detail or "the running set has no robot")
    try:
        return Response(view.urdf.path.read_bytes(), media_type="application/xml")
    except OSError as e:
        raise HTTPException(404, f"{view.config.urdf}: {e.strerror or e}") from e


def _check_map(body: JointMapUpdate, view: View, leaves: dict, scalars: dict) -> list:
    shown = "the joint map"
    try:
        joints = joints_from([j.model_dump() for j in body.joints], shown)
        check_against_urdf(joints, view.urdf, shown, view.config.urdf)
        check_variables(joints, leaves, scalars, shown)
    except MappingError as e:
        raise HTTPException(400, str(e)) from None
    return joints


@router.put(
    "/robot/joints",
    responses={
        400: {"description": "a joint or a variable that does not exist (named)"},
        409: {"description": "the running set has no robot, or irpd refused the set"},
        503: {"description": "irpd unreachable"},
    },
)
def put_joints(body: JointMapUpdate, request: Request, who: AdminDep) -> RobotView:
    """Stores a new mapping as a new version of the running set (history and rollback as for any
    set), activates it (a hot reload that keeps every module) and applies it to the view at once.
    Joints left out are held at 0."""
    state = request.app.state
    with audited(request, who, "robot_joints") as entry:
        view = state.robot.refresh()
        if view.config is None or view.urdf is None:
            raise HTTPException(409, f"no joint map to change: {view.detail}")
        seg = segment(request, state.irpd)
        joints = _check_map(body, view, seg.leaves, seg.scalars)
        entry["joints"] = [j.as_dict() for j in joints]
        status = ask(state.irpd, "status")
        if not status.get("set"):
            raise HTTPException(409, "irpd runs no set")
        base_id, base_files, imported = running_set(state, status, who.as_dict())
        entry["from"], entry["imported"] = base_id, imported
        if view.config.urdf not in {f["path"] for f in base_files}:
            raise HTTPException(409, f"set {base_id} does not hold {view.config.urdf}")
        robot_json = RobotConfig(view.config.urdf, complete(joints, view.urdf), view.config.description).dump()
        manifest = with_robot_json(state, base_files, robot_json, who.as_dict())
        entry["target"] = manifest["id"]
        if manifest["id"] != status.get("set_id"):
            try:
                report = state.activator.activate(manifest["id"], who.as_dict())
            except StoreError as e:
                raise HTTPException(e.status, str(e)) from e
            except IrpdRefused as e:
                raise HTTPException(409, f"irpd refused set {manifest['id']} and kept the running one: {e}") from e
            except IrpdUnavailable as e:
                raise HTTPException(503, str(e)) from e
            entry["generation"] = (report or {}).get("generation")
            entry["kept"] = (report or {}).get("kept")
    view = state.robot.refresh()
    state.events.add(
        "robot_joints",
        f"{who.name} changed the joint map: set {manifest['id']} (from {base_id}) is active",
        set_id=manifest["id"],
    )
    return _public(request, view, who)


# ---- the proxy ------------------------------------------------------------------------------
def _prefix(path: str) -> str:
    """/api/v1/robot/viewer, from a request's path under it."""
    return path[: path.index(VIEWER) + len(VIEWER)]


def _identify(state, cookies, query) -> None:
    """Lets a valid cookie (or ticket) through; TicketError otherwise."""
    if COOKIE in cookies:
        state.tickets.check(cookies[COOKIE], "session")
    elif "ticket" in query:
        state.tickets.check(query["ticket"], "url")
    else:
        raise TicketError("open the 3D view through the viewer_url of GET /api/v1/robot (it carries a ticket)")


@router.get(VIEWER, include_in_schema=False)
def viewer_folder(request: Request) -> RedirectResponse:
    """The viewer's pages load files relative to their folder: go there."""
    query = f"?{request.url.query}" if request.url.query else ""
    return RedirectResponse(f"{request.url.path}/{query}", status_code=307)


@router.get(VIEWER + "/{path:path}", include_in_schema=False)
async def viewer_file(path: str, request: Request) -> Response:
    state = request.app.state
    ticket = request.query_params.get("ticket")
    if ticket is not None:  # trade the ticket for a cookie, and drop it from the URL
        try:
            who = state.tickets.check(ticket, "url")
        except TicketError as e:
            raise HTTPException(401, str(e)) from e
        rest = [(k, v) for k, v in request.query_params.multi_items() if k != "ticket"]
        response = RedirectResponse(request.url.path + (f"?{urlencode(rest)}" if rest else ""), status_code=303)
        response.set_cookie(
            COOKIE,
            state.tickets.issue(who, "session"),
            max_age=int(state.settings.viewer_session_s),
            path=_prefix(request.url.path),
            httponly=True,
            samesite="strict",
            secure=state.settings.tls_cert is not None,
        )
        return response
    try:
        _identify(state, request.cookies, {})
    except TicketError as e:
        raise HTTPException(401, str(e)) from e
    segments = path.split("/")
    if ".." in segments or "\\" in path or any(ord(c) < 0x20 for c in path):
        raise HTTPException(404, "no such file in the viewer")
    viewer = state.robot.viewer
    if viewer is None:
        raise HTTPException(404, f"no 3D view: {state.robot.view.detail}")
    try:
        async with httpx.AsyncClient(timeout=10) as client:
            r = await client.get(viewer.url + viewer.http_path(path), headers={"Accept-Encoding": "identity"})
        body = viewer.rewrite(path, r.content) if r.status_code == 200 else r.content
    except (httpx.HTTPError, ViewerError) as e:
        raise HTTPException(502, f"the {viewer.kind} viewer did not answer: {e}") from e
    headers = {**PAGE_HEADERS, "Content-Type": r.headers.get("content-type", "application/octet-stream")}
    return Response(body, status_code=r.status_code if r.status_code < 500 else 502, headers=headers)


async def _refuse(ws: WebSocket, code: int, reason: str) -> None:
    await ws.close(code=code, reason=reason[:120])


@router.websocket(VIEWER)
@router.websocket(VIEWER + "/{path:path}")
async def viewer_socket(ws: WebSocket, path: str = "") -> None:
    """The viewer's WebSocket, relayed message by message (binary stays binary)."""
    state = ws.app.state
    origin = ws.headers.get("origin")
    if origin and urlsplit(origin).netloc != ws.headers.get("host"):
        return await _refuse(ws, CLOSE_FORBIDDEN, "the viewer's WebSocket takes connections from its own origin only")
    try:
        _identify(state, ws.cookies, ws.query_params)
    except TicketError as e:
        return await _refuse(ws, CLOSE_UNAUTHENTICATED, str(e))
    viewer = state.robot.viewer
    if viewer is None:
        return await _refuse(ws, CLOSE_NO_VIEWER, "no 3D view: the running set has no robot")
    subprotocols = list(ws.scope.get("subprotocols") or [])
    try:
        upstream = await connect(
            f"ws://127.0.0.1:{viewer.port}{viewer.ws_path}",
            subprotocols=subprotocols or None,
            max_size=MAX_MESSAGE_BYTES,
            compression=None,
            open_timeout=10,
            ping_interval=None,
        )
    except (OSError, TimeoutError, websockets.exceptions.WebSocketException, ViewerError) as e:
        return await _refuse(ws, 1011, f"the viewer did not answer: {e}")
    await ws.accept(subprotocol=upstream.subprotocol)

    async def down():
        async for message in upstream:
            if isinstance(message, bytes):
                await ws.send_bytes(message)
            else:
                await ws.send_text(message)

    async def up():
        while True:
            message = await ws.receive()
            if message["type"] == "websocket.disconnect":
                return
            if message.get("bytes") is not None:
                await upstream.send(message["bytes"])
            elif message.get("text") is not None:
                await upstream.send(message["text"])

    tasks = [asyncio.create_task(down()), asyncio.create_task(up())]
    try:
        await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
    finally:
        for t in tasks:
            t.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        await upstream.close()
        try:
            await ws.close()
        except RuntimeError:
            pass  # already closed by the browser

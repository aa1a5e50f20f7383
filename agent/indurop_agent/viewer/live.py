"""live.py -- the background task behind the 3D view: it follows irpd's running set and keeps the
viewer showing that set's robot, moving with its shared variables.

Every 0.5 s it asks irpd's `status` (on a connection of its own); when the running set changed
(its path, generation, set id or irpd's pid) it reads robot.json in the set's folder (the folder
of status `set`), parses the URDF it names, checks the map against the URDF and the layout, and
loads the robot into the viewer (started on first use).  At `robot_rate_hz` (30 Hz) it reads the
mapped variables straight from the shared-variable segment (variables.py, no lock, no HTTP) and
sets the joints: position = value · scale + offset.  It never raises: irpd may come and go.
"""

from __future__ import annotations

import hashlib
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from ..events import AgentEvents
from ..irpd.client import IrpdClient, IrpdRefused, IrpdUnavailable
from ..irpd.variables import Segment, VariableError, number_problem
from . import make_viewer
from .base import Viewer, ViewerError
from .mapping import ROBOT_JSON, JointMapping, MappingError, RobotConfig, check_against_urdf, complete, parse_config
from .urdf import Urdf, UrdfError, parse

STATUS_EVERY_S = 0.5
ERROR_EVENT_EVERY_S = 60.0


def robot_identity(robot_json: Path, urdf: Urdf) -> str:
    """What the viewer shows, by content: robot.json, the URDF and the mesh files it names (a set
    stored again under another id with the same robot is the same robot)."""
    h = hashlib.sha256()
    files = [robot_json]
    if urdf.path is not None:
        files += [urdf.path] + sorted({urdf.path.parent / v.filename for v in urdf.visuals if v.filename})
    for f in files:
        h.update(str(f.relative_to(robot_json.parent) if f.is_relative_to(robot_json.parent) else f).encode() + b"\0")
        try:
            h.update(f.read_bytes())
        except OSError as e:
            h.update(f"unreadable: {e.strerror}".encode())
        h.update(b"\0")
    return h.hexdigest()


@dataclass
class View:
    """What the running set's robot looks like to the API (GET /robot)."""

    available: bool = False
    detail: str | None = "the agent has not asked irpd yet"
    folder: Path | None = None
    set_id: str | None = None
    config: RobotConfig | None = None
    urdf: Urdf | None = None
    joints: list[JointMapping] = field(default_factory=list)  # every movable joint, URDF order
    problems: dict[str, str] = field(default_factory=dict)  # joint -> why its variable is not read


class RobotLive(threading.Thread):
    def __init__(self, viewer_kind: str, irpd_socket: str, events: AgentEvents, rate_hz: float = 30.0):
        super().__init__(name="robot-view", daemon=True)
        self.viewer_kind, self.events, self.period = viewer_kind, events, 1.0 / rate_hz
        self.irpd = IrpdClient(irpd_socket, timeout_s=2.0)
        self.viewer: Viewer | None = None
        self.view = View()
        self._key: tuple | None = None
        self._robot: str | None = None  # robot_identity() of what the viewer shows
        self._checked = -1e9
        self._segment: Segment | None = None
        self._segment_key: tuple | None = None
        self._lock = threading.RLock()
        self._stop_event = threading.Event()
        self._last_error_event = -1e9

    # ---- the thread ------------------------------------------------------------------------
    def run(self) -> None:
        while not self._stop_event.wait(self.period):
            try:
                self.tick()
            except Exception as e:  # noqa: BLE001 -- the view must outlive anything irpd or a viewer does
                now = time.monotonic()
                if now - self._last_error_event > ERROR_EVENT_EVERY_S:
                    self._last_error_event = now
                    self.events.add("agent_error", f"the robot view: {type(e).__name__}: {e}")

    def stop(self) -> None:
        self._stop_event.set()
        if self.is_alive():
            self.join(timeout=10)
        with self._lock:
            if self.viewer is not None:
                self.viewer.close()
                self.viewer = None
            if self._segment is not None:
                self._segment.close()
                self._segment = None
        self.irpd.close()

    def tick(self) -> None:
        with self._lock:
            if time.monotonic() - self._checked >= STATUS_EVERY_S:
                self._check()
            if self.view.available:
                self._move()

    def refresh(self) -> View:
        """Asks irpd now and reloads the robot (after the running set was changed by the agent)."""
        with self._lock:
            self._key = None
            self._check()
            return self.view

    def current(self, max_age_s: float = 2.0) -> View:
        """The view, checked against irpd if the thread has not done so lately (or is not running)."""
        with self._lock:
            if time.monotonic() - self._checked > max_age_s:
                self._check()
            return self.view

    # ---- following the running set ---------------------------------------------------------
    def _check(self) -> None:
        self._checked = time.monotonic()
        try:
            status = self.irpd.request("status")
        except (IrpdUnavailable, IrpdRefused) as e:
            self._key = None
            self.view = View(
                False,
                f"irpd does not answer: {e}",
                self.view.folder,
                self.view.set_id,
                self.view.config,
                self.view.urdf,
                self.view.joints,
            )
            return
        key = (status.get("pid"), status.get("set"), status.get("generation"), status.get("set_id"))
        if key != self._key:
            self._load(status)
            self._key = key

    def _unavailable(self, detail: str, folder: Path | None, set_id: str | None) -> None:
        self._robot = None
        if self.viewer is not None:
            try:
                self.viewer.clear()
            except ViewerError:
                self._drop_viewer()
        self.view = View(False, detail, folder, set_id)

    def _load(self, status: dict) -> None:
        set_path, set_id = status.get("set"), status.get("set_id")
        if not set_path:
            return self._unavailable("irpd runs no set", None, set_id)
        folder = Path(set_path).parent
        robot_json = folder / ROBOT_JSON
        if not robot_json.is_file():
            return self._unavailable(
                f"the running set ({folder}) has no {ROBOT_JSON}: the file that names the robot's URDF and maps "
                "shared variables to its joints (docs/robot-view.md)",
                folder,
                set_id,
            )
        try:
            config = parse_config(robot_json.read_bytes(), str(robot_json))
            urdf = parse(folder / config.urdf, str(folder / config.urdf))
            check_against_urdf(config.joints, urdf, str(robot_json), config.urdf)
        except (MappingError, UrdfError, OSError) as e:
            return self._unavailable(str(e), folder, set_id)
        joints = complete(config.joints, urdf)
        problems = self._check_variables(status, joints)
        robot = robot_identity(robot_json, urdf)
        # A hot reload that leaves the robot as it was (most do: a period, a priority, a module)
        # keeps the scene: no flicker for the viewers, and no scene rebuilt every reload.
        alive = self.viewer is not None and self.viewer.alive()
        keep = robot == self._robot and alive
        if not keep:
            try:
                if not alive:
                    self._drop_viewer()
                    viewer = make_viewer(self.viewer_kind)
                    try:
                        viewer.start()
                    except ViewerError:
                        viewer.close()
                        raise
                    self.viewer = viewer
                self.viewer.load(urdf)
            except ViewerError as e:
                self._drop_viewer()
                return self._unavailable(f"the {self.viewer_kind} viewer: {e}", folder, set_id)
            self._robot = robot
        detail = "; ".join(f"{j}: {p} (held at 0)" for j, p in problems.items()) or None
        self.view = View(True, detail, folder, set_id, config, urdf, joints, problems)
        if not keep:
            self.events.add(
                "robot_view",
                f"the 3D view ({self.viewer_kind}) shows {config.urdf} of {'set ' + set_id if set_id else folder}",
                set_id=set_id,
            )
        self._move()

    def _check_variables(self, status: dict, joints: list[JointMapping]) -> dict[str, str]:
        name = (status.get("shared_memory") or {}).get("variables")
        key = (status.get("pid"), name)
        if key != self._segment_key:
            if self._segment is not None:
                self._segment.close()
            self._segment, self._segment_key = None, key
            if name:
                try:
                    self._segment = Segment(name)
                except VariableError as e:
                    return {j.joint: str(e) for j in joints if j.variable}
        if self._segment is None:
            return {j.joint: "the running set has no shared variables" for j in joints if j.variable}
        out = {}
        for j in joints:
            if j.variable is not None:
                seg = self._segment
                problem = number_problem(j.variable, seg.leaves, seg.scalars, unknown=seg.unknown)
                if problem:
                    out[j.joint] = problem
        return out

    # ---- moving ----------------------------------------------------------------------------
    def _move(self) -> None:
        view = self.view
        values = {}
        if self._segment is not None:
            for j in view.joints:
                if j.variable is not None and j.joint not in view.problems:
                    try:
                        values[j.variable] = self._segment.read(j.variable)
                    except VariableError:
                        pass
        positions = RobotConfig(view.config.urdf, view.joints).positions(values)
        try:
            self.viewer.set_joints(positions)
        except ViewerError as e:
            self._drop_viewer()
            self._key = None  # start a new viewer and load the robot again at the next check
            self.view = View(False, f"the {self.viewer_kind} viewer: {e}", view.folder, view.set_id)

    def _drop_viewer(self) -> None:
        if self.viewer is not None:
            try:
                self.viewer.close()
            except Exception:  # noqa: BLE001 -- it is going away anyway
                pass
            self.viewer = None

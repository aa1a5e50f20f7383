"""viser_view.py -- the viser backend (the default): a ViserServer inside the agent's process (its
own thread and event loop) on 127.0.0.1, the robot drawn by viser.extras.ViserUrdf from the URDF
(yourdfpy: primitives and mesh files), moved with update_cfg.  viser's page builds its WebSocket
URL from its own address (ws + the page's URL without the query and the trailing slash), so it
works under the agent's /api/v1/robot/viewer/ as it is.  Share links (a tunnel to viser's public
relay) are turned off: the view never leaves the machine except through the agent."""

from __future__ import annotations

import contextlib
import io
import threading

import numpy as np

from .base import Viewer, ViewerError
from .urdf import Urdf


@contextlib.contextmanager
def _quiet():
    """viser prints a banner and 'server stopped' on stdout with rich; the agent's stdout is its log."""
    with contextlib.redirect_stdout(io.StringIO()):
        yield


class ViserViewer(Viewer):
    kind = "viser"

    def __init__(self):
        self.server = None
        self._robot = None
        self._names: tuple[str, ...] = ()
        self._last: tuple | None = None
        self._lock = threading.Lock()

    def start(self) -> None:
        try:
            import viser
        except ImportError as e:  # pragma: no cover -- a missing install
            raise ViewerError(f"the viser viewer is not installed ({e}); pip install viser yourdfpy") from e
        try:
            with _quiet():
                server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
        except Exception as e:  # noqa: BLE001 -- whatever keeps it from listening
            raise ViewerError(f"viser could not start: {e}") from e
        server.request_share_url = lambda *args, **kwargs: None  # no public share tunnel, ever
        server.gui.configure_theme(show_logo=False, show_share_button=False)
        server.gui.main_panel.dock_right()
        server.gui.main_panel.minimize()  # the view first; the scene tree and settings one click away
        server.scene.add_grid("/ground", width=2.0, height=2.0, cell_size=0.1, section_size=0.5)
        server.initial_camera.position = (1.7, -1.5, 1.3)
        server.initial_camera.look_at = (0.3, 0.0, 0.45)
        self.server = server

    @property
    def port(self) -> int:
        if self.server is None:
            raise ViewerError("the viser viewer is not started")
        return self.server.get_port()

    def load(self, urdf: Urdf) -> None:
        from viser.extras import ViserUrdf

        if urdf.path is None:
            raise ViewerError("the viser viewer loads a URDF from its file")
        with self._lock:
            self._remove()
            with _quiet():
                self._robot = ViserUrdf(self.server, urdf.path, root_node_name="/robot")
            self._names = tuple(self._robot.get_actuated_joint_names())
            self._last = None
        self.set_joints({})

    def set_joints(self, positions: dict[str, float]) -> None:
        with self._lock:
            if self._robot is None:
                return
            previous = dict(zip(self._names, self._last)) if self._last else {}
            cfg = tuple(float(positions.get(n, previous.get(n, 0.0))) for n in self._names)
            if cfg == self._last:
                return
            with self.server.atomic():
                self._robot.update_cfg(np.array(cfg))
            self._last = cfg

    def _remove(self) -> None:
        if self._robot is not None:
            self._robot.remove()
            self._robot = None

    def clear(self) -> None:
        with self._lock:
            self._remove()

    def close(self) -> None:
        if self.server is not None:
            with _quiet():
                self.server.stop()
            self.server = None

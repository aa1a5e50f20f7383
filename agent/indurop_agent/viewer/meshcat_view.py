"""meshcat_view.py -- the meshcat backend: meshcat's server as a child process on 127.0.0.1
(meshcat_server.py), driven over ZeroMQ with meshcat's own commands.  The scene is built here from
the URDF's visuals (box, cylinder, sphere; .stl/.obj/.dae files inside the set), one node per
link, and each update sends the links' world poses from our forward kinematics (urdf.py), only
those that moved.  meshcat's page connects to ws://<host>/ (the server's root), which cannot work
under a subpath: the proxy hands the browser the page with the WebSocket URL it must use."""

from __future__ import annotations

import subprocess
import sys
import threading
from pathlib import Path

import numpy as np

from .base import Viewer, ViewerError, free_port
from .urdf import Urdf, Visual, homogeneous, rotation

ROOT = ("meshcat", "robot")
REPLY_TIMEOUT_MS = 3000
START_TIMEOUT_S = 30.0
# meshcat's page: viewer.connect() without a URL means ws://<host>/.  Through the proxy, the
# WebSocket is at the page's own URL without its query and trailing slash (as viser does it).
CONNECT = b"viewer.connect();"
CONNECT_HERE = b"viewer.connect(location.href.split(/[?#]/)[0].replace(/^http/, 'ws').replace(/\\/$/, ''));"
# The camera, from the front right and above, orbiting the base (meshcat's camera frame is
# three.js's, y up: world (x, y, z) is (x, -z, y) there; its orbit controls turn about the origin).
CAMERA_POSITION = [1.6, 1.0, 1.6]
# three.js cylinders stand along y; URDF's along z.
CYLINDER_UP = homogeneous(rotation(np.array([1.0, 0, 0]), np.pi / 2), np.zeros(3))


def _rgb(rgba) -> int:
    r, g, b = (max(0, min(255, round(c * 255))) for c in rgba[:3])
    return (r << 16) | (g << 8) | b


class MeshcatViewer(Viewer):
    kind = "meshcat"

    def __init__(self):
        self.proc: subprocess.Popen | None = None
        self._port = 0
        self._zmq = None
        self._urdf: Urdf | None = None
        self._shown: dict[str, np.ndarray] = {}  # link -> the pose last sent
        self._positions: dict[str, float] = {}
        self._lock = threading.Lock()

    # ---- the server ------------------------------------------------------------------------
    def start(self) -> None:
        try:
            import meshcat  # noqa: F401 -- the commands and geometry below
            import zmq
        except ImportError as e:  # pragma: no cover -- a missing install
            raise ViewerError(f"the meshcat viewer is not installed ({e}); pip install meshcat") from e
        last = "no attempt"
        for _ in range(3):  # a port taken between choosing it and binding it: choose again
            zmq_port, web_port = free_port(), free_port()
            proc = subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "indurop_agent.viewer.meshcat_server",
                    "--zmq-port",
                    str(zmq_port),
                    "--web-port",
                    str(web_port),
                ],
                cwd=Path(__file__).resolve().parents[2],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.DEVNULL,
                text=True,
            )
            line = self._first_line(proc)
            if line == "ready":
                self.proc, self._port = proc, web_port
                context = zmq.Context.instance()
                sock = context.socket(zmq.REQ)
                for option, value in (
                    (zmq.RCVTIMEO, REPLY_TIMEOUT_MS),
                    (zmq.SNDTIMEO, REPLY_TIMEOUT_MS),
                    (zmq.LINGER, 0),
                ):
                    sock.setsockopt(option, value)
                sock.connect(f"tcp://127.0.0.1:{zmq_port}")
                self._zmq = sock
                return
            last = line or f"exited with {proc.poll()}"
            self._stop(proc)
        raise ViewerError(f"the meshcat server did not start: {last}")

    @staticmethod
    def _first_line(proc: subprocess.Popen) -> str:
        got: list[str] = []
        reader = threading.Thread(target=lambda: got.append(proc.stdout.readline().strip()), daemon=True)
        reader.start()
        reader.join(START_TIMEOUT_S)
        return got[0] if got else f"no answer within {START_TIMEOUT_S:g} s"

    @staticmethod
    def _stop(proc: subprocess.Popen) -> None:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(5)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        for f in (proc.stdin, proc.stdout):
            if f:
                f.close()

    @property
    def port(self) -> int:
        if not self._port:
            raise ViewerError("the meshcat viewer is not started")
        return self._port

    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def http_path(self, subpath: str) -> str:
        return "/static/" + subpath

    def rewrite(self, subpath: str, body: bytes) -> bytes:
        if subpath in ("", "index.html"):
            if CONNECT not in body:
                raise ViewerError("meshcat's page has changed: it no longer calls viewer.connect()")
            return body.replace(CONNECT, CONNECT_HERE)
        return body

    def _send(self, command) -> None:
        import umsgpack
        import zmq

        data = command.lower()
        try:
            self._zmq.send_multipart([data["type"].encode(), data["path"].encode(), umsgpack.packb(data)])
            self._zmq.recv()
        except zmq.ZMQError as e:
            raise ViewerError(f"the meshcat server stopped answering: {e}") from e

    # ---- the scene -------------------------------------------------------------------------
    def _path(self, *parts: str, root: tuple[str, ...] = ROOT):
        from meshcat.path import Path as MeshcatPath

        return MeshcatPath(root + parts)

    def _geometry(self, v: Visual, base: Path | None):
        import meshcat.geometry as g

        if v.shape == "box":
            return g.Box(list(v.size)), np.eye(4)
        if v.shape == "sphere":
            return g.Sphere(v.size[0]), np.eye(4)
        if v.shape == "cylinder":
            return g.Cylinder(v.size[1], v.size[0]), CYLINDER_UP
        name = v.filename or ""
        if name.startswith("file://"):
            name = name[len("file://") :]
        if base is None or "://" in name or name.startswith("/"):
            return None, None  # package:// and absolute paths name files outside the set
        path = (base / name).resolve()
        if not path.is_relative_to(base.resolve()) or not path.is_file():
            return None, None
        loader = {".stl": g.StlMeshGeometry, ".obj": g.ObjMeshGeometry, ".dae": g.DaeMeshGeometry}.get(
            path.suffix.lower()
        )
        if loader is None:
            return None, None
        return loader.from_file(str(path)), np.diag([*v.size, 1.0])

    def load(self, urdf: Urdf) -> None:
        import meshcat.commands as c
        import meshcat.geometry as g

        base = urdf.path.parent if urdf.path else None
        with self._lock:
            self._send(c.Delete(self._path()))
            self._send(
                c.SetProperty(
                    "position", CAMERA_POSITION, self._path(root=("Cameras", "default", "rotated", "<object>"))
                )
            )
            self._urdf, self._shown = urdf, {}
            self._positions = {j.name: 0.0 for j in urdf.movable_joints()}
            for i, v in enumerate(urdf.visuals):
                geometry, fix = self._geometry(v, base)
                if geometry is None:
                    continue  # a mesh the view cannot load: the link is drawn without it
                material = g.MeshLambertMaterial(color=_rgb(v.rgba), opacity=v.rgba[3], transparent=v.rgba[3] < 1)
                path = self._path(v.link, f"visual_{i}")
                self._send(c.SetObject(geometry, material, path))
                self._send(c.SetTransform(v.origin @ fix, path))
            self._move()

    def set_joints(self, positions: dict[str, float]) -> None:
        with self._lock:
            if self._urdf is None:
                return
            self._positions.update({k: float(v) for k, v in positions.items() if k in self._positions})
            self._move()

    def _move(self) -> None:
        import meshcat.commands as c

        for link, pose in self._urdf.fk(self._positions).items():
            last = self._shown.get(link)
            if last is None or not np.array_equal(last, pose):
                self._send(c.SetTransform(pose, self._path(link)))
                self._shown[link] = pose

    def clear(self) -> None:
        import meshcat.commands as c

        with self._lock:
            if self._urdf is not None:
                self._send(c.Delete(self._path()))
            self._urdf, self._shown = None, {}

    def close(self) -> None:
        with self._lock:
            if self._zmq is not None:
                self._zmq.close(linger=0)
                self._zmq = None
            if self.proc is not None:
                self._stop(self.proc)
                self.proc = None
            self._port = 0

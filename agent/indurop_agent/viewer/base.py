"""base.py -- what the agent asks of a 3D viewer: start its own server on 127.0.0.1, show a URDF,
move its joints, and tell the reverse proxy (api/routes/robot.py) where its page and its
WebSocket are, so the browser reaches it through the agent's port only.  Backends: viser_view.py
(the default) and meshcat_view.py."""

from __future__ import annotations

import socket
from abc import ABC, abstractmethod

from .urdf import Urdf


class ViewerError(Exception):
    """The viewer could not start, or its server stopped answering."""


class Viewer(ABC):
    kind: str = ""
    ws_path: str = "/"  # where the viewer's own server takes its WebSocket

    @abstractmethod
    def start(self) -> None:
        """Starts the viewer's server on a free port of 127.0.0.1 (ViewerError if it cannot)."""

    @abstractmethod
    def load(self, urdf: Urdf) -> None:
        """Shows `urdf` (parsed from a file: its meshes are looked up beside it) at zero joints,
        replacing the robot shown before."""

    @abstractmethod
    def set_joints(self, positions: dict[str, float]) -> None:
        """Moves the robot: joint name -> position (rad or m); joints left out stay where they are."""

    @abstractmethod
    def clear(self) -> None:
        """Removes the robot (the running set has none)."""

    @abstractmethod
    def close(self) -> None:
        """Stops the server and everything it started."""

    @property
    @abstractmethod
    def port(self) -> int:
        """The viewer server's TCP port on 127.0.0.1."""

    def alive(self) -> bool:
        return True

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def http_path(self, subpath: str) -> str:
        """The viewer server's path for the file `subpath` of the proxied viewer folder."""
        return "/" + subpath

    def rewrite(self, subpath: str, body: bytes) -> bytes:
        """The file as the browser gets it through the proxy (a page may need to learn its subpath)."""
        return body


def free_port() -> int:
    """A TCP port of 127.0.0.1 free right now (a server that then fails to bind it is retried)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]

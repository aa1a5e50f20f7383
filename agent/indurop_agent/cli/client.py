"""client.py -- the Python client of the agent's API (/api/v1): REST calls and the sample stream.

    from indurop_agent.cli.client import Client
    c = Client("http://127.0.0.1:8080", token=open("build/demo-data/admin-token").read().strip())
    print(c.status()["cycles"], c.read("knu.Robot.tick"))
    with c.watch(["knu.Robot.tick"], decimation=10) as samples:
        for seq, t_ns, values in samples: ...

Synchronous (httpx; `websockets` for the stream).  Every failure is an `ApiError(status, message)`
whose message is the server's `detail`; status 0 means no answer at all (agent unreachable).
The binary stream frame is decoded by `decode_frame` (stream_frame.py; format in
docs/trace-and-stream.md §4).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import re
import ssl
import threading
import time
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, BinaryIO
from urllib.parse import quote, urlsplit, urlunsplit

import httpx

from ..api.stream_frame import HEADER_SIZE, KIND_SAMPLES, MAGIC, VERSION, Frame, decode, encode, kind
from .client_errors import ApiError, refused
from .client_record import RecordCalls
from .client_system import LONG_TIMEOUT_S, SystemCalls

API = "/api/v1"

# The stream's binary frame (docs/trace-and-stream.md §4): coded once, in stream_frame.py.
FRAME_MAGIC, FRAME_VERSION, FRAME_SAMPLES = MAGIC, VERSION, KIND_SAMPLES
FRAME_HEADER_SIZE = HEADER_SIZE


def decode_frame(data) -> Frame:
    """Decodes one binary sample frame; raises ValueError naming what is wrong with it."""
    return decode(data)


def encode_frame(first_seq: int, t_ns: list[int], columns: list[list[float]], dropped: int = 0) -> bytes:
    """The inverse of decode_frame (tests, and servers written in Python)."""
    return encode(first_seq, t_ns, columns, dropped)


_FLOAT_TYPES = {"float", "double", "real", "lreal", "float32", "float64", "f32", "f64"}


def _typed(value: float, type_name: str):
    """Stream values travel as doubles; integers and bools are given back as such."""
    t = (type_name or "").lower()
    if t == "bool":
        return bool(value)
    if t in _FLOAT_TYPES or not float(value).is_integer():
        return value
    return int(value)


def _archive_name(path: Path) -> bool:
    return path.name.endswith((".tar.gz", ".tgz"))


class Client(SystemCalls, RecordCalls):
    """The agent's API (the System page's calls: client_system.py; the recorder's: client_record.py).  url: "http://host:port" (with or without /api/v1); token: a bearer token;
    ca: a CA file for https; verify=False accepts any certificate; timeout in seconds; transport:
    an httpx transport (tests)."""

    def __init__(
        self,
        url: str = "http://127.0.0.1:8080",
        token: str | None = None,
        *,
        ca: str | os.PathLike | None = None,
        verify: bool = True,
        timeout: float = 10.0,
        transport: httpx.BaseTransport | None = None,
    ):
        url = url.rstrip("/")
        if not url.endswith(API):
            url += API
        parts = urlsplit(url)
        if parts.scheme not in ("http", "https") or not parts.netloc:
            raise ValueError(f"{url!r} is not an agent's URL: give http://HOST:PORT or https://HOST:PORT")
        self.url = url
        self.token = token
        self.timeout = timeout
        if ca is not None:
            self._ssl: ssl.SSLContext | bool = ssl.create_default_context(cafile=str(ca))
        elif not verify:
            self._ssl = False
        else:
            self._ssl = True
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        self._http = httpx.Client(base_url=url, headers=headers, timeout=timeout, verify=self._ssl, transport=transport)

    def close(self) -> None:
        self._http.close()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- plumbing ---------------------------------------------------------------------------------
    def _send(self, method: str, path: str, *, timeout: float | None = None, **kwargs) -> httpx.Response:
        """One API call (path under /api/v1); the response, or ApiError."""
        try:
            r = self._http.request(method, path, timeout=timeout or self.timeout, **kwargs)
        except httpx.TimeoutException as e:
            raise ApiError(0, f"the agent at {self.url} did not answer {method} {path} in time ({e})") from e
        except httpx.HTTPError as e:
            raise ApiError(0, f"cannot reach the agent at {self.url}: {e}") from e
        if r.status_code >= 400:
            raise refused(r)
        return r

    def request(self, method: str, path: str, *, timeout: float | None = None, **kwargs) -> Any:
        """One API call (path under /api/v1); the answer's JSON, or ApiError."""
        r = self._send(method, path, timeout=timeout, **kwargs)
        if not r.content:
            return None
        try:
            return r.json()
        except ValueError as e:
            raise ApiError(r.status_code, f"{method} {path}: the answer is not JSON") from e

    def get(self, path: str, **params) -> Any:
        return self.request("GET", path, params={k: v for k, v in params.items() if v is not None} or None)

    def download(self, path: str, params, target, default: str, what: str = "download") -> Path:
        """Streams GET `path` to `target` (a file, or a folder for the name the agent gives, `default`
        without one; default the current folder), through a `.part` file renamed when complete;
        returns the file written.  A .zip (several files came) keeps its suffix."""
        try:
            with self._http.stream("GET", path, params=params, timeout=httpx.Timeout(LONG_TIMEOUT_S)) as r:
                if r.status_code >= 400:
                    r.read()
                    raise refused(r)
                named = re.search(r'filename="?([^";]+)"?', r.headers.get("content-disposition", ""))
                name = os.path.basename(named.group(1)) if named else default
                out = Path(target) if target is not None else Path(name)
                if out.is_dir():
                    out = out / name
                elif Path(name).suffix != out.suffix and Path(name).suffix == ".zip":
                    out = out.with_suffix(".zip")  # several files came: not an .mcap, whatever it was to be called
                partial = out.with_name(out.name + ".part")
                with open(partial, "wb") as f:
                    for chunk in r.iter_bytes(1 << 20):
                        f.write(chunk)
                os.replace(partial, out)
                return out
        except httpx.HTTPError as e:
            raise ApiError(0, f"the {what} from {self.url} broke: {e}") from e

    # -- the running set --------------------------------------------------------------------------
    def health(self) -> dict:
        return self.get("/health")

    def status(self) -> dict:
        return self.get("/status")

    def schedule(self) -> dict:
        return self.get("/schedule")

    def modules(self) -> list[dict]:
        return self.get("/modules")

    def module(self, name: str) -> dict:
        return self.get(f"/modules/{quote(name, safe='')}")

    def patch_module(
        self, name: str, period_ns: int | None = None, priority: int | None = None, enabled: bool | None = None
    ) -> dict:
        """Changes a module of the running set (hot reload); the swap report."""
        body = {
            k: v for k, v in (("period_ns", period_ns), ("priority", priority), ("enabled", enabled)) if v is not None
        }
        if not body:
            raise ValueError("patch_module needs at least one of period_ns, priority, enabled")
        return self.request("PATCH", f"/modules/{quote(name, safe='')}", json=body, timeout=max(self.timeout, 60))

    def jitter(self) -> dict:
        return self.get("/jitter")

    # -- module sets ------------------------------------------------------------------------------
    def upload(
        self, source: str | os.PathLike | Iterable[str | os.PathLike], root: str | os.PathLike | None = None
    ) -> dict:
        """Uploads a module set: a directory (every file under it but hidden ones), a .tar.gz, or a
        list of files (named relative to `root`, by default their common folder).  The answer has
        the set's id, its files and the validation report."""
        files = [Path(source)] if isinstance(source, (str, os.PathLike)) else [Path(p) for p in source]
        if not files:
            raise ValueError("nothing to upload: give a directory, a .tar.gz or files")
        if len(files) == 1 and files[0].is_file() and _archive_name(files[0]):
            with open(files[0], "rb") as f:
                return self.request(
                    "POST",
                    "/sets",
                    files=[("archive", (files[0].name, f, "application/gzip"))],
                    timeout=max(self.timeout, 120),
                )
        named = set_files(files, root)
        opened: list[BinaryIO] = []
        try:
            parts = []
            for name, path in named:
                f = open(path, "rb")
                opened.append(f)
                parts.append(("files", (name, f, "application/octet-stream")))
            return self.request("POST", "/sets", files=parts, timeout=max(self.timeout, 120))
        finally:
            for f in opened:
                f.close()

    def sets(self) -> list[dict]:
        return self.get("/sets")

    def set(self, set_id: str) -> dict:
        return self.get(f"/sets/{quote(set_id, safe='')}")

    def active_set(self) -> dict:
        return self.get("/sets/active")

    def check(self, set_id: str) -> dict:
        """irpd checks the stored set again against what runs now (the dry run of an activation); the
        set with that validation: online or why only a restart can, the variables and the modules
        it would keep, start, stop and replace."""
        return self.request("POST", f"/sets/{quote(set_id, safe='')}/check", timeout=max(self.timeout, 90))

    def activate(self, set_id: str, mode: str = "online") -> dict:
        """Puts the set into irpd: mode online (hot reload), restart (irpd restarts onto it) or auto
        (a restart only when irpd cannot take it online); the swap report (mode, downtime_ns)."""
        return self.request(
            "POST", f"/sets/{quote(set_id, safe='')}/activate", json={"mode": mode}, timeout=max(self.timeout, 90)
        )

    def rollback(self, mode: str = "online") -> dict:
        """Activates the set that was active before the current one; the swap report."""
        return self.request("POST", "/sets/rollback", json={"mode": mode}, timeout=max(self.timeout, 90))

    # -- variables, events, audit -----------------------------------------------------------------
    def variables(self) -> dict:
        return self.get("/variables")

    def layout(self) -> str:
        """The running layout.json as irpd published it (for glbc --previous)."""
        return self._send("GET", "/layout").text

    def variable(self, path: str) -> dict:
        """GET /variables/{path} as the agent answers it: {"path", "value", "layout_hash"} for a leaf,
        {"path", "values": [{"path", "type", "value"}], "layout_hash"} for a group (a namespace, a
        struct, an array or one of its elements)."""
        return self.get(f"/variables/{quote(path, safe='')}")

    def read(self, path: str) -> Any:
        """The value of a shared variable, e.g. read("joint[1].y"); for a group, {leaf path: value}
        of every leaf under it, e.g. read("joint[1]") -> {"joint[1].x": ..., "joint[1].y": ...}."""
        answer = self.variable(path)
        return answer["value"] if "value" in answer else {v["path"]: v["value"] for v in answer["values"]}

    def write(self, path: str, value: float | int | bool) -> Any:
        """Writes a shared variable; the value as irpd stored it."""
        if not isinstance(value, (bool, int, float)):
            raise ValueError(f"a variable takes a number or a bool, not {type(value).__name__}")
        return self.request("PUT", f"/variables/{quote(path, safe='')}", json={"value": value})["value"]

    def events(self, since: int = 0, limit: int | None = None, agent_since: int | None = None) -> dict:
        """irpd's and the agent's events merged by time: {"events": [...], "next", "agent_next",
        "dropped"}; ask again with since=next, agent_since=agent_next for the newer ones."""
        return self.get("/events", since=since, agent_since=agent_since, limit=limit)

    # -- alarms (docs/alarms.md) -----------------------------------------------------------------
    def alarms(self) -> dict:
        """The alarms that need attention or are shelved, the counts, the newest one."""
        return self.get("/alarms")

    def alarm_history(self, **filters) -> dict:
        """Transitions, newest first: {"transitions", "total", "offset", "limit"}; filters are
        since, until (ISO 8601), module, key, severity, state, after (a seq), limit, offset."""
        return self.get("/alarms/history", **filters)

    def acknowledge(self, key: str) -> dict:
        """Acknowledges alarm `key` (e.g. "PLC/8"; operator); its state afterwards."""
        return self.request("POST", f"/alarms/{quote(key, safe='')}/ack")

    def acknowledge_all(self, module: str | None = None) -> dict:
        """Acknowledges every unacknowledged alarm (of `module`); {"acknowledged": keys, "counts"}."""
        return self.request("POST", "/alarms/ack", json={"module": module} if module else None)

    def shelve(self, key: str, minutes: float, reason: str) -> dict:
        return self.request(
            "POST", f"/alarms/{quote(key, safe='')}/shelve", json={"minutes": minutes, "reason": reason}
        )

    def unshelve(self, key: str) -> dict:
        return self.request("POST", f"/alarms/{quote(key, safe='')}/unshelve")

    def audit(self, limit: int | None = None) -> list[dict]:
        return self.get("/audit", limit=limit)

    def create_token(self, name: str, role: str, owner: str | None = None) -> str:
        """A new token (shown only now) for `role`, belonging to `owner` (default: the caller's user)."""
        body = {"name": name, "role": role, **({"owner": owner} if owner else {})}
        return self.request("POST", "/tokens", json=body)["token"]

    # -- users (docs/administration.md) ----------------------------------------------------------
    def users(self) -> list[dict]:
        return self.get("/users")

    def user(self, name: str) -> dict:
        return self.get(f"/users/{quote(name, safe='')}")

    def add_user(self, name: str, role: str, password: str) -> dict:
        return self.request("POST", "/users", json={"name": name, "role": role, "password": password})

    def change_user(self, name: str, role: str | None = None, disabled: bool | None = None) -> dict:
        """An admin's change: the role, or disabled (tokens revoked, sessions ended) or enabled."""
        body = {k: v for k, v in (("role", role), ("disabled", disabled)) if v is not None}
        return self.request("PATCH", f"/users/{quote(name, safe='')}", json=body)

    def set_password(self, name: str, password: str, current: str | None = None) -> None:
        """One's own new password (give `current`), or an admin's reset of another user's."""
        body = {"password": password, **({"current_password": current} if current is not None else {})}
        self.request("PUT", f"/users/{quote(name, safe='')}/password", json=body)

    def user_tokens(self, name: str) -> list[dict]:
        return self.get(f"/users/{quote(name, safe='')}/tokens")

    # -- the stream -------------------------------------------------------------------------------
    def watch(self, paths: Iterable[str], decimation: int = 1, seconds: float | None = None) -> Stream:
        """The samples of `paths` (every `decimation`-th basic period) as an iterator of
        (seq, t_ns, {path: value}), ending after `seconds` if given; `.dropped` counts the
        samples the server lost."""
        return Stream(self, list(paths), decimation, seconds)

    stream = watch

    def _stream_url(self) -> str:
        parts = urlsplit(self.url)
        scheme = "wss" if parts.scheme == "https" else "ws"
        return urlunsplit((scheme, parts.netloc, parts.path + "/stream", "", ""))

    def _stream_headers(self) -> dict[str, str]:
        """The token goes in the handshake's Authorization header, never in the URL."""
        return {"Authorization": f"Bearer {self.token}"} if self.token else {}

    def _stream_ssl(self) -> ssl.SSLContext | None:
        if not self.url.startswith("https"):
            return None
        if isinstance(self._ssl, ssl.SSLContext):
            return self._ssl
        ctx = ssl.create_default_context()
        if self._ssl is False:
            ctx.check_hostname = False
            ctx.verify_mode = ssl.CERT_NONE
        return ctx


def set_files(paths: list[Path], root: str | os.PathLike | None = None) -> list[tuple[str, Path]]:
    """(name relative to the set root, file) for every file to upload: a directory gives every file
    under it (hidden ones left out), files are named relative to `root` or their common folder."""
    if len(paths) == 1 and paths[0].is_dir():
        base = paths[0]
        found = sorted(
            p
            for p in base.rglob("*")
            if p.is_file() and not any(part.startswith(".") for part in p.relative_to(base).parts)
        )
        if not found:
            raise ValueError(f"{base} has no files to upload")
        return [(p.relative_to(base).as_posix(), p) for p in found]
    for p in paths:
        if not p.is_file():
            raise ValueError(f"{p}: no such file (give a set folder, a .tar.gz, or the set's files)")
    absolute = [Path(os.path.abspath(p)) for p in paths]  # symbolic links are sent as the files they point to
    base = Path(os.path.abspath(root)) if root is not None else Path(os.path.commonpath([p.parent for p in absolute]))
    named = []
    for p, a in zip(paths, absolute):
        try:
            named.append((a.relative_to(base).as_posix(), p))
        except ValueError:
            raise ValueError(f"{p} is not under the set root {base}") from None
    return named


class Stream:
    """A WebSocket subscription to /api/v1/stream; iterate it for (seq, t_ns, {path: value}).
    Use it in a `with` block, or call close().

    The connection lives on an event loop of its own thread: one thread reads, writes and closes
    it.  An SSL socket must not be read in one thread while another writes or closes it (OpenSSL's
    SSL object is not thread-safe), which a threaded WebSocket client does under wss://."""

    def __init__(self, client: Client, paths: list[str], decimation: int = 1, seconds: float | None = None):
        if not paths:
            raise ValueError("watch needs at least one variable path")
        if int(decimation) < 1:
            raise ValueError(f"decimation {decimation}: give 1 (every sample) or more")
        self.client = client
        self.paths = paths
        self.decimation = int(decimation)
        self.channels: list[dict] = []  # the server's {"index", "path", "type"} per channel
        self.dropped = 0  # samples the server lost since the stream began (its counter)
        self.seconds = seconds
        self._until: float | None = None
        self._ws = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None

    def _call(self, awaitable):
        """Awaits on the stream's loop and gives the result (or raises the exception)."""
        if self._loop is None:
            self._loop = asyncio.new_event_loop()
            self._thread = threading.Thread(target=self._loop.run_forever, name="irp-stream", daemon=True)
            self._thread.start()

        async def result():
            return await awaitable

        return asyncio.run_coroutine_threadsafe(result(), self._loop).result()

    def _stop_loop(self) -> None:
        loop, thread, self._loop, self._thread = self._loop, self._thread, None, None
        if loop is None:
            return
        loop.call_soon_threadsafe(loop.stop)
        if thread is not None:
            thread.join()
        loop.close()

    def _connect(self):
        from websockets.asyncio.client import connect
        from websockets.exceptions import ConnectionClosed, InvalidHandshake, InvalidStatus

        url = self.client._stream_url()
        try:
            # A deep queue: reading is not paused while the reader is busy, so a close is answered at once.
            ws = self._call(
                connect(
                    url,
                    additional_headers=self.client._stream_headers(),
                    ssl=self.client._stream_ssl(),
                    open_timeout=self.client.timeout,
                    max_size=None,
                    max_queue=4096,
                    compression=None,
                )
            )
        except InvalidStatus as e:
            self._stop_loop()
            response = e.response
            try:
                message = json.loads(response.body or b"{}").get("detail")
            except (ValueError, AttributeError):
                message = (response.body or b"").decode(errors="replace").strip()
            if not message and response.status_code == 403:  # what a server without the route answers too
                message = "the agent refused the WebSocket: the token, or an agent without /api/v1/stream"
            raise ApiError(response.status_code, f"stream: {message or response.reason_phrase}") from e
        except (OSError, TimeoutError, InvalidHandshake) as e:
            self._stop_loop()
            raise ApiError(0, f"cannot open the stream at {url.split('?')[0]}: {e}") from e
        try:
            self._call(ws.send(json.dumps({"subscribe": self.paths, "decimation": self.decimation})))
        except ConnectionClosed as e:  # refused right after the handshake
            self._ws = ws
            self.close()
            _raise_for_close(e)
        return ws

    def __enter__(self) -> Stream:
        if self._ws is None:
            self._ws = self._connect()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Closes the WebSocket (the closing handshake, at most the client's timeout) and its loop."""
        ws, self._ws = self._ws, None
        if ws is not None:
            with contextlib.suppress(Exception):
                self._call(asyncio.wait_for(ws.close(), self.client.timeout))
        self._stop_loop()

    def _recv(self, timeout: float | None):
        """The next message, or None when `timeout` seconds pass without one."""
        ws = self._ws

        async def receive():
            try:
                return await asyncio.wait_for(ws.recv(), timeout)
            except TimeoutError:
                return None

        return self._call(receive())

    def __iter__(self) -> Iterator[tuple[int, int, dict[str, Any]]]:
        for frame in self.frames():
            names = [(c.get("path", f"#{i}"), c.get("type", "")) for i, c in enumerate(self.channels)]
            if len(names) != len(frame.columns):
                raise ApiError(
                    502, f"stream: a frame has {len(frame.columns)} channels, the server announced {len(names)}"
                )
            for seq, t, values in frame.samples():
                yield seq, t, {name: _typed(v, kind) for (name, kind), v in zip(names, values)}

    def frames(self) -> Iterator[Frame]:
        """The decoded sample frames as they come (columns, for plots and bulk export)."""
        from websockets.exceptions import ConnectionClosed

        if self._ws is None:
            self._ws = self._connect()
        if self.seconds is not None and self._until is None:
            self._until = time.monotonic() + self.seconds
        try:
            while True:
                left = None if self._until is None else self._until - time.monotonic()
                if left is not None and left <= 0:
                    return
                try:
                    message = self._recv(left)
                except ConnectionClosed as e:
                    _raise_for_close(e)
                    return
                if message is None:
                    return  # the seconds asked have passed
                if isinstance(message, str):
                    self._control(message)
                    continue
                if kind(message) not in (None, FRAME_SAMPLES):
                    continue  # a frame kind of a newer server: not ours to read
                try:
                    frame = decode_frame(message)
                except ValueError as e:
                    raise ApiError(502, f"stream: {e}") from e
                self.dropped = frame.dropped
                yield frame
        finally:
            self.close()  # the stream ended, failed, or its reader left

    def _control(self, text: str) -> None:
        try:
            message = json.loads(text)
        except ValueError:
            return
        if not isinstance(message, dict):
            return
        if "error" in message:
            raise ApiError(int(message.get("status", 400)), f"stream: {message['error']}")
        if "channels" in message:
            self.channels = sorted(message["channels"], key=lambda c: c.get("index", 0))
        if "dropped" in message:
            self.dropped = int(message["dropped"])


def _raise_for_close(e) -> None:
    """A normal close ends the stream; a refusal (1008, or 4000 + an HTTP status) is an ApiError."""
    frame = getattr(e, "rcvd", None)
    code = frame.code if frame is not None else 1006
    reason = (frame.reason if frame is not None else "") or "the connection closed"
    if code in (1000, 1001):
        return
    if code == 1008:
        raise ApiError(403, f"stream: {reason}")
    if 4400 <= code < 4600:
        raise ApiError(code - 4000, f"stream: {reason}")
    raise ApiError(0, f"stream: closed ({code}) {reason}")

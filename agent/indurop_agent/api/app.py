"""app.py -- the FastAPI application: routers under /api/v1, the built web UI at /, and in
app.state the irpd clients, users, tokens, browser sessions, the lockouts, the set store, the
activator, the audit log, the agent's events and the host-load sampler.  While the app runs, a
watcher restores the active set into a (re)started irpd (activation.py), and the robot view follows
the running set's robot (viewer/live.py), the alarm watcher keeps the alarms current
(alarms/watcher.py), the recorder writes the running recordings (recorder/manager.py) and the
capture engine runs the triggered captures (recorder/capture_engine.py)."""

from __future__ import annotations

import math
import threading
from contextlib import asynccontextmanager
from pathlib import Path

from argon2 import PasswordHasher
from fastapi import FastAPI, HTTPException, Request
from fastapi.encoders import jsonable_encoder
from fastapi.exception_handlers import http_exception_handler
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from fastapi.staticfiles import StaticFiles
from starlette.exceptions import HTTPException as StarletteHTTPException

from .. import __version__
from ..access.audit import AuditLog
from ..access.auth import TokenStore
from ..access.refusals import RefusalAudit
from ..access.security import BodyLimitMiddleware, BodyTimeoutMiddleware, Lockout
from ..access.sessions import SessionStore
from ..access.users import UserStore
from ..alarms.manager import AlarmManager
from ..alarms.store import AlarmStore
from ..alarms.system import SystemAlarms, Thresholds
from ..alarms.watcher import AlarmWatcher
from ..config import Settings, default_webui_dir
from ..events import AgentEvents
from ..irpd.client import IrpdClient
from ..opcua.link import ensure_token
from ..recorder.capture_engine import CaptureEngine
from ..recorder.capture_files import CaptureFiles
from ..recorder.manager import Recorder
from ..recorder.scope_configs import ScopeConfigs
from ..recorder.store import Store
from ..sets.activation import Activator, Restorer
from ..sets.errors import LocatedError, located_error
from ..sets.store import SetStore
from ..sets.watch_lists import WatchLists
from ..system.host import Sampler
from ..system.restart import AgentRestarter, detect_supervisor
from ..system.restore import apply_pending
from ..viewer.live import RobotLive
from ..viewer.ticket import Tickets
from .deps import audit_refusal, identity_by_id
from .docs import serve_docs
from .headers import VIEWER, SecurityHeaders, docs_policy
from .routes import (
    alarms,
    audit,
    captures,
    diagrams,
    events,
    forces,
    health,
    jitter,
    line,
    modules,
    opcua,
    opcua_alarms,
    programs,
    recordings,
    robot,
    scopes,
    session,
    sets,
    status,
    stream,
    system,
    tokens,
    users,
    variables,
    watches,
)

API = "/api/v1"


def is_upload(method: str, path: str) -> bool:
    """Set uploads and backups sent to restore check their own (larger) limits while they stream to disk."""
    return method == "POST" and path.rstrip("/") in (f"{API}/sets", f"{API}/system/restore")


def json_safe(value):
    """JSON without NaN/Infinity and without unpaired surrogates (written as \\udXXX): Python's
    parser accepts both in a body (e.g. "\\ud800"), an answer in UTF-8 can hold neither."""
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, str):
        return value.encode("utf-8", "backslashreplace").decode("utf-8")
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return value


# What a 422 tells of each problem: where it is and what is wrong; never the value sent ("input",
# and "ctx", which may quote it): an answer must not echo a password back.
ERROR_FIELDS = ("loc", "msg", "type")


async def validation_error(request: Request, exc: RequestValidationError) -> JSONResponse:
    """FastAPI's 422 without the values sent, made safe for names such as an unpaired surrogate in a
    key (its own answer would be a 500); audited as a refusal."""
    problems = json_safe(jsonable_encoder([{k: e[k] for k in ERROR_FIELDS if k in e} for e in exc.errors()]))
    audit_refusal(request, 422, problems, "invalid")
    return JSONResponse(status_code=422, content={"detail": problems})


async def http_error(request: Request, exc: StarletteHTTPException):
    """FastAPI's answer to an HTTPException; a 401 or 403 is audited first (unless the route wrote
    its own line, as a wrong sign-in does)."""
    if exc.status_code in (401, 403) and not getattr(request.state, "audited", False):
        audit_refusal(request, exc.status_code, str(exc.detail))
    return await http_exception_handler(request, exc)


NO_WEBUI = (
    "the web UI is not built: cd webui && npm ci && npm run build (or start the agent with "
    "--webui-dir DIR, a folder holding the built index.html); the API is at /api/v1/docs"
)


class WebUI(StaticFiles):
    """The built web UI's files (no token: the UI signs in with one).  Paths under /api/ are never
    files: an unknown API route stays a JSON 404."""

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":  # a WebSocket to an unknown path
            await send({"type": "websocket.close", "code": 1008})
            return
        await super().__call__(scope, receive, send)

    async def get_response(self, path: str, scope):
        if path == "api" or path.startswith("api/"):
            raise HTTPException(404, f"no route {scope['path']}; /api/v1/openapi.json lists them")
        return await super().get_response(path, scope)


def webui_dir(settings: Settings) -> Path | None:
    """The folder of the built UI to serve, or None when there is none (no index.html)."""
    folder = settings.webui_dir or default_webui_dir()
    return folder if (folder / "index.html").is_file() else None


def serve_webui(app: FastAPI, folder: Path | None) -> None:
    """Mounts the UI at / after the API routes (they match first); without a build, GET / says how
    to make one."""
    if folder is not None:
        app.mount("/", WebUI(directory=folder, html=True), name="webui")
        return

    @app.get("/", include_in_schema=False)
    def no_webui():
        return JSONResponse(status_code=404, content={"detail": NO_WEBUI})


def _restored(state, record: dict) -> None:
    """The audit line and event of a restore applied at this start (into the restored audit log;
    the replaced one has the line of the request)."""
    plan = record.get("plan") or {}
    created = (plan.get("archive") or {}).get("created")
    state.audit.write(
        "restore_applied",
        who=record.get("who"),
        client=record.get("client"),
        target=created,
        result="ok",
        replaced_to=record.get("replaced_to"),
        files=[f["path"] for f in plan.get("files") or []],
        sets_added=(plan.get("sets") or {}).get("added"),
    )
    state.events.add(
        "restore_applied",
        f"the backup of {created} is restored; the files it replaced are in {record.get('replaced_to')}",
    )


def create_app(settings: Settings, *, restore: bool = True) -> FastAPI:
    """The agent.  restore=False leaves out the watcher that re-activates the stored set."""
    settings.data_dir = settings.data_dir.resolve()
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    # A restore staged before the agent restarted, applied before anything opens the data folder.
    restored = apply_pending(settings.data_dir)

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        restorer = None
        if restore:
            restorer = Restorer(
                app.state.activator, settings.irpd_socket, app.state.events, app.state.audit, settings.irpd_poll_s
            )
            restorer.start()
        app.state.restorer = restorer
        app.state.robot.start()
        watcher = AlarmWatcher(
            app.state.alarms,
            app.state.system_alarms,
            settings.irpd_socket,
            app.state.events,
            settings.alarm_poll_s,
            settings.irpd_poll_s,
            on_events=[app.state.captures.on_irpd_events],
        )
        unsubscribe = app.state.alarms.subscribe(app.state.captures.on_alarms)
        app.state.captures.start()
        watcher.start()
        app.state.recorder.start()
        yield
        app.state.recorder.stop()
        watcher.stop()
        unsubscribe()
        app.state.captures.stop()
        app.state.robot.stop()
        if restorer is not None:
            restorer.stop()
        app.state.irpd.close()
        app.state.irpd_swap.close()

    app = FastAPI(
        title="indurop agent",
        version=__version__,
        openapi_url=f"{API}/openapi.json",
        docs_url=None,  # served from the agent's own files: docs.py
        redoc_url=None,
        lifespan=lifespan,
    )
    state = app.state
    state.settings = settings
    state.agent_restart = AgentRestarter(detect_supervisor())
    state.log_followers = 0
    state.tokens = TokenStore(settings.data_dir)
    hasher = PasswordHasher(settings.argon2_time_cost, settings.argon2_memory_kib, settings.argon2_parallelism)
    state.users = UserStore(settings.data_dir, hasher)
    state.sessions = SessionStore(
        settings.data_dir / "sessions.json", settings.session_idle_s, settings.session_lifetime_s
    )
    state.hash_slots = threading.BoundedSemaphore(settings.password_hash_slots)
    state.lockout = Lockout(settings.lockout_attempts, settings.lockout_window_s)
    state.name_lockout = Lockout(settings.signin_attempts, settings.signin_window_s)
    state.irpd = IrpdClient(settings.irpd_socket)
    state.irpd_swap = IrpdClient(settings.irpd_socket)  # load, set_period, ...: long calls, own connection
    state.events = AgentEvents()
    state.audit = AuditLog(settings.data_dir / "audit.jsonl")
    state.refusals = RefusalAudit(state.audit)
    state.store = SetStore(settings.data_dir)
    state.scopes = ScopeConfigs(state.store)  # trace configurations kept with the sets
    state.watches = WatchLists(state.store)  # watch lists kept with the sets
    state.activator = Activator(state.store, state.irpd_swap, state.events, settings.swap_timeout_s)
    state.host = Sampler()
    state.webui_dir = webui_dir(settings)
    state.robot = RobotLive(settings.viewer, settings.irpd_socket, state.events, settings.robot_rate_hz)
    state.tickets = Tickets(lambda i: identity_by_id(state, i), settings.viewer_ticket_s, settings.viewer_session_s)
    alarm_store = AlarmStore(settings.data_dir / "alarms.sqlite3", settings.alarm_history_rows)
    if alarm_store.moved_aside is not None:
        state.events.add("agent_error", f"the alarm database did not open: moved aside to {alarm_store.moved_aside}")
    state.alarms = AlarmManager(alarm_store, settings.alarm_history_per_s)
    state.opcua_token = ensure_token(settings.data_dir)  # the OPC UA server's credential (opcua/link.py)
    state.recordings = Store(
        settings.data_dir / "recordings", settings.recordings_quota_bytes, settings.recordings_min_free_bytes
    )
    state.recorder = Recorder(state.recordings, settings.irpd_socket, state.events)
    state.system_alarms = SystemAlarms(
        state.alarms,
        Thresholds(
            settings.alarm_overruns_per_s,
            settings.alarm_misses_per_s,
            settings.alarm_clear_s,
            settings.alarm_unreachable_s,
        ),
    )
    shots = CaptureFiles(state.recordings)
    for name in shots.cleared:
        state.events.add("agent_error", f"capture shot {name} was cut short when the agent stopped: deleted")
    state.captures = CaptureEngine(settings.irpd_socket, settings.data_dir / "captures", shots, state.events)
    if restored is not None:
        _restored(state, restored)
    app.add_exception_handler(RequestValidationError, validation_error)
    app.add_exception_handler(StarletteHTTPException, http_error)
    app.add_exception_handler(LocatedError, located_error)
    app.add_middleware(BodyLimitMiddleware, limit=settings.max_body_bytes, exempt=is_upload)
    app.add_middleware(
        BodyTimeoutMiddleware, idle_s=settings.body_idle_s, total_s=settings.body_timeout_s, exempt=is_upload
    )
    routers = (health, status, modules, jitter, variables, sets, robot, events, alarms, audit, tokens, session, users)
    routers += (line,)  # the line of controllers, from the DDS bridge
    routers += (recordings,)  # the recorder (docs/recorder.md)
    routers += (captures,)  # the scope's triggered captures
    routers += (scopes,)  # trace configurations kept with a set
    routers += (opcua,)  # the OPC UA server's state and trust list (docs/opcua.md)
    routers += (opcua_alarms,)  # the OPC UA server's Acknowledge and Confirm, with its own token
    routers += (programs,)  # the Programs page: ST files, the check as you type, edits applied (docs/programming.md)
    routers += (diagrams,)  # the live view of LD, FBD and SFC POUs (docs/programming.md)
    routers += (forces,)  # forcing (docs/forcing.md)
    routers += (watches,)  # watch lists kept with a set (docs/programming.md)
    for module in (*routers, stream):
        app.include_router(module.router, prefix=API)
    app.include_router(system.router, prefix=API)  # the System page (and POST /sets/prune)
    scripts = serve_docs(app, f"{API}/docs", app.openapi_url)
    serve_webui(app, state.webui_dir)  # last: the API routes match first
    with_headers(app, [(f"{API}/docs", docs_policy(scripts)), (f"{API}{robot.VIEWER}", VIEWER)])
    return app


def with_headers(app: FastAPI, pages: list) -> None:
    """SecurityHeaders around everything, even Starlette's own answer to an unhandled exception (its
    ServerErrorMiddleware is outside every middleware add_middleware adds)."""
    build = app.build_middleware_stack
    app.build_middleware_stack = lambda: SecurityHeaders(build(), pages)

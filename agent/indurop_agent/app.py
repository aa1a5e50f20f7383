"""app.py -- the FastAPI application: routers under /api/v1, and in app.state the irpd clients,
tokens, the lockout, the set store, the activator, the audit log and the agent's events.  While
the app runs, a watcher restores the active set into a (re)started irpd (activation.py), and the
robot view follows the running set's robot (viewer/live.py)."""
from __future__ import annotations

import math
from contextlib import asynccontextmanager

from fastapi import FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse

from . import __version__
from .activation import Activator, Restorer
from .api.routes import audit, events, health, jitter, modules, robot, sets, status, stream, tokens, variables
from .audit import AuditLog
from .auth import TokenStore
from .config import Settings
from .events import AgentEvents
from .irpd_client import IrpdClient
from .security import BodyLimitMiddleware, Lockout
from .store import SetStore
from .viewer.live import RobotLive
from .viewer.ticket import Tickets

API = "/api/v1"


def is_upload(method: str, path: str) -> bool:
    """Set uploads check their own (larger) limits while they stream to disk."""
    return method == "POST" and path.rstrip("/") == f"{API}/sets"


def json_safe(value):
    """JSON without NaN/Infinity: Python's parser accepts them in a body, JSON answers cannot hold them."""
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return value


async def validation_error(_: Request, exc: RequestValidationError) -> JSONResponse:
    """FastAPI's 422, made safe for inputs such as {"value": NaN} (its own answer would be a 500)."""
    return JSONResponse(status_code=422, content={"detail": json_safe(jsonable_encoder(exc.errors()))})


def create_app(settings: Settings, *, restore: bool = True) -> FastAPI:
    """The agent.  restore=False leaves out the watcher that re-activates the stored set."""
    settings.data_dir = settings.data_dir.resolve()
    settings.data_dir.mkdir(parents=True, exist_ok=True)

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        restorer = None
        if restore:
            restorer = Restorer(app.state.activator, settings.irpd_socket, app.state.events, app.state.audit,
                                settings.irpd_poll_s)
            restorer.start()
        app.state.restorer = restorer
        app.state.robot.start()
        yield
        app.state.robot.stop()
        if restorer is not None:
            restorer.stop()
        app.state.irpd.close()
        app.state.irpd_swap.close()

    app = FastAPI(title="indurop agent", version=__version__, openapi_url=f"{API}/openapi.json",
                  docs_url=f"{API}/docs", redoc_url=None, lifespan=lifespan)
    state = app.state
    state.settings = settings
    state.tokens = TokenStore(settings.data_dir)
    state.lockout = Lockout(settings.lockout_attempts, settings.lockout_window_s)
    state.irpd = IrpdClient(settings.irpd_socket)
    state.irpd_swap = IrpdClient(settings.irpd_socket)  # load, set_period, ...: long calls, own connection
    state.events = AgentEvents()
    state.audit = AuditLog(settings.data_dir / "audit.jsonl")
    state.store = SetStore(settings.data_dir)
    state.activator = Activator(state.store, state.irpd_swap, state.events, settings.swap_timeout_s)
    state.robot = RobotLive(settings.viewer, settings.irpd_socket, state.events, settings.robot_rate_hz)
    state.tickets = Tickets(state.tokens, settings.viewer_ticket_s, settings.viewer_session_s)
    app.add_exception_handler(RequestValidationError, validation_error)
    app.add_middleware(BodyLimitMiddleware, limit=settings.max_body_bytes, exempt=is_upload)
    for module in (health, status, modules, jitter, variables, sets, robot, events, audit, tokens, stream):
        app.include_router(module.router, prefix=API)
    return app

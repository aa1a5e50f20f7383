"""app.py -- the FastAPI application: routers under /api/v1, the irpd client and tokens in app.state."""
from __future__ import annotations

from fastapi import FastAPI

from . import __version__
from .api.routes import health, jitter, status, stream, tokens, variables
from .auth import TokenStore
from .config import Settings
from .irpd_client import IrpdClient

API = "/api/v1"


def create_app(settings: Settings) -> FastAPI:
    app = FastAPI(title="indurop agent", version=__version__, openapi_url=f"{API}/openapi.json",
                  docs_url=f"{API}/docs", redoc_url=None)
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    app.state.settings = settings
    app.state.tokens = TokenStore(settings.data_dir)
    app.state.irpd = IrpdClient(settings.irpd_socket)
    for module in (health, status, jitter, tokens, variables, stream):
        app.include_router(module.router, prefix=API)
    return app

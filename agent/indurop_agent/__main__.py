"""indurop-agent's entry: python -m indurop_agent --host H --port P --data-dir D --irpd-socket PATH
[--tls-cert CERT.pem --tls-key KEY.pem] [--webui-dir DIR] [--viewer viser|meshcat] [--config agent.json]."""

from __future__ import annotations

import os
import sys

import uvicorn

from . import config
from .api import server
from .api.app import create_app
from .system import memtrace

GRACEFUL_STOP_S = 5
STARTUP_FAILURE = 3  # as uvicorn.run exits when the server did not start


def main(argv: list[str] | None = None) -> int:
    settings = config.parse(argv)
    app = create_app(settings)
    created = app.state.tokens.ensure_admin()
    if created:
        print(f"indurop-agent: the admin token is in {created} (mode 0600); keep it safe", flush=True)
    if not app.state.users.any():
        print(
            "indurop-agent: no user yet: the web UI's first-run page, or `irpctl --token-file "
            f"{app.state.tokens.admin_token_path} user add NAME --role admin`, sets the first admin's password",
            flush=True,
        )
    scheme = "https" if settings.tls_cert else "http"
    print(
        f"indurop-agent: {scheme}://{settings.host}:{settings.port}/api/v1/docs  (irpd: {settings.irpd_socket}, "
        f"data: {settings.data_dir})",
        flush=True,
    )
    if app.state.webui_dir is not None:
        print(
            f"indurop-agent: the web UI at {scheme}://{settings.host}:{settings.port}/  ({app.state.webui_dir})",
            flush=True,
        )
    else:
        print("indurop-agent: no web UI built (cd webui && npm ci && npm run build)", flush=True)
    snapshots = memtrace.install(settings.data_dir)
    if snapshots is not None:
        print(
            f"indurop-agent: tracing memory (PYTHONTRACEMALLOC); kill -USR2 {os.getpid()} writes a snapshot to "
            f"{snapshots}",
            flush=True,
        )
    max_connections, why = server.connection_cap(settings.max_connections)
    if why:
        print(why, flush=True)
    tls = {"ssl_certfile": str(settings.tls_cert), "ssl_keyfile": str(settings.tls_key)} if settings.tls_cert else {}
    server_config = uvicorn.Config(
        app,
        host=settings.host,
        port=settings.port,
        log_level="warning",
        http=server.protocol(settings.header_timeout_s, max_connections),
        ws_max_size=settings.max_body_bytes,
        proxy_headers=bool(settings.forwarded_allow_ips),
        forwarded_allow_ips=settings.forwarded_allow_ips or None,
        # a stop (SIGTERM, a restart from the System page) does not wait for ever on followed logs
        timeout_graceful_shutdown=GRACEFUL_STOP_S,
        **tls,
    )
    # uvicorn.run's server, held here so that a restart can ask it to stop as SIGTERM does (a
    # signal would be raised again once uvicorn stopped, and end the process by it instead of 75)
    http_server = uvicorn.Server(server_config)
    app.state.agent_restart.terminate = lambda: setattr(http_server, "should_exit", True)
    try:
        http_server.run()
    except KeyboardInterrupt:
        pass
    if not http_server.started:
        return STARTUP_FAILURE  # the address is taken, the certificate unreadable, ...: uvicorn said why
    return app.state.agent_restart.exit_code()  # 75 when a restart was asked: the supervisor starts it again


if __name__ == "__main__":
    sys.exit(main())

"""meshcat_server.py -- meshcat's own server (meshcat.servers.zmqserver: tornado for the page and
the WebSocket, ZeroMQ for the commands) as the agent's child process, bound to 127.0.0.1 on the
ports it is given (meshcat's own entry point listens on every address and picks its ports).

    python -m indurop_agent.viewer.meshcat_server --zmq-port Z --web-port W

Prints "ready" once both ports are bound; ends when its standard input closes, so it never
outlives the agent that started it."""

from __future__ import annotations

import argparse
import os
import sys
import threading


def _exit_with_parent() -> None:
    sys.stdin.read()  # returns at EOF: the agent closed the pipe or died
    os._exit(0)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="indurop_agent.viewer.meshcat_server")
    ap.add_argument("--zmq-port", type=int, required=True)
    ap.add_argument("--web-port", type=int, required=True)
    a = ap.parse_args(argv)
    threading.Thread(target=_exit_with_parent, name="parent-watch", daemon=True).start()

    from meshcat.servers.zmqserver import ZMQWebSocketBridge

    class LoopbackBridge(ZMQWebSocketBridge):
        def make_app(self):
            app = super().make_app()
            listen = app.listen
            app.listen = lambda port, **kwargs: listen(port, address="127.0.0.1", **kwargs)
            return app

    try:
        bridge = LoopbackBridge(zmq_url=f"tcp://127.0.0.1:{a.zmq_port}", host="127.0.0.1", port=a.web_port)
    except Exception as e:  # noqa: BLE001 -- a port taken meanwhile: the agent retries with others
        print(f"failed: {type(e).__name__}: {e}", flush=True)
        return 1
    print("ready", flush=True)
    bridge.run()
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""config.py -- the agent's settings: command line first, then an optional JSON config file."""
from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from pathlib import Path


@dataclass
class Settings:
    host: str = "127.0.0.1"
    port: int = 8080
    data_dir: Path = Path("/var/lib/indurop")
    irpd_socket: str = "/run/indurop/irpd.sock"


def parse(argv: list[str] | None = None) -> Settings:
    ap = argparse.ArgumentParser(prog="indurop-agent", description="indurop's REST/WebSocket agent (non-RT)")
    ap.add_argument("--config", type=Path, help="a JSON file with host, port, data_dir, irpd_socket")
    ap.add_argument("--host")
    ap.add_argument("--port", type=int)
    ap.add_argument("--data-dir", type=Path)
    ap.add_argument("--irpd-socket")
    a = ap.parse_args(argv)
    s = Settings()
    if a.config:
        try:
            values = json.loads(a.config.read_text())
        except (OSError, ValueError) as e:
            ap.error(f"--config {a.config}: {e}")
        unknown = set(values) - {"host", "port", "data_dir", "irpd_socket"}
        if unknown:
            ap.error(f"--config {a.config}: unknown keys {', '.join(sorted(unknown))}")
        for key, value in values.items():
            setattr(s, key, Path(value) if key == "data_dir" else value)
    for key in ("host", "port", "data_dir", "irpd_socket"):
        if getattr(a, key) is not None:
            setattr(s, key, getattr(a, key))
    if not 0 < int(s.port) < 65536:
        ap.error(f"port {s.port} is not a TCP port")
    return s

"""cell_operator.py -- the agent in front of a running PLC + robot cell (test_plc_robot.Cell), as an
operator or a script uses it: variables read and written, sets uploaded and activated, the alarm
list and history, all over the REST API with the admin token."""

from __future__ import annotations

import sys
from pathlib import Path

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import API, free_port, start_agent, stop  # noqa: E402

NS = "PLC_ROBOT."


class Operator:
    """The agent in front of the cell, with the admin token."""

    def __init__(self, sock: Path, tmp: Path):
        self.port, self.data = free_port(), tmp / "data"
        self.agent = start_agent(self.port, self.data, sock)
        self.url = f"http://127.0.0.1:{self.port}{API}"
        self.h = {"Authorization": f"Bearer {(self.data / 'admin-token').read_text().strip()}"}

    def get(self, path: str, **params):
        r = httpx.get(f"{self.url}{path}", headers=self.h, params=params, timeout=40)
        assert r.status_code == 200, r.text
        return r.json()

    def read(self, path: str):
        return self.get(f"/variables/{NS}{path}")["value"]

    def write(self, path: str, value) -> None:
        r = httpx.put(f"{self.url}/variables/{NS}{path}", json={"value": value}, headers=self.h, timeout=40)
        assert r.status_code == 200, r.text

    def upload(self, folder: Path) -> str:
        files = [
            ("files", (str(p.relative_to(folder)), p.read_bytes())) for p in sorted(folder.rglob("*")) if p.is_file()
        ]
        r = httpx.post(f"{self.url}/sets", files=files, headers=self.h, timeout=120)
        assert r.status_code == 201, r.text
        assert r.json()["validation"]["valid"], r.json()["validation"]
        return r.json()["id"]

    def restart_onto(self, set_id: str) -> dict:
        r = httpx.post(f"{self.url}/sets/{set_id}/activate", json={"mode": "restart"}, headers=self.h, timeout=120)
        assert r.status_code == 200, r.text
        return r.json()

    def newest(self) -> int:
        """The alarm history's newest row (its seq), 0 when empty."""
        rows = self.get("/alarms/history", limit=1)["transitions"]
        return rows[0]["seq"] if rows else 0

    def transitions(self, key: str, after: int) -> list[str]:
        """The events of alarm `key` recorded after row `after`, oldest first."""
        rows = self.get("/alarms/history", key=key, after=after, limit=1000)["transitions"]
        return [r["event"] for r in reversed(rows)]

    def alarm(self, key: str) -> dict:
        """Alarm `key` as GET /alarms lists it, or an inactive "normal" one when it is not listed."""
        listed = self.get("/alarms")["alarms"]
        return next((a for a in listed if a["key"] == key), {"active": False, "state": "normal"})

    def close(self) -> None:
        stop(self.agent)

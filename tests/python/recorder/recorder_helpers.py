"""recorder_helpers.py -- what the recorder's live tests share: a running irpd and agent with a
token per role, the recordings API, and the rows of MCAP files read back with the mcap library."""

from __future__ import annotations

import hashlib
import io
import json
import sys
import time
import zipfile
from dataclasses import dataclass
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "tests" / "python"))
sys.path.insert(0, str(ROOT / "agent"))
import orjson  # noqa: E402
from indurop_agent.events import AgentEvents  # noqa: E402
from indurop_agent.irpd.client import IrpdClient, IrpdRefused, IrpdUnavailable  # noqa: E402
from indurop_agent.recorder.manager import Recorder  # noqa: E402
from live_processes import BUILD, IRPD, free_port, output, start_agent, start_irpd, stop, wait_until  # noqa: E402
from mcap.reader import make_reader  # noqa: E402

SAMPLES = "/indurop/samples"
NOTES = "/indurop/notes"


def irpd_ready(sock: Path, seconds: float = 30) -> dict:
    """irpd's status once it dispatches its set."""
    client = IrpdClient(str(sock))
    deadline = time.monotonic() + seconds
    try:
        while True:
            try:
                return client.request("status")
            except (IrpdRefused, IrpdUnavailable):
                assert time.monotonic() < deadline, "irpd did not start dispatching"
                time.sleep(0.1)
    finally:
        client.close()


@dataclass
class Api:
    url: str
    tokens: dict[str, str]  # role -> token
    data: Path

    def h(self, role: str) -> dict:
        return {"Authorization": f"Bearer {self.tokens[role]}"} if role in self.tokens else {}

    def call(self, method: str, path: str, role: str = "operator", **kw) -> httpx.Response:
        return httpx.request(method, f"{self.url}{path}", headers=self.h(role), timeout=30, **kw)

    def start(self, name: str, variables, role: str = "operator", **body) -> httpx.Response:
        return self.call("POST", "/recordings", role, json={"name": name, "variables": variables, **body})

    def get(self, name: str) -> dict:
        r = self.call("GET", f"/recordings/{name}", "viewer")
        assert r.status_code == 200, r.text
        return r.json()

    def wait_state(self, name: str, state: str, seconds: float = 120) -> dict:
        deadline = time.monotonic() + seconds
        while True:
            got = self.get(name)
            if got["state"] == state:
                return got
            assert time.monotonic() < deadline, f"{name} is {got['state']}, not {state}: {got}"
            time.sleep(0.2)

    def download(self, name: str, folder: Path, **params) -> list[Path]:
        """The recording's files as the API sends them (an .mcap, or the members of a .zip)."""
        r = self.call("GET", f"/recordings/{name}/download", "viewer", params=params)
        assert r.status_code == 200, r.text
        folder.mkdir(parents=True, exist_ok=True)
        if r.headers["content-type"] == "application/zip":
            with zipfile.ZipFile(io.BytesIO(r.content)) as z:
                z.extractall(folder)
                return [folder / n for n in z.namelist()]
        path = folder / f"{name}.mcap"
        path.write_bytes(r.content)
        return [path]


def start_cell(tmp: Path, config: Path, instance: str, agent_config: dict | None = None) -> tuple:
    """irpd running `config` and an agent beside it; (irpd, agent, Api, socket)."""
    sock = tmp / "irpd.sock"
    irpd = start_irpd(sock, config, instance)
    irpd_ready(sock)
    data = tmp / "data"
    extra = []
    if agent_config:
        (tmp / "agent.json").write_text(json.dumps(agent_config))
        extra = ["--config", str(tmp / "agent.json")]
    port = free_port()
    agent = start_agent(port, data, sock, *extra)
    url = f"http://127.0.0.1:{port}/api/v1"
    admin = (data / "admin-token").read_text().strip()
    tokens = {"admin": admin}
    for role in ("operator", "viewer"):
        r = httpx.post(f"{url}/tokens", json={"name": role, "role": role}, headers={"Authorization": f"Bearer {admin}"})
        tokens[role] = r.json()["token"]
    return irpd, agent, Api(url, tokens, data), sock


def recorder_of(store, sock: Path, **kw):
    """A Recorder thread of its own (not the agent's) on irpd's socket, started."""
    rec = Recorder(store, str(sock), AgentEvents(), owner="recorder-test", **kw)
    rec.start()
    return rec


def wait_done(store, name: str, seconds: float = 60) -> dict:
    """The entry.json of a recording of `store` once it is no longer being recorded."""
    deadline = time.monotonic() + seconds
    while True:
        meta = store.get(name).meta
        if meta["state"] != "recording":
            return meta
        assert time.monotonic() < deadline, meta
        time.sleep(0.1)


def samples_of(paths: list[Path]) -> list[dict]:
    """Every row of the samples channel of the files, in file order (the indexed reader)."""
    out = []
    for path in paths:
        if path.name.endswith(".joint_states.mcap"):
            continue
        with open(path, "rb") as f:
            for _, channel, message in make_reader(f).iter_messages(log_time_order=False):
                if channel.topic == SAMPLES:
                    out.append(orjson.loads(message.data))
    return out


def notes_of(paths: list[Path]) -> list[dict]:
    out = []
    for path in paths:
        if path.name.endswith(".joint_states.mcap"):
            continue
        with open(path, "rb") as f:
            out += [orjson.loads(m.data) for _, c, m in make_reader(f).iter_messages() if c.topic == NOTES]
    return out


def assert_in_time_order(path: Path) -> int:
    """The strictest order checks the mcap library allows a reader: the messages in file order
    (the indexed reader's log_time_order=False) never go back in log_time, so that file order is
    the order the reader sorts into (log_time_order=True); every chunk's index holds its messages'
    times and the chunks' times do not overlap; the statistics' start and end are the first and
    last message's.  Returns the messages counted."""
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        in_file = [(m.log_time, c.topic, m.sequence) for _, c, m in reader.iter_messages(log_time_order=False)]
        for k in range(1, len(in_file)):
            assert in_file[k][0] >= in_file[k - 1][0], (
                f"{path.name}: message {k} ({in_file[k][1]}, log_time {in_file[k][0]}) comes after one at "
                f"{in_file[k - 1][0]} ({in_file[k - 1][1]}): log_time goes backwards"
            )
        by_time = [(m.log_time, c.topic, m.sequence) for _, c, m in reader.iter_messages(log_time_order=True)]
        assert by_time == in_file
        summary = reader.get_summary()
    assert summary is not None, f"{path.name} has no summary"
    chunks = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    for a, b in zip(chunks, chunks[1:]):
        assert a.message_start_time <= a.message_end_time <= b.message_start_time, f"{path.name}: chunks overlap"
    if in_file:
        stats = summary.statistics
        assert (stats.message_start_time, stats.message_end_time) == (in_file[0][0], in_file[-1][0])
        assert stats.message_count == len(in_file)
    return len(in_file)


def digests(folder: Path) -> dict[str, str]:
    """sha256 of every file under `folder` (what must not change)."""
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.rglob("*.mcap"))
    }


__all__ = ["BUILD", "IRPD", "output", "stop", "wait_until"]

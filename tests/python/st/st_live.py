# st_live.py -- runs ST programs for the conformance tests: `stc build` (the executable, as the agent
# and CMake call it) into a set folder, a real irpd on it (unique instance, stopped by pid, shared
# memory removed), the values read from the shared-variable segment and the events from irpd.

from __future__ import annotations

import json
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

from indurop_agent.irpd.client import IrpdClient
from indurop_agent.irpd.variables import Segment
from live_processes import BUILD, ROOT, remove_shm, start_irpd, stop, wait_dispatching, wait_until

STC = ROOT / "st" / "stc"


def stc_build(folder: Path, files: dict[str, str | Path], *extra: str, out: str = "set") -> subprocess.CompletedProcess:
    """Writes the ST files into folder/src and runs `stc build -o folder/<out> ... --json` there; a file
    given as a Path (a PLCopen XML project, say) is built where it is."""
    src = folder / "src"
    src.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        if not isinstance(text, Path):
            (src / name).write_text(text)
    cmd = [sys.executable, str(STC), "build", "-o", str(folder / out), "--json", "--sdk", str(BUILD), *extra]
    names = [str(text) if isinstance(text, Path) else name for name, text in files.items()]
    return subprocess.run(cmd + names, cwd=src, capture_output=True, text=True, timeout=300)


def build_errors(folder: Path, files: dict[str, str], *extra: str) -> list[dict]:
    r = stc_build(folder, files, *extra)
    assert r.returncode == 1, r.stdout + r.stderr
    return json.loads(r.stdout)


class Running:
    """A built ST set running in irpd."""

    def __init__(self, folder: Path, files: dict[str, str | Path], *extra: str, irpd: tuple = ()) -> None:
        r = stc_build(folder, files, *extra)
        assert r.returncode == 0, r.stdout + r.stderr
        self.folder = folder
        self.instance = f"st-{folder.name[-24:]}-{id(self) % 100000}"
        self.irpd_args = irpd
        self.start()

    def start(self) -> None:
        """irpd on the built set (again, after close())."""
        folder = self.folder
        self.process = start_irpd(
            folder / "irpd.sock",
            folder / "set" / "module.xml",
            self.instance,
            "--no-rt",
            *self.irpd_args,
            log=folder / "irpd.log",
        )
        self.client = IrpdClient(str(folder / "irpd.sock"), timeout_s=30)
        wait_dispatching(self.client)
        self.segment = Segment(f"/indurop.{self.instance}.vars")

    def value(self, path: str):
        return self.segment.read(path)

    def values(self, prefix: str) -> dict:
        leaves = self.segment.select(prefix)
        return {leaf["path"]: v for leaf, v in zip(leaves, self.segment.values(leaves), strict=True)}

    def string(self, path: str) -> str:
        raw = bytes(b & 0xFF for b in self.values(path).values())
        return raw.split(b"\0", 1)[0].decode()

    def wait_value(self, path: str, want, seconds: float = 20.0):
        wait_until(lambda: self.value(path) == want, seconds)

    def events(self, kind: str) -> list[dict]:
        return [e for e in self.client.request("events", since=0)["events"] if e["kind"] == kind]

    def running_layout(self) -> Path:
        """The layout irpd runs now, as a file (what `irpctl layout -o` writes)."""
        self.segment.refresh()
        path = self.folder / f"running-{self.segment.hash[:12]}.json"
        path.write_bytes(self.segment.text)
        return path

    def load(self, files: dict[str, str], out: str, *extra: str) -> dict:
        """Builds the changed sources against the running layout and loads them online (`load`)."""
        r = stc_build(self.folder, files, "--previous", str(self.running_layout()), *extra, out=out)
        assert r.returncode == 0, r.stdout + r.stderr
        return self.client.request("load", config=str(self.folder / out / "module.xml"))

    def close(self) -> None:
        """Stops irpd; the values it had last are in segment_values_at_close."""
        if self.process.poll() is not None:
            return
        self.segment.refresh()
        leaves = self.segment.layout["leaves"]
        self.segment_values_at_close = {
            leaf["path"]: v for leaf, v in zip(leaves, self.segment.values(leaves), strict=True)
        }
        self.segment.close()
        self.client.close()
        stop(self.process)
        remove_shm(self.instance)


@contextmanager
def ran_once(folder: Path, files: dict[str, str], done: str):
    """A program that computes its values in one pass and then sets its flag `done` (a path),
    running in irpd until the with block ends."""
    run = Running(folder, files)
    try:
        run.wait_value(done, 1)
        yield run
    finally:
        run.close()


def periods(n: int, period_s: float = 0.01) -> None:
    time.sleep(n * period_s)


__all__ = ["BUILD", "Running", "build_errors", "stc_build", "periods", "ran_once"]

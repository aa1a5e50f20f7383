"""agent_helpers.py -- plain helpers of the agent's tests (fixtures are in conftest.py): paths,
the in-process agent's handle, a real irpd with a real agent in front of it (LiveCell), ELF
patching, module.xml text, and upload bodies written byte by byte so that a test controls every
name it sends."""

from __future__ import annotations

import io
import json
import os
import signal
import socket
import subprocess
import sys
import tarfile
import time
from dataclasses import dataclass
from pathlib import Path

import httpx
from fastapi.testclient import TestClient
from indurop_agent.cli import irpctl as cli

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import API, BUILD, FIG1, IRPD, ROOT, copy_cell, free_port, output, start_agent, start_irpd, stop  # noqa: E402,F401


@dataclass
class Agent:
    client: TestClient
    data: Path
    tokens: dict[str, str]  # role -> token

    def h(self, role: str = "admin") -> dict:
        return {"Authorization": f"Bearer {self.tokens[role]}"}

    def stored(self) -> list[str]:
        """Everything the store holds (blobs, sets, uploads in progress), as relative paths."""
        return sorted(
            str(p.relative_to(self.data)) for d in ("blobs/sha256", "sets", "tmp") for p in (self.data / d).rglob("*")
        )

    def audit(self) -> list[dict]:
        path = self.data / "audit.jsonl"
        return [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []


class LiveCell:
    """A real irpd on `config` (Figure 1 by default; `irpd_args` added to its command line) and a
    real agent in front of it polling it every 0.2 s (`settings` added to its agent.json), with the
    admin token.  Each test file's Cell adds what its tests ask of it."""

    def __init__(self, tmp: Path, config: Path = FIG1, *irpd_args: str, instance: str | None = None, **settings):
        self.tmp, self.sock, self.data = tmp, tmp / "irpd.sock", tmp / "data"
        self.token_file = self.data / "admin-token"
        self.irpd = start_irpd(self.sock, config, instance, *irpd_args)
        self.config = tmp / "agent.json"
        self.config.write_text(json.dumps({"irpd_poll_s": 0.2, **settings}))
        self.port = free_port()
        self.agent = start_agent(self.port, self.data, self.sock, "--config", str(self.config))
        self.base = f"http://127.0.0.1:{self.port}"
        self.url = f"{self.base}{API}"
        self.h = {"Authorization": f"Bearer {self.token_file.read_text().strip()}"}

    def call(self, method: str, path: str, **kw) -> httpx.Response:
        return httpx.request(method, f"{self.url}{path}", headers=self.h, timeout=120, **kw)

    def get(self, path: str, **kw) -> httpx.Response:
        return self.call("GET", path, **kw)

    def post(self, path: str, **kw) -> httpx.Response:
        return self.call("POST", path, **kw)

    def upload(self, files) -> dict:
        """POST /sets with `files` (httpx's files=): the stored set, which must be accepted."""
        r = self.post("/sets", files=files)
        assert r.status_code == 201, r.text
        return r.json()

    def irpctl(self, capsys, *argv: str) -> tuple[int, str]:
        """irpctl's main() against this agent as admin: (exit code, what it printed)."""
        capsys.readouterr()
        code = cli.main(["--url", self.base, "--token-file", str(self.token_file), *argv])
        out, err = capsys.readouterr()
        return code, out + err

    def close(self) -> None:
        stop(self.agent)
        stop(self.irpd)


@dataclass
class Elves:
    """Real ELF files built by gcc for the tests."""

    module: bytes  # a thread module: ELF64 x86-64 ET_DYN defining run()
    descriptor: bytes  # a thread module that defines only indurop_module_v1_descriptor
    library: bytes  # a shared object defining neither
    pie: bytes  # an executable (PIE: ET_DYN with PT_INTERP)
    exec_: bytes  # an executable (ET_EXEC, -no-pie)


def patched(elf: bytes, offset: int, value: bytes) -> bytes:
    return elf[:offset] + value + elf[offset + len(value) :]


def wrong_machine(elf: bytes, machine: int) -> bytes:
    """The same ELF with another e_machine (offset 18, little-endian u16): 3 = i386, 183 = aarch64."""
    return patched(elf, 18, machine.to_bytes(2, "little"))


# ---- sets and upload bodies ---------------------------------------------------------------------
def st_configuration(program_type: str, interval: str = "T#1ms") -> str:
    """A Structured Text CONFIGURATION: one instance Main of PROGRAM `program_type` every `interval`."""
    return (
        "CONFIGURATION Cell\n  RESOURCE Cpu ON PLC\n"
        f"    TASK Fast (INTERVAL := {interval}, PRIORITY := 1);\n"
        f"    PROGRAM Main WITH Fast : {program_type};\n  END_RESOURCE\nEND_CONFIGURATION\n"
    )


def module_xml(*modules: tuple[str, str], extra: str = "") -> bytes:
    """module.xml text naming (filename, moduletype) modules, each periodic at 1 ms."""
    body = "".join(
        f"""  <module>
    <filename>{filename}</filename>
    <moduletype>{kind}</moduletype>
    <operationtype>periodic</operationtype>
    <period>1000000</period>
    <priority>{i}</priority>
  </module>
"""
        for i, (filename, kind) in enumerate(modules, 1)
    )
    return f'<?xml version="1.0" encoding="UTF-8"?>\n<root>\n{body}{extra}</root>\n'.encode()


def small_set(elves: Elves) -> dict[str, bytes]:
    """A set of one thread module, one process module, a layout and a note."""
    return {
        "module.xml": module_xml(("./lib/ctl.so", "thread"), ("./proc.exe", "process")),
        "lib/ctl.so": elves.module,
        "proc.exe": elves.pie,
        "layout.json": b'{"leaves": []}',
        "README.md": b"# a test set\n",
    }


def multipart(
    parts: list[tuple[str, str | bytes | None, bytes]], boundary: str = "indurop-test-boundary"
) -> tuple[bytes, str]:
    """A multipart/form-data body written byte by byte: (field name, filename or None, content).
    Names go out exactly as given (bytes: as they are), as a hostile client would send them."""
    out = io.BytesIO()
    for field, filename, content in parts:
        out.write(f"--{boundary}\r\n".encode())
        disposition = f'form-data; name="{field}"'.encode()
        if filename is not None:
            raw = filename if isinstance(filename, bytes) else filename.encode("utf-8")
            disposition += b'; filename="' + raw + b'"'
        out.write(b"Content-Disposition: " + disposition + b"\r\n")
        out.write(b"Content-Type: application/octet-stream\r\n\r\n")
        out.write(content + b"\r\n")
    out.write(f"--{boundary}--\r\n".encode())
    return out.getvalue(), f"multipart/form-data; boundary={boundary}"


def files_body(files: dict[str, bytes]) -> tuple[bytes, str]:
    return multipart([("files", name, content) for name, content in files.items()])


def tar_gz(members: list[tarfile.TarInfo | tuple[str, bytes]], **tar_options) -> bytes:
    """A .tar.gz of (name, content) regular files and ready-made TarInfo entries (links, devices)."""
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz", **tar_options) as tar:
        for m in members:
            if isinstance(m, tarfile.TarInfo):
                tar.addfile(m)
            else:
                name, content = m
                info = tarfile.TarInfo(name)
                info.size = len(content)
                info.mode = 0o644
                tar.addfile(info, io.BytesIO(content))
    return buf.getvalue()


def post_set(agent: Agent, body: bytes, content_type: str, role: str = "admin"):
    return agent.client.post(f"{API}/sets", content=body, headers={**agent.h(role), "Content-Type": content_type})

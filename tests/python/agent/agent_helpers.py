"""agent_helpers.py -- plain helpers of the agent's tests (fixtures are in conftest.py): paths,
the in-process agent's handle, ELF patching, module.xml text, and upload bodies written byte by
byte so that a test controls every name it sends."""

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

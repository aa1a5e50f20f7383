# conftest.py -- fixtures for glbc's tests: a folder to compile .glb text in, and g++ with the
# runtime headers for the compile tests.

from __future__ import annotations

from pathlib import Path

import pytest
from glb_helpers import RTCORE_INCLUDE, gxx, run_glbc


class GlbRun:
    """Writes .glb files into a folder and runs glbc on them there."""

    def __init__(self, folder: Path):
        self.folder = folder

    def __call__(self, files: dict[str, str | bytes], *extra: str, order: list[str] | None = None):
        for name, text in files.items():
            path = self.folder / name
            if isinstance(text, bytes):
                path.write_bytes(text)
            else:
                path.write_text(text, encoding="utf-8")
        return run_glbc([*(order or list(files)), "-o", "out", *extra], self.folder)

    @property
    def out(self) -> Path:
        return self.folder / "out"


@pytest.fixture
def glb(tmp_path: Path) -> GlbRun:
    return GlbRun(tmp_path)


@pytest.fixture(scope="session")
def cxx() -> str:
    compiler = gxx()
    if compiler is None:
        pytest.skip("g++ is not installed")
    return compiler


@pytest.fixture(scope="session")
def shared_include(cxx: str) -> Path:
    """The include folder holding indurop/shared.h."""
    return RTCORE_INCLUDE

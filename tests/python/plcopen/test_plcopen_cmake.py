# test_plcopen_cmake.py -- CMake's indurop_add_st (cmake/InduropModule.cmake) takes a PLCopen XML
# project as a source: a project of a module author configured and built with ninja makes a set
# (module.xml, layout.json, the instance's module) that carries the .xml, as it does .st files.

from __future__ import annotations

import shutil
import subprocess
import sys

import pytest
from live_processes import BUILD, ROOT
from plcopen_live import shared

pytestmark = pytest.mark.skipif(not shutil.which("ninja"), reason="ninja is not installed")


def test_indurop_add_st_builds_a_plcopen_project(tmp_path):
    xml = shared("tutorial_xor_xnor")
    (tmp_path / "CMakeLists.txt").write_text(
        "cmake_minimum_required(VERSION 3.25)\nproject(plcopen_set CXX)\n"
        f"include({ROOT}/cmake/InduropModule.cmake)\n"
        f"indurop_add_st(xor SOURCES {xml})\n"
    )
    configure = [
        "cmake", "-S", str(tmp_path), "-B", str(tmp_path / "b"), "-G", "Ninja",
        f"-DINDUROP_SDK_PREFIX={BUILD}", f"-DPython3_EXECUTABLE={sys.executable}",
    ]  # fmt: skip
    r = subprocess.run(configure, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    r = subprocess.run(["ninja", "-C", str(tmp_path / "b")], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    built = tmp_path / "b" / "xor"
    assert {"module.xml", "layout.json", "instance0.so", "plc.xml"} <= {p.name for p in built.iterdir()}
    assert "instance0.so" in (built / "module.xml").read_text()

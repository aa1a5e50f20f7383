"""conftest.py -- the DDS tests' separate peer, ros2_reader (tools/dds/ros2_reader.c): C types made
by Debian's idlc from protocol/ros2's IDL, run on Debian's libddsc 0.10.2 while the bridge runs the
cyclonedds wheel's 11.x.  `ros2_reader` is the tool the build makes (build/tools/dds), the one the
README runs; `cell_reader` is the same source built here with the declared-type test's own IDL
(idl/cell_msgs) and -DROS2_READER_CELL_MSGS."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

HERE = Path(__file__).parent
ROOT = HERE.parents[2]
SOURCE = ROOT / "tools" / "dds" / "ros2_reader.c"
BUILT = ROOT / "build" / "tools" / "dds" / "ros2_reader"
IDL_DIRS = {
    ROOT / "protocol" / "ros2": [
        "builtin_interfaces/msg/Time",
        "std_msgs/msg/Header",
        "sensor_msgs/msg/JointState",
        "diagnostic_msgs/msg/KeyValue",
        "diagnostic_msgs/msg/DiagnosticStatus",
        "diagnostic_msgs/msg/DiagnosticArray",
        "std_msgs/msg/Float64",
        "std_msgs/msg/Bool",
        "std_msgs/msg/Int32",
    ],
    HERE / "idl": ["cell_msgs/msg/Cell"],
}


@pytest.fixture(scope="session")
def ros2_reader() -> Path:
    """The separate DDS peer as the build makes it (tools/dds/CMakeLists.txt)."""
    if not BUILT.exists():
        pytest.skip(
            f"{BUILT} is not built: packaging/deps.sh installs cyclonedds-dev and cyclonedds-tools, then packaging/build.sh"
        )
    return BUILT


@pytest.fixture(scope="session")
def cell_reader(tmp_path_factory) -> Path:
    """The same peer with the declared-type test's cell_msgs types (cell_status, cell_command)."""
    if not shutil.which("idlc") or not Path("/usr/include/dds/dds.h").exists():
        pytest.skip("Debian's cyclonedds-dev and cyclonedds-tools are not installed (packaging/deps.sh)")
    out = tmp_path_factory.mktemp("cell_reader")
    for folder, files in IDL_DIRS.items():
        for f in files:
            (out / f).parent.mkdir(parents=True, exist_ok=True)
            idlc = ["idlc", "-x", "final", "-I", str(ROOT / "protocol" / "ros2"), "-o", str((out / f).parent)]
            subprocess.run([*idlc, str(folder / f"{f}.idl")], check=True, capture_output=True)
    exe = out / "ros2_reader"
    sources = [str(p) for p in out.rglob("*.c")]
    cc = ["cc", "-O1", "-Wall", "-Werror", "-DROS2_READER_CELL_MSGS", "-I", str(out), "-o", str(exe)]
    subprocess.run([*cc, str(SOURCE), *sources, "-lddsc"], check=True)
    return exe

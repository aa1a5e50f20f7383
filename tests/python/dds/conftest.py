"""conftest.py -- the DDS tests' separate peer: ros2_reader.c, its C types made by Debian's idlc
from protocol/ros2's IDL and the declared-type test's own IDL (idl/cell_msgs), run on Debian's
libddsc 0.10.2 while the bridge runs the cyclonedds wheel's 11.x."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

HERE = Path(__file__).parent
ROOT = HERE.parents[2]
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
def ros2_reader(tmp_path_factory) -> Path:
    """The separate DDS peer (ros2_reader.c), its types made by idlc from the IDL files."""
    if not shutil.which("idlc") or not Path("/usr/include/dds/dds.h").exists():
        pytest.skip("Debian's cyclonedds-dev and cyclonedds-tools are not installed (packaging/deps.sh)")
    out = tmp_path_factory.mktemp("ros2_reader")
    for folder, files in IDL_DIRS.items():
        for f in files:
            (out / f).parent.mkdir(parents=True, exist_ok=True)
            subprocess.run(
                [
                    "idlc",
                    "-x",
                    "final",
                    "-I",
                    str(ROOT / "protocol" / "ros2"),
                    "-o",
                    str((out / f).parent),
                    str(folder / f"{f}.idl"),
                ],
                check=True,
                capture_output=True,
            )
    exe = out / "ros2_reader"
    sources = [str(p) for p in out.rglob("*.c")]
    subprocess.run(
        [
            "cc",
            "-O1",
            "-Wall",
            "-Werror",
            "-I",
            str(out),
            "-o",
            str(exe),
            str(HERE / "ros2_reader.c"),
            *sources,
            "-lddsc",
        ],
        check=True,
    )
    return exe

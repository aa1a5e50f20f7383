"""machine.py -- the description of the machine that goes into the report: kernel, PREEMPT_RT,
CPU, virtualization, clock source, cpuidle, RT throttling, isolated CPUs, cyclictest's version.
"""

from __future__ import annotations

import os
import platform
import shutil
import subprocess
from pathlib import Path

from .common import REPO


def read_text(path: str) -> str:
    try:
        return Path(path).read_text().strip()
    except OSError:
        return ""


def command_output(cmd: list[str]) -> str:
    try:
        return subprocess.run(cmd, capture_output=True, text=True, timeout=20).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""


def machine() -> dict:
    uname = platform.uname()
    model = ""
    for line in read_text("/proc/cpuinfo").splitlines():
        if line.startswith("model name"):
            model = line.split(":", 1)[1].strip()
            break
    flags = read_text("/proc/cpuinfo")
    preempt_rt = "PREEMPT_RT" in uname.version or read_text("/sys/kernel/realtime") == "1"
    vm = command_output(["systemd-detect-virt", "--vm"]) or (
        "hypervisor flag set" if " hypervisor" in flags else "none"
    )
    container = command_output(["systemd-detect-virt", "--container"]) or "none"
    virt = f"VM: {vm}; container: {container}"
    ct_version = ""
    if shutil.which("cyclictest"):
        ct_version = command_output(["dpkg-query", "-W", "-f=${Version}", "rt-tests"])
        ct_version = f"rt-tests {ct_version}" if ct_version else "unknown version"
    git = command_output(["git", "-C", str(REPO), "describe", "--always", "--dirty", "--abbrev=12"])
    return {
        "hostname": uname.node,
        "kernel_release": uname.release,
        "kernel_version": uname.version,
        "preempt_rt": preempt_rt,
        "cpu_model": model or uname.machine,
        "nproc": os.cpu_count(),
        "virtualization": virt,
        "clocksource": read_text("/sys/devices/system/clocksource/clocksource0/current_clocksource"),
        "cpuidle_driver": read_text("/sys/devices/system/cpu/cpuidle/current_driver"),
        "rt_runtime_us": read_text("/proc/sys/kernel/sched_rt_runtime_us"),
        "cmdline_isolcpus": " ".join(
            w for w in read_text("/proc/cmdline").split() if w.startswith(("isolcpus", "nohz_full"))
        ),
        "cyclictest": ct_version,
        "git": git,
        "loadavg_start": read_text("/proc/loadavg"),
    }

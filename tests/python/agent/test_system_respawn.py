"""test_system_respawn.py -- packaging/respawn.sh, how packaging/demo.sh brings the agent back after a
restart from the System page: the command is started again after exit 75 and not after another
exit, and a SIGTERM to the supervisor reaches the command, which is waited for."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

from agent_helpers import ROOT

RESPAWN = ROOT / "packaging" / "respawn.sh"
# a command that counts its starts in a file and exits with the code given for that start
COUNTING = """
import pathlib, sys, time
runs = pathlib.Path(sys.argv[1])
n = int(runs.read_text()) + 1 if runs.exists() else 1
runs.write_text(str(n))
codes = sys.argv[2].split(",")
if codes[min(n, len(codes)) - 1] == "sleep":
    pathlib.Path(sys.argv[1] + ".pid").write_text(str(__import__("os").getpid()))
    time.sleep(60)
sys.exit(int(codes[min(n, len(codes)) - 1]))
"""


def respawn(tmp_path, codes: str) -> subprocess.Popen:
    script = tmp_path / "counting.py"
    script.write_text(COUNTING)
    return subprocess.Popen(
        ["bash", str(RESPAWN), sys.executable, str(script), str(tmp_path / "runs"), codes],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )


def test_exit_75_starts_the_command_again_and_another_exit_ends_it(tmp_path):
    p = respawn(tmp_path, "75,75,3")
    assert p.wait(30) == 3
    assert (tmp_path / "runs").read_text() == "3"
    assert p.stderr.read().count("exit 75") == 2


def test_a_sigterm_reaches_the_command_and_is_waited_for(tmp_path):
    p = respawn(tmp_path, "75,sleep")
    pid_file = tmp_path / "runs.pid"
    deadline = time.monotonic() + 30
    while not pid_file.exists():
        assert time.monotonic() < deadline and p.poll() is None, "the command was not started again"
        time.sleep(0.05)
    child = int(pid_file.read_text())
    p.send_signal(signal.SIGTERM)
    assert p.wait(30) == 143
    try:
        os.kill(child, 0)
        alive = True
    except ProcessLookupError:
        alive = False
    assert not alive, "the command still runs after its supervisor ended"

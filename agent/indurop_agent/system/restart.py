"""restart.py -- the agent restarting itself: it cannot start a new process of itself (it runs as an
unprivileged user, NoNewPrivileges), so it ends with EXIT_RESTART and lets whatever supervises it
start it again: systemd (Restart=on-failure, RestartForceExitStatus=75 in indurop-agent.service) or
packaging/demo.sh (whose packaging/respawn.sh starts the agent again when it exits with 75).  Without a supervisor the
restart is refused, since the agent would just be gone.

The exit is graceful: a moment after the answer went out, uvicorn is asked to stop as a SIGTERM
would ask it (__main__ sets `terminate`), so that it closes the connections and the lifespan stops
the watchers; __main__ then returns EXIT_RESTART.
"""

from __future__ import annotations

import os
import signal
import threading

EXIT_RESTART = 75  # EX_TEMPFAIL: "try again"; the supervisors start the agent again on it
DELAY_S = 0.5  # the answer (and its audit line) goes out first


def detect_supervisor(environ=os.environ, pid: int | None = None, parent: int | None = None) -> str | None:
    """Who starts the agent again after it exits: "systemd" when this process is the one a unit
    started (systemd names it in SYSTEMD_EXEC_PID; older ones: INVOCATION_ID and systemd as the
    parent), the name in INDUROP_SUPERVISOR (packaging/demo.sh sets "demo"), or None.  Only the
    unit's own process counts: a test run inside a unit passes INVOCATION_ID on to what it starts."""
    pid = os.getpid() if pid is None else pid
    parent = os.getppid() if parent is None else parent
    if environ.get("SYSTEMD_EXEC_PID") == str(pid) or (environ.get("INVOCATION_ID") and parent == 1):
        return "systemd"
    return environ.get("INDUROP_SUPERVISOR") or None


class NoSupervisor(Exception):
    """Nothing would start the agent again."""


class AgentRestarter:
    """Restarts the agent by exiting gracefully with EXIT_RESTART.  `terminate` is what stops the
    server (__main__ gives uvicorn's; without one, SIGTERM; tests give their own)."""

    def __init__(self, supervisor: str | None = None, terminate=None, delay_s: float = DELAY_S):
        self.supervisor = supervisor
        self.terminate = terminate or (lambda: os.kill(os.getpid(), signal.SIGTERM))
        self.delay_s = delay_s
        self.requested = False
        self._lock = threading.Lock()

    def request(self) -> None:
        """Schedules the exit; raises NoSupervisor when nothing would start the agent again."""
        if self.supervisor is None:
            raise NoSupervisor(
                "the agent runs without a supervisor that would start it again (systemd, or packaging/demo.sh "
                "with INDUROP_SUPERVISOR=demo); restart it by hand"
            )
        with self._lock:
            if self.requested:
                return  # one restart is already on its way
            self.requested = True
        timer = threading.Timer(self.delay_s, lambda: self.terminate())  # the one set by then
        timer.daemon = True
        timer.start()

    def exit_code(self) -> int:
        """What the agent's process exits with once uvicorn has stopped."""
        return EXIT_RESTART if self.requested else 0

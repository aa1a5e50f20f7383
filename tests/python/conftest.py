"""conftest.py -- for every test that starts live processes (live_processes.py): a fixture whose
setup fails half way, irpd started and the agent not, leaves nothing running behind it, so the next
test does not find irpd's shared-memory instance still in use."""

from __future__ import annotations

import live_processes
import pytest


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_setup(item):
    first = len(live_processes.STARTED)
    outcome = yield
    if outcome.excinfo is not None:
        for p in live_processes.STARTED[first:]:
            live_processes.stop(p)

"""conftest.py -- for every test that starts live processes (live_processes.py): a fixture whose
setup fails half way, irpd started and the agent not, or a test body that fails before stopping what
it started, leaves nothing running behind it, so the next
test does not find irpd's shared-memory instance still in use; an irpd the test killed (or that
crashed) leaves no segment in /dev/shm; and the tests that cannot run beside others on xdist's
workers (pytest -n) share a group that --dist loadgroup runs on one worker (xdist_group)."""

from __future__ import annotations

from pathlib import Path

import live_processes
import pytest


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_setup(item):
    first = len(live_processes.STARTED)
    outcome = yield
    if outcome.excinfo is not None:
        for p in live_processes.STARTED[first:]:
            live_processes.stop(p)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_call(item):
    """A test body that fails leaves none of the processes it started running: an exception between
    its start_irpd() and its own stop (a helper's constructor that times out, say) would otherwise
    leave irpd running and its segments mapped after the run."""
    first = len(live_processes.STARTED)
    outcome = yield
    if outcome.excinfo is not None:
        for p in live_processes.STARTED[first:]:
            if p.poll() is None:
                live_processes.stop(p)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_teardown(item, nextitem):
    """After the test's (and its ending module's) fixtures are torn down: the segments of every irpd
    started here that has ended, which no live process maps any more, are removed.  irpd removes its
    own when it stops; one killed by the test (SIGKILL, a crash) cannot."""
    yield
    for p in live_processes.STARTED:
        if getattr(p, "instance", None) and p.poll() is not None:
            live_processes.remove_shm(p.instance)
    live_processes.STARTED[:] = [p for p in live_processes.STARTED if p.poll() is None]


# pytest -n (tests/run.sh: --dist loadgroup): the tests of one file stay together on one worker,
# in their order, as in a serial run: a file's module-scoped irpd, agent or cell is started once,
# not once per worker.  The DDS bridge's and the line's tests run on one worker together: they pick
# their DDS domains from ranges they share in turns ("never at once"; the pid keeps two test runs
# apart, not two workers of one run).
SHARED_GROUPS = {"dds": "dds-domains", "line": "dds-domains"}


def xdist_group(item) -> str:
    """The group xdist runs `item` in: its folder's shared one, else its file's."""
    path = item.path.relative_to(Path(__file__).parent)
    return SHARED_GROUPS.get(path.parts[0], path.as_posix()) if len(path.parts) > 1 else path.as_posix()


@pytest.hookimpl(tryfirst=True)  # before xdist's own, which puts the group in each test's id
def pytest_collection_modifyitems(items):
    for item in items:
        item.add_marker(pytest.mark.xdist_group(xdist_group(item)))

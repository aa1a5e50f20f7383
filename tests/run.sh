#!/usr/bin/env bash
# run.sh -- the whole test suite: installs what is missing, builds, runs every test (ctest, pytest,
# the UI's unit tests with Vitest, the browser tests with Playwright on Debian's chromium), the
# formatting and lint checks of every language (tests/lint.sh, seconds), a short
# run of every fuzz target (tests/fuzz/run.sh: its own clang build in build-fuzz/), and the Debian
# package in a chroot.
# Timing figures are not tested here; tests/bench/ measures them.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/packaging/deps.sh"
bash "$root/packaging/build.sh"

# Python tests (glbc, the agent) in the project's own venv.
venv=$(bash "$root/packaging/venv.sh")
# ROS 2's rclpy from PyPI's wheels, apart (.venv-ros2): the DDS bridge's test with a real ROS 2
# node.  Without it (no network) that one test is skipped and says so.
bash "$root/packaging/ros2-venv.sh" >/dev/null || echo "run.sh: .venv-ros2 not made; the rclpy test of the DDS bridge is skipped" >&2
# The browser tests' own packages (Playwright's runner; the browser is Debian's chromium), and
# node-opcua, the independent OPC UA client of tests/python/opcua/test_node_opcua.py.
bash "$root/packaging/npm-ci.sh" "$root/tests/browser"
bash "$root/packaging/npm-ci.sh" "$root/tests/opcua-client"

status=0
bash "$root/tests/lint.sh" || status=1
(cd "$root/build" && ctest --output-on-failure --timeout 300) || status=1
"$venv/bin/pytest" -q "$root/tests/python" || status=1
(cd "$root/webui" && npx vitest run) || status=1
(cd "$root/tests/browser" && npx playwright test) || status=1
# The Debian package: built (packaging/deb.sh), its units verified, installed, run, removed and
# purged in a Debian 12 chroot (tests/package/deb_test.sh; skipped where it cannot run).
bash "$root/tests/package/deb_test.sh" || status=1
bash "$root/tests/fuzz/run.sh" "${INDUROP_FUZZ_SECONDS:-20}" || status=1
exit $status

#!/usr/bin/env bash
# run.sh -- the whole test suite: installs what is missing, builds (packaging/build.sh --tests: the
# demo's targets and the tests', in the same build/), runs every test (ctest, pytest, the UI's
# unit tests with Vitest, the browser tests with Playwright on Debian's chromium), the formatting
# and lint checks of every language (tests/lint.sh, seconds), a short run of every fuzz target
# (tests/fuzz/run.sh: its own clang build in build-fuzz/), and the Debian package in a chroot.
# Independent tests run side by side (ctest -j, pytest -n, the package's chroot test beside the
# fuzz targets); what runs serially and why: docs/test-suite.md.  At the end it prints each step's
# wall time and the 20 slowest tests (tests/slowest.py), and fails if a test left a shared-memory
# segment of irpd's (/dev/shm/indurop.*) behind.  INDUROP_TEST_JOBS (default 2) sets -j and -n.
# Timing figures are not tested here; tests/bench/ measures them.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
jobs=${INDUROP_TEST_JOBS:-2}
results="$root/build/test-results"
started=$SECONDS

# step NAME COMMAND...: runs it and records its wall time and outcome in $results/steps.txt (a
# step in the background records too); returns its status.  check: the same for a test step, whose
# failure does not stop the others (the run fails at the end).
step() {
  local name=$1 t0=$SECONDS rc=0
  shift
  "$@" || rc=$?
  printf '%-12s %5d s  %s\n' "$name" $((SECONDS - t0)) "$([ $rc = 0 ] && echo ok || echo "FAILED (exit $rc)")" >>"$results/steps.txt"
  return $rc
}
check() { step "$@" || true; }
mkdir -p "$results"
rm -f "$results"/*.xml "$results/steps.txt"
ls /dev/shm >"$results/shm-before.txt"  # segments that are not this run's (tests/shm_leaks.sh)

step deps bash "$root/packaging/deps.sh"
# The Python tests (glbc, the agent) in the project's own venv; ROS 2's rclpy from PyPI's wheels,
# apart (.venv-ros2): the DDS bridge's test with a real ROS 2 node (without it, no network, that one
# test is skipped and says so); the browser tests' own packages (Playwright's runner; the browser is
# Debian's chromium), and node-opcua, the independent OPC UA client of tests/python/opcua/test_node_opcua.py.
# Beside them, the package test's downloads: the .deb's own venv (agent-venv.sh, which deb.sh then
# finds made) and the Debian 12 chroot's tarball (deb_chroot.sh --seed); a failure there is the
# package test's to report.
venvs() {
  (bash "$root/packaging/agent-venv.sh" "$root/build/deb/venv" >/dev/null
   bash "$root/tests/package/deb_chroot.sh" --seed) >"$results/package-downloads.log" 2>&1 &
  local downloads=$! rc=0
  bash "$root/packaging/venv.sh" >/dev/null || rc=1
  bash "$root/packaging/ros2-venv.sh" >/dev/null || echo "run.sh: .venv-ros2 not made; the rclpy test of the DDS bridge is skipped" >&2
  [ $rc = 0 ] && bash "$root/packaging/npm-ci.sh" "$root/tests/browser" && bash "$root/packaging/npm-ci.sh" "$root/tests/opcua-client" || rc=1
  wait $downloads || echo "run.sh: the package test's downloads failed (build/test-results/package-downloads.log); deb-chroot makes them again" >&2
  return $rc
}
# The venvs and the test runners' npm packages (network and disk) beside the build (CPU); their
# output goes to a log, shown when both are done.
step setup venvs >"$results/setup.log" 2>&1 &
setup_pid=$!
build_rc=0
step build bash "$root/packaging/build.sh" --tests || build_rc=$?
setup_rc=0
wait $setup_pid || setup_rc=$?
cat "$results/setup.log"
[ $build_rc = 0 ] && [ $setup_rc = 0 ] || exit 1
venv=$root/.venv

check lint bash "$root/tests/lint.sh"
# ctest -j: the tests that cannot share the machine say so (RUN_SERIAL, RESOURCE_LOCK; tests/cpp).
check ctest bash -c "cd '$root/build' && ctest -j $jobs --output-on-failure --timeout 300 --output-junit '$results/ctest.xml'"
# pytest -n: xdist's workers; tests that cannot run beside others share an xdist_group
# (tests/python/conftest.py), which --dist loadgroup runs on one worker.
check pytest "$venv/bin/pytest" -q -n "$jobs" --dist loadgroup --junitxml="$results/pytest.xml" "$root/tests/python"
check vitest bash -c "cd '$root/webui' && npx vitest run --reporter=default --reporter=junit --outputFile.junit='$results/vitest.xml'"
# Playwright: one worker, the specs share one irpd + agent (global-setup.ts); its JUnit file goes
# to build/test-results/playwright.xml (playwright.config.ts).
check playwright bash -c "cd '$root/tests/browser' && npx playwright test"
# The Debian package (built, its units verified, installed, run, removed and purged in a Debian 12
# chroot; mostly disk and network) beside the fuzz targets (CPU), which touch neither build/ nor
# webui/dist.  Its output goes to a log, shown when it is done.
check deb-chroot bash "$root/tests/package/deb_test.sh" >"$results/deb_test.log" 2>&1 &
deb_pid=$!
check fuzz bash "$root/tests/fuzz/run.sh" "${INDUROP_FUZZ_SECONDS:-20}"
wait $deb_pid || true
cat "$results/deb_test.log"

# No test left a segment of an irpd it started (or one it wrote itself) in /dev/shm.
check shm-leaks bash "$root/tests/shm_leaks.sh" "$results/shm-before.txt"

python3 "$root/tests/slowest.py" -n 20 "$results"/*.xml || true
echo "each step's wall time (total $((SECONDS - started)) s):"
cat "$results/steps.txt"
! grep -q FAILED "$results/steps.txt"

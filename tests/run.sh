#!/usr/bin/env bash
# run.sh -- the whole test suite: installs what is missing, builds, runs every test (ctest).
# Timing figures are not tested here; tests/bench/ measures them.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/packaging/deps.sh"
bash "$root/packaging/build.sh"
cd "$root/build"
ctest --output-on-failure --timeout 300

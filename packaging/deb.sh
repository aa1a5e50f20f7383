#!/usr/bin/env bash
# deb.sh -- builds the appliance's Debian package: build/indurop_<version>_amd64.deb.
#   bash packaging/deb.sh
# Installs what is missing (deps.sh), builds everything and the web UI (build.sh), makes the
# agent's own venv from wheels (agent-venv.sh -> build/deb/venv, installed as
# /usr/lib/indurop/venv), then cpack (the install rules; packaging/CMakeLists.txt) strips, runs
# dpkg-shlibdeps for the Depends and writes the .deb.  Prints the .deb's path.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/packaging/deps.sh"
bash "$root/packaging/build.sh"
test -f "$root/webui/dist/index.html" || { echo "deb: webui/dist was not built" >&2; exit 1; }
venv=$(bash "$root/packaging/agent-venv.sh" "$root/build/deb/venv")

cd "$root/build"
rm -f indurop_*.deb
INDUROP_AGENT_VENV=$venv cpack -G DEB -B "$root/build/deb/cpack" >"$root/build/deb/cpack.log" 2>&1 \
  || { cat "$root/build/deb/cpack.log" >&2; echo "deb: cpack failed" >&2; exit 1; }
deb=$(ls "$root"/build/deb/cpack/indurop_*.deb)
mv "$deb" "$root/build/"
echo "$root/build/$(basename "$deb")"

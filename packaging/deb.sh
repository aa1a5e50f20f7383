#!/usr/bin/env bash
# deb.sh -- builds the appliance's Debian package: build/indurop_<version>_amd64.deb.
#   bash packaging/deb.sh
# Installs what is missing (deps.sh), builds what the package holds in build/ (build.sh: irpd,
# libindurop, the sets, the web UI; not the tests), makes the agent's own venv
# from wheels (agent-venv.sh -> build/deb/venv, installed as /usr/lib/indurop/venv), finds the Depends with dpkg-shlibdeps (shlibdeps.sh), then cpack (the
# install rules; packaging/CMakeLists.txt) strips and writes the .deb.  Prints the .deb's path.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
# stdout carries the .deb's path only (callers take it with $(...)): the steps' output goes to stderr
exec 3>&1 1>&2
bash "$root/packaging/deps.sh"
# What the demo runs is what the package holds (the tests' targets are not in `all`).
bash "$root/packaging/build.sh"
test -f "$root/webui/dist/index.html" || { echo "deb: webui/dist was not built" >&2; exit 1; }
venv=$(bash "$root/packaging/agent-venv.sh" "$root/build/deb/venv")

# The Depends of every ELF file the package holds (CPack's own SHLIBDEPS is slow on the venv).
shlibdeps=$(bash "$root/packaging/shlibdeps.sh" "$root/build/bin/irpd" "$root"/build/rtcore/libindurop.so.*.*.* \
            "$root/build/sets" "$venv")

cd "$root/build"
rm -f indurop_*.deb
INDUROP_AGENT_VENV=$venv INDUROP_DEB_SHLIBDEPS=$shlibdeps cpack -G DEB -B "$root/build/deb/cpack" >"$root/build/deb/cpack.log" 2>&1 \
  || { cat "$root/build/deb/cpack.log" >&2; echo "deb: cpack failed" >&2; exit 1; }
deb=$(ls "$root"/build/deb/cpack/indurop_*.deb)
mv "$deb" "$root/build/"
echo "$root/build/$(basename "$deb")" >&3

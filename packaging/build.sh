#!/usr/bin/env bash
# build.sh -- configures and builds everything into build/ (irpd, libindurop, the sets, the tests)
# and the web UI into webui/dist (npm ci only when package-lock.json changed).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cmake -S "$root" -B "$root/build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build "$root/build"

bash "$root/packaging/npm-ci.sh" "$root/webui"
(cd "$root/webui" && npm run --silent build >/dev/null)

#!/usr/bin/env bash
# build.sh [--tests] -- configures and builds into build/ what the demo and the package run (irpd,
# libindurop, the sets with the drive simulator and the I/O dispatcher, tools/dds) and the web UI
# into webui/dist (npm ci only when package-lock.json changed), the two side by side.  --tests also
# builds the tests' targets (the tests/all target: the C++ tests, their fixtures and sets, the
# benchmark's binaries), as tests/run.sh does, in the same build/.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
targets=(all)
[ "${1:-}" = --tests ] && targets+=(tests/all)
# The web UI (npm ci: mostly the disk and the npm cache; then Vite) beside the C++ build.
(bash "$root/packaging/npm-ci.sh" "$root/webui" && cd "$root/webui" && npm run --silent build >/dev/null) &
webui=$!
status=0
cmake -S "$root" -B "$root/build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null &&
  cmake --build "$root/build" --target "${targets[@]}" || status=1
wait $webui || { echo "build: the web UI was not built (webui/: npm ci, npm run build)" >&2; status=1; }
exit $status

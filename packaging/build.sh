#!/usr/bin/env bash
# build.sh -- configures and builds everything into build/ (irpd, libindurop, the sets, the tests).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cmake -S "$root" -B "$root/build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build "$root/build"

#!/usr/bin/env bash
# demo.sh -- installs what is missing, builds, and starts the default demo: irpd running the
# paper's Figure 1 set (config/sets/paper-fig1) until Ctrl-C.  Extra arguments go to irpd,
# e.g. `bash packaging/demo.sh --duration 10 --stats-json /tmp/stats.json`.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/packaging/deps.sh"
bash "$root/packaging/build.sh"
echo "demo: irpd --config build/sets/paper-fig1/module.xml $*  (Ctrl-C stops it)"
exec "$root/build/bin/irpd" --config "$root/build/sets/paper-fig1/module.xml" "$@"

#!/usr/bin/env bash
# npm-ci.sh DIR -- a clean `npm ci` of DIR's package-lock.json, redone only when the lock changed.
set -euo pipefail
dir=$1
if [ ! -f "$dir/node_modules/.ci-stamp" ] || [ "$dir/package-lock.json" -nt "$dir/node_modules/.ci-stamp" ]; then
  (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error >/dev/null)
  touch "$dir/node_modules/.ci-stamp"
fi

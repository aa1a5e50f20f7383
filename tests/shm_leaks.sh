#!/usr/bin/env bash
# shm_leaks.sh BEFORE -- fails naming every irpd shared-memory segment (/dev/shm/indurop.*,
# docs/shared-memory.md) that a test run left: not listed in the file BEFORE (`ls /dev/shm` when the
# run started: another run's, an older leak) and mapped by no live process (an irpd still running
# is not a leak).  tests/run.sh runs it at the end.
set -euo pipefail
before=$1
leaks=()
for f in /dev/shm/indurop.*; do
  [ -e "$f" ] || continue
  grep -qxF "${f#/dev/shm/}" "$before" && continue
  grep -qsF "$f" /proc/[0-9]*/maps && continue
  leaks+=("${f#/dev/shm/}")
done
if [ ${#leaks[@]} -gt 0 ]; then
  echo "shm_leaks: the tests left ${#leaks[@]} segment(s) in /dev/shm: ${leaks[*]}" >&2
  exit 1
fi

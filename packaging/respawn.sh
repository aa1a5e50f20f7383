#!/usr/bin/env bash
# respawn.sh CMD [ARGS...] -- runs CMD, and again each time it exits with 75 (what indurop-agent
# exits with when it is asked to restart: docs/administration.md, "Restarts"); ends with CMD's
# other exit status.  SIGTERM and SIGINT are passed on to CMD, which is waited for.
# packaging/demo.sh supervises the agent with it, as systemd's RestartForceExitStatus=75 does.
set -u
child=
stop() {
  [ -n "$child" ] && kill -TERM "$child" 2>/dev/null
  wait "$child" 2>/dev/null
  exit 143
}
trap stop TERM INT
while :; do
  "$@" &
  child=$!
  wait "$child"
  rc=$?
  [ "$rc" -eq 75 ] || exit "$rc"
  echo "respawn: exit 75 (a restart was asked): starting it again" >&2
done

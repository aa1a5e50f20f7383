#!/usr/bin/env bash
# demo-set.sh -- which set packaging/demo.sh runs, and making it the active set of the agent's set
# store (docs/set-store.md), so that what irpd runs is a stored set with its files, its history and,
# for a set in Structured Text, its sources (the Programs page edits the active set's .st files):
#
#   demo-set.sh pick DATA SETS
#       prints the module.xml irpd starts on: with INDUROP_SET=<name>, SETS/<name> (the build's
#       sets) unless the store's active set is already the one stored from that build of it (then
#       DATA/active: the stored set itself); without it, the set activated last (DATA/active), else
#       SETS/plc-robot, the cell of the paper's §4.  Exit 2, listing SETS, when <name> is not there.
#   demo-set.sh store DATA FOLDER URL IRPCTL
#       once the agent answers on URL: uploads the set folder FOLDER (a set of the build, the one
#       irpd was started on) with the admin token and activates it (online when possible, else by a
#       managed restart), as `irpctl upload FOLDER --activate` does, then records in DATA/demo-set
#       which build of which set the active set was stored from.  An ST set's .st files are
#       compiled again by the agent on the way (docs/set-store.md "The Structured Text build").
set -euo pipefail

# "<name> <sha256 of the folder's files> <the active set's id>": equal to DATA/demo-set while the
# active set is the one stored from this build of the set
record() {
  local data=$1 folder=$2 digest active=""
  digest=$(cd "$folder" && find . -type f -print0 | LC_ALL=C sort -z | xargs -0 sha256sum | sha256sum)
  [ -L "$data/active" ] && active=$(basename "$(dirname "$(readlink "$data/active")")")
  echo "$(basename "$folder") ${digest%% *} $active"
}

case ${1:-} in
pick)
  data=$2 sets=$3
  if [ -z "${INDUROP_SET:-}" ] && [ -f "$data/active/module.xml" ]; then
    echo "$data/active/module.xml"
    exit 0
  fi
  folder=$sets/${INDUROP_SET:-plc-robot}
  if [ ! -f "$folder/module.xml" ]; then
    echo "demo: INDUROP_SET=${INDUROP_SET:-}: no $folder/module.xml; the built sets are: $(cd "$sets" && ls -d */ | tr -d / | tr '\n' ' ')" >&2
    exit 2
  fi
  if [ -f "$data/active/module.xml" ] && [ "$(cat "$data/demo-set" 2>/dev/null)" = "$(record "$data" "$folder")" ]; then
    echo "$data/active/module.xml"  # the store's active set is this build of the set already
  else
    echo "$folder/module.xml"
  fi
  ;;
store)
  data=$2 folder=$3 url=$4 irpctl=$5
  if ! INDUROP_URL=$url INDUROP_TOKEN_FILE=$data/admin-token "$irpctl" upload "$folder" --activate --mode auto >/dev/null; then
    echo "demo: $folder could not be stored in the set store (above: why); it runs as started" >&2
    exit 1
  fi
  record "$data" "$folder" >"$data/demo-set"
  ;;
*)
  echo "usage: demo-set.sh pick DATA SETS | store DATA FOLDER URL IRPCTL" >&2
  exit 2
  ;;
esac

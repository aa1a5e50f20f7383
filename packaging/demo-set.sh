#!/usr/bin/env bash
# demo-set.sh -- which set packaging/demo.sh runs, and making it the active set of the agent's set
# store (docs/set-store.md), so that what irpd runs is a stored set with its files, its history and,
# for a set in Structured Text, its sources (the Programs page edits the active set's .st files):
#
#   demo-set.sh pick DATA SETS
#       prints the module.xml irpd starts on: with INDUROP_SET=<name>, SETS/<name> (the build's
#       sets) unless the demo stored that build of it already (DATA/demo-set says so): then the
#       store's active set (DATA/active), which is that set or what was activated since through the
#       agent (an edit of its program on the Programs page, a rollback): the edits are kept across
#       restarts of the demo, and the build's set is stored again once it is built anew; without
#       INDUROP_SET, the set activated last (DATA/active), else SETS/plc-robot-st, the cell of the
#       paper's §4 with its PLC program in Structured Text.  Exit 2, listing SETS, when <name> is
#       not there.
#   demo-set.sh store DATA FOLDER URL IRPCTL
#       once the agent answers on URL: uploads the set folder FOLDER (a set of the build, the one
#       irpd was started on) with the admin token and activates it (online when possible, else by a
#       managed restart), as `irpctl upload FOLDER --activate` does, then records in DATA/demo-set
#       which build of which set it stored, and as which set.  An ST set's .st files are compiled
#       again by the agent on the way (docs/set-store.md "The Structured Text build").
set -euo pipefail

# "<name> <sha256 of the folder's files>": DATA/demo-set starts so while the demo's last upload was
# this build of the set (then the id of the set it was stored as)
build() {
  local digest
  digest=$(cd "$1" && find . -type f -print0 | LC_ALL=C sort -z | xargs -0 sha256sum | sha256sum)
  echo "$(basename "$1") ${digest%% *}"
}
active_id() {
  if [ -L "$1/active" ]; then basename "$(dirname "$(readlink "$1/active")")"; fi
}

case ${1:-} in
pick)
  data=$2 sets=$3
  if [ -z "${INDUROP_SET:-}" ] && [ -f "$data/active/module.xml" ]; then
    echo "$data/active/module.xml"
    exit 0
  fi
  folder=$sets/${INDUROP_SET:-plc-robot-st}
  if [ ! -f "$folder/module.xml" ]; then
    echo "demo: INDUROP_SET=${INDUROP_SET:-}: no $folder/module.xml; the built sets are: $(cd "$sets" && ls -d */ | tr -d / | tr '\n' ' ')" >&2
    exit 2
  fi
  stored=$(cat "$data/demo-set" 2>/dev/null || true)
  if [ -f "$data/active/module.xml" ] && [ "${stored% *}" = "$(build "$folder")" ]; then
    active=$(active_id "$data")
    if [ "$active" != "${stored##* }" ]; then
      echo "demo: $folder as built is set ${stored##* } of the set store; irpd starts on the active set $active, activated since through the agent (\`irpctl activate ${stored##* }\` goes back)" >&2
    fi
    echo "$data/active/module.xml"
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
  echo "$(build "$folder") $(active_id "$data")" >"$data/demo-set"
  ;;
*)
  echo "usage: demo-set.sh pick DATA SETS | store DATA FOLDER URL IRPCTL" >&2
  exit 2
  ;;
esac

#!/usr/bin/env bash
# demo-irpd.sh DATA IRPD [ARGS...] -- runs irpd (the executable IRPD with ARGS) as packaging/demo.sh
# does: its state folder (crash records, the RETAIN and PERSISTENT values, docs/retain.md) is DATA/state,
# in the demo's data folder, so that a restart of the demo restores the retained values for any user
# (irpd's default, /var/lib/indurop/irpd, is root's: a user's irpd cannot write there and keeps none).
# A --state-dir among ARGS wins.  irpd replaces this shell: its pid is the one the caller started.
set -euo pipefail
data=$1
irpd=$2
shift 2
exec "$irpd" --state-dir "$data/state" "$@"

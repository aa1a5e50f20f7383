#!/usr/bin/env bash
# old_deb.sh NEW_DEB OUT_DEB [REF] -- an "older build" of the package to upgrade from: NEW_DEB with
# the maintainer scripts, the agent's unit and activate-default-set of the commit REF (default: the
# parent of the commit that made the agent serve HTTPS) and a lower version (<version>~before-https).
# What an upgrade meets is then what that build left: its data folder (tokens, the set store, no
# certificate) and its unit (plain HTTP on 127.0.0.1:8080).  The programs inside are NEW_DEB's: the
# data folder's formats did not change between REF and now; the old scripts' imports of the agent
# are pointed at where NEW_DEB's agent has those modules.  Exit 77 when there is no such commit
# in this clone's history (a shallow clone).
set -euo pipefail
new=$(realpath "$1")
out=$2
root=$(cd "$(dirname "$0")/../.." && pwd)
# the default: the parent of the commit that made the agent's unit serve HTTPS
https=$(git -C "$root" log -1 --format=%H -S'--tls-cert /var/lib/indurop/tls/cert.pem' \
        -- packaging/systemd/indurop-agent.service 2>/dev/null || true)
ref=${3:-${https:+$https^}}
[ -n "$ref" ] && git -C "$root" rev-parse -q --verify "$ref^{commit}" >/dev/null \
  || { echo "old_deb: no commit before HTTPS in this clone's history (shallow?)" >&2; exit 77; }
work=$(mktemp -d /tmp/indurop-old-deb-XXXXXX)
trap 'rm -rf "$work"' EXIT
dpkg-deb -R "$new" "$work/pkg"
old_file() { git -C "$root" show "$ref:$1" > "$2"; }
for s in postinst prerm postrm; do
  old_file "packaging/debian/$s" "$work/pkg/DEBIAN/$s"
  chmod 0755 "$work/pkg/DEBIAN/$s"
done
# The agent's modules the old scripts import, at their place in NEW_DEB's agent (a real older build
# ships the programs its scripts were written for; the agent's modules have moved since: docs/architecture.md).
sed -i 's/\bindurop_agent\.auth\b/indurop_agent.access.auth/g' "$work/pkg/DEBIAN/postinst"
old_file packaging/systemd/indurop-agent.service "$work/pkg/usr/lib/systemd/system/indurop-agent.service"
old_file packaging/systemd/activate-default-set "$work/pkg/usr/lib/indurop/activate-default-set"
version=$(dpkg-deb -f "$new" Version)
sed -i "s/^Version: .*/Version: ${version}~before-https/" "$work/pkg/DEBIAN/control"
(cd "$work/pkg" && find . -path ./DEBIAN -prune -o -type f -printf '%P\0' | sort -z | xargs -0 md5sum > DEBIAN/md5sums)
dpkg-deb --root-owner-group -Zgzip -z1 -b "$work/pkg" "$out" >/dev/null
echo "old_deb: $out (version ${version}~before-https, scripts and agent unit of $ref)" >&2

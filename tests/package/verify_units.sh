#!/usr/bin/env bash
# verify_units.sh DEB -- `systemd-analyze verify` of the package's units against its own files:
# the .deb unpacked over a copy of this machine's unit folders (for the targets they name), so that
# every ExecStart path, user and directive is checked as systemd would.  Any message fails (verify
# only warns about unknown keys).  Exit 77 (skip) without systemd-analyze.
set -euo pipefail
deb=$(realpath "$1")
command -v systemd-analyze >/dev/null || { echo "verify_units: systemd-analyze is not installed" >&2; exit 77; }
root=$(mktemp -d /tmp/indurop-units-XXXXXX)
trap 'rm -rf "$root"' EXIT
mkdir -p "$root/usr/lib/systemd" "$root/etc"
cp -a /usr/lib/systemd/system "$root/usr/lib/systemd/"
ln -s usr/lib "$root/lib" && ln -s usr/bin "$root/bin" && ln -s usr/sbin "$root/sbin"
cp /etc/passwd /etc/group "$root/etc/"
dpkg-deb -x "$deb" "$root"
out=$(systemd-analyze verify --root="$root" /usr/lib/systemd/system/irpd.service \
      /usr/lib/systemd/system/indurop-agent.service /usr/lib/systemd/system/indurop-dds-bridge.service \
      /usr/lib/systemd/system/indurop-opcua.service 2>&1) || { echo "$out"; echo "FAILED: systemd-analyze verify"; exit 1; }
[ -z "$out" ] || { echo "$out"; echo "FAILED: systemd-analyze verify has something to say"; exit 1; }
systemd-analyze security --offline=yes --root="$root" irpd.service indurop-agent.service indurop-dds-bridge.service indurop-opcua.service 2>/dev/null | grep "Overall" || true
echo "verify_units: irpd.service, indurop-agent.service, indurop-dds-bridge.service and indurop-opcua.service verified"

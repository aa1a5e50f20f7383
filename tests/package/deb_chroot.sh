#!/usr/bin/env bash
# deb_chroot.sh DEB [OLD_DEB] -- installs the .deb into a clean Debian 12 (bookworm) minbase chroot
# with apt (real dependency resolution), checks what it installed and that it runs, then removes and
# purges it and checks that nothing of it is left; with OLD_DEB (an older build: old_deb.sh), then
# installs that, runs it (a user added and signed in), upgrades it to DEB and checks that the
# upgrade kept the data, the users and their sessions, and that the old admin token, the old session
# and the user's password sign in over HTTPS; then upgrades again and checks the certificate is kept.  Needs root (debootstrap, chroot, mounts).
#
#   bash tests/package/deb_chroot.sh build/indurop_0.1.0_amd64.deb [build/indurop-old.deb]
#
# The chroot is made once by debootstrap (a few minutes, most of it downloading) and kept as a
# tarball in build/package-chroot/; later runs unpack a fresh copy of it (seconds).  The packages
# apt downloads are kept there too.  Exit 77 (skip) when debootstrap is not installed or the
# Debian mirror cannot be reached.
#
# In the chroot (no systemd running there): the package's files, the user and group indurop, the
# data folder and first admin token, every ELF file's libraries resolved, irpd --version,
# indurop-agent --help, irpd running a shipped set for a second, irpd started the way irpd.service
# starts it (irpd-start, without SCHED_FIFO: --no-rt) with the agent beside it as the user
# indurop started with its unit's arguments (HTTPS with the certificate postinst made, its
# fingerprint the one the install printed; plain HTTP not answered; on 127.0.0.1 and a free port
# instead of every interface and 8443), the default set stored and activated
# (activate-default-set), irpd restarted on the active set, an ST set using PLCopen blocks uploaded
# and compiled there (and the ST SDK and the ST cell's example installed); then `apt-get remove` (data kept),
# `apt-get purge --autoremove` (the file system's names as before the install).  The upgrade:
# OLD_DEB installed and run as its unit has it (HTTP), its default set activated; DEB installed
# over it: the tokens, the set store and the active set kept, a certificate made, the agent on
# HTTPS answering the old admin token with the same active set; then purged again.
# deb_chroot.sh --seed: only makes the chroot's tarball (tests/run.sh makes it beside the build: it is
# mostly downloading).
set -euo pipefail
seed_only=0
[ "${1:-}" = --seed ] && seed_only=1
deb=$([ $seed_only = 1 ] || realpath "$1")
old_deb=${2:+$(realpath "$2")}
root=$(cd "$(dirname "$0")/../.." && pwd)
cache=${INDUROP_CHROOT_CACHE:-$root/build/package-chroot}
mirror=${INDUROP_DEBIAN_MIRROR:-http://deb.debian.org/debian}
tarball=$cache/bookworm-minbase.tar.gz
[ "$(id -u)" -eq 0 ] || { echo "deb_chroot: needs root (debootstrap, chroot)" >&2; exit 77; }
command -v debootstrap >/dev/null || { echo "deb_chroot: debootstrap is not installed" >&2; exit 77; }
mkdir -p "$cache/archives/partial" "$cache/lists/partial"

# Unmounts what is mounted below $1, deepest first: debootstrap mounts proc (and sys) in its target,
# and a run killed meanwhile leaves them mounted, which rm must not walk into.
unmount_below() {
  awk -v d="$1/" 'index($2, d) == 1 {print $2}' /proc/mounts | sort -r | while read -r m; do umount -l "$m"; done
}

if [ ! -f "$tarball" ]; then
  echo "deb_chroot: debootstrap bookworm minbase into $cache (once; kept as $(basename "$tarball"))"
  unmount_below "$cache/seed"
  rm -rf --one-file-system "$cache/seed"
  debootstrap --variant=minbase bookworm "$cache/seed" "$mirror" >"$cache/debootstrap.log" 2>&1 \
    || { tail -5 "$cache/debootstrap.log" >&2; echo "deb_chroot: debootstrap failed (no mirror?)" >&2; exit 77; }
  unmount_below "$cache/seed"
  tar -C "$cache/seed" -czf "$tarball.part" . && mv "$tarball.part" "$tarball"
  rm -rf --one-file-system "$cache/seed"
fi
[ $seed_only = 0 ] || exit 0

chr=$(mktemp -d "$cache/root-XXXXXX")
irpd_pid=
# The processes this test started in the chroot (irpd, runuser and the agent under it): by pid,
# found by their root folder.
stop_chroot_processes() {
  local p pids=()
  for p in /proc/[0-9]*; do
    [ "$(readlink "$p/root" 2>/dev/null)" = "$chr" ] && pids+=("${p#/proc/}")
  done
  [ ${#pids[@]} -eq 0 ] && return 0
  kill "${pids[@]}" 2>/dev/null || true
  for _ in $(seq 50); do kill -0 "${pids[@]}" 2>/dev/null || break; sleep 0.1; done
  kill -9 "${pids[@]}" 2>/dev/null || true
  wait 2>/dev/null || true
}
cleanup() {
  stop_chroot_processes
  for m in var/lib/apt/lists var/cache/apt/archives dev/shm dev proc; do
    mountpoint -q "$chr/$m" && umount -l "$chr/$m"
  done
  rm -rf --one-file-system "$chr"
}
trap cleanup EXIT
tar -C "$chr" -xzf "$tarball"
mount -t proc proc "$chr/proc"
mount -t tmpfs -o mode=0755 dev "$chr/dev"
for d in null zero random urandom tty; do touch "$chr/dev/$d"; mount --bind "/dev/$d" "$chr/dev/$d"; done
mkdir -p "$chr/dev/shm" && mount -t tmpfs -o mode=1777 shm "$chr/dev/shm"
mount --bind "$cache/archives" "$chr/var/cache/apt/archives"
mount --bind "$cache/lists" "$chr/var/lib/apt/lists"
in_chroot() { chroot "$chr" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin LANG=C.UTF-8 "$@"; }
fail() { echo "FAILED: $*" >&2; exit 1; }

# What the system has before: the names of its files, outside what apt and dpkg keep for themselves.
snapshot() {
  (cd "$chr" && find . -xdev \( -path ./proc -o -path ./dev -o -path ./tmp -o -path ./var/cache -o -path ./var/lib/apt \
      -o -path ./var/lib/dpkg -o -path ./var/log -o -path ./run \) -prune -o -print | sort)
}
snapshot > "$cache/before.txt"

echo "deb_chroot: apt-get install ./$(basename "$deb")"
cp "$deb" "$chr/tmp/"
in_chroot apt-get update -qq >/dev/null 2>"$cache/apt.log" || { cat "$cache/apt.log" >&2; echo "deb_chroot: apt-get update failed (no mirror?)" >&2; exit 77; }
t0=$(date +%s)
in_chroot env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "/tmp/$(basename "$deb")" \
  >"$cache/install.log" 2>&1 || { tail -30 "$cache/install.log" >&2; fail "apt-get install of the .deb"; }
echo "deb_chroot: installed in $(( $(date +%s) - t0 )) s: $(grep -c '^Unpacking' "$cache/install.log") packages unpacked"
grep "admin token" "$cache/install.log" || fail "postinst did not say where the first admin token is"
# The certificate the agent serves: made at the install, its fingerprint in the install log.
fingerprint=$(sed -n 's/.*SHA-256 fingerprint \([0-9A-F:]*\).*/\1/p' "$cache/install.log" | tail -1)
[ ${#fingerprint} -eq 95 ] || { tail -20 "$cache/install.log"; fail "postinst did not print the certificate's SHA-256 fingerprint"; }
echo "deb_chroot: the install made a TLS certificate, SHA-256 $fingerprint"

# Files.
for f in /usr/bin/irpd /usr/bin/glbc /usr/bin/indurop-agent /usr/bin/irpctl /usr/include/indurop/indurop.h \
         /usr/lib/cmake/indurop/induropConfig.cmake /usr/lib/pkgconfig/indurop.pc \
         /usr/share/indurop/webui/index.html /usr/share/indurop/sets/signals/module.xml \
         /usr/share/indurop/sets/plc-robot/module.xml /usr/lib/systemd/system/irpd.service \
         /usr/lib/systemd/system/indurop-agent.service /usr/lib/systemd/system/indurop-dds-bridge.service \
         /usr/bin/indurop-dds-bridge /usr/lib/systemd/system/indurop-opcua.service /usr/bin/indurop-opcua \
         /usr/share/doc/indurop/opcua.md /usr/lib/sysusers.d/indurop.conf \
         /usr/lib/tmpfiles.d/indurop.conf /usr/lib/indurop/venv/bin/python; do
  [ -e "$chr$f" ] || fail "$f is not installed"
done
ls "$chr"/usr/lib/libindurop.so.* >/dev/null || fail "libindurop is not installed"
# The user, the data folder, the token.
in_chroot id indurop >/dev/null || fail "no user indurop"
# (stat in the chroot: the names are the chroot's users)
[ "$(in_chroot stat -c '%U:%G %a' /var/lib/indurop)" = "indurop:indurop 750" ] || fail "/var/lib/indurop: $(in_chroot stat -c '%U:%G %a' /var/lib/indurop)"
[ "$(in_chroot stat -c '%U %a' /var/lib/indurop/admin-token)" = "indurop 600" ] || fail "the admin token is not indurop's, 0600"
[ "$(in_chroot stat -c '%U %a' /var/lib/indurop/tls/key.pem)" = "indurop 600" ] || fail "the TLS key is not indurop's, 0600"
[ "$(in_chroot stat -c '%U' /var/lib/indurop/tls/cert.pem)" = "indurop" ] || fail "the TLS certificate is not indurop's"
for f in "$chr"/etc/systemd/system/{irpd,indurop-agent,indurop-dds-bridge,indurop-opcua}.service.d/50-cpus.conf; do
  grep -q '^CPUAffinity=' "$f" || fail "$f has no CPUAffinity"
done
for unit in irpd indurop-agent indurop-dds-bridge indurop-opcua; do   # enabled for the next boot (deb-systemd-helper)
  [ -L "$chr/etc/systemd/system/multi-user.target.wants/$unit.service" ] || fail "$unit.service is not enabled"
done
# Every ELF file's libraries are found: the Depends are complete.  (A library a wheel bundles
# beside another in its .libs folder is found there at run time, when the extension module that
# needs them has loaded the first.)
missing=$(in_chroot python3 - <<'PY'
import os, subprocess
files = subprocess.run(["dpkg", "-L", "indurop"], capture_output=True, text=True).stdout.split("\n")
for f in files:
    if not os.path.isfile(f) or os.path.islink(f):
        continue
    with open(f, "rb") as fh:
        if fh.read(4) != b"\x7fELF":
            continue
    out = subprocess.run(["ldd", f], capture_output=True, text=True).stdout
    for line in out.splitlines():
        if "not found" in line:
            lib = line.split()[0]
            if not os.path.exists(os.path.join(os.path.dirname(f), lib)):
                print(f"{f}: {lib} not found")
PY
)
[ -z "$missing" ] || { echo "$missing" | head -20; fail "libraries not found (Depends incomplete)"; }

# The commands.
in_chroot irpd --version | grep -q . || fail "irpd --version"
in_chroot indurop-agent --help >/dev/null || fail "indurop-agent --help"
in_chroot irpctl --help >/dev/null || fail "irpctl --help"
in_chroot indurop-dds-bridge --help >/dev/null || fail "indurop-dds-bridge --help"
in_chroot indurop-opcua --help >/dev/null || fail "indurop-opcua --help"
in_chroot glbc --version >/dev/null || fail "glbc --version"
out=$(in_chroot irpd --config /usr/share/indurop/sets/signals/module.xml --duration 1 --no-rt --instance pkg-chroot 2>&1) \
  || { echo "$out"; fail "irpd on the signals set"; }

# irpd as irpd.service starts it (root, group indurop, then --user indurop), the agent as the user indurop.
port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
start_irpd() {
  in_chroot install -d -o root -g indurop -m 0770 /run/indurop
  chroot "$chr" /usr/bin/env -i PATH=/usr/bin:/bin IRPD_ARGS=--no-rt \
    setpriv --regid indurop --clear-groups sh -c 'umask 0007; exec /usr/lib/indurop/irpd-start --user indurop --group indurop --state-dir /var/lib/indurop/irpd' >>"$cache/irpd.log" 2>&1 &
  irpd_pid=$!
  for _ in $(seq 100); do [ -S "$chr/run/indurop/irpd.sock" ] && return 0; sleep 0.1; done
  cat "$cache/irpd.log"; fail "irpd did not open its control socket"
}
: > "$cache/irpd.log"
start_irpd
grep -q "no set activated yet" "$cache/irpd.log" || fail "irpd-start did not fall back to the default set"
[ "$(in_chroot stat -c %U /run/indurop/irpd.sock)" = indurop ] || fail "irpd did not switch to the user indurop (socket: $(in_chroot stat -c %U /run/indurop/irpd.sock))"
# The agent as its unit starts it (its INDUROP_AGENT_ARGS), but on 127.0.0.1 and a free port.
unit_args() {
  sed -n 's/^Environment="INDUROP_AGENT_ARGS=\(.*\)"$/\1/p' "$chr/usr/lib/systemd/system/indurop-agent.service" \
    | sed -e 's/--host [^ ]*/--host 127.0.0.1/' -e "s/--port [0-9]*/--port $port/"
}
ca="$chr/var/lib/indurop/tls/cert.pem"
start_agent() {  # SCHEME: runs the agent as its unit has it; waits for /health over SCHEME
  local scheme=$1 health=
  # shellcheck disable=SC2046  # the unit's arguments, word-split as systemd does
  in_chroot runuser -u indurop -- /usr/bin/indurop-agent $(unit_args) --data-dir /var/lib/indurop \
    --irpd-socket /run/indurop/irpd.sock >"$cache/agent.log" 2>&1 &
  for _ in $(seq 300); do
    health=$(curl -sf $([ "$scheme" = https ] && echo --cacert "$ca") "$scheme://127.0.0.1:$port/api/v1/health" || true)
    [ -n "$health" ] && break; sleep 0.1
  done
  [ -n "$health" ] || { cat "$cache/agent.log"; fail "the agent did not answer $scheme://127.0.0.1:$port/api/v1/health"; }
  echo "deb_chroot: /api/v1/health over $scheme: $health"
}
served_fingerprint() {
  python3 -c 'import hashlib, ssl, sys
der = ssl.PEM_cert_to_DER_cert(ssl.get_server_certificate(("127.0.0.1", int(sys.argv[1]))))
print(hashlib.sha256(der).hexdigest().upper())' "$port" | sed 's/../&:/g; s/:$//'
}
case " $(unit_args) " in *" --tls-cert "*) ;; *) fail "the agent's unit does not serve HTTPS: $(unit_args)" ;; esac
grep -q '^Environment="INDUROP_AGENT_ARGS=--host 0.0.0.0 --port 8443 ' "$chr/usr/lib/systemd/system/indurop-agent.service" \
  || fail "the agent's unit does not listen on every interface, port 8443"
start_agent https
[ "$(served_fingerprint)" = "$fingerprint" ] || fail "the agent serves $(served_fingerprint), not the certificate the install made ($fingerprint)"
! curl -sf -m 5 "http://127.0.0.1:$port/api/v1/health" >/dev/null 2>&1 || fail "the agent answers plain HTTP"
in_chroot runuser -u indurop -- env INDUROP_URL="https://127.0.0.1:$port" /usr/lib/indurop/activate-default-set \
  || { cat "$cache/agent.log"; fail "activate-default-set"; }
[ -L "$chr/var/lib/indurop/active" ] && [ -f "$chr/var/lib/indurop/active/module.xml" ] || fail "no active set after activate-default-set"
# irpd killed: started again, it runs the active set (the store's link), not the default one.
kill -9 "$irpd_pid"; wait "$irpd_pid" 2>/dev/null || true
: > "$cache/irpd.log"
start_irpd
! grep -q "no set activated yet" "$cache/irpd.log" || fail "irpd-start did not start the active set"
# api PATH [SCHEME]: GET as the first admin
api() {
  local scheme=${2:-https}
  curl -sf $([ "$scheme" = https ] && echo --cacert "$ca") -H "Authorization: Bearer $(cat "$chr/var/lib/indurop/admin-token")" \
    "$scheme://127.0.0.1:$port/api/v1/$1" || true
}
active_id() { readlink "$chr/var/lib/indurop/active" | cut -d/ -f2; }
runs_active_set() {  # until irpd (through the agent) runs the store's active set
  local status
  for _ in $(seq 50); do status=$(api status "$@"); echo "$status" | grep -q "$(active_id)" && return 0; sleep 0.2; done
  echo "$status"; return 1
}
runs_active_set || fail "irpd does not run the active set after its restart"
# A set in Structured Text, uploaded: the agent compiles it here (stc, python3-lark, g++, the SDK's
# headers, the ST runtime and st/lib, libindurop and libindurop_plcopen.a as the package installs
# them) and stores the module it built; its PLCopen blocks (MC_Power, MC_MoveAbsolute) are linked in.
in_chroot install -d -o indurop /tmp/st-set
printf '%s\n' 'PROGRAM Counter VAR n : DINT; Robot : AXES_GROUP_REF; Power : MC_Power;' \
  'MoveJ : MC_MoveAbsolute; Home : AXES; powered : BOOL; END_VAR n := n + 1;' \
  'Power(AxesGroup := Robot, Enable := TRUE, Status => powered);' \
  'MoveJ(AxesGroup := Robot, Execute := powered, Position := Home, Velocity := 0.5, Acceleration := 0.5);' \
  'END_PROGRAM' \
  'CONFIGURATION Cell RESOURCE Cpu ON PLC TASK Fast (INTERVAL := T#1ms, PRIORITY := 1);' \
  'PROGRAM Main WITH Fast : Counter; END_RESOURCE END_CONFIGURATION' > "$chr/tmp/st-set/main.st"
st=$(in_chroot runuser -u indurop -- irpctl --url "https://127.0.0.1:$port" --ca /var/lib/indurop/tls/cert.pem \
  --token-file /var/lib/indurop/admin-token --json upload /tmp/st-set 2>&1) || { echo "$st"; cat "$cache/agent.log"; fail "upload of an ST set"; }
echo "$st" | grep -q '"path": "Main.so"' || { echo "$st"; fail "the uploaded ST set holds no Main.so"; }
echo "$st" | grep -q '"valid": true' || { echo "$st"; fail "irpd does not find the compiled ST set valid"; }
# The installed SDK and the ST cell's example (stc links the blocks from libindurop_plcopen.a).
for f in /usr/share/indurop/st/lib/plcopen.st /usr/include/indurop/st/st.hpp /usr/include/indurop/plcopen/plcopen.h \
  /usr/share/indurop/examples/plc-robot-st/main.st; do
  [ -e "$chr$f" ] || fail "the package has no $f"
done
[ -n "$(find "$chr/usr/lib" -name libindurop_plcopen.a)" ] || fail "the package has no libindurop_plcopen.a"
stop_chroot_processes

# remove: the programs go, the data stays.
in_chroot env DEBIAN_FRONTEND=noninteractive apt-get remove -y -q indurop >"$cache/remove.log" 2>&1 \
  || { tail -20 "$cache/remove.log" >&2; fail "apt-get remove"; }
left=$(cd "$chr" && find usr/bin/irpd usr/lib/indurop usr/share/indurop 2>/dev/null | head -20 || true)
[ -z "$left" ] || { echo "$left"; fail "files left after remove"; }
[ -f "$chr/var/lib/indurop/admin-token" ] && in_chroot id indurop >/dev/null || fail "remove took the data or the user"
# purge (with the dependencies it brought): nothing of it is left.
in_chroot env DEBIAN_FRONTEND=noninteractive apt-get purge -y -q --autoremove indurop >"$cache/purge.log" 2>&1 \
  || { tail -20 "$cache/purge.log" >&2; fail "apt-get purge"; }
! in_chroot id indurop >/dev/null 2>&1 || fail "the user indurop is left after purge"
! in_chroot getent group indurop >/dev/null || fail "the group indurop is left after purge"
snapshot > "$cache/after.txt"
# Backups that useradd and userdel keep of the account files (/etc/passwd- ...) are not ours.
left=$(comm -13 "$cache/before.txt" "$cache/after.txt" | grep -v -E '^\./etc/(passwd|group|shadow|gshadow)-$' || true)
[ -z "$left" ] || { echo "$left" | head -30; fail "left after purge (not there before the install)"; }
echo "deb_chroot: installed, ran (irpd, the agent on https://127.0.0.1:$port, the default set activated, irpd restarted on it), removed, purged: nothing left"

[ -n "$old_deb" ] || exit 0
# The upgrade from an older build: installed and run as its unit has it (plain HTTP).
cp "$old_deb" "$chr/tmp/old.deb"
in_chroot env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends /tmp/old.deb \
  >"$cache/install-old.log" 2>&1 || { tail -30 "$cache/install-old.log" >&2; fail "apt-get install of the older build"; }
[ ! -e "$chr/var/lib/indurop/tls" ] || fail "the older build made a certificate: it is not the build before HTTPS"
: > "$cache/irpd.log"
start_irpd
start_agent http
in_chroot runuser -u indurop -- env INDUROP_URL="http://127.0.0.1:$port" /usr/lib/indurop/activate-default-set \
  || { cat "$cache/agent.log"; fail "activate-default-set of the older build"; }
runs_active_set http || fail "the older build's irpd does not run its active set"
# a person of the older build: added with the admin token, signed in (a session cookie in the jar)
password="upgrade kept me $$"
curl -sf -H "Authorization: Bearer $(cat "$chr/var/lib/indurop/admin-token")" -H 'Content-Type: application/json' \
  -d "{\"name\": \"ana\", \"role\": \"operator\", \"password\": \"$password\"}" "http://127.0.0.1:$port/api/v1/users" >/dev/null \
  || fail "the older build did not add a user"
jar="$cache/cookies"
rm -f "$jar"
sign_in() {  # SCHEME: name and password -> 200 and a session cookie in the jar
  curl -sf -c "$jar" $([ "$1" = https ] && echo --cacert "$ca") -H 'Content-Type: application/json' \
    -d "{\"name\": \"ana\", \"password\": \"$password\"}" "$1://127.0.0.1:$port/api/v1/session" >/dev/null
}
session_of() {  # SCHEME: who the jar's session cookie is (GET /session)
  curl -sf -b "$jar" $([ "$1" = https ] && echo --cacert "$ca") "$1://127.0.0.1:$port/api/v1/session" \
    | python3 -c 'import json, sys; s = json.load(sys.stdin); print(s["name"] if s["signed_in"] else "nobody")'
}
sign_in http || fail "the older build's user did not sign in"
[ "$(session_of http)" = ana ] || fail "the older build's session is not ana's"
kept_files="tokens.json active.json history.jsonl admin-token users.json sessions.json"
kept() {  # FILE...: the files' hashes under the data folder and the stored sets, to compare across an upgrade
  (cd "$chr/var/lib/indurop" && sha256sum "$@" && ls sets)
}
active_before=$(active_id)
stop_chroot_processes
# shellcheck disable=SC2086  # the names, word-split
kept_before=$(kept $kept_files)
# The upgrade (the units would be stopped and started again around it under systemd).
in_chroot env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "/tmp/$(basename "$deb")" \
  >"$cache/upgrade.log" 2>&1 || { tail -30 "$cache/upgrade.log" >&2; fail "apt-get install of DEB over the older build"; }
grep -q "Unpacking indurop .* over " "$cache/upgrade.log" || { tail -20 "$cache/upgrade.log"; fail "the install was not an upgrade"; }
fingerprint=$(sed -n 's/.*SHA-256 fingerprint \([0-9A-F:]*\).*/\1/p' "$cache/upgrade.log" | tail -1)
[ ${#fingerprint} -eq 95 ] || fail "the upgrade did not make a certificate and print its fingerprint"
# shellcheck disable=SC2086
[ "$(kept $kept_files)" = "$kept_before" ] \
  || fail "the upgrade changed the tokens, the users, their sessions, the set store or the active set"
: > "$cache/irpd.log"
start_irpd
start_agent https
[ "$(served_fingerprint)" = "$fingerprint" ] || fail "after the upgrade the agent serves another certificate than the one made"
[ "$(api sets/active | python3 -c 'import json, sys; print(json.load(sys.stdin)["id"])')" = "$active_before" ] \
  || fail "after the upgrade the old admin token does not sign in, or the active set changed"
runs_active_set || fail "after the upgrade irpd does not run the active set"
[ "$(session_of https)" = ana ] || fail "after the upgrade the session of the older build is not ana's over HTTPS"
sign_in https || fail "after the upgrade ana does not sign in with her password over HTTPS"
stop_chroot_processes
# The next upgrade (the same build again) keeps the certificate the first one made, and the rest.
kept_before=$(kept tls/cert.pem tls/key.pem users.json tokens.json)
in_chroot env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --reinstall --no-install-recommends "/tmp/$(basename "$deb")" \
  >"$cache/reinstall.log" 2>&1 || { tail -30 "$cache/reinstall.log" >&2; fail "apt-get install --reinstall of DEB"; }
[ "$(kept tls/cert.pem tls/key.pem users.json tokens.json)" = "$kept_before" ] \
  || fail "the second upgrade changed the certificate, the users, the tokens or the set store"
: > "$cache/irpd.log"
start_irpd
start_agent https
[ "$(served_fingerprint)" = "$fingerprint" ] || fail "after the second upgrade the agent serves another certificate"
[ "$(session_of https)" = ana ] || fail "after the second upgrade the session is not ana's"
stop_chroot_processes
in_chroot env DEBIAN_FRONTEND=noninteractive apt-get purge -y -q --autoremove indurop >"$cache/purge.log" 2>&1 \
  || { tail -20 "$cache/purge.log" >&2; fail "apt-get purge after the upgrade"; }
echo "deb_chroot: upgraded from $(basename "$old_deb"): tokens, users, their sessions, sets and the active set kept, a certificate made and kept by the next upgrade, the old admin token and the old session over HTTPS, the user signs in with her password"

#!/usr/bin/env bash
# deb_test.sh -- the package's tests as tests/run.sh runs them: builds the .deb (packaging/deb.sh),
# checks its units with systemd-analyze (verify_units.sh), installs, runs, removes and purges it in
# a clean Debian 12 chroot, then upgrades an older build to it there (deb_chroot.sh, old_deb.sh).  A test that cannot run here (exit 77: no root, no
# debootstrap, no mirror) is reported as skipped.  The QEMU guest (deb_qemu.sh) is not run here: it
# takes minutes more and nested KVM is not everywhere; run it by hand (docs/operations.md).
set -uo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
here=$root/tests/package
t0=$(date +%s)
deb=$(bash "$root/packaging/deb.sh") || { echo "FAILED: packaging/deb.sh"; exit 1; }
echo "deb_test: $deb ($(du -h "$deb" | cut -f1)) built in $(( $(date +%s) - t0 )) s"
status=0
# An older build to upgrade from (old_deb.sh); without it deb_chroot.sh tests the fresh install only.
old="$root/build/deb/indurop-before-https.deb"
rm -f "$old"
bash "$here/old_deb.sh" "$deb" "$old" || { echo "deb_test: no older build to upgrade from (see above)"; old=; }
for t in verify_units deb_chroot; do
  t1=$(date +%s)
  if [ "$t" = deb_chroot ]; then bash "$here/$t.sh" "$deb" $old; else bash "$here/$t.sh" "$deb"; fi
  rc=$?
  case $rc in
    0) echo "deb_test: $t passed ($(( $(date +%s) - t1 )) s)" ;;
    77) echo "deb_test: $t skipped (see above)" ;;
    *) echo "deb_test: $t FAILED"; status=1 ;;
  esac
done
exit $status

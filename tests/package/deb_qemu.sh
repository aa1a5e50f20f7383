#!/usr/bin/env bash
# deb_qemu.sh DEB -- the .deb under systemd for real: a Debian 12 guest (systemd as init, Debian's
# stock kernel and initramfs) with the package installed boots in QEMU, and a test unit inside it
# (guest_test.sh) checks the supervision: both units active, irpd killed with SIGKILL comes back on
# the active set, irpd stopped with SIGSTOP is killed by the watchdog and comes back, the agent
# sees irpd again.  Its results (RESULT lines, with the restart and detection times measured)
# come out on the guest's second serial port; this script prints them and fails on a FAIL line.
#
#   bash tests/package/deb_qemu.sh build/indurop_0.1.0_amd64.deb
#
# The guest's base (bookworm minbase + systemd, the kernel, curl) is made once from
# deb_chroot.sh's debootstrap tarball and kept in build/package-guest/; each run unpacks it, installs
# the .deb with apt, packs the tree into an ext4 image (mke2fs -d) and boots it (TCG: nested KVM
# inside a VM, as on the machines here, may hang before the kernel prints; INDUROP_GUEST_KVM=1
# tries KVM).  Needs root.  Exit 77 (skip) without qemu, debootstrap or mirror.
set -euo pipefail
deb=$(realpath "$1")
root=$(cd "$(dirname "$0")/../.." && pwd)
here=$(cd "$(dirname "$0")" && pwd)
chroot_cache=${INDUROP_CHROOT_CACHE:-$root/build/package-chroot}
cache=${INDUROP_GUEST_CACHE:-$root/build/package-guest}
base=$cache/bookworm-systemd.tar.gz
[ "$(id -u)" -eq 0 ] || { echo "deb_qemu: needs root" >&2; exit 77; }
command -v qemu-system-x86_64 >/dev/null || { echo "deb_qemu: qemu-system-x86_64 is not installed" >&2; exit 77; }
command -v mke2fs >/dev/null || { echo "deb_qemu: mke2fs (e2fsprogs) is not installed" >&2; exit 77; }
mkdir -p "$cache" "$chroot_cache/archives/partial" "$chroot_cache/lists/partial"

tree=$(mktemp -d "$cache/root-XXXXXX")
cleanup() {
  for m in var/lib/apt/lists var/cache/apt/archives dev/shm dev/pts dev proc sys; do
    mountpoint -q "$tree/$m" && umount -l "$tree/$m"
  done
  rm -rf --one-file-system "$tree" "$cache/guest.img"
}
trap cleanup EXIT
mount_all() {
  mount -t proc proc "$tree/proc"; mount -t sysfs sys "$tree/sys"
  mount --bind /dev "$tree/dev"; mount -t tmpfs -o mode=1777 shm "$tree/dev/shm"
  mount --bind "$chroot_cache/archives" "$tree/var/cache/apt/archives"
  mount --bind "$chroot_cache/lists" "$tree/var/lib/apt/lists"
}
umount_all() {
  for m in var/lib/apt/lists var/cache/apt/archives dev/shm dev sys proc; do umount "$tree/$m"; done
}
in_tree() { chroot "$tree" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin LANG=C.UTF-8 DEBIAN_FRONTEND=noninteractive "$@"; }

# The guest's base, once.
if [ ! -f "$base" ]; then
  [ -f "$chroot_cache/bookworm-minbase.tar.gz" ] || { echo "deb_qemu: run tests/package/deb_chroot.sh first (it makes the debootstrap tarball)" >&2; exit 77; }
  echo "deb_qemu: making the guest's base (systemd, the kernel, curl) once: $base"
  tar -C "$tree" -xzf "$chroot_cache/bookworm-minbase.tar.gz"
  mount_all
  in_tree apt-get update -qq >/dev/null
  in_tree apt-get install -y -q --no-install-recommends systemd-sysv udev kmod linux-image-amd64 initramfs-tools \
    curl procps iproute2 >"$cache/base.log" 2>&1 || { tail -20 "$cache/base.log" >&2; exit 1; }
  umount_all
  echo "indurop-guest" > "$tree/etc/hostname"
  echo "/dev/vda / ext4 rw,errors=remount-ro 0 1" > "$tree/etc/fstab"
  in_tree passwd -d root >/dev/null
  tar -C "$tree" -czf "$base.part" . && mv "$base.part" "$base"
  rm -rf --one-file-system "$tree" && mkdir -p "$tree"
fi

tar -C "$tree" -xzf "$base"
mount_all
cp "$deb" "$tree/tmp/"
in_tree apt-get install -y -q --no-install-recommends "/tmp/$(basename "$deb")" >"$cache/install.log" 2>&1 \
  || { tail -20 "$cache/install.log" >&2; exit 1; }
umount_all
rm -f "$tree/tmp/$(basename "$deb")"
# The test unit: after the agent, once; its output on ttyS1, then the guest powers off.
install -m 0755 "$here/guest_test.sh" "$tree/usr/local/bin/guest_test.sh"
cat > "$tree/etc/systemd/system/indurop-guest-test.service" <<'UNIT'
[Unit]
Description=indurop supervision test (deb_qemu.sh)
After=indurop-agent.service
Wants=indurop-agent.service
[Service]
Type=oneshot
ExecStart=/usr/local/bin/guest_test.sh /dev/ttyS1
ExecStopPost=/usr/bin/systemctl --no-block poweroff
[Install]
WantedBy=multi-user.target
UNIT
ln -sf /etc/systemd/system/indurop-guest-test.service "$tree/etc/systemd/system/multi-user.target.wants/"
kernel=$(ls "$tree"/boot/vmlinuz-* | head -1)
initrd=$(ls "$tree"/boot/initrd.img-* | head -1)
cp "$kernel" "$cache/vmlinuz"; cp "$initrd" "$cache/initrd.img"
size_mb=$(( $(du -sm "$tree" | cut -f1) + 1024 ))
mke2fs -q -F -t ext4 -d "$tree" "$cache/guest.img" "${size_mb}M"

accel=(-machine accel=tcg)
[ -w /dev/kvm ] && [ "${INDUROP_GUEST_KVM:-0}" = 1 ] && accel=(-enable-kvm -cpu host)
: > "$cache/console.log"; : > "$cache/results.log"
echo "deb_qemu: booting the guest (${accel[*]}), console in $cache/console.log"
t0=$(date +%s)
timeout "${INDUROP_GUEST_TIMEOUT:-900}" qemu-system-x86_64 "${accel[@]}" -m 2048 -smp 2 -nographic -no-reboot \
  -kernel "$cache/vmlinuz" -initrd "$cache/initrd.img" \
  -append "root=/dev/vda rw console=ttyS0 panic=-1 systemd.show_status=0" \
  -drive "file=$cache/guest.img,format=raw,if=virtio" \
  -serial "file:$cache/console.log" -serial "file:$cache/results.log" -monitor none -display none \
  -nic none >/dev/null 2>&1 || true
echo "deb_qemu: the guest ran $(( $(date +%s) - t0 )) s"
tr -d '\r' < "$cache/results.log" | tee "$cache/results.txt"
grep -q "^RESULT done" "$cache/results.txt" || { tail -40 "$cache/console.log"; echo "FAILED: the guest test did not finish"; exit 1; }
! grep -q "^FAIL" "$cache/results.txt" || { echo "FAILED: see the FAIL lines above"; exit 1; }
echo "deb_qemu: the units under systemd: started, restarted after SIGKILL and after SIGSTOP (watchdog), the agent back"

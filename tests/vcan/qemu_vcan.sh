#!/usr/bin/env bash
# qemu_vcan.sh -- runs a static test program inside a small QEMU guest whose kernel has vcan.
#
#   tests/vcan/qemu_vcan.sh PROGRAM [ARGS...]
#   INDUROP_VCAN_FILES=/abs/a:/abs/b tests/vcan/qemu_vcan.sh ...   (files the program reads, copied
#                                                                   into the guest at the same paths)
#
# The machines that build indurop may run a kernel without CAN (no vcan); Debian's stock kernel
# has it.  This script downloads that kernel's package (apt-get download, cached in
# build/vcan-guest/), builds an initramfs with busybox, the kernel's can, can-raw and vcan
# modules, PROGRAM and the shared libraries it needs (ldd), boots it (TCG), creates vcan0 in the guest, runs PROGRAM ARGS there, and exits with its status.
# Exit 77 when the guest cannot be run here (no qemu, no kernel package): the caller skips.
set -euo pipefail
program=$1; shift
root=$(cd "$(dirname "$0")/../.." && pwd)
cache=${INDUROP_VCAN_CACHE:-$root/build/vcan-guest}
mkdir -p "$cache"
command -v qemu-system-x86_64 >/dev/null || { echo "qemu_vcan: qemu-system-x86_64 is not installed" >&2; exit 77; }
command -v busybox >/dev/null || { echo "qemu_vcan: busybox (busybox-static) is not installed" >&2; exit 77; }
file -L "$(command -v busybox)" | grep -q "statically linked" || { echo "qemu_vcan: busybox is not the static one (busybox-static)" >&2; exit 77; }

# The kernel: the newest linux-image-*-amd64 that linux-image-amd64 depends on.
if [ ! -f "$cache/kernel/vmlinuz" ]; then
  pkg=$(apt-cache depends linux-image-amd64 2>/dev/null | awk '/Depends: linux-image-[0-9]/ {print $2; exit}')
  [ -n "$pkg" ] || { echo "qemu_vcan: no linux-image package known to apt" >&2; exit 77; }
  (cd "$cache" && rm -f linux-image-*.deb && apt-get download -qq "$pkg" 2>/dev/null) || { echo "qemu_vcan: cannot download $pkg" >&2; exit 77; }
  rm -rf "$cache/unpacked" && dpkg-deb -x "$cache"/linux-image-*.deb "$cache/unpacked"
  mkdir -p "$cache/kernel"
  cp "$cache"/unpacked/boot/vmlinuz-* "$cache/kernel/vmlinuz"
  for m in net/can/can.ko net/can/can-raw.ko drivers/net/can/dev/can-dev.ko drivers/net/can/vcan.ko; do
    found=$(find "$cache/unpacked/lib/modules" -path "*/kernel/$m*" | head -1)
    [ -n "$found" ] || { echo "qemu_vcan: $m is not in $pkg" >&2; exit 77; }
    case "$found" in *.xz) xz -dc "$found" > "$cache/kernel/$(basename "$m")" ;; *) cp "$found" "$cache/kernel/" ;; esac
  done
  rm -rf "$cache/unpacked" "$cache"/linux-image-*.deb
fi

guest=$(mktemp -d)
trap 'rm -rf "$guest"' EXIT
mkdir -p "$guest"/{bin,proc,sys,dev,tmp,modules}
cp "$(command -v busybox)" "$guest/bin/busybox"
for tool in sh mount ip insmod echo poweroff cat mkdir; do ln -s busybox "$guest/bin/$tool"; done
cp "$cache"/kernel/*.ko "$guest/modules/"
cp "$program" "$guest/bin/test"
# A dynamic program: its libraries and loader, at the paths ldd names.
ldd "$program" 2>/dev/null | grep -o '/[^ ]*' | while read -r lib; do
  mkdir -p "$guest$(dirname "$lib")" && cp -L "$lib" "$guest$lib"
done
IFS=: read -r -a extra <<< "${INDUROP_VCAN_FILES:-}"
for f in "${extra[@]}"; do
  [ -n "$f" ] && mkdir -p "$guest$(dirname "$f")" && cp -L "$f" "$guest$f"
done
printf '%s\n' "$@" > "$guest/args"
cat > "$guest/init" <<'INIT'
#!/bin/sh
mount -t proc proc /proc; mount -t sysfs sys /sys; mount -t devtmpfs dev /dev
mkdir -p /dev/shm /tmp; mount -t tmpfs shm /dev/shm   # /tmp stays the initramfs (files may have been put there)
insmod /modules/can.ko && insmod /modules/can-raw.ko && insmod /modules/can-dev.ko && insmod /modules/vcan.ko
ip link add dev vcan0 type vcan && ip link set vcan0 up
set --
while read -r a; do set -- "$@" "$a"; done < /args
/bin/test "$@"
echo "VCAN-GUEST-EXIT $?"
poweroff -f
INIT
chmod +x "$guest/init"
(cd "$guest" && find . | busybox cpio -o -H newc 2>/dev/null | gzip -1) > "$guest.cpio.gz"
# TCG by default: it boots this small guest in seconds, while nested KVM inside a VM (as on the
# CI machines) may not boot at all.  INDUROP_VCAN_KVM=1 tries KVM.
accel=(-machine accel=tcg)
[ "${INDUROP_VCAN_KVM:-0}" = 1 ] && [ -w /dev/kvm ] && accel=(-enable-kvm -cpu host)
out=$(timeout 300 qemu-system-x86_64 "${accel[@]}" -m 256 -smp 1 -nographic -no-reboot \
      -kernel "$cache/kernel/vmlinuz" -initrd "$guest.cpio.gz" -append "console=ttyS0 quiet panic=-1 edd=off" 2>&1 || true)
rm -f "$guest.cpio.gz"
printf '%s\n' "$out" | sed -n '/VCAN-GUEST-EXIT/!p' | grep -v "^\s*$" | tail -n 200
status=$(printf '%s\n' "$out" | sed -n 's/.*VCAN-GUEST-EXIT \([0-9]*\).*/\1/p' | tail -1)
[ -n "$status" ] || { echo "qemu_vcan: the guest did not report (boot failed?)" >&2; exit 1; }
exit "$status"

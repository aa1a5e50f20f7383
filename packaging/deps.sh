#!/usr/bin/env bash
# deps.sh -- installs the Debian 12 packages indurop builds, runs and tests with.
# Safe to run again: only what is missing is installed.  Needs root (or sudo).
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config   # toolchain
  python3 python3-venv python3-lark              # glbc, stc (st/), the Python tests
  python3-lxml python3-xmlschema                 # stc reading PLCopen XML (plcopen/): indurop_add_st with a .xml source
  libpugixml-dev nlohmann-json3-dev              # module.xml, JSON output
  libssl-dev                                     # SHA-256 of module files (hot reload)
  libelf-dev                                     # a module's identity: its loadable sections (online change)
  libeigen3-dev liborocos-kdl-dev liburdfdom-dev # robot kinematics (the plc-robot cell)
  libsystemd-dev                                 # sd_notify, the watchdog (irpd as a Type=notify service)
  libcap-dev                                     # irpd --user: keeps CAP_SYS_NICE and CAP_IPC_LOCK, drops the rest
  libmodbus-dev                                  # Modbus TCP/RTU (the I/O dispatcher, the drive simulator)
  cyclonedds-dev cyclonedds-tools                # the DDS bridge's test: a separate ROS 2 peer in C (idlc, libddsc)
  qemu-system-x86 busybox-static file            # SocketCAN on vcan in a small guest (tests/vcan/)
  googletest libgtest-dev                        # C++ tests
  rt-tests                                       # cyclictest: the benchmark's reference
  stress-ng                                      # the soak's and io_load's load on the other CPU (tests/bench/)
  tcpdump                                        # the Modbus transactions' times on the wire (tests/bench/io_load.py)
  clang libclang-rt-14-dev llvm                  # the fuzz targets: libFuzzer, ASan + UBSan, llvm-symbolizer, llvm-cov (tests/fuzz/)
  clang-format                                   # the C++ formatting check (tests/lint.sh, .clang-format)
  util-linux                                     # setpriv, prlimit: the non-RT fallback test
  chromium fonts-dejavu-core                     # the browser tests (Playwright drives Debian's chromium)
  debootstrap curl                               # the .deb's install test in a Debian 12 chroot (tests/package/)
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
command -v node >/dev/null || missing+=(nodejs npm)   # the web UI's build (Vite) and tests

sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
if [ ${#missing[@]} -gt 0 ]; then
  echo "deps: installing ${missing[*]}"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# Vite needs Node.js 20.19 or later (Debian 12's own nodejs is 18).
node -e 'const [a, b] = process.versions.node.split(".").map(Number); process.exit(a > 20 || (a === 20 && b >= 19) ? 0 : 1)' || {
  echo "deps: Node.js $(node --version) is too old for the web UI's build; install Node.js 20.19 or later (e.g. from NodeSource) and run again" >&2
  exit 1
}

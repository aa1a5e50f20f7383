#!/usr/bin/env bash
# cell.sh BUILD_DIR -- the plc-robot cell's own modules rebuilt from the installed SDK alone, as a
# user changing Robot.cpp or main.cpp would: the build installed into a scratch prefix, the cell's
# sources taken from there (share/indurop/examples/plc-robot), built outside the tree with
# find_package(indurop COMPONENTS plcopen kinematics) (main.so on indurop::plcopen, Robot.so on
# indurop::kinematics, libiodispat.so and the drive simulator from the package), then run by the
# installed irpd with the simulator on a free port: every module loads (its layout stamp accepted),
# initializes with its properties, runs every period and stops.  Without one of the kinematics'
# packages the configuration stops, naming it.  Then the ST cell the same way, from its installed
# example (share/indurop/examples/plc-robot-st, beside plc-robot's): main.st compiled by the
# installed stc against the installed headers, runtime and st/lib, main.so linked to the installed
# libindurop_plcopen.a (its MC_ blocks), run by the installed irpd with the C++ cell's other modules.
set -euo pipefail
build=$1
work=$(mktemp -d /tmp/indurop-package-cell-XXXXXX)
irpd_pid=
trap '[ -z "$irpd_pid" ] || kill "$irpd_pid" 2>/dev/null; rm -rf "$work"' EXIT
prefix=$work/prefix
fail() { echo "FAILED: $*"; exit 1; }

cmake --install "$build" --prefix "$prefix" >/dev/null
src=$prefix/share/indurop/examples/plc-robot
[ -f "$src/CMakeLists.txt" ] || fail "the package has no cell sources ($src)"
cp -r "$src" "$work/plc-robot"
[ -f "$prefix/share/indurop/examples/plc-robot-st/main.st" ] || fail "the package has no ST cell sources"
cp -r "$prefix/share/indurop/examples/plc-robot-st" "$work/plc-robot-st"

# Nothing of the source tree: only the prefix on CMake's search path.
cmake -S "$work/plc-robot" -B "$work/build" -G Ninja -DCMAKE_PREFIX_PATH="$prefix" >"$work/configure.log" 2>&1 \
  || { cat "$work/configure.log"; fail "configuring the cell against the installed package"; }
cmake --build "$work/build" >"$work/build.log" 2>&1 || { cat "$work/build.log"; fail "building the cell against the installed package"; }
set=$work/build/plc-robot
# Without one of the kinematics' packages the configuration stops and names it.
if cmake -S "$work/plc-robot" -B "$work/no-urdfdom" -G Ninja -DCMAKE_PREFIX_PATH="$prefix" \
     -DCMAKE_DISABLE_FIND_PACKAGE_urdfdom=ON >"$work/no-urdfdom.log" 2>&1; then
  fail "the cell configured without urdfdom"
fi
tr -s " \n" " " <"$work/no-urdfdom.log" | grep -q "needs the CMake package urdfdom (Debian: liburdfdom-dev)" || { cat "$work/no-urdfdom.log"; fail "the refusal does not name urdfdom"; }
for f in main.so Robot.so libiodispat.so indurop-drivesim indurop6.urdf layout.json module.xml ioconfig.xml; do
  [ -e "$set/$f" ] || fail "the built set lacks $f"
done
if grep -q "$(cd "$(dirname "$0")/../.." && pwd)" "$work/build/CMakeCache.txt"; then
  fail "the cell's build names the source tree"
fi

# The drive simulator on a free port (the set's default 15020 may be taken by another test).
port=$(python3 -S -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
sed -i "s/15020/$port/" "$set/module.xml" "$set/ioconfig.xml"
"$prefix/bin/irpd" --config "$set/module.xml" --duration 2 --instance "package-cell-$$" >"$work/irpd.log" 2>&1 &
irpd_pid=$!
wait "$irpd_pid" || { cat "$work/irpd.log"; fail "irpd did not run the rebuilt cell"; }
irpd_pid=
expect() { grep -Eq "$1" "$work/irpd.log" || { cat "$work/irpd.log"; fail "$2"; }; }
expect '^\[Robot\] .*indurop6\.urdf: base_link -> tool0, joints' "Robot.so did not load its URDF"
expect '^\[PLC\] pick and place: ' "main.so did not read its properties"
expect '^iodispat: .*ioconfig\.xml: 1 device' "libiodispat.so did not read ioconfig.xml"
expect '^irpd: stopped after [1-9][0-9]* basic periods' "irpd did not run the set's periods"
expect '^\[PLC\] stop after ' "main.so was not stopped after running"

# The ST cell: its CMakeLists adds ../plc-robot (the copy above) for the other modules.
cmake -S "$work/plc-robot-st" -B "$work/st-build" -G Ninja -DCMAKE_PREFIX_PATH="$prefix" >"$work/st-configure.log" 2>&1 \
  || { cat "$work/st-configure.log"; fail "configuring the ST cell against the installed package"; }
cmake --build "$work/st-build" >"$work/st-build.log" 2>&1 || { cat "$work/st-build.log"; fail "building the ST cell against the installed package"; }
st_set=$work/st-build/plc-robot-st
for f in main.so Robot.so libiodispat.so indurop-drivesim layout.json module.xml; do
  [ -e "$st_set/$f" ] || fail "the built ST set lacks $f"
done
symbols=$(nm -C "$st_set/main.so")
grep -qF "plcopen::MC_MoveAbsolute::operator()" <<<"$symbols" || fail "main.so does not link the PLCopen blocks"
if grep -rq "$(cd "$(dirname "$0")/../.." && pwd)" "$work/st-build/CMakeCache.txt" "$st_set/module.xml"; then
  fail "the ST cell's build names the source tree"
fi
sed -i "s/15020/$port/" "$st_set/module.xml" "$st_set/ioconfig.xml"
"$prefix/bin/irpd" --config "$st_set/module.xml" --duration 2 --instance "package-st-cell-$$" >"$work/irpd.log" 2>&1 &
irpd_pid=$!
wait "$irpd_pid" || { cat "$work/irpd.log"; fail "irpd did not run the ST cell"; }
irpd_pid=
expect '^irpd: stopped after [1-9][0-9]* basic periods' "irpd did not run the ST cell's periods"
expect '^\[Robot\] .*plc-robot-st/indurop6\.urdf: base_link -> tool0' "Robot.so did not load in the ST cell"

echo "package: the plc-robot cell's modules, and its ST cell, built from the installed SDK alone and run by the installed irpd"

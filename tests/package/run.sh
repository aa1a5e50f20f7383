#!/usr/bin/env bash
# run.sh BUILD_DIR -- installs the build into a scratch prefix, then builds modules outside the tree
# the two ways a module author would (find_package(indurop) + indurop_add_glb/indurop_add_module,
# and pkg-config), and runs them with the installed irpd and glbc.
set -euo pipefail
build=$1
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d /tmp/indurop-package-XXXXXX)
trap 'rm -rf "$work"' EXIT
prefix=$work/prefix

cmake --install "$build" --prefix "$prefix" >/dev/null
test -x "$prefix/bin/irpd" && test -x "$prefix/bin/glbc"
"$prefix/bin/glbc" --version >/dev/null

# 1. CMake: find_package(indurop), a .glb, a thread module using its variable.
cmake -S "$here/external" -B "$work/ext" -G Ninja -DCMAKE_PREFIX_PATH="$prefix" >/dev/null
cmake --build "$work/ext" >/dev/null

# 2. pkg-config.
export PKG_CONFIG_PATH="$prefix/lib/pkgconfig:$prefix/lib/x86_64-linux-gnu/pkgconfig"
g++ -shared -fPIC "$here/external/pc_counter.cpp" $(pkg-config --cflags --libs indurop) -o "$work/ext/pc_counter.so"

cat > "$work/ext/module.xml" <<XML
<?xml version="1.0" encoding="UTF-8"?>
<root>
  <layout>./ext_glb/layout.json</layout>
  <module><filename>./ext_counter.so</filename><moduletype>thread</moduletype><operationtype>periodic</operationtype>
          <period>1000000</period><priority>1</priority></module>
  <module><filename>./pc_counter.so</filename><moduletype>thread</moduletype><operationtype>periodic</operationtype>
          <period>2000000</period><priority>2</priority></module>
</root>
XML
out=$("$prefix/bin/irpd" --config "$work/ext/module.xml" --duration 0.2 --instance "package-$$" 2>&1)
echo "$out" | grep -q "\[ext_counter\] count = 200" || { echo "$out"; echo "FAILED: ext_counter did not count 200 periods"; exit 1; }
echo "$out" | grep -q "\[pc_counter\] runs = 100" || { echo "$out"; echo "FAILED: pc_counter did not run 100 times"; exit 1; }
echo "package: installed, built outside the tree with CMake and pkg-config, ran with the installed irpd"

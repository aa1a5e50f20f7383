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

# 3. An online change, built with the installed SDK: irpd runs the set; the project gains a
#    variable laid out against the running layout (indurop_add_glb ... PREVIOUS); irpd swaps the
#    rebuilt set in and keeps ext_counter (the same code) running.
sock=$work/irpd.sock
"$prefix/bin/irpd" --config "$work/ext/module.xml" --instance "package-online-$$" --control-socket "$sock" \
    --module-cache "$work/cache" >"$work/irpd.log" 2>&1 &
irpd_pid=$!
trap 'kill $irpd_pid 2>/dev/null || true; rm -rf "$work"' EXIT
for _ in $(seq 100); do [ -S "$sock" ] && break; sleep 0.05; done
cp "$work/ext/ext_glb/layout.json" "$work/running-layout.json"
printf 'namespace ext;\ndouble added;\n' > "$work/more.glb"
cmake -S "$here/external" -B "$work/ext2" -G Ninja -DCMAKE_PREFIX_PATH="$prefix" \
      -DEXT_MORE_GLB="$work/more.glb" -DEXT_PREVIOUS="$work/running-layout.json" >/dev/null
cmake --build "$work/ext2" >/dev/null
cp "$work/ext/pc_counter.so" "$work/ext2/"
cp "$work/ext/module.xml" "$work/ext2/module.xml"
report=$(python3 -S - "$sock" "$work/ext2/module.xml" <<'PY'
import json, socket, sys
s = socket.socket(socket.AF_UNIX); s.connect(sys.argv[1]); f = s.makefile("rw")
f.readline()  # hello
f.write(json.dumps({"cmd": "load", "config": sys.argv[2]}) + "\n"); f.flush()
print(f.readline())
PY
)
kill $irpd_pid; wait $irpd_pid 2>/dev/null || true
echo "$report" | python3 -S -c '
import json, sys
a = json.loads(sys.stdin.read())
assert a.get("ok"), a
r = a["result"]
assert r["kept"] == ["ext_counter", "pc_counter"], r
assert r["variables"]["added"] == ["ext.added"], r["variables"]
' || { cat "$work/irpd.log"; echo "$report"; echo "FAILED: the online change built with the installed SDK"; exit 1; }
echo "package: installed, built outside the tree with CMake and pkg-config, ran with the installed irpd, changed online"

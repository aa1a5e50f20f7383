#!/usr/bin/env bash
# shlibdeps.sh FILE_OR_DIR... -- the Debian packages the ELF files among FILE_OR_DIR need, as a
# Depends field (dpkg-shlibdeps), e.g. "libc6 (>= 2.34), libmodbus5 (>= 3.1.4), ...".  Libraries
# found among the files themselves (libindurop, a wheel's bundled .libs) need no package.
set -euo pipefail
work=$(mktemp -d /tmp/indurop-shlibdeps-XXXXXX)
trap 'rm -rf "$work"' EXIT
# ELF files by their first four bytes, in one pass.
python3 - "$@" > "$work/elf" <<'PY'
import os, sys
for top in sys.argv[1:]:
    walk = [(top, [], [""])] if os.path.isfile(top) else os.walk(top)
    for d, _, files in walk:
        for f in files:
            p = os.path.join(d, f) if f else d
            if os.path.isfile(p) and not os.path.islink(p):
                with open(p, "rb") as fh:
                    if fh.read(4) == b"\x7fELF":
                        print(os.path.abspath(p))
PY
# The folders of the ELF files that are shared libraries: where dpkg-shlibdeps finds those that
# the others link against (libindurop.so.0 in the build tree).
dirs=$(xargs -r -n1 dirname < "$work/elf" | sort -u | sed 's/^/-l/')
mkdir -p "$work/debian"
printf 'Source: indurop\n\nPackage: indurop\nArchitecture: any\n' > "$work/debian/control"
# shellcheck disable=SC2046
mapfile -t elf < "$work/elf"
(cd "$work" && dpkg-shlibdeps -O --ignore-missing-info $dirs "${elf[@]}" 2>"$work/log") > "$work/out" \
  || { cat "$work/log" >&2; echo "shlibdeps: dpkg-shlibdeps failed" >&2; exit 1; }
sed -n 's/^shlibs:Depends=//p' "$work/out"

#!/usr/bin/env bash
# lint.sh -- the formatting and lint checks, in seconds: clang-format (.clang-format) on the C and
# C++ sources, ruff (ruff.toml) on the Python ones, Biome (biome.json) on the TypeScript ones.
# Left out: generated files (glbc's golden outputs, the OpenAPI client, what protocol/ generates) and
# the paper's programs of config/sets/paper-figures/, kept as the paper prints them.
# `bash tests/lint.sh --fix` formats and fixes in place instead of checking.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
fix=0
[ "${1:-}" = "--fix" ] && fix=1
venv=$(bash packaging/venv.sh)
status=0

# C and C++: every tracked source but generated ones and the paper's.
mapfile -t cxx < <(git ls-files '*.c' '*.h' '*.cpp' '*.hpp' |
  grep -v -e '/golden/' -e '^rtcore/src/protocol/limits.hpp$' -e '^rtcore/src/protocol/command_table.hpp$' \
          -e '^config/sets/paper-figures/' || true)
if [ $fix -eq 1 ]; then
  clang-format -i "${cxx[@]}"
else
  clang-format --dry-run --Werror "${cxx[@]}" || { echo "lint: clang-format: run bash tests/lint.sh --fix" >&2; status=1; }
fi

# Python
if [ $fix -eq 1 ]; then
  "$venv/bin/ruff" format -q . && "$venv/bin/ruff" check -q --fix . || status=1
else
  "$venv/bin/ruff" format -q --check . || { echo "lint: ruff format: run bash tests/lint.sh --fix" >&2; status=1; }
  "$venv/bin/ruff" check -q . || status=1
fi

# TypeScript (Biome from the web UI's packages)
biome="$root/webui/node_modules/.bin/biome"
[ -x "$biome" ] || bash packaging/npm-ci.sh webui
if [ $fix -eq 1 ]; then
  "$biome" check --write --colors=off --reporter=summary . || status=1
else
  "$biome" ci --colors=off --reporter=summary . || status=1
fi
exit $status

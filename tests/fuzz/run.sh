#!/usr/bin/env bash
# run.sh [SECONDS] -- builds the fuzz targets (clang, libFuzzer, ASan + UBSan) into build-fuzz/ and
# runs each for SECONDS (default 20) from its seed corpus in tests/fuzz/corpus/<target>, then the
# atheris targets of the .glb and the Structured Text compilers (tests/fuzz/fuzz_glb.py, fuzz_st.py)
# in the project's venv.  Fails on any
# crash, sanitizer report (memory error, leak, undefined behaviour), uncaught exception or
# time-out; the input that caused it is kept in build-fuzz/artifacts/<target>/ and the log in
# build-fuzz/logs/<target>.log.  New inputs the fuzzers find go to build-fuzz/corpus/<target>
# (kept between runs; not the seeds).  Two targets run at a time (FUZZ_JOBS).  FUZZ_TARGETS="fuzz_control fuzz_glb" runs only those
# (only Python targets: no clang build).
# docs/fuzzing.md: what each target covers, longer runs, reproducing a crash.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
seconds=${1:-20}
build="$root/build-fuzz"
here="$root/tests/fuzz"
all=(fuzz_module_xml fuzz_control fuzz_modbus fuzz_can fuzz_ioconfig fuzz_glb fuzz_st)
python_targets=" fuzz_glb fuzz_st "  # atheris targets: tests/fuzz/<target>.py
read -r -a targets <<< "${FUZZ_TARGETS:-${all[*]}}"

t0=$(date +%s)
need_build=0
for t in "${targets[@]}"; do [[ $python_targets == *" $t "* ]] || need_build=1; done
if [ $need_build -eq 1 ]; then
  cmake -S "$root" -B "$build" -G Ninja -DINDUROP_FUZZ=ON -DINDUROP_BUILD_TESTS=OFF \
    -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only" -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only" >/dev/null
  cmake --build "$build" --target fuzz_targets
  echo "fuzz: built in $(( $(date +%s) - t0 )) s"
fi

export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:symbolize=1:detect_stack_use_after_return=1"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
export ASAN_SYMBOLIZER_PATH=${ASAN_SYMBOLIZER_PATH:-$(command -v llvm-symbolizer || true)}

venv=$(bash "$root/packaging/venv.sh")  # the atheris targets' (made before the runs start side by side)
# fuzz_one TARGET: one target's run; prints its outcome, fails on a crash or report.
fuzz_one() {
  local t=$1 log dict=() options cmd start summary
  mkdir -p "$build/corpus/$t" "$build/artifacts/$t" "$build/logs"
  log="$build/logs/$t.log"
  [ -f "$here/dict/$t.dict" ] && dict=(-dict="$here/dict/$t.dict")
  options=(-max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1
           -artifact_prefix="$build/artifacts/$t/" "${dict[@]}")
  if [[ $python_targets == *" $t "* ]]; then
    cmd=("$venv/bin/python" "$here/$t.py")
  else
    cmd=("$build/fuzz/$t")
  fi
  start=$(date +%s)
  if "${cmd[@]}" "${options[@]}" "$build/corpus/$t" "$here/corpus/$t" >"$log" 2>&1; then
    summary=$(grep -E '^#[0-9]+[[:space:]]+DONE' "$log" | tail -1 | sed -E 's/^#([0-9]+)[[:space:]]+DONE[[:space:]]+/\1 runs, /' || true)
    echo "fuzz: $t: ok in $(( $(date +%s) - start )) s: ${summary:-see $log}"
  else
    echo "fuzz: $t: FAILED (log $log, input in $build/artifacts/$t/):" >&2
    grep -E 'ERROR|SUMMARY|runtime error|Traceback|Error|artifact' "$log" | head -20 >&2 || tail -30 "$log" >&2
    return 1
  fi
}

# FUZZ_JOBS targets at a time (default 2; each is one process on one CPU, and its SECONDS are wall
# time, so each target gets as long as when run alone).
jobs=${FUZZ_JOBS:-2}
declare -A running=()  # pid -> target
failed=()
reap() {
  local pid
  wait -n -p pid "${!running[@]}" || failed+=("${running[$pid]}")
  unset "running[$pid]"
}
for t in "${targets[@]}"; do
  [ ${#running[@]} -lt "$jobs" ] || reap
  fuzz_one "$t" &
  running[$!]=$t
done
while [ ${#running[@]} -gt 0 ]; do reap; done
echo "fuzz: total $(( $(date +%s) - t0 )) s"
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz: failed: ${failed[*]}" >&2
  exit 1
fi

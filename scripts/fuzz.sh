#!/usr/bin/env bash
# Builds ftid's libFuzzer targets (fuzz/, docs/fuzzing.md) with clang, AddressSanitizer and
# UndefinedBehaviorSanitizer in their own build directory, then runs each for a bounded time.
#
#   scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]     (default: 20 s, every target)
#
# Targets: csv_log recordings parameter_yaml trajectory_yaml daemon_config dbc can_assembler rtde_packet lcm_messages.
# The seed corpus of each is fuzz/<target>/corpus/ (in git); inputs the fuzzer finds interesting are
# kept in $FTID_FUZZ_BUILD_DIR/corpus/<target>/ (not in git) so later runs continue from them.
# Targets run FTID_FUZZ_PARALLEL at a time (default: one per core), each for the full time.
# A crash, sanitizer report, uncaught non-ftid exception, leak or 10 s hang fails the run: the
# reproducer is saved as $FTID_FUZZ_BUILD_DIR/artifacts/<target>/crash-* (rerun the target binary
# with that file as its only argument) and the script exits 1.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
seconds=${1:-20}
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(csv_log recordings parameter_yaml trajectory_yaml daemon_config dbc can_assembler rtde_packet lcm_messages)
case "$seconds" in ''|*[!0-9]*) echo "fuzz.sh: SECONDS_PER_TARGET must be a whole number, got '$seconds'" >&2; exit 2;; esac
build=${FTID_FUZZ_BUILD_DIR:-$root/build-fuzz}
jobs=${FTID_FUZZ_JOBS:-2}

cc=""; cxx=""
for v in "" -14 -15 -16; do
  if command -v "clang++$v" >/dev/null 2>&1 && command -v "clang$v" >/dev/null 2>&1; then cc="clang$v"; cxx="clang++$v"; break; fi
done
if [ -z "$cxx" ]; then
  echo "fuzz.sh: clang not found; install clang-14 and libclang-rt-14-dev (scripts/packages.txt)" >&2
  exit 2
fi
launcher=()
command -v ccache >/dev/null 2>&1 && launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)

flags="-O1 -g1 -fno-omit-frame-pointer -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined"
mkdir -p "$build"
start=$(date +%s)
echo "fuzz.sh: building ${#targets[@]} target(s) with $cxx in $build"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=None \
  -DCMAKE_C_COMPILER="$cc" -DCMAKE_CXX_COMPILER="$cxx" "${launcher[@]}" \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_C_FLAGS="$flags" \
  -DFTID_BUILD_FUZZ=ON -DFTID_BUILD_TESTS=OFF -DFTID_BUILD_BENCH=OFF -DFTID_WERROR=OFF >"$build/configure.log" 2>&1 \
  || { cat "$build/configure.log" >&2; exit 1; }
cmake --build "$build" -j"$jobs" --target $(printf 'fuzz_%s ' "${targets[@]}")
echo "fuzz.sh: built in $(( $(date +%s) - start )) s; running each target for $seconds s"

export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1:allocator_may_return_null=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
for t in "${targets[@]}"; do
  [ -d "$root/fuzz/$t/corpus" ] || { echo "fuzz.sh: unknown target '$t' (no $root/fuzz/$t/corpus)" >&2; exit 2; }
done
# Each target is one single-threaded libFuzzer process; FTID_FUZZ_PARALLEL of them run at a time
# (default: the number of cores), so every target still gets its full SECONDS of one core and the
# whole run takes about targets/cores x SECONDS instead of targets x SECONDS.
parallel=${FTID_FUZZ_PARALLEL:-$(nproc)}
case "$parallel" in ''|*[!0-9]*|0) echo "fuzz.sh: FTID_FUZZ_PARALLEL must be a whole number >= 1, got '$parallel'" >&2; exit 2;; esac
run_start=$(date +%s)
fuzz_one() {  # TARGET: runs it and writes its verdict to $build/fuzz-TARGET.result
  local t=$1 seeds="$root/fuzz/$1/corpus" work="$build/corpus/$1" art="$build/artifacts/$1"
  local log="$build/fuzz-$1.log"
  mkdir -p "$work" "$art"
  if "$build/fuzz/fuzz_$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=65536 \
       -print_final_stats=1 -artifact_prefix="$art/" "$work" "$seeds" >"$log" 2>&1; then
    local execs cov
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
    cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
    echo "ok (${execs:-?} inputs, coverage ${cov:-?} edges, corpus $(ls "$work" | wc -l) files)" >"$build/fuzz-$t.result"
  else
    echo "FAILED" >"$build/fuzz-$t.result"
  fi
}
running=0
for t in "${targets[@]}"; do
  rm -f "$build/fuzz-$t.result"
  fuzz_one "$t" &
  running=$((running + 1))
  if [ "$running" -ge "$parallel" ]; then wait -n || true; running=$((running - 1)); fi
done
wait
failed=()
for t in "${targets[@]}"; do
  verdict=$(cat "$build/fuzz-$t.result" 2>/dev/null || echo FAILED)
  if [ "$verdict" = FAILED ]; then
    echo "fuzz.sh: $t: FAILED; last lines of $build/fuzz-$t.log:" >&2
    tail -40 "$build/fuzz-$t.log" >&2
    ls "$build/artifacts/$t" >&2 || true
    failed+=("$t")
  else
    echo "fuzz.sh: $t: $verdict"
  fi
done
echo "fuzz.sh: ran ${#targets[@]} target(s) x $seconds s, $parallel at a time, in $(( $(date +%s) - run_start )) s; total $(( $(date +%s) - start )) s"
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz.sh: FAILED: ${failed[*]} (reproducers in $build/artifacts/)" >&2
  exit 1
fi

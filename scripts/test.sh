#!/usr/bin/env bash
# Sets everything up and runs the whole test suite:
#   1. install packages, build (warnings are errors), run every CTest test, then the kernel rig
#      (scripts/kernel-rig.sh: SocketCAN and PREEMPT_RT tests inside qemu); clang-tidy
#      (scripts/tidy.sh, findings are errors) runs beside CTest as step 4's check does (below) and
#      is waited for at the end (after the kernel rig with FTID_TEST_QUICK=1);
#   2. rebuild the unit tests with AddressSanitizer + UndefinedBehaviorSanitizer and run them;
#   3. fuzz every parser for ~20 s with libFuzzer + ASan + UBSan (scripts/fuzz.sh, docs/fuzzing.md;
#      FTID_FUZZ_SECONDS sets the time per target);
#   4. build the Debian package and verify the systemd unit (scripts/check_package.sh). It starts
#      in the background, at nice 19, when CTest starts, as clang-tidy does: the integration tests
#      leave the two cores idle more than half of CTest's time (they wait on sockets and timers),
#      and these two fill that idle time; their output is printed when the suite waits for them.
#      The package's compiles come from the compiler cache that step 1's build has just filled
#      (docs/testing.md "Time").
# Set FTID_TEST_QUICK=1 to skip steps 2 to 4 and CTest's many-seed statistics studies (label slow).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(dirname "$here")"
build="${FTID_BUILD_DIR:-$root/build}"
jobs="$(nproc)"
start=$(date +%s)
# Wall time per step, printed at the end (docs/testing.md "Time" keeps the measured figures).
step_times=""
step_name=""
step_start=$start
step() {
  local now
  now=$(date +%s)
  [ -n "$step_name" ] && step_times="${step_times}${step_name} $((now - step_start)) s, "
  step_name="$1"
  step_start=$now
}
# ccache where installed (scripts/packages.txt), keyed on paths relative to the checkout: a rerun
# or another clone recompiles only what changed (setup.sh and fuzz.sh do the same).
launcher=()
if command -v ccache >/dev/null 2>&1; then
  export CCACHE_BASEDIR="$root" CCACHE_NOHASHDIR=1
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi

step "setup+build"
"$here/setup.sh" "$build"
# clang-tidy and step 4 in the background from here on (see the top), each in its own process
# group (job control on for the one command), so that it can be stopped with everything it
# started if an earlier step fails. Not setsid: a new session is a new scheduler autogroup, and
# autogroups share the CPU equally whatever their nice value (measured: CTest's CPU-bound tests
# took 2.2 times as long beside a setsid'd build at nice 19; in the same session nice 19 leaves
# them the CPU).
tidy_pid="" tidy_log="" pkg_pid="" pkg_log=""
stop_background() {
  local pid rc
  # An earlier step failed: clang-tidy's findings, if it finished with some, are shown too.
  if [ -n "$tidy_pid" ] && ! kill -0 "$tidy_pid" 2>/dev/null; then
    rc=0
    wait "$tidy_pid" 2>/dev/null || rc=$?
    [ "$rc" != 0 ] && { echo "== test: clang-tidy (finished in the background, exit $rc)"; cat "$tidy_log"; }
    tidy_pid=""
  fi
  for pid in "$tidy_pid" "$pkg_pid"; do
    if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then
      kill -TERM -- "-$pid" 2>/dev/null || true
      wait "$pid" 2>/dev/null || true
    fi
  done
  rm -f "$tidy_log" "$pkg_log"
  return 0
}
trap stop_background EXIT
# Waits for a background check, prints its output and fails the suite if it failed.
finish_background() {
  local what="$1" pid="$2" log="$3" rc=0
  wait "$pid" || rc=$?
  cat "$log"
  if [ "$rc" != 0 ]; then
    echo "test: $what failed (exit $rc)" >&2
    exit 1
  fi
}
# clang-tidy with the repository's .clang-tidy on every source (a few minutes; fails on findings).
tidy_log="$(mktemp)"
echo "== test: clang-tidy (scripts/tidy.sh) started in the background at nice 19 (its output comes at the end)"
set -m
nice -n 19 "$here/tidy.sh" "$build" > "$tidy_log" 2>&1 &
tidy_pid=$!
set +m
if [ "${FTID_TEST_QUICK:-0}" != 1 ] && [ -x "$here/check_package.sh" ]; then
  pkg_log="$(mktemp)"
  echo "== test: Debian package check started in the background at nice 19 (its output comes at the end)"
  set -m
  nice -n 19 "$here/check_package.sh" > "$pkg_log" 2>&1 &
  pkg_pid=$!
  set +m
fi

step "ctest"
echo "== test: ctest ($build)"
summary="$(mktemp)"
# FTID_TEST_QUICK=1 leaves out the many-seed statistics studies (CTest label slow): the loop a
# developer runs between changes; the full suite (and CI) runs them.
ctest_select=()
if [ "${FTID_TEST_QUICK:-0}" = 1 ]; then
  ctest_select=(-LE slow)
  echo "== test: FTID_TEST_QUICK=1: the statistics studies (label slow) are left out"
fi
(cd "$build" && ctest --output-on-failure -j"$jobs" --timeout 600 "${ctest_select[@]}") | tee "$summary"
# Real SocketCAN (vcan0) and PREEMPT_RT: Debian's RT kernel in qemu (docs/kernel-rig.md, ~1 min).
step "kernel rig"
echo "== test: kernel rig (PREEMPT_RT kernel in qemu: SocketCAN on vcan0, RT set-up, ftidd)"
"$here/kernel-rig.sh" "$build" | tee -a "$summary"
if [ "${FTID_TEST_QUICK:-0}" = 1 ]; then
  step "clang-tidy"
  echo "== test: clang-tidy (waiting for the background check)"
  finish_background "clang-tidy" "$tidy_pid" "$tidy_log"
  tidy_pid=""
fi

if [ "${FTID_TEST_QUICK:-0}" != 1 ]; then
  asan="$root/build-asan"
  step "sanitizer build"
  echo "== test: AddressSanitizer + UBSan build of the unit tests ($asan)"
  # -g1 (line tables) is all the sanitizer reports need and compiles about 20 % faster than -g.
  cmake -S "$root" -B "$asan" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DFTID_SANITIZE=ON \
        -DFTID_BUILD_BENCH=OFF -DCMAKE_CXX_FLAGS_DEBUG="-O0 -g1" "${launcher[@]}" >/dev/null
  cmake --build "$asan" -j"$jobs" --target ftid_unit_tests
  # Every unit test, DaemonClientOverLcm.* included (its LCM-facing files are built without the
  # vptr check only: cmake/FtidDefaults.cmake, docs/testing.md "Sanitizers").
  step "sanitizer run"
  (cd "$asan" && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
      ctest --output-on-failure -j"$jobs" --timeout 900 -LE 'integration|slow' -E '_NOT_BUILT$')
  step "fuzzing"
  echo "== test: fuzzing (scripts/fuzz.sh)"
  "$here/fuzz.sh" "${FTID_FUZZ_SECONDS:-20}"
  step "clang-tidy"
  echo "== test: clang-tidy (waiting for the background check)"
  finish_background "clang-tidy" "$tidy_pid" "$tidy_log"
  tidy_pid=""
  if [ -n "$pkg_pid" ]; then
    step "package"
    echo "== test: Debian package and systemd unit (waiting for the background check)"
    finish_background "the package check" "$pkg_pid" "$pkg_log"
    pkg_pid=""
  fi
fi
step ""
echo "== test: everything passed in $(( $(date +%s) - start )) s (${step_times%, })"
# One plain closing line for CI: the main CTest run's counts.
total=$(grep -oE 'tests failed out of [0-9]+' "$summary" | grep -oE '[0-9]+$' || echo 0)
skipped=$(grep -cE '\(Skipped\)$' "$summary" || true)
grep -E '^kernel-rig: [0-9]+ passed' "$summary" || true
rm -f "$summary"
echo "ctest: $((total - skipped)) passed, 0 failed, ${skipped} skipped"

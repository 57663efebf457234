#!/usr/bin/env bash
# Sets everything up and runs the whole test suite:
#   1. install packages, build (warnings are errors), run every CTest test;
#   2. rebuild the unit tests with AddressSanitizer + UndefinedBehaviorSanitizer and run them;
#   3. build the Debian package and verify the systemd unit (scripts/check_package.sh).
# Set FTID_TEST_QUICK=1 to skip steps 2 and 3.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(dirname "$here")"
build="${FTID_BUILD_DIR:-$root/build}"
jobs="$(nproc)"
start=$(date +%s)

"$here/setup.sh" "$build"
echo "== test: ctest ($build)"
(cd "$build" && ctest --output-on-failure -j"$jobs" --timeout 600)

if [ "${FTID_TEST_QUICK:-0}" != 1 ]; then
  asan="$root/build-asan"
  echo "== test: AddressSanitizer + UBSan build of the unit tests ($asan)"
  cmake -S "$root" -B "$asan" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DFTID_SANITIZE=ON \
        -DFTID_BUILD_BENCH=OFF >/dev/null
  cmake --build "$asan" -j"$jobs"
  (cd "$asan" && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
      ctest --output-on-failure -j"$jobs" --timeout 900 -LE 'integration|slow')
  if [ -x "$here/check_package.sh" ]; then
    echo "== test: Debian package and systemd unit"
    "$here/check_package.sh"
  fi
fi
echo "== test: all passed in $(( $(date +%s) - start )) s"

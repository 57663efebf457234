#!/usr/bin/env bash
# clang-tidy (Debian's clang-tidy-14) with the repository's .clang-tidy over every source file of
# the modules and apps (src/, apps/), using the build's compile_commands.json. Exits non-zero on
# any finding (every enabled check is an error). Run by scripts/test.sh after the build; takes
# a few minutes on 2 cores (the check set in .clang-tidy is chosen for that).
# Usage: scripts/tidy.sh [BUILD_DIR]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(dirname "$here")"
build="${1:-${FTID_BUILD_DIR:-$root/build}}"
tidy="${CLANG_TIDY:-clang-tidy-14}"
if ! command -v "$tidy" >/dev/null; then
  echo "tidy: $tidy not found (install clang-tidy-14, scripts/packages.txt)" >&2
  exit 1
fi
if [ ! -f "$build/compile_commands.json" ]; then
  echo "tidy: $build/compile_commands.json missing (configure with CMAKE_EXPORT_COMPILE_COMMANDS=ON)" >&2
  exit 1
fi
start=$(date +%s)
mapfile -t files < <(cd "$root" && find src apps -name '*.cpp' | sort)
out="$(mktemp)"
trap 'rm -f "$out"' EXIT
# One clang-tidy per file, nproc at a time; --warnings-as-errors makes any finding fail the file.
status=0
printf '%s\n' "${files[@]}" | (cd "$root" && xargs -P "$(nproc)" -n 1 \
    "$tidy" -p "$build" --quiet --warnings-as-errors='*') >"$out" 2>&1 || status=$?
grep -E '(warning|error):' "$out" | sort -u || true
n=$(grep -cE '(warning|error):' "$out" || true)
echo "tidy: ${#files[@]} files, $n findings, $(( $(date +%s) - start )) s"
if [ "$status" -ne 0 ] || [ "$n" -ne 0 ]; then
  echo "tidy: FAILED" >&2
  exit 1
fi

#!/usr/bin/env bash
# clang-tidy (Debian's clang-tidy-14) with the repository's .clang-tidy over every source file of
# the modules and apps (src/, apps/), using the build's compile_commands.json. Exits non-zero on
# any finding (every enabled check is an error). Run by scripts/test.sh after the build; takes
# a few minutes on 2 cores (the check set in .clang-tidy is chosen for that).
# A file that passed is remembered (an empty file named by a hash of everything its result
# depends on: its text, its compile command with the checkout and build paths taken out, every
# header of the project, .clang-tidy, clang-tidy's version and the installed packages' versions),
# so a run after a small change checks only what the change can affect. Findings are never
# cached. The cache is FTID_TIDY_CACHE (default ~/.cache/ftid-tidy); FTID_TIDY_CACHE=off turns it off.
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
cache="${FTID_TIDY_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/ftid-tidy}"
todo=("${files[@]}")
keys=()
if [ "$cache" != off ]; then
  mkdir -p "$cache"
  build_abs="$(cd "$build" && pwd)"
  common="$({ "$tidy" --version; cat "$root/.clang-tidy"
              (cd "$root" && find include src apps -name '*.hpp' -o -name '*.h' | sort | xargs sha256sum)
              dpkg-query -W 2>/dev/null || true; } | sha256sum | cut -c1-64)"
  # One key per file, in the order of files (compile commands from the build's database).
  mapfile -t keys < <(python3 - "$root" "$build_abs" "$common" "${files[@]}" <<'PY'
import hashlib, json, os, sys
root, build, common, files = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
db = {}
for e in json.load(open(os.path.join(build, "compile_commands.json"))):
    path = os.path.normpath(os.path.join(e["directory"], e["file"]))
    cmd = e.get("command") or " ".join(e.get("arguments", []))
    db[path] = cmd.replace(build, "@BUILD@").replace(root, "@ROOT@")
for f in files:
    path = os.path.join(root, f)
    h = hashlib.sha256((common + "\0" + f + "\0" + db.get(path, "?") + "\0").encode())
    h.update(open(path, "rb").read())
    print(h.hexdigest())
PY
)
  todo=()
  for i in "${!files[@]}"; do
    [ -e "$cache/${keys[$i]}" ] || todo+=("${files[$i]}")
  done
  echo "tidy: ${#files[@]} files, $(( ${#files[@]} - ${#todo[@]} )) passed before unchanged (cache $cache)"
fi
# One clang-tidy per file, nproc at a time; --warnings-as-errors makes any finding fail the file.
status=0
if [ "${#todo[@]}" -gt 0 ]; then
  printf '%s\n' "${todo[@]}" | (cd "$root" && xargs -P "$(nproc)" -n 1 \
      "$tidy" -p "$build" --quiet --warnings-as-errors='*') >"$out" 2>&1 || status=$?
fi
grep -E '(warning|error):' "$out" | sort -u || true
n=$(grep -cE '(warning|error):' "$out" || true)
echo "tidy: ${#files[@]} files, $n findings, $(( $(date +%s) - start )) s"
if [ "$status" -ne 0 ] || [ "$n" -ne 0 ]; then
  echo "tidy: FAILED" >&2
  exit 1
fi
# Every file passed: remember them (a failed run remembers nothing, so nothing is ever skipped
# on a guess about which file a finding belonged to).
for key in "${keys[@]}"; do : > "$cache/$key"; done

#!/usr/bin/env bash
# The README's main job: `ftid demo` runs the whole cell (simulated UR controller and sensor,
# ftidd, two signed `ftid --identify` runs, live compensation during a push) in a private network
# namespace and exits 0, naming the hidden effect and showing only the contact during the push.
# Usage: demo_test.sh FTID_BINARY
set -euo pipefail
ftid="$1"
work="$(mktemp -d /tmp/ftid-demo-test.XXXXXX)"
trap 'rm -rf "$work"' EXIT
if ! unshare -rn true 2>/dev/null; then
  echo "SKIP: no private network namespaces here"
  exit 77
fi
out="$work/out.txt"
if ! timeout 600 "$ftid" demo --workdir "$work/demo" > "$out" 2>&1; then
  cat "$out"
  echo "FAIL: ftid demo exited non-zero"
  exit 1
fi
for want in "temperature_drift" "only the contact remains" "demo finished"; do
  if ! grep -q "$want" "$out"; then
    cat "$out"
    echo "FAIL: the demo's output lacks '$want'"
    exit 1
  fi
done
echo "PASS: ftid demo"

#!/usr/bin/env bash
# The main job: set up, build, and run the ftid demo against the simulators on loopback.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(dirname "$here")"
build="${FTID_BUILD_DIR:-$root/build}"
"$here/setup.sh" "$build"
exec "$build/apps/ftid/ftid" demo --workdir "${FTID_DEMO_DIR:-$root/out/demo}" "$@"

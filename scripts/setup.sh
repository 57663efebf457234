#!/usr/bin/env bash
# Installs the Debian 12 packages ftid needs (scripts/packages.txt), then configures and builds.
# Usage: scripts/setup.sh [BUILD_DIR]   (run as root, or with sudo, on Debian 12)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(dirname "$here")"
build="${1:-$root/build}"

mapfile -t pkgs < <(grep -vE '^\s*(#|$)' "$here/packages.txt")
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "== setup: installing ${#missing[@]} Debian packages: ${missing[*]}"
  if [ "$(id -u)" -ne 0 ]; then
    echo "setup: need root to install packages (run with sudo)" >&2
    exit 1
  fi
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "== setup: all ${#pkgs[@]} Debian packages present"
fi

echo "== setup: configuring $build"
# ccache (scripts/packages.txt) keyed on paths relative to the checkout, so a second clone or a
# second build of the same sources reuses the objects (docs/testing.md "Time").
launcher=()
if command -v ccache >/dev/null 2>&1; then
  export CCACHE_BASEDIR="$root" CCACHE_NOHASHDIR=1
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
# RelWithDebInfo with line tables only (-g1): same code as -O2 -g, backtraces keep file:line, and
# the Eigen-heavy sources compile about 40 % faster than with full debug info.
# scripts/check_package.sh compiles the package with these same flags, so that its objects come
# from the cache this build fills: change the flags in both places together.
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" -DFTID_BUILD_TESTS=ON "${launcher[@]}" >/dev/null
echo "== setup: building (this takes a few minutes on 2 cores)"
cmake --build "$build" -j"$(nproc)"

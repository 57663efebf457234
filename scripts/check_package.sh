#!/usr/bin/env bash
# Builds the Debian package from a clean copy of the tracked tree, checks it with lintian
# (no errors allowed), checks its contents, and verifies the systemd unit with
# `systemd-analyze verify` (which exits 0 even on warnings, so its output must be empty).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(dirname "$here")"
work="$(mktemp -d /tmp/ftid-pkg.XXXXXX)"
trap 'rm -rf "$work"' EXIT
# scripts/test.sh runs this in the background and stops it with SIGTERM when an earlier step fails:
# exit through the EXIT trap so that the copy and the build are removed.
trap 'exit 143' TERM INT

echo "== package: copying the tracked tree to $work/ftid"
mkdir -p "$work/ftid"
if git -C "$root" rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  # tracked + untracked-but-not-ignored files, as they are in the working tree
  (cd "$root" && git ls-files -z --cached --others --exclude-standard | \
     xargs -0 -I{} cp --parents -- {} "$work/ftid/" 2>/dev/null || true)
else
  cp -a "$root/." "$work/ftid/"
fi

# The package build compiles every product file. With ccache (scripts/packages.txt) it compiles
# them exactly as the release build of scripts/setup.sh does, so that they come from the cache
# that build has just filled (docs/testing.md "Time"); every item below is needed for a hit:
# - the same flags: -O2 -g1 -DNDEBUG in place of dpkg-buildflags' CFLAGS/CXXFLAGS/CPPFLAGS (its
#   -ffile-prefix-map holds the absolute path of the copy, -D_FORTIFY_SOURCE and -g differ from the
#   release build) and -Werror (FTID_WERROR, default OFF in debian/rules); LDFLAGS (relro, now)
#   stay, linking is not cached;
# - the same relative paths: CCACHE_BASEDIR is the copy, and debian/rules builds in
#   obj-<triplet>, one level below it like build/ in the tree; CCACHE_NOHASHDIR=1 as setup.sh;
# - the same cache: debhelper points HOME at a fresh directory and clears XDG_CACHE_HOME;
# - the same locale: ccache hashes LANG, LC_ALL, LC_CTYPE and LC_MESSAGES, and debhelper runs
#   ninja with LC_ALL=C.UTF-8, so the launcher gives the compiler this script's LC_ALL back.
# A plain `dpkg-buildpackage` (none of this) keeps Debian's flags, hardening and dbgsym.
# Without ccache: noopt and -g0 (the code itself is built and tested with -O2 above) halve the
# compile time of the uncached build.
pkg_env=(DEB_BUILD_OPTIONS="parallel=$(nproc) nocheck noopt" DEB_CFLAGS_APPEND=-g0 DEB_CXXFLAGS_APPEND=-g0)
if command -v ccache >/dev/null 2>&1; then
  if [ -n "${LC_ALL+set}" ]; then launcher="env;LC_ALL=$LC_ALL;ccache"; else launcher="env;-u;LC_ALL;ccache"; fi
  release_flags="-O2 -g1 -DNDEBUG"  # scripts/setup.sh, CMAKE_CXX_FLAGS_RELWITHDEBINFO
  pkg_env=(DEB_BUILD_OPTIONS="parallel=$(nproc) nocheck"
           DEB_CFLAGS_SET="$release_flags" DEB_CXXFLAGS_SET="$release_flags" DEB_CPPFLAGS_SET=""
           FTID_WERROR=ON CMAKE_C_COMPILER_LAUNCHER="$launcher" CMAKE_CXX_COMPILER_LAUNCHER="$launcher"
           CCACHE_BASEDIR="$work/ftid" CCACHE_NOHASHDIR=1 CCACHE_DIR="$(ccache -k cache_dir)"
           CCACHE_STATSLOG="$work/ccache-stats.log")
fi
echo "== package: dpkg-buildpackage -us -uc -b"
(cd "$work/ftid" && env "${pkg_env[@]}" dpkg-buildpackage -us -uc -b > "$work/build.log" 2>&1) || \
  { tail -50 "$work/build.log"; exit 1; }
if [ -f "$work/ccache-stats.log" ]; then
  echo "package: ccache $(CCACHE_STATSLOG="$work/ccache-stats.log" ccache --show-log-stats | \
                           sed -n 's/^ *Hits: *\([0-9]* \/ *[0-9]*\).*/\1/p' | head -1 | tr -s ' ') hits"
fi
deb="$(ls "$work"/ftid_*.deb | head -1)"
echo "== package: built $(basename "$deb")"

echo "== package: contents"
contents="$(dpkg-deb -c "$deb")"
for f in ./usr/bin/ftid ./usr/sbin/ftidd ./etc/ftid/ftidd.yaml ./etc/ftid/cell_limits.yaml ./lib/systemd/system/ftidd.service \
         ./usr/lib/sysusers.d/ftid.conf ./usr/share/man/man1/ftid.1.gz ./usr/share/man/man8/ftidd.8.gz; do
  if ! grep -q " $f\$" <<<"$contents"; then
    echo "package: missing $f" >&2
    exit 1
  fi
done
dpkg-deb -I "$deb" conffiles | grep -q /etc/ftid/ftidd.yaml || { echo "package: ftidd.yaml is not a conffile" >&2; exit 1; }
dpkg-deb -I "$deb" conffiles | grep -q /etc/ftid/cell_limits.yaml || { echo "package: cell_limits.yaml is not a conffile" >&2; exit 1; }

echo "== package: lintian"
lint="$(lintian --tag-display-limit 0 "$deb" 2>&1 | grep -v 'running with root privileges' || true)"
[ -n "$lint" ] && echo "$lint"
if grep -q '^E:' <<<"$lint"; then
  echo "package: lintian reported errors" >&2
  exit 1
fi

echo "== package: systemd-analyze verify"
unitdir="$work/unit"
mkdir -p "$unitdir/bin"
dpkg-deb -x "$deb" "$work/pkgroot"
unit="$unitdir/ftidd.service"
# Point ExecStart at the packaged binary; drop man: links (the man pages are not installed on
# this machine, which systemd-analyze would report).
sed -e "s#/usr/sbin/ftidd#$work/pkgroot/usr/sbin/ftidd#" -e '/^Documentation=/d' \
    "$work/pkgroot/lib/systemd/system/ftidd.service" > "$unit"
out="$(systemd-analyze verify --man=no "$unit" 2>&1 || true)"
if [ -n "$out" ]; then
  echo "$out" >&2
  echo "package: systemd-analyze verify printed the above for ftidd.service" >&2
  exit 1
fi
echo "== package: systemd-analyze security (exposure must be <= 1.5, docs/operations.md)"
sec="$(systemd-analyze security --offline=true "$unit" 2>&1 || true)"
exposure="$(printf '%s\n' "$sec" | sed -n 's/.*Overall exposure level for [^:]*: \([0-9.]*\).*/\1/p' | tail -1)"
if [ -z "$exposure" ]; then
  echo "$sec" >&2
  echo "package: could not read the exposure level from systemd-analyze security" >&2
  exit 1
fi
echo "ftidd.service exposure: $exposure"
if ! awk -v e="$exposure" 'BEGIN { exit !(e <= 1.5) }'; then
  printf '%s\n' "$sec" | grep -F '✗' >&2 || true
  echo "package: ftidd.service exposure $exposure is above 1.5" >&2
  exit 1
fi
echo "== package: default files from an empty directory (packaged ftid, data in its share/ftid)"
"$root/test/integration/default_files_test.sh" "$work/pkgroot/usr/bin/ftid" "$work/pkgroot/usr/sbin/ftidd"
echo "== package: OK"

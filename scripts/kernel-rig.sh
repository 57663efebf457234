#!/usr/bin/env bash
# The kernel rig: runs the tests that need real SocketCAN (vcan0) and a PREEMPT_RT kernel inside
# qemu, on Debian 12's own PREEMPT_RT kernel, every time (docs/kernel-rig.md).
#
#   scripts/kernel-rig.sh [BUILD_DIR]        (default: $FTID_BUILD_DIR or ./build)
#
#  1. installs qemu-system-x86, busybox-static, cpio, iproute2 and xz-utils if missing (root);
#  2. downloads the kernel package linux-image-rt-amd64 currently depends on (apt-get download,
#     never installed) and extracts vmlinuz plus can.ko, can-raw.ko, can-dev.ko, vcan.ko;
#  3. builds an initramfs: busybox, iproute2's ip, the build tree's ftid, ftidd,
#     ftid_drivers_can_test and ftid_kernel_test with their shared libraries (ldd), the config
#     files they read, and test/kernel/rig_init.sh as /init;
#  4. boots it with qemu-system-x86_64 -accel tcg (software emulation: the PREEMPT_RT kernel hangs
#     at boot under nested KVM), reads the results from the serial console and exits non-zero on
#     any failure, with a closing "kernel-rig: N passed, N failed" line.
# Cache (kernel parts and the busybox/ip/modules initramfs part): $FTID_KERNEL_RIG_CACHE, else
# /var/cache/ftid-kernel-rig if writable, else BUILD_DIR/kernel-rig-cache. The console log of the
# last run: BUILD_DIR/kernel-rig/console.log.
# If qemu cannot boot the kernel here, this script fails and says why: it never skips.
#
# Latency mode (KVM or bare-metal-like hosts; not part of the test command):
#   FTID_KERNEL_RIG_ACCEL=kvm FTID_KERNEL_RIG_LATENCY_S=60 scripts/kernel-rig.sh build
# boots the same initramfs plus rt-tests' cyclictest and build/bench/bench_rt_loop, and instead of
# the tests runs cyclictest alone, then bench_rt_loop with cyclictest beside it, and prints both
# (docs/kernel-rig.md, "Measuring latency"). Under TCG the figures mean nothing.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(dirname "$here")"
build="$(cd "${1:-${FTID_BUILD_DIR:-$root/build}}" 2>/dev/null && pwd)" || {
  echo "kernel-rig: build directory '${1:-${FTID_BUILD_DIR:-$root/build}}' does not exist" >&2
  echo "kernel-rig: 0 passed, 1 failed"; exit 1; }
timeout_s="${FTID_KERNEL_RIG_TIMEOUT:-480}"   # whole VM run, wall clock (both stages)
accel="${FTID_KERNEL_RIG_ACCEL:-tcg}"          # tcg (default) or kvm
latency_s="${FTID_KERNEL_RIG_LATENCY_S:-0}"    # > 0: latency mode, seconds per measurement
case "$accel" in tcg|kvm) ;; *) echo "kernel-rig: FTID_KERNEL_RIG_ACCEL must be tcg or kvm" >&2; exit 2 ;; esac
case "$latency_s" in ''|*[!0-9]*) echo "kernel-rig: FTID_KERNEL_RIG_LATENCY_S must be whole seconds" >&2; exit 2 ;; esac
smp="${FTID_KERNEL_RIG_CPUS:-2}"
mem_mb="${FTID_KERNEL_RIG_MEM_MB:-1536}"
start=$(date +%s)
work="$build/kernel-rig"

fail() {  # a set-up failure: say why, count it, stop
  echo "kernel-rig: FAILED: $*" >&2
  echo "kernel-rig: 0 passed, 1 failed"
  exit 1
}
log() { echo "kernel-rig: $*"; }

# ---- 1. packages -------------------------------------------------------------------------------
need_pkgs=()
rig_pkgs="qemu-system-x86 busybox-static cpio iproute2 xz-utils binutils"
[ "$latency_s" -gt 0 ] && rig_pkgs="$rig_pkgs rt-tests"
for p in $rig_pkgs; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || need_pkgs+=("$p")
done
if [ ${#need_pkgs[@]} -gt 0 ]; then
  [ "$(id -u)" = 0 ] || fail "missing Debian packages ${need_pkgs[*]} (run as root, or: apt-get install ${need_pkgs[*]})"
  log "installing ${need_pkgs[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get install -y --no-install-recommends "${need_pkgs[@]}" >/dev/null 2>&1 ||
    { apt-get update >/dev/null && apt-get install -y --no-install-recommends "${need_pkgs[@]}" >/dev/null; } ||
    fail "apt-get install ${need_pkgs[*]} failed"
fi
command -v qemu-system-x86_64 >/dev/null || fail "qemu-system-x86_64 not found after installing qemu-system-x86"

# ---- 2. the PREEMPT_RT kernel ------------------------------------------------------------------
cache="${FTID_KERNEL_RIG_CACHE:-}"
if [ -z "$cache" ]; then
  if mkdir -p /var/cache/ftid-kernel-rig 2>/dev/null && [ -w /var/cache/ftid-kernel-rig ]; then
    cache=/var/cache/ftid-kernel-rig
  else
    cache="$build/kernel-rig-cache"
  fi
fi
mkdir -p "$cache" "$work"
# The package linux-image-rt-amd64 depends on right now, e.g. linux-image-6.1.0-57-rt-amd64.
kpkg="$(apt-cache depends linux-image-rt-amd64 2>/dev/null | awk '/Depends: linux-image-/ {print $2; exit}')"
if [ -z "$kpkg" ]; then
  [ "$(id -u)" = 0 ] && apt-get update >/dev/null 2>&1 || true
  kpkg="$(apt-cache depends linux-image-rt-amd64 2>/dev/null | awk '/Depends: linux-image-/ {print $2; exit}')"
fi
if [ -z "$kpkg" ]; then
  # Offline and no package lists: use the newest kernel already in the cache.
  kpkg="$(ls -1 "$cache" 2>/dev/null | grep -E '^linux-image-.*-rt-amd64$' | sort -V | tail -1 || true)"
  [ -n "$kpkg" ] || fail "cannot resolve linux-image-rt-amd64 (apt-cache depends) and nothing is cached in $cache"
  log "package lists unavailable: using the cached $kpkg"
fi
kdir="$cache/$kpkg"
if [ ! -f "$kdir/.complete" ]; then
  log "fetching $kpkg (apt-get download, not installed)"
  rm -rf "$kdir" && mkdir -p "$kdir/deb"
  (cd "$kdir/deb" && apt-get download "$kpkg" >/dev/null 2>&1) ||
    (cd "$kdir/deb" && chmod 777 . && apt-get download "$kpkg" >/dev/null) ||
    fail "apt-get download $kpkg failed (network or package lists?)"
  deb="$(ls "$kdir"/deb/*.deb | head -1)"
  mkdir -p "$kdir/x"
  dpkg-deb --fsys-tarfile "$deb" |
    tar -x -C "$kdir/x" --wildcards './boot/vmlinuz-*' '*/kernel/net/can/*' '*/drivers/net/can/vcan.ko*' \
        '*/drivers/net/can/dev/can-dev.ko*' || fail "cannot extract $deb"
  mkdir -p "$kdir/modules"
  cp "$kdir"/x/boot/vmlinuz-* "$kdir/vmlinuz"
  for m in can can-raw can-dev vcan; do
    f="$(find "$kdir/x" -name "$m.ko*" | head -1)"
    [ -n "$f" ] || fail "$m.ko is not in $deb"
    case "$f" in
      *.ko) cp "$f" "$kdir/modules/$m.ko" ;;
      *.ko.xz) xz -dc "$f" > "$kdir/modules/$m.ko" ;;
      *.ko.zst) zstd -dcq "$f" > "$kdir/modules/$m.ko" ;;
      *.ko.gz) gzip -dc "$f" > "$kdir/modules/$m.ko" ;;
      *) fail "unknown module compression: $f" ;;
    esac
  done
  rm -rf "$kdir/x" "$kdir/deb"  # keep only what the rig boots (the .deb is 70 MB)
  touch "$kdir/.complete"
fi
# Module order: can (AF_CAN), can-raw (CAN_RAW sockets), can-dev, vcan.
modules="can.ko can-raw.ko can-dev.ko vcan.ko"

# ---- 3. initramfs ------------------------------------------------------------------------------
# Copies a file to the same path under $2, with the shared libraries it links (ldd).
copy_with_libs() {
  local f="$1" dest="$2" strip="${3:-no}"
  mkdir -p "$dest$(dirname "$f")"
  if [ "$strip" = strip ]; then
    strip --strip-debug -o "$dest$f" "$f" || fail "strip $f"
  else
    cp -L "$f" "$dest$f"
  fi
  local lib
  for lib in $(ldd "$f" 2>/dev/null | awk '/=> \// {print $3} /^\t\/[^ ]+ \(/ {print $1}'); do
    if [ ! -e "$dest$lib" ]; then
      mkdir -p "$dest$(dirname "$lib")"
      cp -L "$lib" "$dest$lib"
    fi
  done
}

# Part 1 (cached per kernel and busybox/iproute2 version): busybox, ip, the modules.
bb_ver="$(dpkg-query -W -f='${Version}' busybox-static)-$(dpkg-query -W -f='${Version}' iproute2)"
base="$kdir/base-v2-$bb_ver.cpio.gz"  # v2: bump when the part's layout changes
if [ ! -f "$base" ]; then
  log "building the base initramfs (busybox, ip, CAN modules)"
  stage="$(mktemp -d "$work/base.XXXXXX")"
  mkdir -p "$stage/bin" "$stage/sbin" "$stage/rig/modules"
  cp /bin/busybox "$stage/bin/busybox"
  ln -s busybox "$stage/bin/sh"  # for /init's #!/bin/sh; the other applets are linked by /init
  copy_with_libs /sbin/ip "$stage"
  # Only iproute2's ip understands "type vcan"; it must win over busybox's applet.
  [ -e "$stage/bin/ip" ] || ln -s /sbin/ip "$stage/bin/ip"
  cp "$kdir"/modules/*.ko "$stage/rig/modules/"
  (cd "$stage" && find . -mindepth 1 | cpio -o -H newc --quiet | gzip -1) > "$base.tmp.$$"
  mv "$base.tmp.$$" "$base"
  rm -rf "$stage"
fi

# Part 2 (every run): the build tree's programs at their build paths, the files they read at
# their source paths, the init script and its settings.
ftid="$build/apps/ftid/ftid"
ftidd="$build/apps/ftidd/ftidd"
cantest="$build/test/unit/drivers/can/ftid_drivers_can_test"
ktest="$build/test/kernel/ftid_kernel_test"
bench="$build/bench/bench_rt_loop"
programs=("$ftid" "$ftidd" "$cantest" "$ktest")
[ "$latency_s" -gt 0 ] && programs+=("$bench" "$(command -v cyclictest || echo /usr/bin/cyclictest)")
for b in "${programs[@]}"; do
  [ -x "$b" ] || fail "$b is not built (cmake --build $build --target ftid ftidd ftid_drivers_can_test ftid_kernel_test bench_rt_loop)"
done
stage="$(mktemp -d "$work/stage.XXXXXX")"
trap 'rm -rf "$stage"' EXIT
for b in "${programs[@]}"; do copy_with_libs "$b" "$stage" strip; done
for f in config/ur10.urdf config/ftsensor.dbc; do
  mkdir -p "$stage$root/$(dirname "$f")"
  cp "$root/$f" "$stage$root/$f"
done
mkdir -p "$stage/rig"
cp "$root/test/kernel/rig_init.sh" "$stage/init"
chmod 755 "$stage/init"
cp "$root/test/kernel/rig_lib.sh" "$stage/rig/lib.sh"
# Stage 2 (not in latency mode): after the tests above, /init switches to a tmpfs root and execs
# systemd as PID 1, which runs the packaged ftidd.service unchanged (the UnderSystemd.* tests).
# Laid out as the .deb installs it: /usr/sbin/ftidd, /lib/systemd/system/ftidd.service,
# /usr/lib/sysusers.d/ftid.conf, /usr/share/ftid/config/; the postinst runs there.
systemd_stage=0
if [ "$latency_s" -eq 0 ]; then
  systemd_stage=1
  for f in /lib/systemd/systemd /lib/systemd/systemd-journald /bin/systemctl /bin/journalctl \
           /bin/systemd-sysusers; do
    [ -x "$f" ] || fail "$f not found (Debian package systemd)"
    copy_with_libs "$f" "$stage" strip
  done
  mkdir -p "$stage/etc/systemd/system" "$stage/lib/systemd/system" "$stage/usr/lib/sysusers.d" \
           "$stage/usr/sbin" "$stage/usr/share/ftid/config" "$stage/etc/ftid"
  cp /usr/lib/os-release "$stage/usr/lib/os-release"
  ln -sf ../usr/lib/os-release "$stage/etc/os-release"
  printf 'root:x:0:0:root:/root:/bin/sh\n' > "$stage/etc/passwd"
  printf 'root:x:0:\n' > "$stage/etc/group"
  : > "$stage/etc/shadow"; : > "$stage/etc/gshadow"; chmod 600 "$stage/etc/shadow" "$stage/etc/gshadow"
  # systemd's own targets (sysinit, basic, network-online ...: ftidd.service's default and
  # explicit dependencies), the system slice and journald; nothing else is installed.
  for u in /lib/systemd/system/*.target system.slice systemd-journald.service \
           systemd-journald.socket systemd-journald-dev-log.socket; do
    case "$u" in /*) ;; *) u="/lib/systemd/system/$u" ;; esac
    [ -f "$u" ] && [ ! -L "$u" ] && cp "$u" "$stage/lib/systemd/system/"
  done
  cp "$root/debian/ftid.ftidd.service" "$stage/lib/systemd/system/ftidd.service"
  cp "$root/debian/ftid.sysusers" "$stage/usr/lib/sysusers.d/ftid.conf"
  strip --strip-debug -o "$stage/usr/sbin/ftidd" "$ftidd"
  cp "$root/config/ur10.urdf" "$root/config/ftsensor.dbc" "$stage/usr/share/ftid/config/"
  cp "$root/debian/ftid.postinst" "$stage/rig/ftid.postinst"
  cp "$root/test/kernel/rig_systemd_checks.sh" "$stage/rig/systemd_checks.sh"
  chmod 755 "$stage/rig/ftid.postinst" "$stage/rig/systemd_checks.sh"
  cat > "$stage/etc/systemd/system/ftid-rig.target" <<'EOF'
[Unit]
Description=ftid kernel rig, stage 2
Requires=ftid-rig.service systemd-journald.socket
AllowIsolate=yes
EOF
  cat > "$stage/etc/systemd/system/ftid-rig.service" <<'EOF'
[Unit]
Description=ftid kernel rig checks under systemd
After=systemd-journald.socket

[Service]
Type=oneshot
ExecStart=/rig/systemd_checks.sh
StandardOutput=tty
StandardError=tty
TTYPath=/dev/ttyS0
TTYReset=no
TTYVHangup=no
EOF
  ln -sf ftid-rig.target "$stage/etc/systemd/system/default.target"
fi
# The SocketCAN unit tests, all of them: ConstructorExplainsMissingSupport checks the error on a
# kernel WITHOUT AF_CAN and is excluded here (it runs, and passes, on the build machines).
# UnderSystemd.* runs in stage 2 only.
gtests="socketcan_unit=$cantest:SocketCan.*:-SocketCan.ConstructorExplainsMissingSupport kernel=$ktest:-UnderSystemd.*"
gtest_names="socketcan_unit kernel"
[ "$systemd_stage" = 1 ] && gtest_names="$gtest_names systemd"
if [ "$latency_s" -gt 0 ]; then gtests=""; gtest_names=""; fi  # measure on a quiet VM
cat > "$stage/rig/env" <<EOF
RIG_MODULES="$modules"
RIG_GTESTS="$gtests"
RIG_LATENCY_S=$latency_s
RIG_BENCH="$bench"
RIG_SYSTEMD=$( [ "$systemd_stage" = 1 ] && echo 1 )
RIG_KTEST="$ktest"
EOF
initrd="$work/initrd.cpio.gz"
cp "$base" "$initrd"
(cd "$stage" && find . -mindepth 1 | cpio -o -H newc --quiet | gzip -1) >> "$initrd"
rm -rf "$stage"
trap - EXIT

# ---- 4. boot -----------------------------------------------------------------------------------
console="$work/console.log"
prep_s=$(( $(date +%s) - start ))
vm_start=$(date +%s)
log "booting $kpkg in qemu ($accel, $smp CPUs, $mem_mb MB; initramfs $(du -m "$initrd" | cut -f1) MB)"
if [ "$accel" = kvm ]; then
  accel_args=(-accel kvm -cpu host)
else
  accel_args=(-accel tcg -cpu max)
fi
[ "$latency_s" -gt 0 ] && timeout_s=$(( timeout_s + 12 * latency_s ))
set +e
timeout --kill-after=10 "$timeout_s" qemu-system-x86_64 "${accel_args[@]}" -smp "$smp" -m "$mem_mb" \
  -kernel "$kdir/vmlinuz" -initrd "$initrd" \
  -append "console=ttyS0 panic=-1 quiet loglevel=3 rdinit=/init" \
  -display none -no-reboot -nic none -monitor none -serial stdio </dev/null > "$console" 2>&1
qrc=$?
set -e
tr -d '\r' < "$console" > "$console.txt" && mv "$console.txt" "$console"
vm_s=$(( $(date +%s) - vm_start ))

if ! grep -q '^@@RIG start' "$console"; then
  tail -n 30 "$console" >&2
  if [ $qrc = 124 ]; then
    fail "the VM did not boot within ${timeout_s} s (qemu TCG; console: $console)"
  fi
  fail "qemu could not boot $kpkg (exit $qrc; console: $console)"
fi

# ---- results -----------------------------------------------------------------------------------
passed=0; failed=0
while IFS= read -r line; do
  case "$line" in
    "@@RIG check "*)
      read -r _ _ cname cresult _ <<< "$line"
      if [ "$cresult" = PASS ]; then passed=$((passed + 1)); else
        failed=$((failed + 1)); echo "kernel-rig: FAILED check $cname: ${line#*FAIL }"; fi ;;
  esac
done < "$console"
# GoogleTest per-test result lines (with the run time; the summary repeats names without it).
ok=$(grep -cE '^\[       OK \] [A-Za-z0-9_]+\.[A-Za-z0-9_/]+ \([0-9]+ ms\)$' "$console" || true)
bad=$(grep -E '^\[  (FAILED  |SKIPPED )\] [A-Za-z0-9_]+\.[A-Za-z0-9_/]+ \([0-9]+ ms\)$' "$console" || true)
passed=$((passed + ok))
if [ -n "$bad" ]; then
  failed=$((failed + $(echo "$bad" | wc -l)))
  echo "$bad" | sed -e 's/^\[  SKIPPED \]/[  SKIPPED ] (a skip is a failure here)/' -e 's/^/kernel-rig: FAILED: /'
fi
# Every listed GoogleTest binary must have run at least one test and exited 0 (a crash prints no
# FAILED line; a filter that matches nothing runs no test).
for g in $gtest_names; do
  ran=$(awk -v g="$g" '$0 == "@@RIG gtest " g {on = 1; next} /^@@RIG gtest/ {on = 0}
                       on && /^\[ RUN      \]/ {n++} END {print n + 0}' "$console")
  if [ "$ran" -eq 0 ]; then
    failed=$((failed + 1))
    echo "kernel-rig: FAILED: test program '$g' ran no test"
  fi
  if ! grep -q "^@@RIG gtest-exit $g 0$" "$console"; then
    failed=$((failed + 1))
    echo "kernel-rig: FAILED: test program '$g' did not finish cleanly: $(grep "^@@RIG gtest-exit $g " "$console" || echo 'no exit line')"
  fi
done
if ! grep -q '^@@RIG done' "$console"; then
  failed=$((failed + 1))
  echo "kernel-rig: FAILED: the VM stopped before the end of the tests (timeout ${timeout_s} s or crash; qemu exit $qrc)"
fi
if [ "$failed" -gt 0 ]; then
  echo "kernel-rig: console log ($console), failing parts:"
  grep -vE '^\[       OK \]|^\[ RUN      \]' "$console" | tail -n 150
fi
log "$(grep '^@@RIG start' "$console" | cut -d' ' -f3-)"
log "wall time $(( $(date +%s) - start )) s (preparation $prep_s s, VM $vm_s s)"
echo "kernel-rig: $passed passed, $failed failed"
[ "$failed" -eq 0 ]

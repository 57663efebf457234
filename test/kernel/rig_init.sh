#!/bin/sh
# /init of the kernel rig's initramfs (scripts/kernel-rig.sh, docs/kernel-rig.md). Runs as PID 1
# under busybox inside qemu on Debian's PREEMPT_RT kernel: sets up /proc, /sys, /dev, the CAN
# modules, vcan0 and loopback multicast, runs the tests listed in /rig/env and powers off.
# Everything goes to the serial console; the host reads these marker lines:
#   @@RIG check NAME PASS|FAIL [why]   one check of the rig itself (counted as a test)
#   @@RIG gtest NAME                   the output of a GoogleTest run follows
#   @@RIG done                         the end (missing = the VM crashed or timed out)
# With RIG_SYSTEMD set (/rig/env), the end is stage 2: systemd as PID 1 runs the packaged unit
# (see the end of this file and /rig/systemd_checks.sh).
# A GoogleTest run's "[       OK ]", "[  FAILED  ]" and "[  SKIPPED ]" lines are counted by the
# host: a skip is a failure here.
export PATH=/bin:/sbin:/usr/bin:/usr/sbin
/bin/busybox mkdir -p /proc /sys /dev /tmp /run /var/tmp
/bin/busybox mount -t proc proc /proc
/bin/busybox mount -t sysfs sys /sys
/bin/busybox mount -t devtmpfs dev /dev
/bin/busybox mkdir -p /dev/shm
/bin/busybox mount -t tmpfs shm /dev/shm
# /tmp stays part of the initramfs (already RAM): a checkout under /tmp puts the build tree there.
/bin/busybox chmod 1777 /tmp
/bin/busybox mount -t tmpfs run /run
/bin/busybox --install -s /bin
. /rig/env

. /rig/lib.sh  # check NAME COMMAND...

echo "@@RIG start $(uname -r) $(uname -v) cpus=$(nproc)"
check preempt_rt_kernel sh -c 'uname -v | grep -q PREEMPT_RT && [ "$(cat /sys/kernel/realtime)" = 1 ]'
mods_ok=1
for m in $RIG_MODULES; do
  if ! out=$(insmod "/rig/modules/$m" 2>&1); then
    mods_ok=0
    echo "insmod $m: $out"
  fi
done
check can_modules [ $mods_ok = 1 ]
# iproute2's ip by its full path: busybox's sh prefers its own (smaller) ip applet.
IP=/sbin/ip
check vcan0_up sh -c "$IP link add dev vcan0 type vcan && $IP link set vcan0 up && $IP -details link show vcan0 | grep -q vcan"
check loopback_multicast sh -c "$IP link set lo up && $IP route add 224.0.0.0/4 dev lo"
echo "@@RIG info $($IP -details link show vcan0 | tr '\n' ' ')"

cd /tmp
set -f  # the filters contain '*'
for t in $RIG_GTESTS; do
  # NAME=BINARY[:FILTER]
  name=${t%%=*}; rest=${t#*=}
  bin=${rest%%:*}; filter=
  [ "$rest" != "$bin" ] && filter=${rest#*:}
  echo "@@RIG gtest $name"
  if [ -n "$filter" ]; then
    "$bin" --gtest_color=no "--gtest_filter=$filter" 2>&1
  else
    "$bin" --gtest_color=no 2>&1
  fi
  echo "@@RIG gtest-exit $name $?"
done
if [ "${RIG_LATENCY_S:-0}" -gt 0 ]; then
  # Latency mode (docs/kernel-rig.md): cyclictest alone, then bench_rt_loop with cyclictest
  # beside it on the same CPUs. Figures are printed, not judged.
  ct="cyclictest --mlockall --priority=90 --interval=1000 --distance=0 --smp --quiet"
  echo "@@RIG latency cyclictest alone (${RIG_LATENCY_S} s)"
  check cyclictest_alone sh -c "$ct --duration=${RIG_LATENCY_S} > /tmp/ct1.txt 2>&1"
  cat /tmp/ct1.txt
  echo "@@RIG latency bench_rt_loop ${RIG_LATENCY_S} s per run, cyclictest beside it"
  $ct > /tmp/ct2.txt 2>&1 &
  ctpid=$!
  check bench_rt_loop sh -c "'$RIG_BENCH' $RIG_LATENCY_S > /tmp/bench.txt 2>&1"
  cat /tmp/bench.txt
  kill -INT $ctpid 2>/dev/null
  wait $ctpid
  echo "@@RIG latency cyclictest beside bench_rt_loop"
  cat /tmp/ct2.txt
fi
if [ -n "${RIG_SYSTEMD:-}" ] && [ -x /lib/systemd/systemd ]; then
  # Stage 2: the packaged unit under a real systemd as PID 1 (docs/kernel-rig.md). systemd wants
  # a real root file system, not the initramfs: copy this tree to a tmpfs and switch_root into it.
  # vcan0, lo's multicast route and the loaded modules stay (they belong to the kernel).
  # /rig/systemd_checks.sh (a oneshot unit) prints the markers, "@@RIG done" and powers off.
  echo "@@RIG phase systemd"
  mkdir -p /newroot
  mount -t tmpfs -o mode=755 newroot /newroot
  set +f
  for d in /*; do
    case "$d" in /proc|/sys|/dev|/run|/newroot|/init) ;; *) cp -a "$d" /newroot/ ;; esac
  done
  mkdir -p /newroot/proc /newroot/sys /newroot/dev /newroot/run
  cd /
  umount /dev/shm /dev /sys /proc /run 2>/dev/null
  exec switch_root /newroot /lib/systemd/systemd --log-level=warning --show-status=false \
    --crash-reboot=yes
fi
echo "@@RIG done"
sync
poweroff -f

#!/bin/bash
# Half-open robot link (issue 14, "Links"): the controller loses power, no FIN or RST arrives.
#
#   link_loss_test.sh FTID FTIDD SRC_DIR
#
# ftidd and the sensor simulator run in a private network namespace A (unshare -rn; LCM
# multicast on lo); `ftid sim-robot` runs in a second namespace B joined to A by a veth pair
# (10.77.0.1 <-> 10.77.0.2), the "cell network". Once ftidd runs, B's end of the link is set
# down: packets from ftidd vanish, nothing answers, no FIN, no RST (a pulled cable or a
# controller without power). A NOTIFY_SOCKET collects ftidd's systemd notifications
# (WATCHDOG_USEC=400000 so it feeds the watchdog every 0.2 s).
# (No parameter file: every cycle's wrench is valid = false anyway; the supervisor's messages are
# told apart by cycle = -1.)
# Checks: ftidd publishes the wrench with valid = false (cycle = -1) within 0.5 s of the link
# going down and keeps doing so; it stops feeding the watchdog within watchdog_silence_s (1 s
# here) + 0.5 s; its log names the cause; TCP keepalive ends the connection (ftidd exits 1 with a
# message naming the controller link) within 10 s.
# Exit status: 0 pass, 1 fail, 77 skip (namespaces or veth not permitted).
set -u
FTID=${1:?usage: link_loss_test.sh FTID FTIDD SRC_DIR}
FTIDD=${2:?}
SRC=${3:?}
SKIP=77

if [ -z "${FTID_LINK_TEST_IN_NS:-}" ]; then
  if [ "$(id -u)" -eq 0 ]; then flags=-n; else flags=-rn; fi
  unshare $flags true 2>/dev/null || { echo "SKIP: cannot create a network namespace"; exit $SKIP; }
  FTID_LINK_TEST_IN_NS=1 exec unshare $flags "$0" "$@"
fi
command -v python3 >/dev/null || { echo "SKIP: python3 not found"; exit $SKIP; }
command -v nsenter >/dev/null || { echo "SKIP: nsenter not found"; exit $SKIP; }

FAILED=0
fail() { echo "FAIL: $*"; FAILED=1; }
WORK=$(mktemp -d /tmp/ftid-link-test.XXXXXX)
PIDS=""
cleanup() {
  for p in $PIDS; do kill -TERM "$p" 2>/dev/null; done
  for p in $PIDS; do wait "$p" 2>/dev/null; done
  if [ $FAILED -eq 0 ]; then rm -rf "$WORK"; else echo "logs kept in $WORK"; fi
}
trap cleanup EXIT

ip link set lo up && ip route add 224.0.0.0/4 dev lo || { echo "SKIP: cannot set up loopback multicast"; exit $SKIP; }

# Namespace B: the robot controller.
unshare -n sh -c "echo \$\$ > '$WORK/robot.pid'; exec sleep 600" &
HOLDER=$!; PIDS="$PIDS $HOLDER"
for _ in $(seq 1 50); do [ -s "$WORK/robot.pid" ] && break; sleep 0.1; done
RPID=$(cat "$WORK/robot.pid")
if ! ip link add vA type veth peer name vB netns "$RPID" 2>"$WORK/veth.err"; then
  echo "SKIP: cannot create a veth pair: $(cat "$WORK/veth.err")"; exit $SKIP
fi
ip addr add 10.77.0.1/24 dev vA && ip link set vA up
nsenter -t "$RPID" -n sh -c 'ip link set lo up; ip addr add 10.77.0.2/24 dev vB; ip link set vB up' ||
  { echo "SKIP: nsenter into the robot namespace failed"; exit $SKIP; }
nsenter -t "$RPID" -n "$FTID" sim-robot --model ur10 --host 10.77.0.2 > "$WORK/robot.log" 2>&1 &
ROBOT=$!; PIDS="$PIDS $ROBOT"

"$FTID" sim-sensor --socket "$WORK/ft.sock" --urdf "$SRC/config/ur10.urdf" \
  --dbc "$SRC/config/ftsensor.dbc" > "$WORK/sensor.log" 2>&1 &
SENSOR=$!; PIDS="$PIDS $SENSOR"

cat > "$WORK/ftidd.yaml" <<YAML
robot:
  host: 10.77.0.2
  rtde_frequency_hz: 125
  urdf_path: $SRC/config/ur10.urdf
  silent_publish_after_ms: 50
  watchdog_silence_s: 1.0
sensor:
  socket_path: $WORK/ft.sock
  dbc_path: $SRC/config/ftsensor.dbc
parameters:
  path: $WORK/none.yaml
lcm:
  url: "udpm://239.255.76.67:7667?ttl=0"
  command_key_path: $WORK/no.key
rt:
  lock_memory: false
YAML

# Listener: systemd notifications and the wrench channel, with monotonic time stamps.
python3 - "$WORK" > "$WORK/events.log" 2>&1 <<'PY' &
import os, select, socket, struct, sys, time
work = sys.argv[1]
n = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
n.bind(work + "/notify.sock")
w = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
w.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
w.bind(("", 7667))
w.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP,
             struct.pack("4s4s", socket.inet_aton("239.255.76.67"), socket.inet_aton("0.0.0.0")))
open(work + "/listener.ready", "w").close()
end = time.monotonic() + 60
while time.monotonic() < end and not os.path.exists(work + "/listener.stop"):
    r, _, _ = select.select([n, w], [], [], 0.2)
    for s in r:
        data = s.recv(65536)
        t = time.monotonic()
        if s is n:
            for line in data.decode(errors="replace").split("\n"):
                if line.startswith("WATCHDOG=1") or line.startswith("READY=1"):
                    print("%.3f notify %s" % (t, line), flush=True)
        elif data[:4] == b"LC02":
            end0 = data.index(b"\0", 8)
            if data[8:end0] != b"FTID_WRENCH":
                continue
            m = data[end0 + 1:]
            # compensated_wrench_t: hash 8, utime 8, cycle 8, robot_time 8, sensor_recv 8,
            # sensor_age 8, raw/modelled/contact 3 x 48, valid 1 (offset 192 after the hash 8).
            cycle = struct.unpack(">q", m[16:24])[0]
            valid = m[8 + 8 + 8 + 8 + 8 + 8 + 144]
            print("%.3f wrench cycle %d valid %d" % (t, cycle, valid), flush=True)
PY
LISTENER=$!; PIDS="$PIDS $LISTENER"
for _ in $(seq 1 50); do [ -e "$WORK/listener.ready" ] && break; sleep 0.1; done

NOTIFY_SOCKET="$WORK/notify.sock" WATCHDOG_USEC=400000 \
  "$FTIDD" --config "$WORK/ftidd.yaml" --connect-timeout 20 > "$WORK/ftidd.log" 2>&1 &
DAEMON=$!; PIDS="$PIDS $DAEMON"
i=0
until grep -q "running at" "$WORK/ftidd.log" 2>/dev/null; do
  sleep 0.2; i=$((i + 1))
  if [ $i -gt 150 ] || ! kill -0 $DAEMON 2>/dev/null; then fail "ftidd did not start"; cat "$WORK/ftidd.log"; exit 1; fi
done
sleep 1.5
T_DOWN=$(python3 -c 'import time; print("%.3f" % time.monotonic())')
nsenter -t "$RPID" -n ip link set vB down   # the controller is gone: no FIN, no RST
echo "link down at $T_DOWN"

i=0
while kill -0 $DAEMON 2>/dev/null && [ $i -lt 75 ]; do sleep 0.2; i=$((i + 1)); done
if kill -0 $DAEMON 2>/dev/null; then
  fail "ftidd still running 15 s after the link went down"
  kill -TERM $DAEMON
fi
wait $DAEMON; RC=$?
touch "$WORK/listener.stop"; wait $LISTENER 2>/dev/null
echo "--- ftidd exit $RC; log:"; cat "$WORK/ftidd.log"

python3 - "$WORK/events.log" "$T_DOWN" <<'PY' || FAILED=1
import sys
events = [l.split() for l in open(sys.argv[1]) if l[:1].isdigit()]
t_down = float(sys.argv[2])
bad = []
before = [e for e in events if float(e[0]) < t_down]
after = [e for e in events if float(e[0]) >= t_down]
cycles_before = [e for e in before if e[1] == "wrench" and int(e[3]) >= 0]
invalid_after = [e for e in after if e[1] == "wrench" and e[5] == "0" and e[3] == "-1"]
cycles_after = [e for e in after if e[1] == "wrench" and (int(e[3]) >= 0 or e[5] == "1") and float(e[0]) > t_down + 0.2]
wd_before = [e for e in before if e[1] == "notify" and e[2] == "WATCHDOG=1"]
wd_after = [float(e[0]) for e in after if e[1] == "notify" and e[2] == "WATCHDOG=1"]
print("cycle wrenches before: %d; watchdog pings before: %d" % (len(cycles_before), len(wd_before)))
if len(cycles_before) < 50: bad.append("too few wrench messages before the link went down")
if len(wd_before) < 3: bad.append("ftidd did not feed the watchdog while the link was up")
if not invalid_after:
    bad.append("no valid=false wrench (cycle -1) after the link went down")
else:
    first = float(invalid_after[0][0]) - t_down
    print("first valid=false %.3f s after the link went down; %d in total" % (first, len(invalid_after)))
    if first > 0.5: bad.append("first valid=false only %.3f s after the link went down" % first)
    if len(invalid_after) < 10: bad.append("valid=false not kept up (%d messages)" % len(invalid_after))
if cycles_after: bad.append("loop cycles or valid wrenches after the link went down")
last_wd = max(wd_after) - t_down if wd_after else 0.0
print("last watchdog ping %.3f s after the link went down" % last_wd)
if last_wd > 1.0 + 0.5: bad.append("watchdog still fed %.3f s after the link went down" % last_wd)
for b in bad: print("FAIL: " + b)
sys.exit(1 if bad else 0)
PY
[ $RC -eq 1 ] || fail "ftidd exit status $RC, expected 1 (robot connection lost)"
grep -q "no robot state package" "$WORK/ftidd.log" || fail "ftidd did not log the silent robot link"
grep -Eq "loop ended.*(keepalive|no answer from the controller)" "$WORK/ftidd.log" ||
  fail "ftidd's exit message does not name the dead controller link"

[ $FAILED -eq 0 ] && echo "PASS" && exit 0
exit 1

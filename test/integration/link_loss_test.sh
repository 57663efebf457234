#!/bin/bash
# Half-open robot link and a restarted sensor, recovered in-process (issue 14, "Links";
# docs/operations.md, "Link loss and reconnect").
#
#   link_loss_test.sh FTID FTIDD SRC_DIR
#
# ftidd and the sensor simulator run in a private network namespace A (unshare -rn; LCM
# multicast on lo); `ftid sim-robot` runs in a second namespace B joined to A by a veth pair
# (10.77.0.1 <-> 10.77.0.2), the "cell network". ftidd has the simulator's true payload
# parameters, so its wrenches are valid and compensated (contact ~ 0 at rest). A NOTIFY_SOCKET
# collects ftidd's systemd notifications (WATCHDOG_USEC=400000: fed every 0.2 s).
#   1. B's end of the link is set down: packets from ftidd vanish, no FIN, no RST (a pulled cable,
#      a controller without power).
#   2. Once TCP keepalive has ended the connection and ftidd has tried to reconnect, the link is
#      set up again.
#   3. The sensor simulator is stopped and started again (its socket closes and reappears).
# Checks, all in one ftidd process (same PID, never restarted):
#   - before: valid compensated wrenches (|contact| small), the watchdog fed;
#   - link down: valid = false (cycle = -1) within 0.5 s of the last cycle and kept up at a steady rate (20 Hz, no
#     gap > 0.3 s) while ftidd reconnects; no valid wrench; the watchdog no longer fed after
#     robot.watchdog_silence_s (1 s here) + 0.5 s; the log names the dead link (keepalive) within
#     10 s and the failed reconnect attempts;
#   - link up: the connection is restored (log), valid compensated wrenches resume within 10 s,
#     cycle numbers continue where they stopped (the same loop), the watchdog is fed again,
#     loop_stats_t counts 1 robot reconnect and the time without a link;
#   - sensor restarted: valid = false while it is gone, then the transport is reopened (log,
#     loop_stats_t.sensor_reconnects >= 1) and valid compensated wrenches resume;
#   - SIGTERM ends ftidd with status 0.
# Exit status: 0 pass, 1 fail, 77 skip (namespaces, veth or lcm-gen not available).
set -u
FTID=${1:?usage: link_loss_test.sh FTID FTIDD SRC_DIR}
FTIDD=${2:?}
SRC=${3:?}
SKIP=77

. "$SRC/test/integration/cell_lib.sh"
cell_reexec_in_netns "" "$@"
for tool in python3 nsenter lcm-gen; do
  command -v $tool >/dev/null || { echo "SKIP: $tool not found"; exit $SKIP; }
done

fail() { echo "FAIL: $*"; FAILED=1; }
cell_begin link-test

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

lcm-gen -p --ppath "$WORK/gen" "$SRC"/lcmtypes/*.lcm >/dev/null || { fail "lcm-gen failed"; exit 1; }

start_sensor() {
  "$FTID" sim-sensor --socket "$WORK/ft.sock" --robot-host 10.77.0.2 --urdf "$SRC/config/ur10.urdf" \
    --dbc "$SRC/config/ftsensor.dbc" >> "$WORK/sensor.log" 2>&1 &
  SENSOR=$!; PIDS="$PIDS $SENSOR"
}
start_sensor

# The simulator's true payload (config/sim_sensor.yaml: the paper's Table 2): the compensated
# contact wrench at rest is then the sensor noise.
python3 "$SRC/test/integration/sim_true_params.py" "$WORK/params.yaml"

write_ftidd_config "$WORK/ftidd.yaml" 10.77.0.2 125 "watchdog_silence_s: 1.0"

# Listener: systemd notifications, the wrench and the stats channels, with monotonic time stamps.
python3 "$SRC/test/integration/ftidd_events.py" "$WORK" > "$WORK/events.log" 2>&1 &
LISTENER=$!; PIDS="$PIDS $LISTENER"
for _ in $(seq 1 50); do [ -e "$WORK/listener.ready" ] && break; sleep 0.1; done

NOTIFY_SOCKET="$WORK/notify.sock" WATCHDOG_USEC=400000 \
  "$FTIDD" --config "$WORK/ftidd.yaml" --connect-timeout 20 > "$WORK/ftidd.log" 2>&1 &
DAEMON=$!; PIDS="$PIDS $DAEMON"
now() { python3 -c 'import time; print("%.3f" % time.monotonic())'; }
# wait_log PATTERN SECONDS: until ftidd's log matches (0) or the time is up / ftidd died (1).
wait_log() {
  local i=0 limit=$(( $2 * 5 ))
  until grep -Eq "$1" "$WORK/ftidd.log" 2>/dev/null; do
    sleep 0.2; i=$((i + 1))
    if [ $i -gt $limit ] || ! kill -0 $DAEMON 2>/dev/null; then return 1; fi
  done
}
wait_log "running at" 30 || { fail "ftidd did not start"; cat "$WORK/ftidd.log"; exit 1; }
sleep 1.5

nsenter -t "$RPID" -n ip link set vB down   # the controller is gone: no FIN, no RST
T_DOWN=$(now)                                # (the link is certainly down from here on)
echo "link down at $T_DOWN"
wait_log "robot link to 10.77.0.2:30004 lost" 15 || fail "ftidd did not declare the link dead within 15 s"
T_LOST=$(now)
wait_log "reconnect attempt 1 failed" 10 || fail "ftidd did not try to reconnect"
sleep 1
T_UP=$(now)
nsenter -t "$RPID" -n ip link set vB up     # the controller is back
echo "link up at $T_UP"
wait_log "robot link to 10.77.0.2:30004 restored" 15 || fail "ftidd did not restore the robot link"
sleep 3
T_SENSOR_STOP=$(now)
kill -TERM $SENSOR; wait $SENSOR 2>/dev/null
T_SENSOR_OFF=$(now)   # the simulator has exited: no frame after this
sleep 1
T_SENSOR_ON=$(now)
start_sensor
wait_log "sensor seqpacket:.* reopened" 10 || fail "ftidd did not reopen the sensor transport"
sleep 3
T_END=$(now)

kill -0 $DAEMON 2>/dev/null || fail "ftidd is not running any more (it must recover in-process)"
kill -TERM $DAEMON
wait $DAEMON; RC=$?
touch "$WORK/listener.stop"; wait $LISTENER 2>/dev/null
echo "--- ftidd exit $RC; log:"; cat "$WORK/ftidd.log"

python3 - "$WORK/events.log" "$T_DOWN" "$T_LOST" "$T_UP" "$T_SENSOR_STOP" "$T_SENSOR_OFF" "$T_SENSOR_ON" "$T_END" <<'PY' || FAILED=1
import sys
events = [l.split() for l in open(sys.argv[1]) if l[:1].isdigit()]
t_down, t_lost, t_up, t_sstop, t_soff, t_son, t_end = (float(x) for x in sys.argv[2:9])
bad = []
def wrenches(a, b):
    return [e for e in events if e[1] == "wrench" and a <= float(e[0]) < b]
def valid(ws):
    return [e for e in ws if e[5] == "1"]
def notifies(a, b):
    return [float(e[0]) for e in events if e[1] == "notify" and e[2] == "WATCHDOG=1" and a <= float(e[0]) < b]
def stats(a, b):
    return [e for e in events if e[1] == "stats" and a <= float(e[0]) < b]

# Before: valid, compensated, cycles counting; the watchdog fed.
before = wrenches(0, t_down)
vb = valid(before)
print("before: %d wrenches, %d valid, %d watchdog pings" % (len(before), len(vb), len(notifies(0, t_down))))
if len(vb) < 50: bad.append("too few valid wrenches before the link went down")
big = [e for e in vb if float(e[7]) > 2.0]
if big: bad.append("contact force up to %s N before the link went down (not compensated?)" % max(e[7] for e in big))
if len(notifies(0, t_down)) < 3: bad.append("ftidd did not feed the watchdog while the link was up")
last_cycle_before = max(int(e[3]) for e in before if int(e[3]) >= 0) if before else -1

# Link down until it is back: valid = false at a steady rate, nothing valid. Times are measured
# from the last loop cycle's message (the last state package that came through).
cycles_to_down = [e for e in wrenches(0, t_down + 1.0) if int(e[3]) >= 0]
t_last = float(cycles_to_down[-1][0]) if cycles_to_down else t_down
down = wrenches(t_last, t_up)
silent = [e for e in down if e[3] == "-1" and e[5] == "0"]
if not silent:
    bad.append("no valid=false wrench (cycle -1) after the link went down")
else:
    first = float(silent[0][0]) - t_last
    times = [float(e[0]) for e in silent]
    gap = max(b - a for a, b in zip(times, times[1:])) if len(times) > 1 else 0.0
    rate = (len(times) - 1) / (times[-1] - times[0]) if len(times) > 1 else 0.0
    print("link down: first valid=false %.3f s after the last cycle; %d messages, %.1f per s, largest gap %.3f s" %
          (first, len(silent), rate, gap))
    if first > 0.5: bad.append("first valid=false only %.3f s after the last cycle" % first)
    if gap > 0.3: bad.append("valid=false not kept up while reconnecting (gap %.3f s)" % gap)
    if not (15.0 <= rate <= 25.0): bad.append("valid=false rate %.1f per s, expected 20" % rate)
if valid([e for e in down if float(e[0]) > t_down + 0.2]):
    bad.append("valid wrenches while the link was down")
print("link declared dead (log) %.1f s after it went down; restored (valid wrenches) see below" % (t_lost - t_down))
wd = notifies(t_last, t_up)
last_wd = max(wd) - t_last if wd else 0.0
print("last watchdog ping %.3f s after the last cycle" % last_wd)
if last_wd > 1.0 + 0.5: bad.append("watchdog still fed %.3f s after the last cycle" % last_wd)

# Link back: the same loop resumes (cycle numbers continue), valid and compensated.
after = wrenches(t_up, t_sstop)
va = [e for e in valid(after) if int(e[3]) >= 0]
if not va:
    bad.append("no valid wrench after the link came back")
else:
    resume = float(va[0][0]) - t_up
    first_cycle = int(va[0][3])
    print("link up: first valid wrench %.3f s after, cycle %d (last before the loss: %d); %d valid" %
          (resume, first_cycle, last_cycle_before, len(va)))
    if resume > 10.0: bad.append("valid wrenches resumed only %.1f s after the link came back" % resume)
    if first_cycle <= last_cycle_before: bad.append("cycle numbers restarted (a new loop, not the same one)")
    if len(va) < 100: bad.append("too few valid wrenches after the link came back (%d)" % len(va))
    big = [e for e in va if float(e[7]) > 2.0]
    if big: bad.append("contact force up to %s N after the reconnect" % max(e[7] for e in big))
if len(notifies(t_up, t_sstop)) < 3: bad.append("the watchdog is not fed again after the reconnect")
st = stats(t_up + 1.0, t_sstop)
if not st:
    bad.append("no loop_stats_t after the reconnect")
else:
    e = st[-1]
    print("stats after the reconnect: " + " ".join(e[2:]))
    if e[3] != "1" or e[5] != "1": bad.append("loop_stats_t: link up %s, reconnects %s (expected 1, 1)" % (e[3], e[5]))
    if float(e[7]) < (t_up - t_lost): bad.append("loop_stats_t: time without a link %s s, expected >= %.1f" % (e[7], t_up - t_lost))

# Sensor restarted: invalid while it is gone, valid again after.
gone = wrenches(t_soff + 0.1, t_son)
if valid(gone): bad.append("valid wrenches while the sensor was stopped")
if not gone: bad.append("no wrenches while the sensor was stopped (the loop must keep running)")
back = [e for e in valid(wrenches(t_son, t_end)) if int(e[3]) >= 0]
print("sensor: %d wrenches while stopped (valid %d), %d valid after the restart" % (len(gone), len(valid(gone)), len(back)))
if len(back) < 50: bad.append("valid wrenches did not resume after the sensor restarted")
st = stats(t_son + 1.0, t_end)
if not st or int(st[-1][9]) < 1: bad.append("loop_stats_t.sensor_reconnects not counted")
for b in bad: print("FAIL: " + b)
sys.exit(1 if bad else 0)
PY
[ $RC -eq 0 ] || fail "ftidd exit status $RC after SIGTERM, expected 0"
[ "$(grep -c "running at" "$WORK/ftidd.log")" = 1 ] || fail "the loop started more than once"
grep -q "no robot state package" "$WORK/ftidd.log" || fail "ftidd did not log the silent robot link"
grep -Eq "lost: .*(keepalive|no answer from the controller)" "$WORK/ftidd.log" ||
  fail "ftidd's message does not name the dead controller link"

[ $FAILED -eq 0 ] && echo "PASS" && exit 0
exit 1

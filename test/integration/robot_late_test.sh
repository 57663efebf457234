#!/bin/bash
# ftidd started before the robot controller (a cell PC that boots first; docs/daemon.md "Running",
# docs/operations.md "Robot not there at start").
#
#   robot_late_test.sh FTID FTIDD SRC_DIR
#
# In a private network namespace (unshare -rn; LCM multicast on lo), with a NOTIFY_SOCKET:
#   1. the sensor simulator and ftidd start, no controller listens on 30004. ftidd must come up
#      anyway: READY=1, valid = false wrenches (cycle -1) at 20 Hz, still running after twice its
#      --connect-timeout, the failed connection attempts in its log, the watchdog fed (a healthy
#      process waiting for its robot);
#   2. `ftid sim-robot` starts: the same ftidd process connects (log), valid compensated wrenches
#      follow (|contact| small), loop_stats_t reports the link up with 0 reconnects;
#   3. a second ftidd asks that CB3 controller (125 Hz at most) for 500 Hz: the controller check
#      refuses every connection. ftidd reports the reason (log and systemd STATUS), keeps retrying
#      with backoff, publishes only valid = false, never sends a program (the simulator's log shows
#      no script connection) and stops with status 0 on SIGTERM.
# Exit status: 0 pass, 1 fail, 77 skip (namespaces or lcm-gen not available).
set -u
FTID=${1:?usage: robot_late_test.sh FTID FTIDD SRC_DIR}
FTIDD=${2:?}
SRC=${3:?}
SKIP=77

. "$SRC/test/integration/cell_lib.sh"
cell_reexec_in_netns "" "$@"
for tool in python3 lcm-gen; do
  command -v $tool >/dev/null || { echo "SKIP: $tool not found"; exit $SKIP; }
done

fail() { echo "FAIL: $*"; FAILED=1; }
cell_begin late-test
lcm-gen -p --ppath "$WORK/gen" "$SRC"/lcmtypes/*.lcm >/dev/null || { fail "lcm-gen failed"; exit 1; }

"$FTID" sim-sensor --socket "$WORK/ft.sock" --robot-host 127.0.0.1 --urdf "$SRC/config/ur10.urdf" \
  --dbc "$SRC/config/ftsensor.dbc" > "$WORK/sensor.log" 2>&1 &
PIDS="$PIDS $!"

# The simulator's true payload (config/sim_sensor.yaml: the paper's Table 2).
python3 "$SRC/test/integration/sim_true_params.py" "$WORK/params.yaml"

write_ftidd_config "$WORK/ftidd.yaml" 127.0.0.1 125
write_ftidd_config "$WORK/ftidd500.yaml" 127.0.0.1 500

# Listener: systemd notifications, the wrench and the stats channels, with monotonic time stamps.
python3 "$SRC/test/integration/ftidd_events.py" "$WORK" > "$WORK/events.log" 2>&1 &
LISTENER=$!; PIDS="$PIDS $LISTENER"
for _ in $(seq 1 50); do [ -e "$WORK/listener.ready" ] && break; sleep 0.1; done
now() { python3 -c 'import time; print("%.3f" % time.monotonic())'; }
# wait_log FILE PID PATTERN SECONDS: until FILE matches (0) or the time is up / PID died (1).
wait_log() {
  local i=0 limit=$(( $4 * 5 ))
  until grep -Eq "$3" "$1" 2>/dev/null; do
    sleep 0.2; i=$((i + 1))
    if [ $i -gt $limit ] || ! kill -0 "$2" 2>/dev/null; then return 1; fi
  done
}

# 1. ftidd first, no controller.
T_START=$(now)
NOTIFY_SOCKET="$WORK/notify.sock" WATCHDOG_USEC=400000 \
  "$FTIDD" --config "$WORK/ftidd.yaml" --connect-timeout 2 > "$WORK/ftidd.log" 2>&1 &
DAEMON=$!; PIDS="$PIDS $DAEMON"
wait_log "$WORK/ftidd.log" $DAEMON "robot connection attempt 1 failed" 15 ||
  fail "ftidd did not report a failed robot connection attempt"
sleep 4   # twice --connect-timeout: the old ftidd would have exited with status 1 by now
kill -0 $DAEMON 2>/dev/null || { fail "ftidd exited without a robot"; cat "$WORK/ftidd.log"; exit 1; }
T_ROBOT=$(now)

# 2. The controller appears.
"$FTID" sim-robot --model ur10 --host 127.0.0.1 --verbose > "$WORK/robot.log" 2>&1 &
ROBOT=$!; PIDS="$PIDS $ROBOT"
wait_log "$WORK/ftidd.log" $DAEMON "robot link to 127.0.0.1:30004 up" 20 || fail "ftidd did not connect to the late robot"
wait_log "$WORK/ftidd.log" $DAEMON "running at" 10 || fail "ftidd's loop did not start"
sleep 3
T_END1=$(now)
kill -0 $DAEMON 2>/dev/null || fail "ftidd is not running any more (it must connect in-process)"
kill -TERM $DAEMON; wait $DAEMON; RC1=$?
[ $RC1 -eq 0 ] || fail "ftidd exit status $RC1 after SIGTERM, expected 0"
T_SECOND=$(now)
ROBOT_LINES=$(wc -l < "$WORK/robot.log")

# 3. A controller that refuses the check (CB3: at most 125 Hz; asked for 500 Hz).
NOTIFY_SOCKET="$WORK/notify.sock" \
  "$FTIDD" --config "$WORK/ftidd500.yaml" --connect-timeout 2 > "$WORK/ftidd500.log" 2>&1 &
DAEMON2=$!; PIDS="$PIDS $DAEMON2"
wait_log "$WORK/ftidd500.log" $DAEMON2 "robot connection attempt 1 failed: .*at most 125 Hz" 15 ||
  fail "ftidd did not report the refused controller check"
sleep 5
kill -0 $DAEMON2 2>/dev/null || fail "ftidd stopped instead of retrying the refused controller"
kill -TERM $DAEMON2; wait $DAEMON2; RC2=$?
[ $RC2 -eq 0 ] || fail "ftidd (refused controller) exit status $RC2 after SIGTERM, expected 0"
T_END2=$(now)
touch "$WORK/listener.stop"; wait $LISTENER 2>/dev/null
echo "--- ftidd (late robot) log:"; cat "$WORK/ftidd.log"
echo "--- ftidd (refused controller) log:"; cat "$WORK/ftidd500.log"

grep -q "running at" "$WORK/ftidd500.log" && fail "the refused controller's ftidd ran cycles"
# Never moves the arm: no script or dashboard traffic at the simulator (only RTDE connections),
# and the refused controller was asked again and again (the backoff: 0.2, 0.4, 0.8, 1, 1 s ...).
MOVES=$(grep -v "listening on" "$WORK/robot.log" | grep -Ei "script|program|dashboard")
[ -z "$MOVES" ] || fail "ftidd talked to the script or dashboard server: $MOVES"
N_RETRIES=$(tail -n +$((ROBOT_LINES + 1)) "$WORK/robot.log" | grep -c "RTDE client .* connected")
echo "refused controller: $N_RETRIES RTDE connection attempts in 5 s"
[ "$N_RETRIES" -ge 4 ] || fail "ftidd did not keep retrying the refused controller ($N_RETRIES attempts)"
N_ATTEMPTS=$(grep -c "connected: robot" "$WORK/ftidd500.log")
[ "$N_ATTEMPTS" -eq 0 ] || fail "the refused controller was reported connected"

python3 - "$WORK/events.log" "$T_START" "$T_ROBOT" "$T_END1" "$T_SECOND" "$T_END2" <<'PY' || FAILED=1
import sys
events = [l.split() for l in open(sys.argv[1]) if l[:1].isdigit()]
t_start, t_robot, t_end1, t_second, t_end2 = (float(x) for x in sys.argv[2:7])
bad = []
def between(kind, a, b):
    return [e for e in events if e[1] == kind and a <= float(e[0]) < b]
ready = [float(e[0]) for e in between("notify", t_start, t_robot) if e[2] == "READY=1"]
print("READY=1 %s s after start (no robot)" % ("%.2f" % (ready[0] - t_start) if ready else "never"))
if not ready: bad.append("no READY=1 while waiting for the robot")
wd = [e for e in between("notify", t_start, t_robot) if e[2] == "WATCHDOG=1"]
if len(wd) < 5: bad.append("the watchdog was not fed while waiting for the robot (%d)" % len(wd))
st = [e for e in between("notify", t_start, t_robot) if e[2].startswith("STATUS=cycles")]
if not st or "DOWN" not in st[-1][2]: bad.append("systemd STATUS does not say the robot link is down")
else: print("STATUS while waiting: " + st[-1][2].replace("_", " "))
w = between("wrench", t_start + 1.0, t_robot)
invalid = [e for e in w if e[3] == "-1" and e[5] == "0"]
rate = (len(invalid) - 1) / (float(invalid[-1][0]) - float(invalid[0][0])) if len(invalid) > 1 else 0.0
print("waiting: %d wrench messages, %d valid=false (cycle -1), %.1f per s" % (len(w), len(invalid), rate))
if len(invalid) < 40 or not (15.0 <= rate <= 25.0): bad.append("valid=false not published at 20 Hz while waiting")
if any(e[5] == "1" for e in w): bad.append("valid wrenches without a robot")
after = [e for e in between("wrench", t_robot, t_end1) if e[5] == "1" and int(e[3]) >= 0]
print("robot up: %d valid wrenches, first %.2f s after the simulator started" %
      (len(after), float(after[0][0]) - t_robot if after else -1))
if len(after) < 200: bad.append("too few valid wrenches after the robot appeared (%d)" % len(after))
big = [e for e in after if float(e[7]) > 2.0]
if big: bad.append("contact force up to %s N (not compensated?)" % max(e[7] for e in big))
s = between("stats", t_robot + 2.0, t_end1)
if not s or s[-1][3] != "1" or s[-1][5] != "0":
    bad.append("loop_stats_t after the late connection: %s (expected up 1, reconnects 0)" % (s[-1][2:] if s else "none"))
w2 = between("wrench", t_second + 1.0, t_end2)
print("refused controller: %d wrench messages, %d valid" % (len(w2), sum(e[5] == "1" for e in w2)))
if len(w2) < 40: bad.append("no valid=false stream while the controller refuses the check")
if any(e[5] == "1" for e in w2): bad.append("valid wrenches from a refused controller")
st2 = [e for e in between("notify", t_second, t_end2) if e[2].startswith("STATUS=cycles")]
if not st2 or "125_Hz" not in st2[-1][2]: bad.append("systemd STATUS does not name the refused check")
for b in bad: print("FAIL: " + b)
sys.exit(1 if bad else 0)
PY
N2=$(grep -c "attempt" "$WORK/ftidd500.log")
[ "$N2" -eq 1 ] || fail "$N2 log lines for one repeated reason (expected one per distinct reason)"

[ $FAILED -eq 0 ] && echo "PASS" && exit 0
exit 1

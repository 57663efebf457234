#!/bin/bash
# The payload monitor online (issue 25): an object grasped while the arm moves is flagged by
# ftidd's monitor, and `ftid reidentify --apply` restores the compensation from ftidd's own ring
# buffer of the running cell.
#
#   payload_change_test.sh FTID FTIDD SRC_DIR
#
# In a private network namespace (LCM multicast on lo): `ftid sim-robot` (UR10, 125 Hz), `ftid
# sim-sensor --effect noise --effect grasp` (the paper payload; a 0.6 kg object at (0, 0, 0.12) m
# held from SIGRTMIN+2 on), ftidd with the simulator's true `paper` parameters, a command key and
# the monitor's defaults, and `ftid run-trajectory` moving the shipped 10 s excitation.
# Checks:
#   - before the grasp (about 3 s of motion) the monitor reports no payload change;
#   - after SIGRTMIN+2 at about 3 s into the motion, ftidd logs `payload monitor: payload_change`
#     within 1.5 s (the issue's offline figure is 0.6 s; the rest is the log's and this script's
#     polling), with delta_mass within 10 % of 0.6 kg;
#   - about 4.5 s after the grasp, still moving, `ftid reidentify --apply` is answered (exit 0) and
#     the parameter file ftidd rewrote holds the paper mass plus 0.6 kg within 10 % of the 0.6 kg;
#   - the motion completes (exit 0) and ftidd is still running;
#   - ftidd's own recording of the run (`ftidd --record`, `ftid lcm-to-csv`) replayed offline by
#     `ftid monitor` with the parameters the cell ran with decides the same: its first payload change
#     has the live delta_mass within 0.001 kg and the same decision delay after the onset (the
#     monitor code is one; this checks the cell feeds it what the recording holds).
# Exit status: 0 pass, 1 fail, 77 skip.
set -u
FTID=${1:?usage: payload_change_test.sh FTID FTIDD SRC_DIR}
FTIDD=${2:?}
SRC=${3:?}
SKIP=77

# A host stall (a virtual machine's, a loaded desktop's) can make a servo target reach the
# simulated controller late or not at all: the arm then jerks (its 40 rad/s^2 clamp for a tick) and
# the sensor simulator, which learns the arm's motion over RTDE a tick later, cannot follow it, so
# the window holds wrenches no physics made. An attempt whose failures are all of the monitor's and
# the re-identification's checks (fail_moving) and whose recording shows such a jerk is said and the
# whole scenario runs again, at most three times; any other failure, one without a jerk, or one on
# the third attempt fails (docs/testing.md, "Host stalls in integration_payload_change").
. "$SRC/test/integration/cell_lib.sh"
cell_run_attempts "the simulated arm jerked (a host stall)" "$@"
cell_reexec_in_netns "" "$@"
command -v python3 >/dev/null || { echo "SKIP: python3 not found"; exit $SKIP; }

fail() { echo "FAIL: $*"; FAILED=1; OTHER_FAILED=1; }
# The checks a jerk of the simulated arm can spoil (the monitor's and the re-identification's, on
# the wrenches of the moving cell); a failure of any other check is never run again.
OTHER_FAILED=0
fail_moving() { echo "FAIL: $*"; FAILED=1; }
cell_begin payload-change

head -c 32 /dev/urandom | od -An -tx1 | tr -d ' \n' > "$WORK/command.key"
chmod 0600 "$WORK/command.key"
PARAMS=$WORK/params.yaml
python3 "$SRC/test/integration/sim_true_params.py" "$PARAMS"
cp "$PARAMS" "$WORK/params_v1.yaml"
MASS0=$(python3 -c 'print(8.862 / 9.80665)')
cat > "$WORK/ftidd.yaml" <<YAML
robot:
  urdf_path: $SRC/config/ur10.urdf
sensor:
  socket_path: $WORK/ft.sock
  dbc_path: $SRC/config/ftsensor.dbc
parameters:
  path: $PARAMS
lcm:
  url: "udpm://239.255.76.67:7667?ttl=0"
  command_key_path: $WORK/command.key
rt:
  lock_memory: false
YAML

# The simulators stand for a controller and a sensor with their own clocks: SCHED_FIFO where
# permitted (as in cell_identify_test.sh and scripts/soak.sh), so the host's load is not physics.
RT=""
chrt -f 70 true 2>/dev/null && RT="chrt -f 70"
$RT "$FTID" sim-robot --model ur10 > "$WORK/robot.log" 2>&1 &
PIDS="$PIDS $!"
$RT "$FTID" sim-sensor --socket "$WORK/ft.sock" --urdf "$SRC/config/ur10.urdf" --dbc "$SRC/config/ftsensor.dbc" \
  --effect noise --effect grasp:mass=0.6,com=0/0/0.12,side=0.06 > "$WORK/sensor.log" 2>&1 &
SENSOR=$!; PIDS="$PIDS $SENSOR"
"$FTIDD" --config "$WORK/ftidd.yaml" --connect-timeout 30 --record "$WORK/cell.lcm" > "$WORK/ftidd.log" 2>&1 &
DAEMON=$!; PIDS="$PIDS $DAEMON"
i=0
until grep -q "running at" "$WORK/ftidd.log" 2>/dev/null; do
  sleep 0.2; i=$((i + 1))
  if [ $i -gt 150 ] || ! kill -0 $DAEMON 2>/dev/null; then fail "ftidd did not start"; cat "$WORK/ftidd.log"; exit 1; fi
done
sleep 1  # the monitor's noise floor settles at rest

"$FTID" run-trajectory "$SRC/config/excitation_ur10_paper.yaml" --out "$WORK/run.csv" --yes \
  > "$WORK/run.out" 2>&1 < /dev/null &
MOTION=$!; PIDS="$PIDS $MOTION"
# In motion: run-trajectory's progress line says "excite" from the first streamed target on.
i=0
until grep -q "excite" "$WORK/run.out" 2>/dev/null; do
  sleep 0.1; i=$((i + 1))
  if [ $i -gt 300 ] || ! kill -0 $MOTION 2>/dev/null; then fail "the excitation did not start"; cat "$WORK/run.out"; exit 1; fi
done
sleep 3
grep "payload monitor: payload_change" "$WORK/ftidd.log" && fail_moving "a payload change was reported before the grasp"
kill -s RTMIN+2 $SENSOR
T_GRASP=$(date +%s.%N)
echo "grasped at $T_GRASP"
i=0
until grep -q "payload monitor: payload_change" "$WORK/ftidd.log"; do
  sleep 0.05; i=$((i + 1))
  [ $i -gt 30 ] && break
done
T_SEEN=$(date +%s.%N)
line=$(grep -m1 "payload monitor: payload_change" "$WORK/ftidd.log")
if [ -z "$line" ]; then
  fail_moving "no payload change reported within 1.5 s of the grasp"
  grep "payload monitor" "$WORK/ftidd.log"
else
  echo "$line (seen $(python3 -c "print('%.2f' % ($T_SEEN - $T_GRASP))") s after the grasp)"
  dm=$(echo "$line" | sed -E 's/.*delta_mass ([-+0-9.]+).*/\1/')
  python3 -c "import sys; sys.exit(0 if abs($dm - 0.6) <= 0.06 else 1)" ||
    fail_moving "the monitor's delta_mass $dm kg is not within 10 % of the grasped 0.6 kg"
fi

sleep 4.5  # the re-identification window (monitor.reidentify_window_s, 4 s) after the grasp, moving
"$FTID" reidentify --apply --config "$WORK/ftidd.yaml" > "$WORK/reid.out" 2> "$WORK/reid.err"; rc=$?
echo "ftid reidentify --apply: exit $rc: $(cat "$WORK/reid.out" "$WORK/reid.err" | tr '\n' ' ')"
if [ $rc -ne 0 ]; then
  fail_moving "ftid reidentify --apply exited $rc"
else
  mass=$(sed -nE 's/^ *mass: *\{value: *([-+0-9.eE]+).*/\1/p' "$PARAMS")
  echo "parameter file mass: $mass kg (was $MASS0 kg)"
  python3 -c "import sys; sys.exit(0 if abs($mass - $MASS0 - 0.6) <= 0.06 else 1)" ||
    fail_moving "re-identified mass $mass kg is not the paper mass $MASS0 kg plus 0.6 kg within 10 %"
  [ -e "$PARAMS.bak" ] || fail "the previous parameter file was not kept as params.yaml.bak"
fi

wait $MOTION; rc=$?
[ $rc -eq 0 ] || { fail "run-trajectory exited $rc"; tail -5 "$WORK/run.out"; }
kill -0 $DAEMON 2>/dev/null || fail "ftidd is no longer running"

# The offline replay of ftidd's recording with the parameters the cell ran with (version 1).
kill -TERM $DAEMON; wait $DAEMON
"$FTID" lcm-to-csv "$WORK/cell.lcm" --out "$WORK/cell.csv" > "$WORK/lcm2csv.out" 2>&1 ||
  { fail "ftid lcm-to-csv failed: $(tail -2 "$WORK/lcm2csv.out")"; }
"$FTID" monitor --log "$WORK/cell.csv" --params "$WORK/params_v1.yaml" --config "$WORK/ftidd.yaml" \
  > "$WORK/replay.txt" 2> "$WORK/replay.err" || fail "ftid monitor failed: $(tail -2 "$WORK/replay.err")"
replay=$(grep -m1 "payload_change" "$WORK/replay.txt")
echo "replay: $replay"
if [ -n "$line" ] && [ -n "$replay" ]; then
  python3 - "$line" "$replay" <<'PY' || fail "the offline replay does not decide as the cell did"
import re, sys
def parse(s):
    t = float(re.search(r"t=([-0-9.]+)", s).group(1))
    onset = float(re.search(r"onset ([-0-9.]+)", s).group(1))
    dm = float(re.search(r"delta_mass ([-+0-9.]+)", s).group(1))
    return t - onset, dm
(live_delay, live_dm), (replay_delay, replay_dm) = parse(sys.argv[1]), parse(sys.argv[2])
print("decision delay after onset: live %.3f s, replay %.3f s; delta_mass live %+.3f, replay %+.3f kg"
      % (live_delay, replay_delay, live_dm, replay_dm))
sys.exit(0 if abs(live_delay - replay_delay) <= 0.0105 and abs(live_dm - replay_dm) <= 0.001 else 1)
PY
elif [ -z "$line" ]; then
  fail_moving "no live payload change to compare the offline replay with"
else
  fail "no payload change in the offline replay of the cell's recording"
fi
[ "$FAILED" -eq 0 ] && echo "PASS" || { echo "--- ftidd.log"; tail -20 "$WORK/ftidd.log"; }
# The simulated arm jerked when it reached its acceleration clamp (40 rad/s^2) on some tick: the
# shipped excitation plans at most 4 rad/s^2, so a tick above 20 rad/s^2 in the runner's recording
# is a target that reached the controller late (a host stall held the previous one) or not at all.
jerks=$(python3 - "$WORK/run.csv" <<'PY' 2>/dev/null
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
print(sum(1 for r in rows if max(abs(float(r["qdd%d" % j])) for j in range(1, 7)) > 20.0))
PY
)
jerks=${jerks:-0}
# A controller stall ftidd saw (no state package for 50 ms: the simulator's host stopped it) spoils
# the same checks: the monitor's decision waits for valid cycles.
grep -q "no robot state package for" "$WORK/ftidd.log" && jerks=$((jerks + 1))
if [ "$FAILED" -ne 0 ] && [ "$OTHER_FAILED" -eq 0 ] && [ "$jerks" -gt 0 ] && [ "$FTID_CELL_ATTEMPT" -lt 3 ]; then
  echo "this attempt's arm jerked at its acceleration clamp on $jerks tick(s) (a servo target late or lost): $(grep -m1 '^loop:' "$WORK/run.out")"
  exit 3
fi
exit "$FAILED"

#!/bin/bash
# End-to-end `ftid --identify` against the simulators (issue 7, "Reliability (tests)").
#
#   cell_identify_test.sh FTID FTIDD SRC_DIR CASE
#
# CASE = normal | protective_stop | sensor_silent | ftidd_killed | disk_full | below_floor | poisoned
#        | sigstop | contact
#
# Each case runs `ftid sim-robot` (UR10, 125 Hz), `ftid sim-sensor` (the paper payload) and ftidd
# in a private network namespace (unshare -rn: loopback only, LCM multicast routed on lo), then
# `ftid --identify --yes` with the shipped 10 s excitation trajectory.
#   normal           exit 0; the identified payload (model paper+rigid_body, the simulator's
#                    physics) matches the simulator's truth (weight, centre of mass, force/torque
#                    offsets, base tilt); parameters written, the previous file kept
#                    byte-identical as .bak, UR + ros2 exports written, ftidd acknowledged and
#                    applied the reload.
#   protective_stop  the robot simulator goes into a protective stop during the motion
#                    (dashboard `sim protective_stop`);
#   sensor_silent    the sensor simulator stops sending during the motion (SIGUSR2, repeated);
#   ftidd_killed     ftidd is killed with SIGKILL during the motion;
#   disk_full        the parameter file lives on a tiny tmpfs (private mount namespace) that is
#                    full when the parameters are written; the runs directory is elsewhere.
#   below_floor      (issue 14) the trajectory's q0 is edited so that the tool passes ~0.26 m
#                    below the floor: refused before any motion, whatever --yes says, naming the
#                    sample and the constraint; the robot program never runs.
#   poisoned         (issue 14) a second publisher on this host republishes every FTID_CYCLE
#                    message 1 ms later (robot time + 1 ms) with fz + 5 N: the run is refused
#                    ("does not match the controller"), the parameters stay byte-identical.
#   sigstop          (issue 14) `ftid --identify` itself is stopped (SIGSTOP) for 0.5 s during
#                    the motion: the message must blame ftid, not ftidd.
#   contact          someone pushes the tool during the motion (the sensor simulator's contact
#                    push on request, SIGRTMIN+1: 8 N down at 12 cm for 2 s, sin^2): the
#                    laboratory finds a change that ends, and the run is refused (a run of two
#                    set-ups describes neither), the parameters unchanged.
# Every fault case must end with exit status 1, a one-line message naming the cause, the arm
# stopped (dashboard programState STOPPED and RTDE actual_qd ~ 0), the previous parameter file
# byte-identical, and the recorded data saved (run.csv with samples).
# Exit status: 0 pass, 1 fail, 77 skip (namespaces or mounts not permitted).
set -u
FTID=${1:?usage: cell_identify_test.sh FTID FTIDD SRC_DIR CASE}
FTIDD=${2:?}
SRC=${3:?}
CASE=${4:?}
SKIP=77

case "$CASE" in normal|protective_stop|sensor_silent|ftidd_killed|disk_full|below_floor|poisoned|sigstop|contact) ;;
  *) echo "unknown case '$CASE'"; exit 2 ;; esac

# A host stall long enough that the motion runner loses three state packages in a row (this VM has
# shown 100 ms with nothing else running) aborts the run, rightly, before the case's own fault: an
# attempt that fails with that abort is said and the case runs again, at most three times in all
# (no case here expects it; a deterministic failure still fails on the third attempt). Not sigstop,
# whose fault is exactly a stall of ftid itself reported as lost packages.
. "$SRC/test/integration/cell_lib.sh"
cell_run_attempts "[$CASE] the host stalled the motion (lost state packages)" "$@"

# ---- re-enter in the private namespaces
cell_reexec_in_netns "$([ "$CASE" = disk_full ] && echo m)" "$@"

fail() { echo "FAIL [$CASE]: $*"; FAILED=1; }
cell_extra_cleanup() { [ "$CASE" = disk_full ] && umount "$WORK/pdir" 2>/dev/null; }
cell_begin cell-test

PDIR=$WORK/pdir
mkdir -p "$PDIR" "$WORK/runs"
if [ "$CASE" = disk_full ]; then
  if ! mount -t tmpfs -o size=64k tmpfs "$PDIR" 2>"$WORK/mount.err"; then
    echo "SKIP: cannot mount a tmpfs in a private mount namespace: $(cat "$WORK/mount.err")"; exit $SKIP
  fi
fi
PARAMS=$PDIR/parameters.yaml

# The previous parameters: a valid file for a DIFFERENT tool (1.5 kg), so a reload is visible.
cat > "$PARAMS" <<'YAML'
# previous tool (cell_identify_test.sh)
model: "paper"
parameters:
  f0_x: {value: 0.1, std: 0, unit: ""}
  f0_y: {value: 0.2, std: 0, unit: ""}
  f0_z: {value: 0.3, std: 0, unit: ""}
  t0_x: {value: 0.01, std: 0, unit: ""}
  t0_y: {value: 0.02, std: 0, unit: ""}
  t0_z: {value: 0.03, std: 0, unit: ""}
  mass: {value: 1.5, std: 0, unit: ""}
  mass_com_x: {value: 0.0, std: 0, unit: ""}
  mass_com_y: {value: 0.0, std: 0, unit: ""}
  mass_com_z: {value: 0.15, std: 0, unit: ""}
tilt:
  estimated: false
  u: {value: 0, std: 0, unit: "rad"}
  v: {value: 0, std: 0, unit: "rad"}
YAML
cp "$PARAMS" "$WORK/previous.yaml"

# The shared command key (the Debian package creates /etc/ftid/command.key the same way).
head -c 32 /dev/urandom | od -An -tx1 | tr -d ' \n' > "$WORK/command.key"
chmod 0600 "$WORK/command.key"

cat > "$WORK/ftidd.yaml" <<YAML
robot:
  rtde_frequency_hz: 125
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
# The paper's 10 s trajectory: long enough to inject each fault during the motion.
cp "$SRC/config/excitation_ur10_paper.yaml" "$WORK/traj.yaml"
if [ "$CASE" = below_floor ]; then  # shoulder edited: `ftid check-trajectory` flags the floor
  sed -i 's/^q0: \[0.0, -1.5707963267948966,/q0: [0.0, -0.6,/' "$WORK/traj.yaml"
  grep -q '^q0: \[0.0, -0.6,' "$WORK/traj.yaml" || { echo "FAIL: could not edit q0"; exit 1; }
fi
[ -f "$SRC/config/excitation_ur10_paper.csv" ] && cp "$SRC/config/excitation_ur10_paper.csv" "$WORK/traj.csv"

if [ "$CASE" = disk_full ]; then  # fill the tmpfs: the previous file stays, nothing new fits
  dd if=/dev/zero of="$PDIR/filler" bs=1k count=1024 2>/dev/null
  df -k "$PDIR" | tail -1
fi

# The simulators stand for real-time devices (a UR controller, a CAN sensor): as root they run
# SCHED_FIFO so that a loaded test host does not make them late (which the motion runner rightly
# treats as lost packages and aborts).
RT=""
chrt -f 70 true 2>/dev/null && RT="chrt -f 70"
$RT "$FTID" sim-robot --model ur10 --verbose > "$WORK/robot.log" 2>&1 &
ROBOT=$!; PIDS="$PIDS $ROBOT"
# The contact case adds the sensor's typical noise: without any, the residual of a fit across the
# push is all push, which the noise estimate can read as strongly coloured noise (docs/analyze.md).
SENSOR_NOISE=""
[ "$CASE" = contact ] && SENSOR_NOISE="--effect noise"
$RT "$FTID" sim-sensor --socket "$WORK/ft.sock" --urdf "$SRC/config/ur10.urdf" \
  --dbc "$SRC/config/ftsensor.dbc" $SENSOR_NOISE > "$WORK/sensor.log" 2>&1 &
SENSOR=$!; PIDS="$PIDS $SENSOR"
"$FTIDD" --config "$WORK/ftidd.yaml" --connect-timeout 30 > "$WORK/ftidd.log" 2>&1 &
DAEMON=$!; PIDS="$PIDS $DAEMON"

i=0
until grep -q "running at" "$WORK/ftidd.log" 2>/dev/null; do
  sleep 0.2; i=$((i + 1))
  if [ $i -gt 200 ] || ! kill -0 $DAEMON 2>/dev/null; then
    fail "ftidd did not start"; cat "$WORK/ftidd.log"; exit 1
  fi
done

dashboard() {  # one dashboard command -> the answer line (the greeting is skipped)
  exec 3<>/dev/tcp/127.0.0.1/29999 || return 1
  local greeting answer
  read -r -t 2 greeting <&3
  printf '%s\n' "$1" >&3
  read -r -t 2 answer <&3
  exec 3<&- 3>&-
  printf '%s\n' "${answer%$'\r'}"
}

# RTDE: max |actual_qd| over a few packets (protocol v2; python3 stdlib only).
max_joint_speed() {
  python3 - <<'PY'
import socket, struct, sys
s = socket.create_connection(("127.0.0.1", 30004), timeout=3)
def send(t, payload=b""):
    s.sendall(struct.pack(">HB", 3 + len(payload), t) + payload)
def recv():
    hdr = b""
    while len(hdr) < 3: hdr += s.recv(3 - len(hdr))
    n, t = struct.unpack(">HB", hdr)
    body = b""
    while len(body) < n - 3: body += s.recv(n - 3 - len(body))
    return t, body
send(ord("V"), struct.pack(">H", 2))
while recv()[0] != ord("V"): pass
send(ord("O"), struct.pack(">d", 125.0) + b"actual_qd")
while True:
    t, b = recv()
    if t == ord("O"): break
if b[1:].decode() != "VECTOR6D": sys.exit("unexpected recipe " + b[1:].decode())
send(ord("S"))
m = 0.0; n = 0
while n < 20:
    t, b = recv()
    if t == ord("U"):
        m = max(m, max(abs(v) for v in struct.unpack(">6d", b[1:49]))); n += 1
print("%.6f" % m)
PY
}

if [ "$CASE" = poisoned ]; then
  # The attacker: republishes each FTID_CYCLE 1 ms later, robot time + 1 ms, fz + 5 N (its own
  # datagrams are marked in LCM's sequence number and not republished again).
  python3 - > "$WORK/poison.log" 2>&1 <<'PY' &
import socket, struct, time
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
s.bind(("", 7667))
s.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP,
             struct.pack("4s4s", socket.inet_aton("239.255.76.67"), socket.inet_aton("0.0.0.0")))
s.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
n = 0
while True:
    pkt = s.recv(65536)
    if pkt[:4] != b"LC02" or struct.unpack(">I", pkt[4:8])[0] >= 0xFFF00000:
        continue
    e = pkt.index(b"\0", 8)
    if pkt[8:e] != b"FTID_CYCLE":
        continue
    m = bytearray(pkt[e + 1:])
    # cycle_sample_t after the 8-byte hash: utime, cycle, robot_state_t (recv_utime, robot_time at
    # 32, q, qd, qdd, valid), sensor_sample_t (recv_utime, counter, wrench at 197: fz at 213).
    rt = struct.unpack(">d", m[32:40])[0]
    fz = struct.unpack(">d", m[213:221])[0]
    m[32:40] = struct.pack(">d", rt + 0.001)
    m[213:221] = struct.pack(">d", fz + 5.0)
    time.sleep(0.001)
    n += 1
    s.sendto(b"LC02" + struct.pack(">I", 0xFFF00000 + (n & 0xFFFFF)) + pkt[8:e + 1] + bytes(m),
             ("239.255.76.67", 7667))
    if n % 500 == 0:
        print("republished", n, flush=True)
PY
  PIDS="$PIDS $!"
fi

# ---- run ftid --identify, injecting the fault during the motion
# The sensor simulator's physics is the full rigid body: the normal case identifies the matching
# model (the paper model alone is biased by the unmodelled rotational terms, which the analysis
# reports); the fault cases skip the analysis to stay short.
extra="--model paper+rigid_body"
[ "$CASE" != normal ] && [ "$CASE" != contact ] && extra="--no-analyze"
# RTDE clients of the robot so far: ftidd and the sensor simulator (it reads the robot's motion;
# it retries every second, so wait until both are there).
i=0
until [ "$(grep -c "RTDE client [0-9]* connected" "$WORK/robot.log")" -ge 2 ] || [ $i -gt 50 ]; do
  sleep 0.2; i=$((i + 1))
done
clients_before=$(grep -c "RTDE client [0-9]* connected" "$WORK/robot.log")
"$FTID" --identify --config "$WORK/ftidd.yaml" --trajectory "$WORK/traj.yaml" --params "$PARAMS" \
  --runs-dir "$WORK/runs" --yes $extra > "$WORK/identify.out" 2> "$WORK/identify.err" < /dev/null &
ID=$!

if [ "$CASE" != normal ] && [ "$CASE" != disk_full ] && [ "$CASE" != below_floor ] && [ "$CASE" != poisoned ]; then
  # Wait until the robot runs ftid's program (motion started), then 2 s more.
  i=0
  until dashboard programState | grep -q PLAYING; do
    sleep 0.1; i=$((i + 1))
    if [ $i -gt 300 ] || ! kill -0 $ID 2>/dev/null; then fail "the motion never started"; break; fi
  done
  sleep 2
  case "$CASE" in
    protective_stop) echo "inject: $(dashboard 'sim protective_stop')" ;;
    sensor_silent) echo "inject: sensor silent"
      for _ in $(seq 1 40); do kill -USR2 $SENSOR 2>/dev/null; sleep 0.05; done & ;;
    ftidd_killed) echo "inject: kill -KILL ftidd"; kill -KILL $DAEMON ;;
    sigstop) echo "inject: SIGSTOP ftid --identify for 0.5 s"; kill -STOP $ID; sleep 0.5; kill -CONT $ID ;;
    contact) echo "inject: a push on the tool"; kill -s RTMIN+1 $SENSOR ;;
  esac
fi

i=0
while kill -0 $ID 2>/dev/null; do
  sleep 0.2; i=$((i + 1))
  if [ $i -gt 600 ]; then fail "ftid --identify did not finish within 120 s"; kill -INT $ID; sleep 2; kill -KILL $ID; break; fi
done
wait $ID; RC=$?
clients_after=$(grep -c "RTDE client [0-9]* connected" "$WORK/robot.log")
echo "--- ftid --identify exit $RC; stdout:"; cat "$WORK/identify.out"
echo "--- stderr (progress lines dropped):"; grep -v '^\[' "$WORK/identify.err"
MSG=$(grep '^ftid --identify:' "$WORK/identify.err" | tail -1)

run_csv=$(ls "$WORK"/runs/*/run.csv 2>/dev/null | head -1)
rows=0
[ -n "$run_csv" ] && rows=$(grep -cv '^#' "$run_csv")

if [ "$CASE" = normal ]; then
  [ $RC -eq 0 ] || fail "exit status $RC, expected 0"
  [ -n "$run_csv" ] && [ "$rows" -gt 500 ] || fail "run.csv missing or short ($rows lines)"
  cmp -s "$WORK/previous.yaml" "$PARAMS.bak" || fail "$PARAMS.bak is not the previous file"
  cmp -s "$WORK/previous.yaml" "$PARAMS" && fail "the parameter file was not replaced"
  [ -s "$PARAMS.urscript" ] && grep -q set_target_payload "$PARAMS.urscript" || fail "UR export missing"
  [ -s "$PARAMS.ros2.yaml" ] && grep -q mass "$PARAMS.ros2.yaml" || fail "ros2 export missing"
  grep -q "ftidd reloaded the new parameters" "$WORK/identify.out" || fail "no reload acknowledged"
  grep -q "parameters reloaded from $PARAMS" "$WORK/ftidd.log" || fail "ftidd did not log the reload"
  # Identified payload vs. the simulator's truth (paper Table 2: G = 8.862 N, c = (0.5, 0.2, 5.1)
  # cm, F0, T0, tilt U/V), compared in the physical quantities.
  val() { sed -n "s/^  $1: {value: \([^,]*\),.*/\1/p" "$PARAMS" | head -1; }
  awk -v m="$(val mass)" -v mx="$(val mass_com_x)" -v my="$(val mass_com_y)" -v mz="$(val mass_com_z)" \
      -v fx="$(val f0_x)" -v fy="$(val f0_y)" -v fz="$(val f0_z)" \
      -v tx="$(val t0_x)" -v ty="$(val t0_y)" -v tz="$(val t0_z)" -v u="$(val u)" -v v="$(val v)" '
    function chk(name, got, want, tol) {
      d = got - want; if (d < 0) d = -d
      printf "  %-8s identified %10.5f  truth %10.5f  |diff| %.5f (tol %.5f)%s\n", name, got, want, d, tol, d <= tol ? "" : "  <- FAIL"
      if (!(d <= tol)) bad = 1
    }
    BEGIN {
      if (m == "" || m + 0 <= 0) { print "  no mass in the parameter file"; exit 1 }
      g = 9.80665; pi = 3.141592653589793
      chk("weight_N", m * g, 8.862, 0.045)         # 0.5 %
      chk("com_x_m", mx / m, 0.005, 0.001)
      chk("com_y_m", my / m, 0.002, 0.001)
      chk("com_z_m", mz / m, 0.051, 0.001)
      chk("f0_x_N", fx, -0.6672, 0.02); chk("f0_y_N", fy, 0.8565, 0.02); chk("f0_z_N", fz, 0.3538, 0.02)
      chk("t0_x_Nm", tx, 0.0228, 0.002); chk("t0_y_Nm", ty, 0.0084, 0.002); chk("t0_z_Nm", tz, 0.0080, 0.002)
      if (u != "") chk("tilt_u_deg", u * 180 / pi, -9.8716, 0.1)
      if (v != "") chk("tilt_v_deg", v * 180 / pi, -5.3709, 0.1)
      exit bad
    }' || fail "identified payload differs from the simulator's truth"
else
  [ $RC -eq 1 ] || fail "exit status $RC, expected 1"
  case "$CASE" in
    protective_stop) want="protective|safety|stopped" ;;
    sensor_silent) want="sensor" ;;
    ftidd_killed) want="ftidd" ;;
    disk_full) want="parameter file.*(space|write)" ;;
    below_floor) want="refused before any motion.*trajectory sample [0-9]+ \(t = [0-9.]+ s\): tool\[0\] above floor.*below the floor" ;;
    # (identification refused; or, if the loaded host aborted the motion first, named as well)
    poisoned) want="FTID_CYCLE stream does not match the controller.*(conflicting|off the controller)" ;;
    sigstop) want="ftid --identify itself was stopped or stalled for [0-9]+ ms.*ftidd was not at fault" ;;
    contact) want="identification refused: the run holds more than one set-up \(the (payload|offsets) changed at .*changed at .*without touching the tool" ;;
  esac
  echo "$MSG" | grep -Eqi "$want" || fail "message does not name the cause (/$want/): $MSG"
  cmp -s "$WORK/previous.yaml" "$PARAMS" || fail "the previous parameter file was changed"
  if [ "$CASE" = below_floor ]; then
    # sim-robot --verbose logs every RTDE client: ftid --identify must not have opened a robot
    # session at all (it refused before).
    [ "$clients_after" -eq "$clients_before" ] ||
      fail "ftid --identify connected to the robot ($clients_before RTDE clients before, $clients_after after)"
    echo "$MSG" | grep -q "nothing moved" || fail "the message does not say that nothing moved"
  else
    [ -n "$run_csv" ] && [ "$rows" -gt 50 ] || fail "recorded data not saved (run.csv: '${run_csv}', $rows lines)"
    echo "$MSG" | grep -q "run.csv" || fail "the message does not say where the data is"
  fi
  ls "$PDIR"/parameters.yaml.tmp.* >/dev/null 2>&1 && fail "a temporary parameter file was left behind"
  if [ "$CASE" = ftidd_killed ]; then
    grep -q "parameters reloaded" "$WORK/ftidd.log" && fail "ftidd reloaded"
  fi
fi

# A protective stop the test did not inject (a servo step the controller refused) is a failure.
if grep -q "protective stop: servoj step" "$WORK/robot.log"; then
  fail "the robot simulator refused a servo step: $(grep -m1 'protective stop: servoj step' "$WORK/robot.log")"
fi

# ---- the arm is stopped (every case: after a normal run too)
state=$(dashboard programState)
echo "robot: programState '$state', $(dashboard safetymode)"
echo "$state" | grep -q '^STOPPED' || fail "robot program not stopped: '$state'"
if command -v python3 >/dev/null; then
  qd=$(max_joint_speed) || qd=""
  echo "robot: max |actual_qd| over 20 packets: ${qd:-?} rad/s"
  awk -v q="${qd:-1}" 'BEGIN { exit !(q < 1e-3) }' || fail "joints still moving (max |qd| = ${qd:-?})"
else
  echo "robot: python3 not found, joint speeds not checked"
fi

[ $FAILED -eq 0 ] && echo "PASS [$CASE]" && exit 0
# (Not for sigstop: there "lost state packages" instead of blaming ftid itself is the fault tested.)
if [ "$CASE" != sigstop ] && echo "${MSG:-}" | grep -q "identification run aborted: lost state packages" &&
   [ "$FTID_CELL_ATTEMPT" -lt 3 ]; then
  exit 3
fi
exit 1

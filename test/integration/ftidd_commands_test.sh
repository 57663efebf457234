#!/bin/bash
# ftidd's command channel under attack (issue 14, "The command and data channels").
#
#   ftidd_commands_test.sh FTID FTIDD SRC_DIR
#
# Namespace A (unshare -rn; LCM multicast on lo): `ftid sim-robot`, `ftid sim-sensor`, ftidd with a
# command key. Namespace B, joined to A by a veth pair (10.77.0.2 -> 10.77.0.1), is "another host
# on the cell network". Commands are built with lcm-gen's Python classes and signed with Python's
# own hmac/hashlib (an implementation independent of ftid's), sent as raw LCM datagrams.
# Checks:
#   - a correctly signed PING and RELOAD are accepted (Python's HMAC = ftid's);
#   - the 69-byte command_t with string length 0 (issue 26) leaves ftidd running, is logged and
#     counted as malformed; `ftid tare` amid a flood of malformed ack_t still gets its ack;
#   - a signed TARE (robot at rest) is acknowledged with the new offsets, saves
#     parameters.yaml.tare.yaml with the parameter file's SHA-256, and RELOAD removes it;
#   - `ftid reidentify --apply` with the robot at rest is refused (no motion), nothing written
#   - `ftid tare` (the command-line sender): prints the offsets of the ack, the same as in the
#     saved tare state (--json parsed by Python); with a wrong key, with the sensor stopped (no
#     valid wrench in the window) it exits 3 with ftidd's reason and nothing changes; an unreadable
#     key exits 1 naming the file; no ftidd on the channel exits 4 naming it; loop_stats_t counts
#     tares done and refused;
#   - unsigned, wrong-key, replayed, stale commands and a signed RELOAD naming a file
#     (parameters.yaml.bak) are refused with the reason, not executed, and counted in loop_stats_t;
#   - a correctly signed RELOAD sent by unicast from namespace B gets no answer and reloads nothing
#     (the source filter drops it in the kernel);
#   - with the parameter file replaced by a FIFO, SIGHUP is refused at once ("not a regular
#     file") and SIGTERM still stops ftidd with status 0.
# Exit status: 0 pass, 1 fail, 77 skip.
set -u
FTID=${1:?usage: ftidd_commands_test.sh FTID FTIDD SRC_DIR}
FTIDD=${2:?}
SRC=${3:?}
SKIP=77

. "$SRC/test/integration/cell_lib.sh"
cell_reexec_in_netns "" "$@"
for tool in python3 nsenter lcm-gen; do
  command -v $tool >/dev/null || { echo "SKIP: $tool not found"; exit $SKIP; }
done

fail() { echo "FAIL: $*"; FAILED=1; }
cell_begin cmd-test
unshare -n sh -c "echo \$\$ > '$WORK/remote.pid'; exec sleep 600" &
HOLDER=$!; PIDS="$PIDS $HOLDER"
for _ in $(seq 1 50); do [ -s "$WORK/remote.pid" ] && break; sleep 0.1; done
RPID=$(cat "$WORK/remote.pid")
ip link add vA type veth peer name vB netns "$RPID" 2>/dev/null || { echo "SKIP: cannot create a veth pair"; exit $SKIP; }
ip addr add 10.77.0.1/24 dev vA && ip link set vA up
nsenter -t "$RPID" -n sh -c 'ip link set lo up; ip addr add 10.77.0.2/24 dev vB; ip link set vB up' ||
  { echo "SKIP: nsenter failed"; exit $SKIP; }

lcm-gen -p --ppath "$WORK/gen" "$SRC"/lcmtypes/*.lcm || { fail "lcm-gen failed"; exit 1; }
head -c 32 /dev/urandom | od -An -tx1 | tr -d ' \n' > "$WORK/command.key"
chmod 0600 "$WORK/command.key"

PARAMS=$WORK/parameters.yaml
cat > "$PARAMS" <<'YAML'
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
sed 's/mass: {value: 1.5/mass: {value: 9.5/' "$PARAMS" > "$PARAMS.bak"   # "the previous tool"

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
  stats_period_s: 0.2
  command_key_path: $WORK/command.key
rt:
  lock_memory: false
YAML

"$FTID" sim-robot --model ur10 > "$WORK/robot.log" 2>&1 &
PIDS="$PIDS $!"
"$FTID" sim-sensor --socket "$WORK/ft.sock" --urdf "$SRC/config/ur10.urdf" \
  --dbc "$SRC/config/ftsensor.dbc" > "$WORK/sensor.log" 2>&1 &
SENSOR=$!; PIDS="$PIDS $SENSOR"
"$FTIDD" --config "$WORK/ftidd.yaml" --connect-timeout 30 > "$WORK/ftidd.log" 2>&1 &
DAEMON=$!; PIDS="$PIDS $DAEMON"
i=0
until grep -q "running at" "$WORK/ftidd.log" 2>/dev/null; do
  sleep 0.2; i=$((i + 1))
  if [ $i -gt 150 ] || ! kill -0 $DAEMON 2>/dev/null; then fail "ftidd did not start"; cat "$WORK/ftidd.log"; exit 1; fi
done

cat > "$WORK/cmd.py" <<'PY'
# Usage: cmd.py WORK MODE [DEST]  -> prints one line per answer: "ack ok|refused MESSAGE" or "noack"
import hashlib, hmac, json, os, select, socket, struct, sys, time
work, mode = sys.argv[1], sys.argv[2]
dest = sys.argv[3] if len(sys.argv) > 3 else "239.255.76.67"
sys.path.insert(0, work + "/gen")
from ftid_lcm.command_t import command_t
from ftid_lcm.ack_t import ack_t
from ftid_lcm.loop_stats_t import loop_stats_t

key = bytes.fromhex(open(work + "/command.key").read().split()[0])

def now_us():
    return int(time.time() * 1e6)

def sign(c, k):
    arg = c.argument.encode()
    msg = b"ftid-command-v1" + struct.pack(">qqBqI", c.utime, c.request_id, c.command & 0xFF, c.sequence, len(arg)) + arg
    c.mac = hmac.new(k, msg, hashlib.sha256).digest()

def packet(channel, payload, seq=1):
    return b"LC02" + struct.pack(">I", seq) + channel + b"\0" + payload

rx = None
if dest.startswith("239."):
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    rx.bind(("", 7667))
    rx.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP,
                  struct.pack("4s4s", socket.inet_aton("239.255.76.67"), socket.inet_aton("0.0.0.0")))
tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
tx.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)

def receive(channel, timeout):
    if rx is None:
        time.sleep(timeout)
        return None
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        r, _, _ = select.select([rx], [], [], 0.05)
        if not r:
            continue
        data = rx.recv(65536)
        if data[:4] != b"LC02":
            continue
        e = data.index(b"\0", 8)
        if data[8:e] == channel:
            return data[e + 1:]
    return None

if mode == "stats":
    data = receive(b"FTID_STATS", 2.0)
    s = loop_stats_t.decode(data)
    print("stats auth %d stale %d replay %d malformed %d applied %d tares_done %d tares_refused %d version %d" % (
        s.commands_refused_auth, s.commands_refused_stale, s.commands_refused_replay,
        s.commands_refused_malformed, s.reloads_applied, s.tares_done, s.tares_refused, s.param_version))
    sys.exit(0)

if mode == "malformed":
    # Issue 26: the 69-byte command_t whose argument length field is 0 (lcm-gen's decoder threw
    # std::length_error and ftidd aborted), by multicast and by unicast to 127.0.0.1.
    bad = command_t._get_packed_fingerprint() + struct.pack(">qqbiq", now_us(), 42, command_t.PING, 0, 7) + bytes(32)
    assert len(bad) == 69, len(bad)
    if rx is not None:
        rx.close()  # a unicast datagram goes to one socket bound to the port: ftidd's, not ours
    tx.sendto(packet(b"FTID_COMMAND", bad, 11), (dest, 7667))
    tx.sendto(packet(b"FTID_COMMAND", bad, 12), ("127.0.0.1", 7667))
    print("sent 2")
    sys.exit(0)

if mode == "ackflood":
    # The same defect as an ack_t (82 bytes, message length 0), every 10 ms for SECONDS.
    bad = ack_t._get_packed_fingerprint() + struct.pack(">qqbbii", now_us(), 42, command_t.TARE, 1, 99, 0) + bytes(48)
    assert len(bad) == 82, len(bad)
    end = time.monotonic() + float(sys.argv[3])
    n = 0
    while time.monotonic() < end:
        n += 1
        tx.sendto(packet(b"FTID_ACK", bad, 100 + n), ("239.255.76.67", 7667))
        time.sleep(0.01)
    sys.exit(0)

if mode == "taretwice":
    # A client that missed the ack sends the same request again, signed afresh (new sequence):
    # ftidd must answer it again, not tare twice.
    c = command_t()
    c.utime = now_us()
    c.request_id = int.from_bytes(os.urandom(6), "big")
    c.command = command_t.TARE
    c.argument = ""
    answers = []
    for attempt in range(2):
        c.sequence = now_us()
        sign(c, key)
        tx.sendto(packet(b"FTID_COMMAND", c.encode(), 3 + attempt), (dest, 7667))
        deadline = time.monotonic() + 3.0
        while time.monotonic() < deadline:
            a = receive(b"FTID_ACK", deadline - time.monotonic())
            if a is None:
                break
            ack = ack_t.decode(a)
            if ack.request_id == c.request_id:
                answers.append(ack)
                break
    same = len(answers) == 2 and answers[0].message == answers[1].message and \
        list(answers[0].offsets) == list(answers[1].offsets) and answers[0].ok == answers[1].ok
    print("taretwice %d answers, %s, %s" % (len(answers), "same" if same else "different",
                                            "ok" if answers and answers[0].ok else "refused"))
    sys.exit(0)

c = command_t()
c.utime = now_us()
c.request_id = int.from_bytes(os.urandom(6), "big")
c.command = {"ping": command_t.PING, "tare": command_t.TARE}.get(mode, command_t.RELOAD_PARAMETERS)
c.argument = "parameters.yaml.bak" if mode == "path" else ""
c.sequence = now_us() - (60_000_000 if mode == "stale" else 0)
c.mac = bytes(32)
if mode in ("ping", "tare", "reload", "path", "stale", "replay", "remote"):
    sign(c, key)
elif mode == "wrongkey":
    sign(c, os.urandom(32))
# mode "unsigned": MAC left zero
data = c.encode()
if mode == "replay":
    # Send the same signed datagram twice: the first is accepted, the second must be refused.
    tx.sendto(packet(b"FTID_COMMAND", data), (dest, 7667))
    a = receive(b"FTID_ACK", 2.0)
    first = ack_t.decode(a) if a else None
    print("first ack %s" % ("ok" if first and first.ok else "missing/refused"))
for attempt in range(1):
    tx.sendto(packet(b"FTID_COMMAND", data, 2), (dest, 7667))
deadline = time.monotonic() + 2.0
while time.monotonic() < deadline:
    a = receive(b"FTID_ACK", deadline - time.monotonic())
    if a is None:
        break
    ack = ack_t.decode(a)
    if ack.request_id != c.request_id:
        continue
    print("ack %s %s" % ("ok" if ack.ok else "refused", ack.message))
    sys.exit(0)
print("noack")
PY

send() { python3 "$WORK/cmd.py" "$WORK" "$@" 2>&1; }
expect() {  # expect MODE REGEX [DEST]
  local mode=$1 want=$2 dest=${3:-}
  local out
  out=$(send "$mode" $dest)
  echo "$mode: $out"
  echo "$out" | grep -Eq "$want" || fail "$mode: expected /$want/, got: $out"
}

expect ping "^ack ok"
# Issue 26: one malformed 69-byte command_t (multicast and unicast) must not end ftidd: dropped,
# counted as malformed in loop_stats_t, and the next command still answered.
malformed_before=$(send stats | awk '{ print $9 }')
send malformed
sleep 0.5
kill -0 $DAEMON 2>/dev/null || { fail "ftidd died on a malformed 69-byte command_t"; cat "$WORK/ftidd.log"; exit 1; }
expect ping "^ack ok"
grep -q "malformed command_t dropped" "$WORK/ftidd.log" || fail "the malformed command_t was not logged"
malformed_after=$(send stats | awk '{ print $9 }')
[ "${malformed_after:-0}" -ge $((${malformed_before:-0} + 2)) ] 2>/dev/null ||
  fail "malformed command_t not counted: commands_refused_malformed $malformed_before -> $malformed_after"
expect unsigned "^ack refused .*bad authenticator"
expect wrongkey "^ack refused .*bad authenticator"
expect path "^ack refused .*takes no path"
expect stale "^ack refused .*stale"
out=$(send replay)
echo "replay: $out"
echo "$out" | grep -q "first ack ok" || fail "replay: the first (genuine) datagram was not accepted: $out"
echo "$out" | grep -Eq "^ack refused .*replayed" || fail "replay: the repeated datagram was not refused: $out"
# TARE with the simulated robot at rest: acknowledged with the new offsets, saved next to the
# parameter file; the RELOAD below discards it.
expect tare "^ack ok tared over [0-9]+ cycles: f0 = \(.*\) N, t0 = \(.*\) Nm"
[ -f "$PARAMS.tare.yaml" ] || fail "TARE did not save $PARAMS.tare.yaml"
grep -q "parameter_sha256: $(sha256sum "$PARAMS" | cut -d' ' -f1)" "$PARAMS.tare.yaml" 2>/dev/null ||
  fail "the tare state does not record the parameter file's SHA-256"
reloads_before=$(grep -c "parameters reloaded" "$WORK/ftidd.log")
# From "another host": a correctly signed RELOAD by unicast. The kernel filter drops it.
out=$(nsenter -t "$RPID" -n python3 "$WORK/cmd.py" "$WORK" remote 10.77.0.1 2>&1)
echo "remote: $out"
sleep 0.5
[ "$(grep -c "parameters reloaded" "$WORK/ftidd.log")" = "$reloads_before" ] || fail "a datagram from another host was executed"
[ "$out" = "noack" ] || fail "a datagram from another host was answered: $out"
expect reload "^ack ok"
[ -e "$PARAMS.tare.yaml" ] && fail "RELOAD did not discard the tare state"
grep -q "reloaded from .*\.bak" "$WORK/ftidd.log" && fail "ftidd loaded the .bak file"
stats=$(send stats)
echo "$stats"
echo "$stats" | awk '{ exit !($3 >= 2 && $5 >= 1 && $7 >= 1 && $9 >= 1 && $11 == 2 && $13 == 1 && $15 == 0) }' ||
  fail "refused commands not counted as expected (auth>=2 stale>=1 replay>=1 malformed>=1, 2 reloads applied: the replayed one and the last, 1 tare done, none refused): $stats"

# ---- `ftid tare`, the command-line sender (after the RELOAD above: no tare state now).
# On a loaded host a window may hold a stale sensor sample: ftidd then rightly refuses ("a cycle
# without a valid compensated wrench"); tare_ok tries up to 3 times. The counters are checked
# against the outcomes ftid tare reported (exit 0 = done, 3 = refused).
DONE=1; REFUSED=0   # the signed TARE sent by Python above
tare_ok() {  # tare_ok OUT [ARGS...]: ftid tare until it exits 0 (3 tries); returns its last status
  local out=$1 rc=0 try; shift
  for try in 1 2 3; do
    "$FTID" tare --config "$WORK/ftidd.yaml" "$@" > "$out" 2> "$WORK/tare.err"; rc=$?
    echo "ftid tare $*: exit $rc: $(cat "$WORK/tare.err")"
    case $rc in 0) DONE=$((DONE + 1)); return 0 ;; 3) REFUSED=$((REFUSED + 1)) ;; esac
    grep -q "without a valid compensated wrench" "$WORK/tare.err" || return $rc
  done
  return $rc
}
# While ftid tare waits, a flood of malformed ack_t (message length 0) on FTID_ACK (issue 26):
# dropped by its ack waiter, the real ack still counts.
python3 "$WORK/cmd.py" "$WORK" ackflood 4 & FLOOD=$!
sleep 0.5   # the flood is running before ftid tare starts waiting
tare_ok "$WORK/tare.out"; rc=$?
kill $FLOOD 2>/dev/null; wait $FLOOD 2>/dev/null
grep -q "malformed message(s) on FTID_ACK dropped" "$WORK/tare.err" ||
  fail "ftid tare did not report the malformed acks it dropped: $(cat "$WORK/tare.err")"
cat "$WORK/tare.out"
[ $rc -eq 0 ] || fail "ftid tare exited $rc, expected 0"
grep -Eq "^tared: f0 = \(.*\) N, t0 = \(.*\) Nm" "$WORK/tare.out" || fail "ftid tare printed no offsets"
[ -f "$PARAMS.tare.yaml" ] || fail "ftid tare: no $PARAMS.tare.yaml saved"
tare_ok "$WORK/tare.json" --json; rc=$?
[ $rc -eq 0 ] || fail "ftid tare --json exited $rc"
cp "$PARAMS.tare.yaml" "$WORK/tare_state_ok.yaml" 2>/dev/null
sleep 0.5
version_tared=$(send stats | awk '{ print $17 }')
# The offsets of the ack are those ftidd saved (full precision in both) and those it now applies.
python3 - "$WORK/tare.json" "$PARAMS.tare.yaml" <<'PY' || fail "ftid tare --json does not match the saved tare state"
import json, sys
ack = json.load(open(sys.argv[1]))
assert ack["ok"] is True, ack
state = {}
for line in open(sys.argv[2]):
    k, _, v = line.split("#")[0].strip().partition(":")
    if k in ("f0_x", "f0_y", "f0_z", "t0_x", "t0_y", "t0_z"):
        state[k] = float(v)
assert len(state) == 6, state
for k, v in state.items():
    assert ack["offsets"][k] == v, (k, ack["offsets"][k], v)
# Taring at rest against the identified model moves the offsets off the file's (0.1, 0.2, 0.3)
# towards what the sensor reads with this (wrong) payload model: they must have changed.
assert abs(ack["offsets"]["f0_z"] - 0.3) > 1e-3, ack
print("json ok:", ack["offsets"])
PY
# A wrong key: refused by ftidd (exit 3, its reason), counted, and the offsets unchanged.
head -c 32 /dev/urandom | od -An -tx1 | tr -d ' \n' > "$WORK/wrong.key"; chmod 0600 "$WORK/wrong.key"
"$FTID" tare --config "$WORK/ftidd.yaml" --key "$WORK/wrong.key" > "$WORK/tare.out" 2> "$WORK/tare.err"; rc=$?
echo "ftid tare (wrong key): exit $rc: $(cat "$WORK/tare.err")"
[ $rc -eq 3 ] && REFUSED=$((REFUSED + 1)) || fail "ftid tare with a wrong key exited $rc, expected 3"
grep -q "refused the tare: .*bad authenticator" "$WORK/tare.err" || fail "ftid tare with a wrong key did not print ftidd's reason"
cmp -s "$PARAMS.tare.yaml" "$WORK/tare_state_ok.yaml" || fail "a refused tare changed the tare state"
# The sensor stopped: no valid wrench in the window -> refused with ftidd's reason.
kill -STOP "$SENSOR"
sleep 0.3
"$FTID" tare --config "$WORK/ftidd.yaml" > "$WORK/tare.out" 2> "$WORK/tare.err"; rc=$?
kill -CONT "$SENSOR"
echo "ftid tare (sensor stopped): exit $rc: $(cat "$WORK/tare.err")"
[ $rc -eq 3 ] && REFUSED=$((REFUSED + 1)) || fail "ftid tare with the sensor stopped exited $rc, expected 3"
grep -q "refused the tare: tare refused: a cycle without a valid compensated wrench" "$WORK/tare.err" ||
  fail "ftid tare with the sensor stopped did not print ftidd's reason"
cmp -s "$PARAMS.tare.yaml" "$WORK/tare_state_ok.yaml" || fail "a refused tare changed the tare state"
# An unreadable key: nothing sent, exit 1, the file named.
"$FTID" tare --config "$WORK/ftidd.yaml" --key "$WORK/no-such.key" > /dev/null 2> "$WORK/tare.err"; rc=$?
echo "ftid tare (no key): exit $rc: $(cat "$WORK/tare.err")"
[ $rc -eq 1 ] || fail "ftid tare with a missing key exited $rc, expected 1"
grep -q "no-such.key" "$WORK/tare.err" || fail "ftid tare with a missing key did not name the file"
# Nobody on the command channel: exit 4 within the timeout, the channels named.
sed 's/^  stats_period_s: 0.2$/  stats_period_s: 0.2\n  channels: {command: NOBODY_COMMAND, ack: NOBODY_ACK}/' \
  "$WORK/ftidd.yaml" > "$WORK/nobody.yaml"
"$FTID" tare --config "$WORK/nobody.yaml" --timeout 0.5 > /dev/null 2> "$WORK/tare.err"; rc=$?
echo "ftid tare (nobody): exit $rc: $(cat "$WORK/tare.err")"
[ $rc -eq 4 ] || fail "ftid tare without ftidd exited $rc, expected 4"
grep -q "no answer from ftidd on NOBODY_ACK .*TARE sent on NOBODY_COMMAND" "$WORK/tare.err" ||
  fail "ftid tare without ftidd did not name the channels"
sleep 0.5
stats=$(send stats)
echo "$stats"
echo "$stats" | awk -v d=$DONE -v r=$REFUSED '{ exit !($13 == d && $15 == r) }' ||
  fail "tares not counted ($DONE done, $REFUSED refused as ftid tare saw them, the wrong key and the stopped sensor among them): $stats"
echo "$stats" | awk -v v="$version_tared" '{ exit !($17 == v) }' ||
  fail "a refused tare changed ftidd's parameters (version $version_tared after the last tare): $stats"
# The same TARE request sent twice (a client that missed the ack resends it, signed afresh): one
# tare, the same answer twice.
# (Refused on a loaded host for a stale sample: then refused once, counted once, nothing changes.)
out=$(send taretwice)
echo "taretwice: $out"
echo "$out" | grep -Eq "^taretwice 2 answers, same" || fail "a resent TARE request was not answered the same: $out"
if echo "$out" | grep -q ", ok$"; then DONE=$((DONE + 1)); version_tared=$((version_tared + 1)); else REFUSED=$((REFUSED + 1)); fi
sleep 0.5
stats=$(send stats)
echo "$stats"
echo "$stats" | awk -v d=$DONE -v r=$REFUSED -v v="$version_tared" '{ exit !($13 == d && $15 == r && $17 == v) }' ||
  fail "a resent TARE request was executed twice (expected $DONE done, $REFUSED refused, version $version_tared): $stats"

# ---- `ftid reidentify` (signed REIDENTIFY) with the robot at rest: refused with the reason (no
# motion in the monitor's buffer), the parameter file untouched.
sum_before=$(sha256sum "$PARAMS" | cut -d' ' -f1)
"$FTID" reidentify --apply --config "$WORK/ftidd.yaml" > "$WORK/reid.out" 2> "$WORK/reid.err"; rc=$?
echo "ftid reidentify --apply: exit $rc: $(cat "$WORK/reid.err")"
[ $rc -eq 3 ] || fail "ftid reidentify at rest exited $rc, expected 3 (refused)"
grep -q "no motion" "$WORK/reid.err" || fail "ftid reidentify at rest: the refusal does not name the missing motion"
[ "$(sha256sum "$PARAMS" | cut -d' ' -f1)" = "$sum_before" ] || fail "a refused REIDENTIFY changed the parameter file"

# The parameter file becomes a FIFO: SIGHUP must not wedge ftidd, SIGTERM must still work.
mv "$PARAMS" "$WORK/saved.yaml" && mkfifo "$PARAMS"
kill -HUP $DAEMON
sleep 0.5
grep -q "not a regular file" "$WORK/ftidd.log" || fail "SIGHUP with a FIFO as parameter file was not refused"
kill -TERM $DAEMON
i=0
while kill -0 $DAEMON 2>/dev/null && [ $i -lt 25 ]; do sleep 0.2; i=$((i + 1)); done
if kill -0 $DAEMON 2>/dev/null; then
  fail "ftidd ignored SIGTERM after a reload of a FIFO"
  kill -KILL $DAEMON
fi
wait $DAEMON; RC=$?
[ $RC -eq 0 ] || fail "ftidd exit status $RC after SIGTERM, expected 0"
echo "--- ftidd log:"; cat "$WORK/ftidd.log"

[ $FAILED -eq 0 ] && echo "PASS" && exit 0
exit 1

#!/bin/sh
# Soak run of ftidd against the simulators (docs/performance.md, section "Soak").
#
#   scripts/soak.sh [DURATION] [BUILD_DIR]
#
#   DURATION   30 (minutes, the default), 45m, 600s or 2h
#   BUILD_DIR  build directory holding apps/ftid/ftid and apps/ftidd/ftidd (default: build).
#              FTID=... FTIDD=... in the environment override the two binaries.
#   SOAK_OUT   directory for the logs and samples (default: a new directory under /tmp; kept).
#   SOAK_RELOAD_S  seconds between parameter reloads (default 60)
#   SOAK_SAMPLE_S  seconds between RSS samples (default 10)
#
# Starts `ftid sim-robot` (UR10, 125 Hz), `ftid sim-sensor` (paper payload, 1000 Hz) and ftidd in
# a private network namespace (unshare -rn; the LCM multicast never leaves it). Every
# SOAK_RELOAD_S seconds it rewrites the parameter file (alternating between two valid payloads,
# so every reload really changes the model) and sends SIGHUP (what `systemctl reload ftidd`
# does). Every SOAK_SAMPLE_S seconds it samples ftidd's VmRSS from /proc and ftidd's loop
# counters: ftidd logs the same counters it publishes in FTID_STATS (cycles, valid, stale,
# missed, params version) every 10 s on stderr, and one line per reload applied or rejected.
#
# Output: samples.csv (elapsed_s, rss_kB, cycles, missed, stale, params_version, reloads_sent),
# the three processes' logs, and a summary. Exit status: 0 if every reload was applied, none
# failed, RSS after warm-up grew by less than SOAK_RSS_SLACK_KB (default 1024 kB) and missed
# cycles stayed within SOAK_MISSED_PPM (default 1000 ppm = 0.1 % of cycles, the bound for a
# non-real-time loaded host; docs/performance.md); 1 otherwise; 77 if namespaces are unavailable.
set -eu

usage() { sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'; exit 2; }
case "${1:-}" in -h|--help) usage ;; esac

DUR_ARG=${1:-30}
case "$DUR_ARG" in
  *s) DURATION_S=${DUR_ARG%s} ;;
  *m) DURATION_S=$(( ${DUR_ARG%m} * 60 )) ;;
  *h) DURATION_S=$(( ${DUR_ARG%h} * 3600 )) ;;
  *)  DURATION_S=$(( DUR_ARG * 60 )) ;;
esac
case "$DURATION_S" in ''|*[!0-9]*) echo "soak.sh: bad duration '$DUR_ARG' (e.g. 30, 45m, 600s)" >&2; exit 2 ;; esac

SRC=$(cd "$(dirname "$0")/.." && pwd)
BUILD=${2:-$SRC/build}
FTID=${FTID:-$BUILD/apps/ftid/ftid}
FTIDD=${FTIDD:-$BUILD/apps/ftidd/ftidd}
RELOAD_S=${SOAK_RELOAD_S:-60}
SAMPLE_S=${SOAK_SAMPLE_S:-10}
RSS_SLACK_KB=${SOAK_RSS_SLACK_KB:-1024}
MISSED_PPM=${SOAK_MISSED_PPM:-1000}
for b in "$FTID" "$FTIDD"; do
  [ -x "$b" ] || { echo "soak.sh: $b not found (build ftid and ftidd, or set FTID/FTIDD)" >&2; exit 2; }
done
OUT=${SOAK_OUT:-$(mktemp -d /tmp/ftid-soak.XXXXXX)}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)

# As root: a plain network namespace (ftidd keeps CAP_SYS_NICE/CAP_IPC_LOCK, so it runs SCHED_FIFO
# with locked memory as in the systemd service, and the simulators run SCHED_FIFO 70 like the
# real-time devices they stand for). Otherwise a user namespace, where nothing is real-time.
if [ "$(id -u)" -eq 0 ]; then NSFLAGS=-n; else NSFLAGS=-rn; fi
if ! unshare $NSFLAGS true 2>/dev/null; then
  echo "soak.sh: SKIP: cannot create a private network namespace (unshare $NSFLAGS)" >&2
  exit 77
fi
RT=""
[ "$NSFLAGS" = -n ] && chrt -f 70 true 2>/dev/null && RT="chrt -f 70"

# Two valid payload parameter files (the simulator's paper payload, and the same with slightly
# different offsets); the soak alternates between them so that each reload changes the model.
write_params() {  # $1 = file, $2 = f0_x
  cat > "$1.tmp" <<YAML
# ftid payload parameters (soak.sh): the paper's Table 2 payload (sim-sensor's default).
model: "paper"
parameters:
  f0_x: {value: $2, std: 0, unit: ""}
  f0_y: {value: 0.8565, std: 0, unit: ""}
  f0_z: {value: 0.3538, std: 0, unit: ""}
  t0_x: {value: 0.0228, std: 0, unit: ""}
  t0_y: {value: 0.0084, std: 0, unit: ""}
  t0_z: {value: 0.0080, std: 0, unit: ""}
  mass: {value: 0.90367250794104004, std: 0, unit: ""}
  mass_com_x: {value: 0.0045183625397052004, std: 0, unit: ""}
  mass_com_y: {value: 0.0018073450158820801, std: 0, unit: ""}
  mass_com_z: {value: 0.046087297904993038, std: 0, unit: ""}
tilt:
  estimated: true
  u: {value: -0.17229192243987226, std: 0, unit: "rad"}
  v: {value: -0.093739888795363435, std: 0, unit: "rad"}
YAML
  mv "$1.tmp" "$1"
}
write_params "$OUT/parameters.yaml" -0.6672

cat > "$OUT/ftidd.yaml" <<YAML
# ftidd configuration of the soak run (scripts/soak.sh)
robot:
  rtde_frequency_hz: 125
  urdf_path: $SRC/config/ur10.urdf
sensor:
  socket_path: $OUT/ft.sock
  dbc_path: $SRC/config/ftsensor.dbc
parameters:
  path: $OUT/parameters.yaml
  required: true
lcm:
  url: "udpm://239.255.76.67:7667?ttl=0"
  stats_period_s: 1.0
YAML

MACHINE="$(nproc) CPUs, $(uname -r), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "soak: ${DURATION_S} s, reload every ${RELOAD_S} s, output in $OUT"
echo "soak: machine: $MACHINE"
echo "$MACHINE" > "$OUT/machine.txt"

# Everything below runs inside the private network namespace.
export FTID FTIDD OUT SRC DURATION_S RELOAD_S SAMPLE_S RT
echo "soak: namespace unshare $NSFLAGS, simulators ${RT:-SCHED_OTHER}"
unshare $NSFLAGS sh -c '
set -u
ip link set lo up && ip route add 224.0.0.0/4 dev lo
$RT "$FTID" sim-robot --model ur10 > "$OUT/robot.log" 2>&1 & R=$!
$RT "$FTID" sim-sensor --socket "$OUT/ft.sock" --urdf "$SRC/config/ur10.urdf" \
    --dbc "$SRC/config/ftsensor.dbc" > "$OUT/sensor.log" 2>&1 & S=$!
"$FTIDD" --config "$OUT/ftidd.yaml" --connect-timeout 30 > "$OUT/ftidd.log" 2>&1 & D=$!
echo "$D" > "$OUT/ftidd.pid"
cleanup() { kill -TERM $D 2>/dev/null; wait $D 2>/dev/null; kill -TERM $S $R 2>/dev/null; wait $S $R 2>/dev/null; }
trap cleanup EXIT
i=0
until grep -q "running at" "$OUT/ftidd.log"; do
  sleep 0.5; i=$((i+1))
  if [ $i -gt 120 ] || ! kill -0 $D 2>/dev/null; then echo "soak: ftidd did not start:"; cat "$OUT/ftidd.log"; exit 1; fi
done
echo "elapsed_s,rss_kB,cycles,missed,stale,params_version,reloads_sent" > "$OUT/samples.csv"
start=$(date +%s); next_reload=$((start + RELOAD_S)); sent=0; flip=0
while :; do
  now=$(date +%s); el=$((now - start))
  kill -0 $D 2>/dev/null || { echo "soak: ftidd exited after ${el} s"; exit 1; }
  rss=$(awk "/^VmRSS/ {print \$2}" /proc/$D/status)
  st=$(grep "cycles [0-9]*, valid" "$OUT/ftidd.log" | tail -1)
  cyc=$(echo "$st" | sed -n "s/.*cycles \([0-9]*\),.*/\1/p")
  mis=$(echo "$st" | sed -n "s/.*missed \([0-9]*\),.*/\1/p")
  stl=$(echo "$st" | sed -n "s/.*stale \([0-9]*\),.*/\1/p")
  ver=$(echo "$st" | sed -n "s/.*params v\([0-9]*\).*/\1/p")
  echo "$el,$rss,${cyc:-},${mis:-},${stl:-},${ver:-},$sent" >> "$OUT/samples.csv"
  [ $el -ge $DURATION_S ] && break
  if [ $now -ge $next_reload ]; then
    flip=$((1 - flip))
    if [ $flip -eq 1 ]; then f0=-0.6670; else f0=-0.6672; fi
    sed "s/^  f0_x: .*/  f0_x: {value: $f0, std: 0, unit: \"\"}/" "$OUT/parameters.yaml" > "$OUT/parameters.yaml.tmp"
    mv "$OUT/parameters.yaml.tmp" "$OUT/parameters.yaml"
    kill -HUP $D; sent=$((sent + 1)); next_reload=$((next_reload + RELOAD_S))
  fi
  sleep $SAMPLE_S
done
echo $sent > "$OUT/reloads_sent"
sleep 11  # one more status line after the last reload
grep "cycles [0-9]*, valid" "$OUT/ftidd.log" | tail -1 > "$OUT/last_status"
' || { echo "soak: FAILED (logs in $OUT)"; tail -5 "$OUT/ftidd.log" 2>/dev/null; exit 1; }

sent=$(cat "$OUT/reloads_sent")
applied=$(grep -c "parameters reloaded from" "$OUT/ftidd.log" || true)
failed=$(grep -c "reload failed" "$OUT/ftidd.log" || true)
last=$(cat "$OUT/last_status")
cycles=$(echo "$last" | sed -n 's/.*cycles \([0-9]*\),.*/\1/p')
missed=$(echo "$last" | sed -n 's/.*missed \([0-9]*\),.*/\1/p')
stale=$(echo "$last" | sed -n 's/.*stale \([0-9]*\),.*/\1/p')
# RSS: first sample, the first sample after 2 min of warm-up (or the first if shorter), last, max.
rss_first=$(awk -F, 'NR==2 {print $2}' "$OUT/samples.csv")
rss_warm=$(awk -F, 'NR>1 && $1>=120 {print $2; exit}' "$OUT/samples.csv")
[ -n "$rss_warm" ] || rss_warm=$rss_first
rss_last=$(awk -F, 'NR>1 {v=$2} END {print v}' "$OUT/samples.csv")
rss_max=$(awk -F, 'NR>1 && $2>m {m=$2} END {print m}' "$OUT/samples.csv")
elapsed=$(awk -F, 'NR>1 {v=$1} END {print v}' "$OUT/samples.csv")

echo "soak: ran ${elapsed} s; $MACHINE"
echo "soak: ftidd VmRSS first ${rss_first} kB, after warm-up ${rss_warm} kB, last ${rss_last} kB, max ${rss_max} kB"
echo "soak: cycles ${cycles:-?}, missed ${missed:-?}, stale sensor ${stale:-?}"
echo "soak: reloads sent ${sent}, applied ${applied}, failed ${failed}"
echo "soak: samples in $OUT/samples.csv"

ok=1
[ "$applied" -eq "$sent" ] || { echo "soak: FAIL: $sent reloads sent, $applied applied"; ok=0; }
[ "$failed" -eq 0 ] || { echo "soak: FAIL: $failed reloads failed"; ok=0; }
[ $((rss_last - rss_warm)) -lt "$RSS_SLACK_KB" ] || { echo "soak: FAIL: RSS grew by $((rss_last - rss_warm)) kB after warm-up"; ok=0; }
if [ -n "${cycles:-}" ] && [ "${cycles:-0}" -gt 0 ]; then
  [ $((missed * 1000000 / cycles)) -le "$MISSED_PPM" ] || { echo "soak: FAIL: missed cycles ${missed} > ${MISSED_PPM} ppm of ${cycles}"; ok=0; }
else
  echo "soak: FAIL: no cycle counters in ftidd's log"; ok=0
fi
[ $ok -eq 1 ] && echo "soak: PASS" && exit 0
exit 1

#!/bin/sh
# CAN frame receipt -> LCM publish latency and published rate of ftidd against the simulators,
# at 125 Hz (UR10 / CB3) and 500 Hz (UR10e). Everything runs inside a private network namespace
# (unshare -rn) so the udpm traffic never leaves it.
#   bench/bench_daemon.sh BUILD_DIR [SECONDS]
set -eu
BUILD=$(cd "${1:?usage: bench_daemon.sh BUILD_DIR [SECONDS]}" && pwd)
SECONDS_RUN=${2:-30}
SRC=$(cd "$(dirname "$0")/.." && pwd)
FTID=$BUILD/apps/ftid/ftid
FTIDD=$BUILD/apps/ftidd/ftidd
BENCH=$BUILD/bench/bench_daemon
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

run_one() {  # $1 = ur10 | ur10e, $2 = RTDE rate
  model=$1 rate=$2
  cat > "$WORK/ftidd.yaml" <<YAML
robot:
  rtde_frequency_hz: $rate
  urdf_path: $SRC/config/$model.urdf
sensor:
  socket_path: $WORK/ft.sock
  dbc_path: $SRC/config/ftsensor.dbc
parameters:
  path: $WORK/none.yaml
lcm:
  url: "udpm://239.255.76.67:7667?ttl=0"
rt:
  lock_memory: false
YAML
  # The simulator's payload as a "paper" parameter file: every cycle is compensated.
  "$BENCH" --write-params "$WORK/none.yaml"
  echo "== $model, RTDE $rate Hz, sensor 1000 Hz, ${SECONDS_RUN} s =="
  unshare -rn sh -c "
    ip link set lo up && ip route add 224.0.0.0/4 dev lo
    '$FTID' sim-robot --model $model > '$WORK/robot.log' 2>&1 & R=\$!
    '$FTID' sim-sensor --socket '$WORK/ft.sock' --urdf '$SRC/config/$model.urdf' --dbc '$SRC/config/ftsensor.dbc' > '$WORK/sensor.log' 2>&1 & S=\$!
    '$FTIDD' --config '$WORK/ftidd.yaml' --connect-timeout 20 > '$WORK/ftidd.log' 2>&1 & D=\$!
    i=0; until grep -q 'running at' '$WORK/ftidd.log'; do sleep 0.2; i=\$((i+1)); [ \$i -gt 150 ] && break; done
    sleep 1
    '$BENCH' 'udpm://239.255.76.67:7667?ttl=0' $SECONDS_RUN FTID_WRENCH
    kill -TERM \$D; wait \$D
    kill -TERM \$S \$R; wait \$S \$R 2>/dev/null
    tail -2 '$WORK/ftidd.log'
  "
}

echo "machine: $(nproc) CPUs, $(uname -r), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
run_one ur10 125
run_one ur10e 500

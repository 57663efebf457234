#!/bin/sh
# Peak memory and wall time of `ftid identify` and `ftid analyze` on a long log (issue 26: 10 M
# rows identified in under 2 GB and 60 s; docs/performance.md "Log memory").
#   bench/bench_log_memory.sh BUILD_DIR [ROWS] [MOTION_S] [WORK_DIR]
# The log: the simulator holding one pose still, then MOTION_S seconds of the paper's excitation
# (MOTION_S / 10 runs of it), ROWS rows in all at 125 Hz (default 10,000,000 rows, 1000 s of
# motion; about 3 GB of disk in WORK_DIR, default a temporary directory removed at the end; a
# WORK_DIR that holds long.csv already reuses it). Each command runs with its default --max-rows
# (thinned), and as the baseline in the same run, on the last rows of the same log read whole
# (--max-rows 0): 500,001 rows for identify, 150,001 for analyze.
# Needs GNU time (/usr/bin/time, Debian package `time`) for the peak resident memory.
set -eu
BUILD=$(cd "${1:?usage: bench_log_memory.sh BUILD_DIR [ROWS] [MOTION_S] [WORK_DIR]}" && pwd)
ROWS=${2:-10000000}
MOTION_S=${3:-1000}
FTID=$BUILD/apps/ftid/ftid
if [ -n "${4:-}" ]; then
  WORK=$4
  mkdir -p "$WORK"
else
  WORK=$(mktemp -d)
  trap 'rm -rf "$WORK"' EXIT
fi
[ -x /usr/bin/time ] || { echo "bench_log_memory: needs /usr/bin/time (apt-get install time)" >&2; exit 1; }

# The motion: MOTION_S / 10 runs of the paper's 10 s excitation (1251 rows each, seeds 4, 5, ..),
# one after another (the excitation ends where it starts); then the rest fills ROWS.
runs=$(awk -v s="$MOTION_S" 'BEGIN { printf "%d", s / 10 }')
motion_rows=$((runs * 1251))
still_rows=$((ROWS - motion_rows))
still_s=$(awk -v n="$still_rows" 'BEGIN { printf "%.3f", n / 125 }')
log=$WORK/long.csv
if [ ! -s "$log" ]; then
  echo "== simulating $still_rows rows holding still and $runs runs of the excitation ($motion_rows rows)"
  "$FTID" simulate --out "$WORK/still.csv" --static-poses 1 --hold "$still_s" --seed 3 2>/dev/null
  cp "$WORK/still.csv" "$log.tmp"
  rm -f "$WORK/still.csv"
  k=0
  while [ "$k" -lt "$runs" ]; do
    "$FTID" simulate --out "$WORK/motion.csv" --seed $((k + 4)) 2>/dev/null
    # Each run's times shifted past the last row so far.
    last_t=$(tail -n 1 "$log.tmp" | cut -d, -f1)
    tail -n +2 "$WORK/motion.csv" | awk -F, -v OFS=, -v d="$last_t" '{ $1 = sprintf("%.17g", $1 + d + 0.008); print }' >> "$log.tmp"
    k=$((k + 1))
  done
  rm -f "$WORK/motion.csv"
  mv "$log.tmp" "$log"
fi
echo "== log: $(($(wc -l < "$log") - 1)) data rows, $(du -m "$log" | cut -f1) MB"

measure() {  # $1 = label, rest = ftid arguments
  label=$1
  shift
  /usr/bin/time -f "%e %M" -o "$WORK/time.txt" "$FTID" "$@" > "$WORK/out.txt" 2> "$WORK/err.txt" || {
    echo "$label: ftid $* failed:" >&2
    tail -n 5 "$WORK/err.txt" >&2
    exit 1
  }
  read -r secs kb < "$WORK/time.txt"
  used=$(grep -o '[0-9]* rows) to stay within' "$WORK/out.txt" "$WORK/err.txt" | head -n 1 | grep -o '^[^ ]*' | sed 's/.*://')
  printf "%-40s %8.1f s %8d MB  rows used: %s\n" "$label" "$secs" $((kb / 1024)) "${used:-all}"
}

# The baselines: the header and the last rows (the end of the rest, then the whole motion).
{ head -n 1 "$log"; tail -n 500001 "$log"; } > "$WORK/identify_base.csv"
{ head -n 1 "$log"; tail -n 150001 "$log"; } > "$WORK/analyze_base.csv"
measure "identify, $ROWS rows (default)" identify --log "$log" --json
measure "identify, last 500001 rows whole (baseline)" identify --log "$WORK/identify_base.csv" --json --max-rows 0
measure "analyze, $ROWS rows (default)" analyze "$log"
measure "analyze, last 150001 rows whole (baseline)" analyze "$WORK/analyze_base.csv" --max-rows 0
rm -f "$WORK/identify_base.csv" "$WORK/analyze_base.csv"

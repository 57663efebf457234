#!/usr/bin/env bash
# Every command that uses default files works from an empty directory (issue 12, item 2): the
# one default-file lookup (include/ftid/common/default_files.hpp) finds them next to the
# executable (build tree), in <prefix>/share/ftid/config or /usr/share/ftid/config, or /etc/ftid.
# Usage: default_files_test.sh FTID [FTIDD]   (also run by scripts/check_package.sh on the
# extracted .deb, where the data directory is <root>/usr/share/ftid/config).
set -euo pipefail
ftid="$(readlink -f "$1")"
ftidd="${2:+$(readlink -f "$2")}"
work="$(mktemp -d /tmp/ftid-defaults.XXXXXX)"
trap 'rm -rf "$work"' EXIT
cd "$work"
fail() { echo "default_files_test: $*" >&2; exit 1; }
# A default file that is not found is named in the error ("default file ... not found" or the
# old "cannot open"); any such message fails the test.
nodefault() { ! grep -qE "not found \(searched|config/[a-z0-9_]+\.(urdf|dbc|yaml): cannot" "$1"; }
run() {  # run NAME CMD...: must succeed
  local name="$1"; shift
  "$@" > "$name.log" 2>&1 || { cat "$name.log" >&2; fail "$name failed from an empty directory"; }
}

# 10 s: the default model (paper+rigid_body) needs the inertia determined; 3 s of the default
# simulation leave it undetermined and identify refuses to write it (docs/identification.md).
run simulate "$ftid" simulate --out run.csv --duration 10 --seed 3
[ -s run.csv ] || fail "simulate wrote no log"
run identify "$ftid" identify --log run.csv --out params.yaml
[ -s params.yaml ] && [ -s params.yaml.ros2.yaml ] && [ -s params.yaml.urscript ] || fail "identify --out wrote no parameters/exports"
run compensate "$ftid" compensate --log run.csv --params params.yaml --out contact.csv
run export "$ftid" export --params params.yaml --ros2 out.ros2.yaml --urscript out.script
grep -q "set_target_payload(" out.script || fail "export wrote no set_target_payload"
run analyze "$ftid" analyze run.csv --model paper --folds 3
run design "$ftid" design --duration 2 --time-budget 1 --baseline-seeds 0 --global-evals 40 \
    --local-evals 40 --quiet --out traj.yaml
# The trajectory names its robot relative to itself or absolutely, never relative to the cwd.
robot_line="$(grep '^robot:' traj.yaml)"
case "$robot_line" in *'"config/'*) fail "traj.yaml records a working-directory path: $robot_line" ;; esac
mkdir sub && (cd sub && run check "$ftid" check-trajectory ../traj.yaml)
# The shipped trajectory: its robot is found relative to the trajectory file.
shipped="$(dirname "$(grep -o '/[^ ]*ur10.urdf' "$work/sub/check.log" | head -1)")/excitation_ur10.yaml"
[ -f "$shipped" ] && run check_shipped "$ftid" check-trajectory "$shipped"
# sim-sensor loads the robot model and the DBC before it connects; with no robot there it must
# fail on the connection, not on a default file.
timeout 3 "$ftid" sim-sensor --rtde-port 1 --socket "$work/s.sock" > sim_sensor.log 2>&1 || true
grep -q "waiting for the robot" sim_sensor.log || { cat sim_sensor.log >&2; fail "sim-sensor did not get as far as connecting"; }
nodefault sim_sensor.log || { cat sim_sensor.log >&2; fail "sim-sensor did not find its default files"; }
if [ -n "$ftidd" ]; then
  "$ftidd" --help > ftidd.log 2>&1 || fail "ftidd --help failed"
fi
echo "default files: every command ran from the empty directory $work"

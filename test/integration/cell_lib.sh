# Shared set-up of the integration tests that run the cell's processes inside a private network
# namespace (cell_identify, ftidd_commands, link_loss, robot_late, payload_change). Sourced by bash
# first (cell_reexec_in_netns), then used inside the namespace after defining SKIP and fail().
#
# cell_begin NAME: WORK (a fresh /tmp/ftid-NAME.XXXXXX), FAILED=0, PIDS (background processes the
# script starts; append with PIDS="$PIDS $!"), loopback up with the multicast route LCM needs.
# On exit every process in PIDS gets SIGTERM and is waited for, then the optional function
# cell_extra_cleanup runs, and WORK is removed if nothing failed (kept and named otherwise).

# cell_reexec_in_netns EXTRA ARGS...: unless already inside, re-executes the calling script ($0
# ARGS...) in a new network namespace, plus the EXTRA unshare flags (e.g. m for a mount namespace).
# As root the real capabilities are kept (SCHED_FIFO for the motion loop and ftidd: on a loaded
# host the motion runner rightly aborts on lost packages without it); otherwise a user namespace.
# Exits 77 (SKIP) where such namespaces cannot be created.
cell_reexec_in_netns() {
  local extra=$1 flags
  shift
  [ -n "${FTID_CELL_TEST_IN_NS:-}" ] && return 0
  if [ "$(id -u)" -eq 0 ]; then flags=-n; else flags=-rn; fi
  flags=$flags$extra
  if ! unshare $flags true 2>/dev/null; then
    echo "SKIP: cannot create private namespaces (unshare $flags) here"; exit 77
  fi
  FTID_CELL_TEST_IN_NS=1 exec unshare $flags "$0" "$@"
}

# cell_run_attempts WHAT ARGS...: unless already inside an attempt (FTID_CELL_ATTEMPT set), runs the
# calling script ($0 ARGS...) as attempts 1..3 and exits with the first status that is not 3; an
# attempt exits 3 when it found its own run spoilt by WHAT (a host stall: the script decides from
# its recordings, and only before its last attempt), which is said before the next; after three
# such attempts it exits 1. Inside an attempt it returns at once.
cell_run_attempts() {
  local what=$1 attempt rc
  shift
  [ -n "${FTID_CELL_ATTEMPT:-}" ] && return 0
  for attempt in 1 2 3; do
    FTID_CELL_ATTEMPT=$attempt "$0" "$@"; rc=$?
    [ $rc -ne 3 ] && exit $rc
    echo "attempt $attempt: $what; running it again"
  done
  exit 1
}

cell_cleanup() {
  for p in $PIDS; do kill -TERM "$p" 2>/dev/null; done
  for p in $PIDS; do wait "$p" 2>/dev/null; done
  if declare -F cell_extra_cleanup >/dev/null; then cell_extra_cleanup; fi
  if [ "$FAILED" -eq 0 ]; then rm -rf "$WORK"; else echo "logs kept in $WORK"; fi
}

cell_begin() {
  FAILED=0
  WORK=$(mktemp -d "/tmp/ftid-$1.XXXXXX")
  PIDS=""
  trap cell_cleanup EXIT
  ip link set lo up && ip route add 224.0.0.0/4 dev lo || { echo "SKIP: cannot set up loopback multicast"; exit "$SKIP"; }
}

# write_ftidd_config FILE HOST HZ [ROBOT_LINE]: the ftidd configuration the link tests share (sensor
# on WORK/ft.sock, parameters WORK/params.yaml, no command key, stats every 0.5 s, no memory lock,
# fast reconnect backoff); ROBOT_LINE is one more `key: value` under robot.
write_ftidd_config() {
  local extra=""
  [ -n "${4:-}" ] && extra="  $4
"
  cat > "$1" <<YAML
robot:
  host: $2
  rtde_frequency_hz: $3
  urdf_path: $SRC/config/ur10.urdf
  silent_publish_after_ms: 50
${extra}  reconnect_backoff_min_s: 0.2
  reconnect_backoff_max_s: 1.0
sensor:
  socket_path: $WORK/ft.sock
  dbc_path: $SRC/config/ftsensor.dbc
parameters:
  path: $WORK/params.yaml
  required: true
lcm:
  url: "udpm://239.255.76.67:7667?ttl=0"
  command_key_path: $WORK/no.key
  stats_period_s: 0.5
rt:
  lock_memory: false
YAML
}

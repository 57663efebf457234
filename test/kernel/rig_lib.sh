# Shared by the kernel rig's two stages (rig_init.sh under busybox, rig_systemd_checks.sh under
# systemd): one check of the rig itself, printed as the marker line the host counts.
check() {  # check NAME COMMAND...
  name=$1; shift
  if out=$("$@" 2>&1); then
    echo "@@RIG check $name PASS"
  else
    echo "@@RIG check $name FAIL $(echo "$out" | tr '\n' ' ' | cut -c1-300)"
  fi
}

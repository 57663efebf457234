#!/bin/sh
# Stage 2 of the kernel rig (scripts/kernel-rig.sh, docs/kernel-rig.md): runs as the oneshot unit
# ftid-rig.service under systemd (PID 1) on Debian's PREEMPT_RT kernel inside qemu. It installs
# what the Debian package's maintainer scripts install (the sysusers entry, the postinst's command
# key), then runs the UnderSystemd.* tests: the packaged ftidd.service, unchanged, started by
# systemctl, real time through its rlimits, publishing over LCM, reloaded and stopped by systemd.
# Markers as in rig_init.sh: "@@RIG check", "@@RIG gtest", "@@RIG done".
export PATH=/bin:/sbin:/usr/bin:/usr/sbin
. /rig/env

. /rig/lib.sh  # check NAME COMMAND...

echo "@@RIG phase systemd-up $(systemctl --version | head -n 1)"
check systemd_is_pid1 sh -c '[ "$(cat /proc/1/comm)" = systemd ]'
# (not is-system-running: the boot is not finished while this oneshot runs)
check journald_up systemctl is-active --quiet systemd-journald.socket
# What the package's maintainer scripts do (dh_installsysusers, then debian/ftid.postinst).
check sysusers sh -c 'systemd-sysusers && grep -q "^ftid:" /etc/passwd'
check postinst_command_key sh -c '/rig/ftid.postinst configure && [ "$(stat -c %U:%G:%a /etc/ftid/command.key)" = root:ftid:640 ]'

echo "@@RIG gtest systemd"
cd /tmp
"$RIG_KTEST" --gtest_color=no '--gtest_filter=UnderSystemd.*' 2>&1
echo "@@RIG gtest-exit systemd $?"
echo "@@RIG info ftidd journal:"
journalctl -u ftidd --no-pager -o short-monotonic 2>&1 | tail -n 40
echo "@@RIG done"
sync
systemctl poweroff --force --force

#!/usr/bin/env python3
"""Listener of the integration tests that watch ftidd (link_loss_test.sh, robot_late_test.sh).

Usage: ftidd_events.py WORK   (WORK/gen holds the Python LCM types from lcm-gen)
Binds WORK/notify.sock (the NOTIFY_SOCKET given to ftidd) and the LCM multicast group, writes
WORK/listener.ready when listening, and prints one line per event with a monotonic time stamp:
  T notify WATCHDOG=1 | READY=1 | STATUS=... (spaces as _)
  T wrench cycle C valid V contact F            (F = largest |contact force| component [N])
  T stats up U reconnects R down D sensor_reconnects S
until WORK/listener.stop exists or 100 s have passed.
"""
import os, select, socket, struct, sys, time
work = sys.argv[1]
sys.path.insert(0, work + "/gen")
from ftid_lcm.compensated_wrench_t import compensated_wrench_t
from ftid_lcm.loop_stats_t import loop_stats_t
n = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
n.bind(work + "/notify.sock")
w = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
w.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
w.bind(("", 7667))
w.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP,
             struct.pack("4s4s", socket.inet_aton("239.255.76.67"), socket.inet_aton("0.0.0.0")))
open(work + "/listener.ready", "w").close()
end = time.monotonic() + 100
while time.monotonic() < end and not os.path.exists(work + "/listener.stop"):
    r, _, _ = select.select([n, w], [], [], 0.2)
    for s in r:
        data = s.recv(65536)
        t = time.monotonic()
        if s is n:
            for line in data.decode(errors="replace").split("\n"):
                if line.startswith(("WATCHDOG=1", "READY=1", "STATUS=")):
                    print("%.3f notify %s" % (t, line.replace(" ", "_")), flush=True)
        elif data[:4] == b"LC02":
            end0 = data.index(b"\0", 8)
            channel = data[8:end0]
            if channel == b"FTID_WRENCH":
                m = compensated_wrench_t.decode(data[end0 + 1:])
                f = max(abs(x) for x in m.contact[:3])
                print("%.3f wrench cycle %d valid %d contact %.4f" % (t, m.cycle, int(m.valid), f), flush=True)
            elif channel == b"FTID_STATS":
                m = loop_stats_t.decode(data[end0 + 1:])
                print("%.3f stats up %d reconnects %d down %.3f sensor_reconnects %d" %
                      (t, int(m.robot_link_up), m.robot_reconnects, m.robot_link_down_s, m.sensor_reconnects),
                      flush=True)

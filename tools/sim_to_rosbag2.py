#!/usr/bin/env python3
"""Write one simulated ftid log (`ftid simulate`) as a ROS 2 bag (rosbag2, sqlite3 storage), the
way a cell recorded with ROS 2 would give it (docs/log-format.md "ROS 2 bags"): /joint_states
(sensor_msgs/msg/JointState, the UR driver's joint order, every `--joint-step`-th row) and
/ft_sensor/wrench (geometry_msgs/msg/WrenchStamped, every `--wrench-step`-th row from
`--wrench-phase`), header stamps = T0 + t. Python's standard library only (sqlite3, struct).

  ftid simulate --out full.csv --rate 1000 --duration 12
  tools/sim_to_rosbag2.py full.csv bag/ && ftid identify --log bag/ --model paper+rigid_body
"""
import argparse
import csv
import math
import os
import shutil
import sqlite3
import struct

T0 = 1700000000
UR = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
DRIVER_ORDER = [1, 2, 3, 4, 5, 0]


class Cdr:
    def __init__(self):
        self.b = bytearray(b"\x00\x01\x00\x00")

    def pad(self, n):
        while (len(self.b) - 4) % n:
            self.b.append(0)

    def u32(self, v):
        self.pad(4)
        self.b += struct.pack("<I", v)

    def i32(self, v):
        self.pad(4)
        self.b += struct.pack("<i", v)

    def f64(self, v):
        self.pad(8)
        self.b += struct.pack("<d", v)

    def string(self, s):
        d = s.encode() + b"\x00"
        self.u32(len(d))
        self.b += d

    def stamp(self, t, frame):
        ns = int(round(t * 1e9))
        self.i32(T0 + ns // 1000000000)
        self.u32(ns % 1000000000)
        self.string(frame)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("log")
    ap.add_argument("bag")
    ap.add_argument("--joint-step", type=int, default=2, help="1 kHz -> 500 Hz joint states (e-Series)")
    ap.add_argument("--wrench-step", type=int, default=1)
    ap.add_argument("--wrench-phase", type=int, default=0)
    a = ap.parse_args()
    with open(a.log, newline="") as f:
        rows = [r for r in csv.reader(f) if r and not r[0].lstrip().startswith("#")]
    col = {n: i for i, n in enumerate(rows[0])}
    data = [[float(x) for x in r] for r in rows[1:]]
    shutil.rmtree(a.bag, ignore_errors=True)
    os.makedirs(a.bag)
    name = os.path.basename(os.path.normpath(a.bag))
    db = sqlite3.connect(os.path.join(a.bag, name + "_0.db3"))
    db.executescript(
        "CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,"
        "serialization_format TEXT NOT NULL,offered_qos_profiles TEXT NOT NULL);"
        "CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,timestamp INTEGER NOT NULL,"
        "data BLOB NOT NULL);")
    db.execute("INSERT INTO topics VALUES (1,'/joint_states','sensor_msgs/msg/JointState','cdr','')")
    db.execute("INSERT INTO topics VALUES (2,'/ft_sensor/wrench','geometry_msgs/msg/WrenchStamped','cdr','')")
    msgs = []
    for i in range(0, len(data), a.joint_step):
        r = data[i]
        c = Cdr()
        c.stamp(r[col["t"]], "")
        c.u32(6)
        for k in DRIVER_ORDER:
            c.string(UR[k])
        for prefix in ("q", "qd"):
            c.u32(6)
            for k in DRIVER_ORDER:
                c.f64(r[col[f"{prefix}{k + 1}"]])
        c.u32(0)
        msgs.append((int(round((T0 + r[col["t"]]) * 1e9)) + 200000, 1, bytes(c.b)))
    for i in range(a.wrench_phase, len(data), a.wrench_step):
        r = data[i]
        c = Cdr()
        c.stamp(r[col["t"]], "ft_sensor")
        for n in ("fx", "fy", "fz", "tx", "ty", "tz"):
            c.f64(r[col[n]])
        msgs.append((int(round((T0 + r[col["t"]]) * 1e9)) + 100000, 2, bytes(c.b)))
    msgs.sort()
    db.executemany("INSERT INTO messages (timestamp, topic_id, data) VALUES (?,?,?)", msgs)
    db.commit()
    db.close()
    with open(os.path.join(a.bag, "metadata.yaml"), "w") as f:
        f.write("rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n"
                f"  relative_file_paths:\n    - {name}_0.db3\n")


if __name__ == "__main__":
    main()

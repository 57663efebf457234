#!/usr/bin/env python3
"""Makes the small rosbag2 fixtures of test/unit/logio/rosbag2_test.cpp (run once; the bags are
checked in). Python's standard library only: sqlite3 for the storage, struct for a hand-written
CDR encoder (little-endian XCDR1, alignment counted from the end of the 4-byte encapsulation
header), so the C++ decoder is tested against an independent writer.

  cd test/unit/logio/rosbag2 && ./make_bags.py

ur_ft/          /joint_states (sensor_msgs/msg/JointState, 100 Hz, 1 s, the UR ROS 2 driver's joint
                order, every 5th state published twice with a later stamp: stair steps),
                /ft/wrench (geometry_msgs/msg/WrenchStamped, 200 Hz, -0.1 .. 1.1 s, frame 'ft_frame'),
                /tf (tf2_msgs/msg/TFMessage, no messages: a topic to list)
no_velocity/    /joint_states without velocities, header stamps zero (the bag's receive time is used),
                two wrench topics (/ft/wrench, /ft/raw): the reader must be told which
mcap/           metadata.yaml of an MCAP bag (refused with the conversion command)

Motion (the test's exact values): q_j(t) = 0.3 (j+1) sin(2 pi 0.7 t + j), j = 0 (shoulder_pan) ..
5 (wrist_3), t in seconds since T0 = 1700000000 s; the wrench component a is (a+1) 0.5 + (a-2.5) t.
"""
import math
import os
import shutil
import sqlite3
import struct

T0 = 1700000000
UR = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
DRIVER_ORDER = [1, 2, 3, 4, 5, 0]  # the UR ROS 2 driver publishes shoulder_lift first, shoulder_pan last


class Cdr:
    def __init__(self):
        self.b = bytearray(b"\x00\x01\x00\x00")  # CDR little-endian

    def align(self, n):
        while (len(self.b) - 4) % n:
            self.b.append(0)

    def u32(self, v):
        self.align(4)
        self.b += struct.pack("<I", v)

    def i32(self, v):
        self.align(4)
        self.b += struct.pack("<i", v)

    def f64(self, v):
        self.align(8)
        self.b += struct.pack("<d", v)

    def string(self, s):
        data = s.encode() + b"\x00"
        self.u32(len(data))
        self.b += data

    def header(self, sec, nsec, frame):
        self.i32(sec)
        self.u32(nsec)
        self.string(frame)


def q(j, t):
    return 0.3 * (j + 1) * math.sin(2 * math.pi * 0.7 * t + j)


def qd(j, t):
    return 0.3 * (j + 1) * 2 * math.pi * 0.7 * math.cos(2 * math.pi * 0.7 * t + j)


def joint_state(t, stamp_t, velocities=True, stamped=True):
    c = Cdr()
    sec, nsec = (T0 + int(math.floor(stamp_t)), int(round((stamp_t - math.floor(stamp_t)) * 1e9))) if stamped else (0, 0)
    c.header(sec, nsec, "")
    c.u32(6)
    for k in DRIVER_ORDER:
        c.string(UR[k])
    for seq in ("position", "velocity", "effort"):
        if seq == "velocity" and not velocities:
            c.u32(0)
            continue
        c.u32(6)
        for k in DRIVER_ORDER:
            c.f64(q(k, t) if seq == "position" else qd(k, t) if seq == "velocity" else 0.0)
    return bytes(c.b)


def wrench(t, stamped=True, frame="ft_frame"):
    c = Cdr()
    sec, nsec = (T0 + int(math.floor(t)), int(round((t - math.floor(t)) * 1e9))) if stamped else (0, 0)
    c.header(sec, nsec, frame)
    for a in range(6):
        c.f64((a + 1) * 0.5 + (a - 2.5) * t)
    return bytes(c.b)


def ns(t):
    return T0 * 1000000000 + int(round(t * 1e9))


def write_bag(name, topics, messages, storage="sqlite3"):
    shutil.rmtree(name, ignore_errors=True)
    os.makedirs(name)
    db_name = name + "_0.db3"
    counts = {}
    if storage == "sqlite3":
        db = sqlite3.connect(os.path.join(name, db_name))
        db.executescript(
            "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY,ros_distro TEXT NOT NULL);"
            "INSERT INTO schema VALUES (3, 'humble');"
            "CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,"
            "serialization_format TEXT NOT NULL,offered_qos_profiles TEXT NOT NULL);"
            "CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,timestamp INTEGER NOT NULL,"
            "data BLOB NOT NULL);"
            "CREATE INDEX timestamp_idx ON messages (timestamp ASC);")
        for i, (topic, typ) in enumerate(topics, 1):
            db.execute("INSERT INTO topics VALUES (?,?,?,?,?)", (i, topic, typ, "cdr", ""))
        names = [t for t, _ in topics]
        for stamp, topic, data in sorted(messages, key=lambda m: m[0]):
            db.execute("INSERT INTO messages (topic_id, timestamp, data) VALUES (?,?,?)",
                       (names.index(topic) + 1, stamp, data))
            counts[topic] = counts.get(topic, 0) + 1
        db.commit()
        db.execute("VACUUM")
        db.close()
    lines = ["rosbag2_bagfile_information:", "  version: 5", f"  storage_identifier: {storage}",
             "  duration:", "    nanoseconds: 1200000000", "  starting_time:",
             f"    nanoseconds_since_epoch: {ns(-0.1)}", f"  message_count: {len(messages)}",
             "  topics_with_message_count:"]
    for topic, typ in topics:
        lines += ["    - topic_metadata:", f"        name: {topic}", f"        type: {typ}",
                  "        serialization_format: cdr", '        offered_qos_profiles: ""',
                  f"      message_count: {counts.get(topic, 0)}"]
    lines += ["  compression_format: \"\"", "  compression_mode: \"\"", "  relative_file_paths:",
              f"    - {db_name if storage == 'sqlite3' else name + '_0.mcap'}", "  files: []"]
    with open(os.path.join(name, "metadata.yaml"), "w") as f:
        f.write("\n".join(lines) + "\n")


def main():
    js_type, w_type = "sensor_msgs/msg/JointState", "geometry_msgs/msg/WrenchStamped"
    msgs = []
    for i in range(100):
        t = i / 100.0
        msgs.append((ns(t) + 300000, "/joint_states", joint_state(t, t)))
        if i % 5 == 4:  # the same state again, 4 ms later
            msgs.append((ns(t + 0.004) + 300000, "/joint_states", joint_state(t, t + 0.004)))
    for i in range(-20, 221):
        t = i / 200.0
        msgs.append((ns(t) + 500000, "/ft/wrench", wrench(t)))
    write_bag("ur_ft", [("/joint_states", js_type), ("/ft/wrench", w_type), ("/tf", "tf2_msgs/msg/TFMessage")], msgs)

    msgs = []
    for i in range(50):
        t = i / 50.0
        msgs.append((ns(t), "/joint_states", joint_state(t, t, velocities=False, stamped=False)))
    for i in range(0, 101):
        t = i / 100.0 + 0.003
        msgs.append((ns(t), "/ft/wrench", wrench(t, stamped=False)))
        msgs.append((ns(t) + 1, "/ft/raw", wrench(t + 1.0, stamped=False)))
    write_bag("no_velocity", [("/joint_states", js_type), ("/ft/wrench", w_type), ("/ft/raw", w_type)], msgs)
    write_bag("mcap", [("/joint_states", js_type)], [], storage="mcap")


if __name__ == "__main__":
    main()

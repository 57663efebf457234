#!/usr/bin/env python3
"""Split one simulated ftid log (`ftid simulate --rate 1000`) into the two recordings a real cell
gives (docs/log-format.md "Two files, one log"): the robot's, as UR's RTDE client record.py writes
it (space-separated, `timestamp actual_q_0..5 actual_qd_0..5`, no accelerations), and the sensor's
own (`time,Fx,Fy,Fz,Tx,Ty,Tz`), at their own rates and spans, on the same clock; plus the native
ftid log of the robot's instants (exact qdd and the wrench) to compare against.

The robot keeps every `--robot-step`-th row from `--robot-phase` (125 Hz from 1000 Hz: step 8),
the sensor every `--sensor-step`-th from `--sensor-phase` (500 Hz: step 2, phase 1, so that no
robot instant coincides with a sensor sample and the wrench is interpolated at every one).

  ftid simulate --out full.csv --rate 1000 --duration 12
  tools/split_sim_log.py full.csv --robot ur_record.txt --sensor ft.csv --native native.csv \\
      --robot-from 1 --robot-to 10
"""
import argparse
import csv


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("log")
    ap.add_argument("--robot", required=True)
    ap.add_argument("--sensor", required=True)
    ap.add_argument("--native", required=True)
    ap.add_argument("--robot-step", type=int, default=8)
    ap.add_argument("--robot-phase", type=int, default=2)
    ap.add_argument("--sensor-step", type=int, default=2)
    ap.add_argument("--sensor-phase", type=int, default=1)
    ap.add_argument("--robot-from", type=float, default=float("-inf"), help="robot span start [s]")
    ap.add_argument("--robot-to", type=float, default=float("inf"), help="robot span end [s]")
    ap.add_argument("--clock-offset", type=float, default=0.0,
                    help="added to the sensor's times (a clock offset between the recorders) [s]")
    a = ap.parse_args()
    with open(a.log, newline="") as f:
        rows = [r for r in csv.reader(f) if r and not r[0].lstrip().startswith("#")]
    head, data = rows[0], rows[1:]
    col = {n: i for i, n in enumerate(head)}
    q = [f"q{j}" for j in range(1, 7)]
    qd = [f"qd{j}" for j in range(1, 7)]
    qdd = [f"qdd{j}" for j in range(1, 7)]
    w = ["fx", "fy", "fz", "tx", "ty", "tz"]
    with open(a.robot, "w") as rf, open(a.native, "w") as nf:
        rf.write(" ".join(["timestamp"] + [f"actual_q_{j}" for j in range(6)] + [f"actual_qd_{j}" for j in range(6)]) + "\n")
        nf.write(",".join(["t"] + q + qd + qdd + w) + "\n")
        for i in range(a.robot_phase, len(data), a.robot_step):
            r = data[i]
            t = float(r[col["t"]])
            if t < a.robot_from or t > a.robot_to:
                continue
            rf.write(" ".join([r[col["t"]]] + [r[col[n]] for n in q + qd]) + "\n")
            nf.write(",".join([r[col[n]] for n in ["t"] + q + qd + qdd + w]) + "\n")
    with open(a.sensor, "w") as sf:
        sf.write("time,Fx,Fy,Fz,Tx,Ty,Tz\n")
        for i in range(a.sensor_phase, len(data), a.sensor_step):
            r = data[i]
            sf.write(",".join([repr(float(r[col["t"]]) + a.clock_offset)] + [r[col[n]] for n in w]) + "\n")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Writes the sensor simulator's true payload as a `paper` parameter file (integration tests).

Usage: sim_true_params.py FILE
The values are config/sim_sensor.yaml's (the paper's Table 2): with them ftidd compensates the
simulator's readings at rest to its sensor noise.
"""
import math, sys
m = 8.862 / 9.80665
c = (0.005, 0.002, 0.051)
f0 = (-0.6672, 0.8565, 0.3538)
t0 = (0.0228, 0.0084, 0.0080)
p = lambda v: "{value: %.9g, std: 0, unit: \"\"}" % v
rows = ["model: \"paper\"", "parameters:"]
for n, v in zip(("f0_x", "f0_y", "f0_z"), f0): rows.append("  %s: %s" % (n, p(v)))
for n, v in zip(("t0_x", "t0_y", "t0_z"), t0): rows.append("  %s: %s" % (n, p(v)))
rows.append("  mass: %s" % p(m))
for n, v in zip(("mass_com_x", "mass_com_y", "mass_com_z"), c): rows.append("  %s: %s" % (n, p(m * v)))
rows += ["tilt:", "  estimated: true",
         "  u: {value: %.9g, std: 0, unit: \"rad\"}" % math.radians(-9.8716),
         "  v: {value: %.9g, std: 0, unit: \"rad\"}" % math.radians(-5.3709)]
open(sys.argv[1], "w").write("\n".join(rows) + "\n")

#!/usr/bin/env python3
"""JSON outputs of `ftid identify --json` and `ftid analyze --json`, read with Python's json module.

Checks what docs/identification.md "Outputs" and docs/analyze.md promise: valid JSON, exactly the
documented keys, numbers or null (never NaN/Infinity tokens), and the one precision policy of
ftid/fileio/json_text.hpp: every number reads back as the double ftid computed (the identify JSON
against the parameter file written in the same run, which keeps full precision), so computed
values carry more significant digits than the old %.6g / %.10g formats could.

usage: json_outputs_test.py FTID WORKDIR
"""
import json
import math
import os
import re
import subprocess
import sys

IDENTIFY_KEYS = ["model", "method", "n_samples", "parameters", "residual_rms", "condition_number",
                 "tilt_estimated", "units", "extras", "data_file", "time_origin_unix_s", "noise_floor", "noise_method",
                 "heldout_rms", "residual_to_noise", "glitches", "saturation", "warnings", "physical_validity", "imu"]
ANALYZE_KEYS = ["model", "log", "validate_log", "samples", "heldout_samples", "folds", "residual_rms",
                "noise_floor", "noise_method", "noise_detail", "noise_ar1", "outliers", "saturation", "warnings",
                "raw_rms", "fit", "windows", "correlations", "extra_signals", "candidates", "family_alpha", "family_size",
                "heldout_margin", "unphysical", "unwritable", "writable_alternative", "change_points",
                "change_point_scan_p_value", "spectrum", "autocorrelation", "dynamics", "imu", "seconds"]
CANDIDATE_KEYS = ["effect", "relative_reduction", "significant", "p_value", "f_statistic", "added_params",
                  "delta_bic", "residual_rms", "description", "next_command", "skipped", "note",
                  "confounded", "confound", "separating_motion", "verdict", "family_p_value", "reason"]
AXES = ["fx", "fy", "fz", "tx", "ty", "tz"]
PAPER = ["mass", "weight", "com_x", "com_y", "com_z", "f0_x", "f0_y", "f0_z", "t0_x", "t0_y", "t0_z",
         "tilt_u", "tilt_v"]

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL:", what)


def run(ftid, *args):
    r = subprocess.run([ftid, *args], capture_output=True, text=True, timeout=120)
    if r.returncode != 0:
        print(r.stdout, r.stderr)
        sys.exit(f"ftid {' '.join(args)}: exit {r.returncode}")
    return r.stdout


def load(text, what):
    """Parses strictly (no NaN/Infinity tokens); numbers as (float, text)."""
    def bad_constant(name):
        raise ValueError(f"{what}: non-standard JSON constant {name}")
    return json.loads(text, parse_float=lambda s: (float(s), s), parse_int=lambda s: (int(s), s),
                      parse_constant=bad_constant)


def significant_digits(text):
    mantissa = re.split("[eE]", text)[0].lstrip("-").replace(".", "").lstrip("0")
    return len(mantissa.rstrip("0")) if mantissa else 0


def axes_of(obj, what):
    check(isinstance(obj, dict) and list(obj.keys()) == AXES, f"{what}: keys fx..tz, got {obj}")
    for v in obj.values():
        check(v is None or isinstance(v, tuple), f"{what}: number or null, got {v!r}")


def main():
    ftid, work = sys.argv[1], sys.argv[2]
    os.makedirs(work, exist_ok=True)
    log = os.path.join(work, "run.csv")
    params = os.path.join(work, "p.yaml")
    run(ftid, "simulate", "--out", log, "--seed", "5", "--effect", "time_drift")

    # ---- ftid identify --json
    ident = load(run(ftid, "identify", "--log", log, "--json", "--out", params), "identify")
    check(list(ident.keys()) == IDENTIFY_KEYS, f"identify keys {list(ident.keys())}")
    for name in PAPER:
        entry = ident["parameters"].get(name)
        check(isinstance(entry, dict) and list(entry.keys()) == ["value", "std"], f"parameters.{name}: {entry}")
    for key in ["residual_rms", "noise_floor", "heldout_rms", "residual_to_noise"]:
        axes_of(ident[key], key)
    check(ident["units"]["tilt_u"] == "rad", "units.tilt_u")
    check(isinstance(ident["warnings"], list), "warnings is a list")
    pv = ident["physical_validity"]
    check(list(pv.keys()) == ["valid", "key", "reason", "line"], f"physical_validity keys {list(pv.keys())}")
    check(pv["valid"] is True and pv["key"] is None and pv["line"].startswith("physical validity: mass"),
          f"physical_validity {pv}")
    # Full precision: the JSON numbers are the doubles the parameter file keeps (same run).
    with open(params) as f:
        text = f.read()
    compared = 0
    for name, entry in ident["parameters"].items():
        m = re.search(r"^  " + re.escape(name) + r": \{value: ([^,]+), std: ([^,]+),", text, re.M)
        if m is None:
            continue
        check(entry["value"][0] == float(m.group(1)), f"{name}: JSON {entry['value'][1]} vs file {m.group(1)}")
        check(entry["std"][0] == float(m.group(2)), f"{name} std: JSON {entry['std'][1]} vs file {m.group(2)}")
        compared += 1
    check(compared >= 10, f"compared {compared} parameters with the parameter file")
    digits = max(significant_digits(v[1]) for v in ident["heldout_rms"].values() if v is not None)
    check(digits > 10, f"heldout_rms written with {digits} significant digits at most")

    # ---- ftid analyze --json
    ana = load(run(ftid, "analyze", log, "--json", "--candidates", "time_drift,crosstalk"), "analyze")
    check(list(ana.keys()) == ANALYZE_KEYS, f"analyze keys {list(ana.keys())}")
    for key in ["residual_rms", "noise_floor", "noise_ar1", "raw_rms"]:
        axes_of(ana[key], key)
    check(list(ana["outliers"].keys()) == ["count", "times"], "outliers keys")
    # The IMU against the kinematics and the model (docs/analyze.md "The IMU"): the simulated log has it.
    check(ana["imu"].get("used") is True and [c["quantity"] for c in ana["imu"]["comparisons"]] == ["mount", "delay", "tilt"],
          f"analyze imu {ana['imu']}")
    check(ana["change_points"] == [], f"no change point on a clean run, got {ana['change_points']}")
    check(ana["saturation"] == [], f"no saturation on a clean run: {ana['saturation']}")
    check(len(ana["candidates"]) == 2, f"two candidates, got {len(ana['candidates'])}")
    for c in ana["candidates"]:
        check(list(c.keys()) == CANDIDATE_KEYS, f"candidate keys {list(c.keys())}")
        axes_of(c["residual_rms"], "candidate residual_rms")
    best = ana["candidates"][0]
    check(best["effect"] == "time_drift" and best["significant"] is True, f"best candidate {best['effect']}")
    check(best["verdict"] == "recommended" and best["family_p_value"] < ana["family_alpha"],
          f"best candidate's verdict {best['verdict']}, family-wise p {best['family_p_value']}")
    check(ana["unphysical"] == [], f"unphysical {ana['unphysical']}")
    fit = ana["fit"]
    check(["model", "residual_rms", "fit_residual_rms", "condition_number", "parameters"] == list(fit.keys())[:5],
          f"fit keys {list(fit.keys())}")
    for name, p in fit["parameters"].items():
        check(list(p.keys()) == ["value", "std", "unit"], f"fit.parameters.{name}")
    digits = max(significant_digits(v[1]) for v in ana["residual_rms"].values() if v is not None)
    check(digits > 10, f"analyze residual_rms written with {digits} significant digits at most")
    for v in ana["residual_rms"].values():
        check(v is None or math.isfinite(v[0]), "finite numbers")

    if failures:
        sys.exit(f"{len(failures)} check(s) failed")
    print("JSON outputs OK")


if __name__ == "__main__":
    main()

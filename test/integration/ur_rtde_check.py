#!/usr/bin/env python3
"""Interoperability check: the third-party client ur_rtde 1.6.5 (PyPI `ur-rtde`) against
`ftid sim-robot` (UR10/CB3 at 125 Hz and UR10e at 500 Hz).

ur_rtde always uses the standard ports (RTDE 30004, dashboard 29999, scripts 30003), so the
simulator and the client run inside a private network namespace (`unshare -rn`, loopback only);
parallel tests and a real controller setup on the host are not disturbed.

Steps: create a venv under --venv and `pip install ur-rtde==1.6.5 numpy` (exit 77 = SKIP when
pip or the namespace is unavailable); then per model: start the simulator, connect
RTDEReceiveInterface + RTDEControlInterface (which uploads ur_rtde's own rtde_control program),
stream a servoJ ramp with initPeriod/waitPeriod, check that actual_q reached the target, then
servoStop, stopScript, disconnect.
"""
import argparse
import os
import shutil
import subprocess
import sys
import time

SKIP = 77


def log(msg):
    print(msg, flush=True)


def ensure_venv(venv):
    py = os.path.join(venv, "bin", "python")
    if os.path.exists(py):
        ok = subprocess.run([py, "-c", "import rtde_control, rtde_receive"], capture_output=True)
        if ok.returncode == 0:
            return py
    try:
        subprocess.run([sys.executable, "-m", "venv", venv], check=True, capture_output=True, timeout=120)
        r = subprocess.run([py, "-m", "pip", "install", "--quiet", "ur-rtde==1.6.5", "numpy"],
                           capture_output=True, text=True, timeout=280)
    except (subprocess.SubprocessError, OSError) as e:
        log(f"SKIP: cannot create the venv / pip install ur-rtde: {e}")
        sys.exit(SKIP)
    if r.returncode != 0:
        log("SKIP: pip install ur-rtde==1.6.5 numpy failed:\n" + r.stderr[-2000:])
        sys.exit(SKIP)
    return py


CLIENT = r'''
import sys, time
import rtde_receive, rtde_control
period = float(sys.argv[1]); n = int(sys.argv[2])
r = rtde_receive.RTDEReceiveInterface("127.0.0.1")
c = rtde_control.RTDEControlInterface("127.0.0.1")
assert r.getRobotMode() == 7, r.getRobotMode()
assert r.getSafetyMode() == 1, r.getSafetyMode()
assert r.getTimestamp() > 40.0, r.getTimestamp()
q0 = list(r.getActualQ())
target = list(q0)
for i in range(1, n + 1):
    t = c.initPeriod()
    target[0] = q0[0] + 0.2 * i / n
    target[5] = q0[5] - 0.1 * i / n
    if not c.servoJ(target, 0.5, 0.5, period, 0.1, 300):
        print("servoJ returned false at step", i); sys.exit(1)
    c.waitPeriod(t)
for i in range(int(0.5 / period)):
    t = c.initPeriod(); c.servoJ(target, 0.5, 0.5, period, 0.1, 300); c.waitPeriod(t)
q = r.getActualQ()
err = max(abs(q[0] - target[0]), abs(q[5] - target[5]))
print("actual q0 %.4f target %.4f, q5 %.4f target %.4f, error %.5f rad" % (q[0], target[0], q[5], target[5], err))
assert err < 0.005, err
assert c.servoStop(), "servoStop failed"
c.stopScript()
# The program stops at the controller's next tick and the receive thread sees it a package later:
# poll (a loaded machine can outlast any fixed sleep) instead of sleeping and asserting.
deadline = time.monotonic() + 5.0
while r.getRuntimeState() == 2 and time.monotonic() < deadline:
    time.sleep(0.01)
assert r.getRuntimeState() != 2, r.getRuntimeState()
c.disconnect(); r.disconnect()
print("OK")
'''


def run_model(ftid, py, model, period, n):
    sim = subprocess.Popen([ftid, "sim-robot", "--model", model], stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True)
    try:
        line = sim.stdout.readline()
        log(line.strip())
        if "listening" not in line:
            log("FAIL: sim-robot did not start")
            return False
        r = subprocess.run([py, "-c", CLIENT, str(period), str(n)], capture_output=True, text=True, timeout=120)
        log(r.stdout.strip())
        if r.returncode != 0:
            log(f"FAIL ({model}): ur_rtde client exited {r.returncode}:\n{r.stderr[-3000:]}")
            return False
        return True
    finally:
        sim.terminate()
        try:
            sim.wait(timeout=10)
        except subprocess.TimeoutExpired:
            sim.kill()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ftid", required=True, help="path to the ftid executable")
    ap.add_argument("--venv", required=True, help="venv directory (created if missing)")
    ap.add_argument("--inner", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if not a.inner:
        py = ensure_venv(a.venv)
        unshare = shutil.which("unshare")
        ip = shutil.which("ip")
        if not unshare or not ip:
            log("SKIP: unshare/ip not available for a private network namespace")
            return SKIP
        probe = subprocess.run([unshare, "-rn", "true"], capture_output=True)
        if probe.returncode != 0:
            log("SKIP: cannot create a network namespace (unshare -rn): " + probe.stderr.decode()[-300:])
            return SKIP
        cmd = f'{ip} link set lo up && exec "{sys.executable}" "{os.path.abspath(__file__)}" --inner ' \
              f'--ftid "{a.ftid}" --venv "{a.venv}"'
        return subprocess.run([unshare, "-rn", "sh", "-c", cmd]).returncode
    py = os.path.join(a.venv, "bin", "python")
    ok = run_model(a.ftid, py, "ur10", 0.008, 250)
    ok = run_model(a.ftid, py, "ur10e", 0.002, 1000) and ok
    log("ur_rtde interoperability: " + ("PASS" if ok else "FAIL"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

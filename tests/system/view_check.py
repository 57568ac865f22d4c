#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""rmd-view's checks (tests/system/test_physics_leg.c:test_view_png runs them):

    view_check.py SRCDIR WORKDIR

An LCM log of state_t written here (the leg of examples/physics/ standing,
then crouched: known joint angles), posed by `python -m rmd.view` headless
(no DISPLAY: EGL) into PNG frames, read back with Pillow:
  - one frame per --every of the log's time, of --size;
  - the picture changes with the joint angle: the crouched frame differs
    from the standing one in many pixels, and two frames of the same
    standing pose (the passive rail settled) are all but the same;
  - bad input: a joint the model lacks, a motor mapped twice, a model that
    does not load: exit 1, a message naming it, no frame.
Prints "view_check: ok" and exits 0, else says what failed and exits 1.
"""

import math
import os
import subprocess
import sys

import lcm
import rmd
from PIL import Image

STAND, CROUCH = (0.60, -1.20), (1.05, -2.10)  # hip, knee: 0.35 m and 0.22 m


def state(utime, hip, knee):
    s = rmd.state_t()
    s.utime = utime
    s.count = 2
    s.motor = []
    for i, q in enumerate((hip, knee)):
        m = rmd.motor_state_t()
        m.index, m.lifecycle, m.position = i, rmd.state_t.LC_ENABLED, q
        s.motor.append(m)
    return s


def write_log(path):
    """1 s standing, 1 s crouched, 1 s standing, states every 10 ms."""
    log = lcm.EventLog(path, "w", overwrite=True)
    for k in range(300):
        hip, knee = CROUCH if 100 <= k < 200 else STAND
        data = state(k * 10000, hip, knee).encode()
        log.write_event(k * 10000, "RMD_STATE", data)
    log.close()


def view(src, args, env):
    return subprocess.run([sys.executable, "-m", "rmd.view",
                           os.path.join(src, "examples/physics/leg.xml")] + args,
                          env=env, capture_output=True, text=True, timeout=300)


def differ(a, b):
    """How many pixels of two frames differ by more than 24 in some channel."""
    pa, pb = a.load(), b.load()
    return sum(1 for y in range(a.height) for x in range(a.width)
               if max(abs(u - v) for u, v in zip(pa[x, y], pb[x, y])) > 24)


def main():
    src, work = sys.argv[1], sys.argv[2]
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    log = os.path.join(work, "view.lcmlog")
    write_log(log)
    out = os.path.join(work, "frames")
    r = view(src, ["--joints", "0=hip_joint,1=knee_joint", "--log", log, "--png", out,
                   "--every", "0.5", "--size", "160x120"], env)
    failures = []
    if r.returncode != 0:
        print(f"view_check: rmd-view exited {r.returncode}:\n{r.stderr}")
        return 1
    frames = sorted(os.listdir(out))
    if len(frames) != 6:
        failures.append(f"{len(frames)} frames for 3 s at --every 0.5, not 6: {frames}")
    img = [Image.open(os.path.join(out, f)).convert("RGB") for f in frames]
    if any(i.size != (160, 120) for i in img):
        failures.append(f"sizes {[i.size for i in img]}, not 160x120")
    if len(img) == 6:
        # frames at 0, 0.5 (standing), 1.0, 1.5 (crouched), 2.0, 2.5 (standing)
        same, moved = differ(img[0], img[1]), differ(img[1], img[3])
        back = differ(img[1], img[5])
        print(f"view_check: pixels that differ: standing/standing {same}, "
              f"standing/crouched {moved}, standing/standing after the crouch {back} "
              f"(of {160 * 120})")
        if moved < 300:
            failures.append(f"the crouch changed {moved} pixels only")
        if same > 30 or back > 30:
            failures.append(f"the same pose drew different pictures ({same}, {back} pixels)")
    bad = [
        (["--joints", "0=hip_joint,1=ankle"], "the model has no joint 'ankle' (its joints: "
         "rail, hip_joint, knee_joint)"),
        (["--joints", "0=hip_joint,0=knee_joint"], "motor 0 mapped twice"),
        (["--joints", "0=hip_joint,1=hip_joint"], "joint 'hip_joint' mapped twice"),
    ]
    for args, want in bad:
        d = os.path.join(work, "bad")
        r = view(src, args + ["--log", log, "--png", d], env)
        if r.returncode != 1 or want not in r.stderr or os.path.exists(d):
            failures.append(f"{args}: exit {r.returncode}, {r.stderr.strip()!r}: want exit 1, "
                            f"{want!r}, no frames")
    broken = os.path.join(work, "broken.xml")
    with open(broken, "w") as f:
        f.write("<mujoco>\n  <worldbody>\n    <body>\n</mujoco>\n")
    r = subprocess.run([sys.executable, "-m", "rmd.view", broken, "--joints", "0=a", "--log",
                        log, "--png", os.path.join(work, "bad")], env=env, capture_output=True,
                       text=True, timeout=300)
    if r.returncode != 1 or broken not in r.stderr:
        failures.append(f"a broken model: exit {r.returncode}, {r.stderr.strip()!r}")
    for f in failures:
        print(f"view_check: FAIL: {f}")
    if not failures:
        print("view_check: ok")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

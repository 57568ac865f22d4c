#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Stand and hop the leg of examples/physics/leg.xml through rmdd, with rmd.Client.

    build/rmdd --config examples/physics/leg.yaml &
    ~/rmd-venv/bin/python3 examples/physics/leg_hop.py --hops 3

The same motion as build/leg_stand (leg_stand.c), in Python: the motors
"hip" and "knee" in MIT mode (a PD in each motor), from where the leg lies
to standing at --height (the foot under the hip) over --rise seconds, then
--hops hops (crouch, push with twice the stiffness, fold, land), then
standing until Ctrl-C or --duration.  Once a second it prints the hip's
height, from the joint angles and the model's link lengths (the foot is on
the floor).  Ctrl-C: enable = 0 (rmd.Client's `with`), exit 0.  It runs
unchanged against leg.yaml (physics in rmdd's sim bus) and leg-vcan.yaml
(rmd-sim on vcan0).  Needs the rmd package (pip install ./python).
"""

import argparse
import math
import os
import signal
import sys
import time

PROG = "leg_hop.py"
DEFAULT_URL = "udpm://239.255.76.67:7667?ttl=0"
# leg.xml's (and leg.h's): the links, the foot's radius
LINK_M, FOOT_R_M, STAND_M = 0.20, 0.02, 0.35
CROUCH_M, PUSH_M = 0.27, 0.41
CROUCH_S, PUSH_S, FOLD_S, LAND_S = 0.30, 0.12, 0.25, 1.0


def height_m(hip, knee):
    """The hip's height above the floor with the foot on it."""
    return FOOT_R_M + LINK_M * math.cos(hip) + LINK_M * math.cos(hip + knee)


def pose(h):
    """(hip, knee) with the foot under the hip at height h."""
    c = min(max((h - FOOT_R_M) / (2 * LINK_M), 0.05), 0.995)
    q = math.acos(c)
    return q, -2 * q


class Stop(Exception):
    """Ctrl-C, SIGTERM or the end of --duration."""


class Leg:
    def __init__(self, client, args, rmd):
        self.c, self.a, self.rmd = client, args, rmd
        self.hip, self.knee = client.index(args.hip), client.index(args.knee)
        self.t0 = time.monotonic()
        self.next_print = self.t0
        self.stop = False

    def angles(self):
        return tuple(self.c.motor_state(i).position for i in (self.hip, self.knee))

    def move(self, frm, h, seconds, kp):
        """From pose `frm` to the pose of height h over `seconds`, at stiffness kp."""
        to = pose(h)

        def step(t):
            s = min(t / seconds, 1.0)
            b = 0.5 - 0.5 * math.cos(math.pi * s)
            slope = math.pi / 2 * math.sin(math.pi * s) / seconds
            for i, f, g in zip((self.hip, self.knee), frm, to):
                self.c.set(i, position=f + (g - f) * b, velocity=(g - f) * slope, kp=kp,
                           kd=self.a.kd)
            now = time.monotonic()
            if now >= self.next_print:
                hip, knee = self.angles()
                print(f"[{now - self.t0:6.1f} s] height {height_m(hip, knee):.3f} m  "
                      f"hip {hip:+.3f} rad  knee {knee:+.3f} rad", flush=True)
                self.next_print += 1.0
            if self.stop or (self.a.duration and now - self.t0 >= self.a.duration):
                raise Stop()

        self.c.spin(seconds, rate_hz=self.a.rate, before_send=step)
        return to

    def run(self):
        a, rmd = self.a, self.rmd
        mit = rmd.command_t.MODE_MIT
        here = self.angles()
        self.c.enable([self.hip, self.knee], mit, setpoints={
            self.hip: {"position": here[0], "kp": a.kp, "kd": a.kd},
            self.knee: {"position": here[1], "kp": a.kp, "kd": a.kd}})
        print(f"{PROG}: standing up to {a.height:.3f} m in {a.rise:g} s, kp {a.kp:g}, "
              f"kd {a.kd:g}", flush=True)
        stand = self.move(here, a.height, a.rise, a.kp)
        self.move(stand, a.height, LAND_S, a.kp)
        for n in range(a.hops):
            print(f"{PROG}: hop {n + 1}", flush=True)
            crouch = self.move(stand, CROUCH_M, CROUCH_S, a.kp)
            push = self.move(crouch, PUSH_M, PUSH_S, 2 * a.kp)
            self.move(push, a.height, FOLD_S, a.kp)
            self.move(stand, a.height, LAND_S, a.kp)
        print(f"{PROG}: standing", flush=True)
        while True:
            self.move(stand, a.height, LAND_S, a.kp)


def main():
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n")[0])
    p.add_argument("--height", type=float, default=STAND_M,
                   help=f"the hip's height, m (default {STAND_M})")
    p.add_argument("--hops", type=int, default=0, help="hops after standing (default 0)")
    p.add_argument("--kp", type=float, default=100.0, help="N*m/rad (default 100)")
    p.add_argument("--kd", type=float, default=2.0, help="N*m*s/rad (default 2)")
    p.add_argument("--rise", type=float, default=1.5, help="s to stand up (default 1.5)")
    p.add_argument("--rate", type=float, default=500.0, help="commands/s (default 500)")
    p.add_argument("--duration", type=float, default=0.0, help="s (default 0: until Ctrl-C)")
    p.add_argument("--hip", default="hip", help="the hip motor's name (default hip)")
    p.add_argument("--knee", default="knee", help="the knee motor's name (default knee)")
    p.add_argument("--url", default=os.environ.get("LCM_DEFAULT_URL", DEFAULT_URL))
    p.add_argument("--prefix", default="RMD_")
    a = p.parse_args()
    if not 0.10 <= a.height <= 0.41 or a.hops < 0 or a.rise <= 0 or not 10 <= a.rate <= 5000:
        p.error("--height 0.10..0.41, --hops >= 0, --rise > 0, --rate 10..5000")
    try:
        import rmd
        rmd.Client
    except (ImportError, AttributeError):
        print(f"{PROG}: the rmd package with its client is missing: pip install ./python "
              "(examples/README.md)", file=sys.stderr)
        return 1
    try:
        with rmd.Client(a.url, a.prefix) as c:
            leg = Leg(c, a, rmd)

            def on_signal(signum, frame):
                leg.stop = True

            signal.signal(signal.SIGINT, on_signal)
            signal.signal(signal.SIGTERM, on_signal)
            try:
                c.wait_state(2.0)
                leg.run()
            except Stop:
                pass
        print(f"{PROG}: stopped: enable = 0 sent", flush=True)
        return 0
    except rmd.RmdError as e:
        print(f"{PROG}: {e}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())

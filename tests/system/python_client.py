#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""rmd.Client against a running rmdd --sim: the Python half of test_python_client.

    python_client.py track URL   enable motor1, make it track a position, leave
                                 the `with` block (enable = 0)
    python_client.py trip URL    enable motor1, go quiet until rmdd's watchdog
                                 latches the safe action (LC_SAFE); enable
                                 motor2 (no exception for motor1): the next
                                 spin() raises MotorStopped, nothing
                                 re-enables motor1; enable() it again:
                                 enable = 0 first, READY, then ENABLED;
                                 track; leave the block
    python_client.py absent URL  no rmdd: connect() raises RmdError, saying so
    python_client.py pause URL T  enable motor1 (rmdd's command timeout T ms,
                                 state_t every 50 ms); pause PAUSES times
                                 for T - 30 ms between spins: motor1 stays
                                 ENABLED (the send() after a pause must not
                                 wait for a state_t); then a pause of 4 T:
                                 the next spin() raises MotorStopped (the
                                 watchdog, the silence named), nothing
                                 re-enables motor1; enable() it, leave
    python_client.py takeover URL  client a enables motor1; client b is
                                 rejected (health_t intruder), then takes it
                                 over (takeover = True) and drives it
    python_client.py mixed URL   two rmdd on URL: connect() or the polls after
                                 it raise MixedStreamError naming both; with
                                 allow_mixed the client keeps the first
                                 daemon's config_t and lists both
    python_client.py robot URL   two rmdd as one robot (instances left and
                                 right, docs/robot.md): rmd.Robot finds them
                                 by their heartbeats, one view of the four
                                 motors and which instance each is on, one
                                 send() drives all, clocks comparable;
                                 stop() makes every motor SAFE

It must run the installed package (pip install ./python), not a checkout:
it prints where rmd comes from.  Each step prints one line; a failed check
prints "FAIL: ..." and exits 1.
"""

import math
import sys
import time

import rmd

TRACK_S = 5.0  # the target must be reached within this
TOL_RAD = 0.01


def fail(msg):
    print(f"FAIL: {msg}", flush=True)
    sys.exit(1)


def track(c, m, target):
    """Stream position `target` until the measured position is within TOL_RAD."""
    c.set(m, position=target)
    t0 = time.monotonic()
    while time.monotonic() - t0 < TRACK_S:
        c.spin(0.05)
        ms = c.motor_state(m)
        if ms.lifecycle != rmd.state_t.LC_ENABLED:
            fail(f"motor1 left ENABLED while tracking: lifecycle {ms.lifecycle}")
        if abs(ms.position - target) < TOL_RAD:
            print(f"tracked: target {target:.4f} rad, at {ms.position:.4f} rad after "
                  f"{time.monotonic() - t0:.2f} s", flush=True)
            return
    fail(f"motor1 at {c.motor_state(m).position:.4f} rad after {TRACK_S} s, "
         f"target {target:.4f} rad")


def connect_and_enable(c):
    cfg = c.config
    print(f"config: {cfg.motor_count} motors, period {cfg.period_us} us, prefix {cfg.prefix}",
          flush=True)
    m = c.index("motor1")
    if c.name(m) != "motor1":
        fail(f"index/name: {m} is {c.name(m)}")
    try:
        c.index("no_such_motor")
        fail("index('no_such_motor') did not raise")
    except rmd.RmdError as e:
        print(f"unknown name: {e}", flush=True)
    seq0 = c.seq
    c.enable([m], rmd.command_t.MODE_POSITION)
    if c.lifecycle(m) != rmd.state_t.LC_ENABLED:
        fail(f"enable() returned with motor1 in lifecycle {c.lifecycle(m)}")
    print(f"enabled: motor1 (index {m}) after {c.seq - seq0} commands", flush=True)
    return m


def spin_until(c, done, seconds):
    """c streams its setpoints until done() or `seconds` pass; returns done()."""
    end = time.monotonic() + seconds
    while not done() and time.monotonic() < end:
        c.spin(0.02)
    return done()


PAUSES = 10


def pause(c, timeout_ms):
    """Short pauses keep the motor; a long one trips the watchdog, said (see the top)."""
    m = connect_and_enable(c)
    short = (timeout_ms - 30) / 1e3
    sent = {"last": time.monotonic(), "gap": 0.0}  # the last send, the longest silence

    def before_send(_t=None):
        now = time.monotonic()
        sent["gap"] = max(sent["gap"], now - sent["last"])
        sent["last"] = now

    slowest, worst, busy = 0.0, 0.0, 0
    for k in range(PAUSES):
        sent["gap"] = 0.0
        try:
            c.spin(0.2, before_send=before_send)
            time.sleep(short)
            before_send()
            c.send()
            slowest = max(slowest, time.monotonic() - sent["last"])
            if c.lifecycle(m) != rmd.state_t.LC_ENABLED:
                fail(f"motor1 in lifecycle {c.lifecycle(m)} after pause {k}")
        except rmd.MotorStopped as e:
            # the machine held this client off near the timeout: not the client's doing
            if sent["gap"] * 1e3 >= timeout_ms - 10:
                print(f"busy machine: a silence of {sent['gap'] * 1e3:.0f} ms around "
                      f"pause {k}: {e}", flush=True)
                busy += 1
                m = connect_and_enable(c)
                continue
            fail(f"pause {k} of {short * 1e3:.0f} ms (the longest silence "
                 f"{sent['gap'] * 1e3:.0f} ms) stopped the motor: {e}")
        worst = max(worst, sent["gap"])
    if busy > PAUSES // 2:
        fail(f"{busy} of {PAUSES} pauses held past the timeout: the machine is too busy "
             "to judge")
    print(f"pauses: {PAUSES - busy} of {short * 1e3:.0f} ms, motor1 ENABLED throughout; the "
          f"longest silence {worst * 1e3:.0f} ms, the slowest send() after one "
          f"{slowest * 1e3:.1f} ms (command timeout {timeout_ms} ms)", flush=True)
    c.spin(0.2)
    time.sleep(4 * timeout_ms / 1e3)
    try:
        c.spin(0.3)
        fail(f"spin() after a pause of {4 * timeout_ms} ms did not raise MotorStopped")
    except rmd.MotorStopped as e:
        if e.motors != [("motor1", "safe")] or not e.watchdog:
            fail(f"MotorStopped: motors {e.motors} watchdog {e.watchdog}: {e}")
        print(f"long pause: {e}", flush=True)
    c.spin(0.3)
    if c.lifecycle(m) == rmd.state_t.LC_ENABLED:
        fail("motor1 ENABLED again after the trip without enable()")
    connect_and_enable(c)
    c.spin(0.2)
    print(f"leaving: seq {c.seq}", flush=True)
    return 0


def ownership(h):
    """health_t's ownership fields, for a message."""
    if h is None:
        return "no health_t"
    return (f"owned {h.owned} owner {h.owner:#x} intruder {h.intruder:#x} "
            f"takeovers {h.takeovers}")


def takeover(url):
    """Two clients: the first to enable owns motor1; the second takes it over."""
    with rmd.Client(url) as a, rmd.Client(url) as b:
        if a.controller == b.controller:
            fail(f"two clients with the same controller id {a.controller:#x}")
        m = connect_and_enable(a)
        b.send()  # no setpoints, still another controller's command: rejected
        if not spin_until(a, lambda: a.health is not None and a.health.intruder == b.controller
                          and a.health.owned and a.health.owner == a.controller, 2.0):
            fail(f"health_t does not name b as the intruder: {ownership(a.health)}")
        if not (a.state.owned and a.state.owner == a.controller):
            fail("state_t does not name a as the owner")
        print("intruder: b rejected while a owns motor1", flush=True)
        try:
            b.enable([m], rmd.command_t.MODE_POSITION)
            fail("b.enable() while a owns motor1 did not raise")
        except rmd.NotOwner as e:
            if e.owner != a.controller or f"{a.controller:#x}" not in str(e):
                fail(f"NotOwner does not name a ({a.controller:#x}): {e}")
            print(f"not owner: {e}", flush=True)
        spin_until(a, lambda: False, 0.05)
        b.takeover = True
        b.enable([m], rmd.command_t.MODE_POSITION)
        if not spin_until(b, lambda: b.health.owner == b.controller
                          and b.health.takeovers == 1, 2.0):
            fail(f"health_t after the takeover: {ownership(b.health)}")
        a.send()  # the old owner is the intruder now
        if not spin_until(b, lambda: b.health.intruder == a.controller, 2.0):
            fail("health_t does not name a as the intruder after the takeover")
        told = []

        def a_told():  # a's next send() says who owns motor1 now
            a.poll()
            try:
                a.send()
            except rmd.NotOwner as e:
                told.append(e)
            return bool(told)
        if not spin_until(b, a_told, 2.0):
            fail(f"a.send() after the takeover did not raise NotOwner: {ownership(a.health)}")
        if told[0].owner != b.controller:
            fail(f"NotOwner names {told[0].owner:#x}, not b {b.controller:#x}: {told[0]}")
        print(f"a told: {told[0]}", flush=True)
        if b.lifecycle(m) != rmd.state_t.LC_ENABLED:
            fail(f"motor1 in lifecycle {b.lifecycle(m)} under b")
        print("takeover: b drives motor1, a is rejected", flush=True)
    return 0


def mixed(url):
    """Two daemons on the prefix: a clear error, never a silent switch."""
    c = rmd.Client(url)
    try:
        c.connect(timeout=2.0)
        c.wait(1.0)
        fail(f"no MixedStreamError after 1 s; instances heard: {c.instances}")
    except rmd.MixedStreamError as e:
        print(f"mixed: {e}", flush=True)
    c.close()
    c = rmd.Client(url)
    c.allow_mixed = True
    first = c.connect(timeout=2.0).instance
    c.wait(1.0)
    if len(c.instances) != 2 or c.config.instance != first or c.health.instance != first:
        fail(f"allow_mixed: instances {c.instances}, config of {c.config.instance:#x}, "
             f"health of {c.health.instance:#x}, first {first:#x}")
    print(f"allow_mixed: kept instance {first & (2**64 - 1):016x} of {len(c.instances)}",
          flush=True)
    c.close()
    return 0


def robot(url):
    """rmd.Robot over the daemons left and right (test_python_client's robot test)."""
    with rmd.Robot(instances=["left", "right"], url=url) as r:
        want = ["left_hip", "left_knee", "right_hip", "right_knee"]
        if sorted(r.motors) != want:
            fail(f"motors {r.motors}, want {want}")
        where = {m: r.instance_of(m) for m in r.motors}
        if where["left_knee"] != "left" or where["right_hip"] != "right":
            fail(f"instance_of: {where}")
        print(f"robot: motors {where}", flush=True)
        r.enable(r.motors, rmd.command_t.MODE_TORQUE, timeout=3.0)
        r.spin(0.5)
        lcs = {m: r.state[m].lifecycle for m in r.motors}
        if any(lc != rmd.state_t.LC_ENABLED for lc in lcs.values()):
            fail(f"not every motor ENABLED after enable() and spin(): {lcs}")
        print("robot: every motor ENABLED through one send()", flush=True)
        now_us = time.time() * 1e6
        for inst, c in r.clients.items():
            if abs(c.state.host_utime - now_us) > 2e6:
                fail(f"{inst}: state_t host_utime {c.state.host_utime} vs now {now_us:.0f}")
        off = r.max_offset_ms()
        if off is None or off > 100:
            fail(f"max_offset_ms() {off}: the peers' offsets on one host")
        print(f"robot: clocks within {off:.3f} ms", flush=True)
        r.stop("python test")
        end = time.monotonic() + 2.0
        while time.monotonic() < end and not all(
                r.state[m].lifecycle == rmd.state_t.LC_SAFE for m in r.motors):
            r.poll(0.02)
        lcs = {m: rmd.lifecycle_name(r.state[m].lifecycle) for m in r.motors}
        if any(lc != "safe" for lc in lcs.values()):
            fail(f"after stop(): {lcs}")
        print(f"robot: stop() -> {lcs}", flush=True)
        r.poll(0.2)
        for inst, c in r.clients.items():
            c.wait(0.15)
            if "python test" not in c.health.robot_reason:
                fail(f"{inst}: health_t robot_reason {c.health.robot_reason!r}")
        print("robot: each daemon says why", flush=True)
    return 0


def main():
    what, url = sys.argv[1], sys.argv[2]
    print(f"rmd from {rmd.__file__}", flush=True)
    if what == "robot":
        return robot(url)
    if what == "mixed":
        return mixed(url)
    if what == "takeover":
        return takeover(url)
    if what == "pause":
        with rmd.Client(url) as c:
            pause(c, int(sys.argv[3]))
        ms = c.motor_state(c.index("motor1"))
        print(f"left: motor1 lifecycle {ms.lifecycle}", flush=True)
        return 0
    if what == "absent":
        c = rmd.Client(url)
        t0 = time.monotonic()
        try:
            c.connect(timeout=1.0)
            fail("connect() without rmdd did not raise")
        except rmd.RmdError as e:
            print(f"absent: after {time.monotonic() - t0:.1f} s: {e}", flush=True)
        c.close()
        return 0

    with rmd.Client(url) as c:
        if c.seq != 0:
            fail(f"a new client's first seq is {c.seq}, not 0")
        m = connect_and_enable(c)
        start = c.motor_state(m).position
        if not math.isfinite(start):
            fail(f"motor1's position is {start}")
        if what == "trip":
            # quiet: rmdd's watchdog (command_timeout_ms) latches the safe action
            end = time.monotonic() + 2.0
            while c.lifecycle(m) != rmd.state_t.LC_SAFE and time.monotonic() < end:
                c.poll(0.05)
            if c.lifecycle(m) != rmd.state_t.LC_SAFE:
                fail(f"no LC_SAFE 2 s after the commands stopped: lifecycle {c.lifecycle(m)}")
            print("tripped: motor1 is safe", flush=True)
            c.wait(0.3)  # health_t (10 Hz) says the watchdog tripped
            # another group: enable() raises nothing for motor1, and enables motor2
            m2 = c.index("motor2")
            c.enable([m2], rmd.command_t.MODE_POSITION)
            if c.lifecycle(m2) != rmd.state_t.LC_ENABLED:
                fail(f"enable() returned with motor2 in lifecycle {c.lifecycle(m2)}")
            print("enabled: motor2 beside the stopped motor1", flush=True)
            try:
                c.spin(0.1)
                fail("spin() after the watchdog trip did not raise MotorStopped")
            except rmd.MotorStopped as e:
                if e.motors != [("motor1", "safe")] or not e.watchdog:
                    fail(f"MotorStopped: motors {e.motors} watchdog {e.watchdog}: {e}")
                print(f"stopped: {e}", flush=True)
            c.spin(0.5)  # no exception again, and no enable = 1 without enable()
            if c.lifecycle(m) == rmd.state_t.LC_ENABLED:
                fail("motor1 ENABLED again after the trip without enable()")
            try:
                c.set(m, position=start)
                fail("set() on a stopped motor did not raise")
            except rmd.RmdError as e:
                print(f"set after the trip: {e}", flush=True)
            m = connect_and_enable(c)
            start = c.motor_state(m).position
        try:
            c.set(m, position=0.1, velocity=float("nan"))
            fail("set(velocity=nan) did not raise")
        except ValueError as e:
            if "motor1" not in str(e) or "velocity" not in str(e):
                fail(f"ValueError does not name motor1 and velocity: {e}")
            print(f"nan: {e}", flush=True)
        track(c, m, start + 0.5)
        track(c, m, start - 0.2)
        print(f"leaving: seq {c.seq}", flush=True)
    ms = c.motor_state(m)
    print(f"left: motor1 lifecycle {ms.lifecycle}", flush=True)
    if ms.lifecycle != rmd.state_t.LC_READY:
        fail(f"after the with block motor1 is in lifecycle {ms.lifecycle}, not READY")
    return 0


if __name__ == "__main__":
    sys.exit(main())

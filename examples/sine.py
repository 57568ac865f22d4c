#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""An rmdd controller in Python: every motor that can follows a sine.

    python3 -m venv ~/rmd-venv             # Debian 12 / Ubuntu 24.04: pip wants a venv
    ~/rmd-venv/bin/pip install ./python    # the rmd package (types, client) and lcm
    build/rmdd --config examples/sim-sine.yaml &
    ~/rmd-venv/bin/python3 examples/sine.py --mode position
    ~/rmd-venv/bin/python3 examples/sine.py --mode mit --kp 20 --kd 1

It talks to rmdd through rmd.Client (python/rmd/client.py): asks for its
configuration (config_t), drives every motor whose modes allow the chosen
mode, publishes command_t at --rate Hz with a sine around each motor's
starting position, and once a second prints each motor's tracking error
(target - measured position from state_t: RMS and largest magnitude).
Ctrl-C (or --duration) sends enable = 0 to every motor it drove and exits 0.
Without an answer from rmdd within 2 s it says so and exits 1.

The rmd package is PYTHONPATH's (`make lcm-python`: PYTHONPATH=build/python),
else the installed one, else build/python beside this file's directory.
examples/README.md has the rest.
"""

import argparse
import math
import os
import signal
import sys
import time

PROG = "sine.py"
DEFAULT_URL = "udpm://239.255.76.67:7667?ttl=0"
CONFIG_WAIT_S = 2.0  # no config_t within this: rmdd is not running
STATE_WAIT_S = 1.0  # no state_t for this long: rmdd went away
READY_WAIT_S = 0.5  # enable = 0 before enable = 1: wait this long for READY (then ENABLED)

VENV_HINT = ("python3 -m venv ~/rmd-venv && ~/rmd-venv/bin/pip install ./python, then "
             "~/rmd-venv/bin/python3 examples/sine.py (examples/README.md)")


def die(msg, status=1):
    print(f"{PROG}: {msg}", file=sys.stderr, flush=True)
    sys.exit(status)


def import_rmd():
    """The rmd package with its client, with a message saying how to get it."""
    try:
        import lcm  # noqa: F401
    except ImportError:
        die(f"the Python module `lcm` is missing: {VENV_HINT}")
    top = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    try:
        import rmd
    except ImportError:
        sys.path.append(os.path.join(top, "build", "python"))
        try:
            import rmd
        except ImportError:
            die(f"the rmd package is missing: {VENV_HINT}")
    if not hasattr(rmd, "Client"):
        # bare types from lcm-gen (no client): the client of this checkout
        src = os.path.join(top, "python", "rmd")
        if not os.path.exists(os.path.join(src, "client.py")):
            die(f"this rmd package ({rmd.__path__[0]}) has no client: {VENV_HINT}")
        rmd.__path__.append(src)
        from rmd.client import Client, RmdError
        rmd.Client, rmd.RmdError = Client, RmdError
    return rmd


def parse_args():
    p = argparse.ArgumentParser(
        prog=PROG,
        description="Make rmdd's motors follow a sine, in position or MIT mode, and "
        "print the tracking error once a second.")
    p.add_argument("--mode", choices=["position", "mit"], default="position",
                   help="command_t mode (default position)")
    p.add_argument("--amplitude", type=float, default=0.5, help="rad (default 0.5)")
    p.add_argument("--freq", type=float, default=0.5, help="Hz (default 0.5)")
    p.add_argument("--rate", type=float, default=500.0,
                   help="commands per second (default 500)")
    p.add_argument("--kp", type=float, default=20.0,
                   help="MIT stiffness, N*m/rad (default 20)")
    p.add_argument("--kd", type=float, default=1.0,
                   help="MIT damping, N*m*s/rad (default 1)")
    p.add_argument("--url", default=os.environ.get("LCM_DEFAULT_URL", DEFAULT_URL),
                   help=f"LCM URL (default $LCM_DEFAULT_URL, else {DEFAULT_URL})")
    p.add_argument("--prefix", default="RMD_", help="rmdd's channel prefix (default RMD_)")
    p.add_argument("--duration", type=float, default=0.0,
                   help="stop after this many seconds (default 0: until Ctrl-C)")
    a = p.parse_args()
    for name in ("amplitude", "freq", "kp", "kd", "duration"):
        v = getattr(a, name)
        if not math.isfinite(v) or v < 0:
            die(f"--{name} {v}: a finite number >= 0", 2)
    if not math.isfinite(a.rate) or not 1 <= a.rate <= 10000:
        die(f"--rate {a.rate}: 1..10000 Hz", 2)
    return a


class Stopped(Exception):
    """Ctrl-C or SIGTERM before the sine runs."""


class Motor:
    """A motor we drive: its configuration, the sine's centre and the error statistics."""

    def __init__(self, cfg):
        self.cfg = cfg
        self.index = cfg.index
        self.name = cfg.name
        self.center = 0.0
        self.lifecycle = -1
        self.was_enabled = False
        self.stopped = False  # the client stopped driving it (MotorStopped, NotOwner)
        self.window = [0.0, 0.0, 0]  # sum of squares, max |error|, samples (this second)
        self.total = [0.0, 0.0, 0]  # the same over the whole run

    def add_error(self, e):
        for acc in (self.window, self.total):
            acc[0] += e * e
            acc[1] = max(acc[1], abs(e))
            acc[2] += 1


def report(acc, m, lc_name):
    """'rms X rad  max Y rad  (N states)' of an accumulator."""
    sq, mx, n = acc
    if n == 0:
        return f"none: the motor is {lc_name(m.lifecycle)}, not enabled"
    return f"rms {math.sqrt(sq / n):.5f} rad  max {mx:.5f} rad  ({n} states)"


class Controller:
    def __init__(self, args, rmd):
        self.a = args
        self.rmd = rmd
        from rmd.client import lifecycle_name
        self.lc_name = lifecycle_name
        self.motors = []
        self.t0 = 0.0
        self.stop = False
        self.running = False  # the sine runs: a signal only sets stop
        try:
            self.c = rmd.Client(args.url, args.prefix, on_state=self.on_state)
        except rmd.RmdError as e:
            die(str(e))
        self.mode = (rmd.command_t.MODE_MIT if args.mode == "mit"
                     else rmd.command_t.MODE_POSITION)

    def on_signal(self, signum, frame):
        self.stop = True
        if not self.running:
            raise Stopped()

    def on_state(self, s):
        if self.t0:
            self.track(s, self.c.state_rx - self.t0)

    # ---- commands --------------------------------------------------------

    def setpoint(self, m, t):
        """The sine at time t, for one motor: set() arguments."""
        w = 2 * math.pi * self.a.freq
        sp = {"position": m.center + self.a.amplitude * math.sin(w * t)}
        if self.a.mode == "mit":
            sp.update(velocity=self.a.amplitude * w * math.cos(w * t), kp=self.a.kp,
                      kd=self.a.kd)
        # position mode: max_velocity 0 = the motor's configured velocity_max
        return sp

    def publish(self, t):
        """One command_t with every driven motor on the sine at time t."""
        try:
            for m in self.motors:
                if not m.stopped and m.index not in getattr(self.c, "stopped", {}):
                    self.c.set(m.index, **self.setpoint(m, t))
            self.c.send()
        except self.rmd.RmdError as e:
            # MotorStopped (SAFE, LOST, FAULT) or NotOwner (taken over): the
            # client no longer drives them; the sine goes on for the others
            print(f"{PROG}: {e}", flush=True)
            names = {n for n, _lc in getattr(e, "motors", [])}
            for m in self.motors:
                if not names or m.name in names:
                    m.stopped = True

    def target(self, m, t):
        return m.center + self.a.amplitude * math.sin(2 * math.pi * self.a.freq * t)

    def track(self, s, t):
        """Tracking error and lifecycle changes from one state_t."""
        for m in self.motors:
            if m.index >= s.count:
                continue
            ms = s.motor[m.index]
            if ms.lifecycle != m.lifecycle:
                # said once: a motor that leaves ENABLED (safe action, fault, loss)
                if m.was_enabled:
                    print(f"{PROG}: {m.name}: now {self.lc_name(ms.lifecycle)}", flush=True)
                m.lifecycle = ms.lifecycle
                m.was_enabled |= ms.lifecycle == self.rmd.state_t.LC_ENABLED
            if ms.lifecycle == self.rmd.state_t.LC_ENABLED and math.isfinite(ms.position):
                m.add_error(self.target(m, t) - ms.position)

    # ---- the run ---------------------------------------------------------

    def choose_motors(self):
        rmd = self.rmd
        c = self.c.config
        mit = self.a.mode == "mit"
        bit = (rmd.motor_config_t.MODE_BIT_MIT if mit
               else rmd.motor_config_t.MODE_BIT_POSITION)
        left_out = []
        for mc in c.motor[:c.motor_count]:
            if not mc.modes & bit:
                left_out.append(mc.name)
                continue
            if mit and not (mc.kp_min <= self.a.kp <= mc.kp_max
                            and mc.kd_min <= self.a.kd <= mc.kd_max):
                die(f"{mc.name}: --kp {self.a.kp:g} --kd {self.a.kd:g} outside its ranges "
                    f"kp {mc.kp_min:g}..{mc.kp_max:g}, kd {mc.kd_min:g}..{mc.kd_max:g}", 2)
            self.motors.append(Motor(mc))
        print(f"{PROG}: rmdd at {self.a.url}: {c.motor_count} motors on {c.bus_count} "
              f"buses, loop {1e6 / c.period_us:.0f} Hz, prefix {c.prefix}", flush=True)
        if not self.motors:
            die(f"no motor of rmdd's configuration takes {self.a.mode} mode "
                "(examples/sim-sine.yaml has both kinds)")
        if left_out:
            print(f"{PROG}: left alone (no {self.a.mode} mode): {' '.join(left_out)}",
                  flush=True)

    def set_centers(self):
        """Each sine is centred on the motor's position, moved inside its limits."""
        if self.c.state is None:
            try:
                self.c.wait_state(STATE_WAIT_S)
            except self.rmd.RmdError as e:
                die(str(e))
        amp = self.a.amplitude
        for m in self.motors:
            ms = self.c.motor_state(m.index)
            p = ms.position if ms is not None and math.isfinite(ms.position) else 0.0
            lo, hi = m.cfg.position_min + amp, m.cfg.position_max - amp
            if lo > hi:
                die(f"{m.name}: --amplitude {amp:g} does not fit its position limits "
                    f"{m.cfg.position_min:g}..{m.cfg.position_max:g} rad", 2)
            m.center = min(max(p, lo), hi)

    def enable(self):
        """rmd.Client.enable: enable = 0 until READY (a motor back from a fault or
        loss needs it), then enable = 1 holding the sine's start."""
        start = {m.index: dict(self.setpoint(m, 0.0), velocity=0.0) for m in self.motors}
        bad = self.c.enable([m.index for m in self.motors], self.mode, setpoints=start,
                            timeout=READY_WAIT_S, strict=False)
        for name, lc in bad:
            print(f"{PROG}: {name}: {lc}, not ready: it may not follow", flush=True)

    def print_window(self, t):
        for m in self.motors:
            print(f"[{t:6.1f} s] {m.name:<12} {self.a.mode:<8} tracking error "
                  f"{report(m.window, m, self.lc_name)}", flush=True)
            m.window = [0.0, 0.0, 0]

    def run(self):
        try:
            try:
                self.c.connect(CONFIG_WAIT_S)
            except self.rmd.RmdError as e:
                die(str(e))
            self.choose_motors()
            self.set_centers()
            a = self.a
            names = " ".join(m.name for m in self.motors)
            print(f"{PROG}: {a.mode} mode on {len(self.motors)} motors: {names}; amplitude "
                  f"{a.amplitude:g} rad, {a.freq:g} Hz, {a.rate:g} commands/s"
                  + (f", kp {a.kp:g}, kd {a.kd:g}" if a.mode == "mit" else ""), flush=True)
            self.enable()
            self.running = True
        except Stopped:
            if not self.motors:
                return 0
            self.running = True
        except self.rmd.RmdError as e:  # MixedStreamError: two rmdd on the prefix
            return self.refuse(e)
        try:
            status = self.sine() if not self.stop else 0
        except self.rmd.RmdError as e:
            return self.refuse(e)
        self.shutdown()
        return status

    def refuse(self, e):
        """Two rmdd answer on the prefix (rmd.MixedStreamError): enable = 0, exit 1."""
        print(f"{PROG}: {e}: stopping", file=sys.stderr, flush=True)
        self.c.allow_mixed = True  # the enable = 0 goes out to both
        self.shutdown()
        return 1

    def sine(self):
        """Stream the sine until a stop; 1 when rmdd stops publishing state."""
        a = self.a
        period = 1.0 / a.rate
        self.t0 = time.monotonic()
        next_pub = self.t0
        next_print = self.t0 + 1.0
        last_states, last_look = self.c.n_states, self.t0
        while not self.stop:
            now = time.monotonic()
            t = now - self.t0
            if a.duration and t >= a.duration:
                break
            if now >= next_pub:
                self.publish(t)
                next_pub += period
                if next_pub <= now:  # late: skip, never catch up in a burst
                    next_pub = now + period
            if now >= next_print:
                self.print_window(t)
                next_print += 1.0
            if now - last_look >= STATE_WAIT_S:
                if self.c.n_states == last_states:
                    print(f"{PROG}: no state_t from rmdd for {STATE_WAIT_S:.0f} s: stopping",
                          file=sys.stderr, flush=True)
                    return 1
                last_states, last_look = self.c.n_states, now
            self.c.poll(max(0.0, min(next_pub, next_print) - time.monotonic()))
        return 0

    def shutdown(self):
        """enable = 0 for every driven motor, until rmdd shows them off (3 at least)."""
        self.t0 = 0.0  # the sine is over: READY now is no news
        self.c.disable()
        self.c.close()
        print(f"{PROG}: stopped: enable = 0 sent to {len(self.motors)} motors", flush=True)
        for m in self.motors:
            print(f"{PROG}: whole run: {m.name:<12} {self.a.mode:<8} tracking error "
                  f"{report(m.total, m, self.lc_name)}", flush=True)


def main():
    args = parse_args()
    rmd = import_rmd()
    ctl = Controller(args, rmd)
    signal.signal(signal.SIGINT, ctl.on_signal)
    signal.signal(signal.SIGTERM, ctl.on_signal)
    return ctl.run()


if __name__ == "__main__":
    sys.exit(main())

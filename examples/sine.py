#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""An rmdd controller in Python: every motor that can follows a sine.

    pip install lcm                      # the LCM Python module
    make lcm-python                      # the rmd types, in build/python
    rmdd --config examples/sim-sine.yaml &
    python3 examples/sine.py --mode position
    python3 examples/sine.py --mode mit --kp 20 --kd 1

It asks rmdd for its configuration (config_t on PREFIX + CONFIG, requested on
PREFIX + CONFIG_REQUEST), drives every motor whose modes allow the chosen
mode, publishes command_t at --rate Hz with a sine around each motor's
starting position, and once a second prints each motor's tracking error
(target - measured position from state_t: RMS and largest magnitude).
Ctrl-C (or --duration) sends enable = 0 to every motor it drove and exits 0.
Without an answer from rmdd within 2 s it says so and exits 1.

The rmd types are found through PYTHONPATH (PYTHONPATH=build/python), else in
build/python beside this file's directory.  examples/README.md has the rest.
"""

import argparse
import math
import os
import select
import signal
import sys
import time

PROG = "sine.py"
DEFAULT_URL = "udpm://239.255.76.67:7667?ttl=0"
CONFIG_WAIT_S = 2.0  # no config_t within this: rmdd is not running
STATE_WAIT_S = 1.0  # no state_t for this long: rmdd went away
READY_WAIT_S = 0.5  # enable = 0 before enable = 1: wait this long for READY

LC_NAMES = ["probe", "ready", "enabled", "fault", "lost", "safe"]


def die(msg, status=1):
    print(f"{PROG}: {msg}", file=sys.stderr, flush=True)
    sys.exit(status)


def import_modules():
    """The LCM module and the generated rmd package, with a message saying how to get them."""
    try:
        import lcm  # noqa: F401
    except ImportError:
        die("the Python module `lcm` is missing: pip install lcm")
    try:
        import rmd  # noqa: F401
    except ImportError:
        here = os.path.dirname(os.path.abspath(__file__))
        sys.path.append(os.path.join(here, "..", "build", "python"))
        try:
            import rmd  # noqa: F401
        except ImportError:
            die("the rmd types are missing: run `make lcm-python` and set "
                "PYTHONPATH=build/python")
    import lcm
    import rmd
    return lcm, rmd


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


class Motor:
    """A motor we drive: its configuration, the sine's centre and the error statistics."""

    def __init__(self, cfg):
        self.cfg = cfg
        self.index = cfg.index
        self.name = cfg.name
        self.center = 0.0
        self.lifecycle = -1
        self.was_enabled = False
        self.window = [0.0, 0.0, 0]  # sum of squares, max |error|, samples (this second)
        self.total = [0.0, 0.0, 0]  # the same over the whole run

    def add_error(self, e):
        for acc in (self.window, self.total):
            acc[0] += e * e
            acc[1] = max(acc[1], abs(e))
            acc[2] += 1


def lc_name(lc):
    return LC_NAMES[lc] if 0 <= lc < len(LC_NAMES) else "unknown"


def report(acc, m):
    """'rms X rad  max Y rad  (N states)' of an accumulator."""
    sq, mx, n = acc
    if n == 0:
        return f"none: the motor is {lc_name(m.lifecycle)}, not enabled"
    return f"rms {math.sqrt(sq / n):.5f} rad  max {mx:.5f} rad  ({n} states)"


class Controller:
    def __init__(self, args, lcm, rmd):
        self.a = args
        self.rmd = rmd
        try:
            self.lc = lcm.LCM(args.url)
        except (IOError, OSError, RuntimeError) as e:
            die(f"LCM {args.url}: {e} (multicast not routable? see docs/lcm.md)")
        self.config = None
        self.state = None
        self.state_rx = 0.0
        self.n_states = 0
        self.motors = []
        self.seq = 0
        self.t0 = 0.0
        self.stop = False
        pre = args.prefix
        self.ch_command = pre + "COMMAND"
        self.lc.subscribe(pre + "CONFIG", self.on_config)
        self.lc.subscribe(pre + "STATE", self.on_state)

    # ---- LCM -------------------------------------------------------------

    def on_config(self, channel, data):
        try:
            self.config = self.rmd.config_t.decode(data)
        except ValueError:
            pass  # another type on the channel: not ours

    def on_state(self, channel, data):
        try:
            s = self.rmd.state_t.decode(data)
        except ValueError:
            return
        self.state = s
        self.state_rx = time.monotonic()
        self.n_states += 1
        if self.t0:
            self.track(s, self.state_rx - self.t0)

    def handle_until(self, deadline):
        """Handle messages until `deadline` (time.monotonic()) or a stop."""
        fd = self.lc.fileno()
        while not self.stop:
            left = deadline - time.monotonic()
            if left <= 0:
                return
            r, _, _ = select.select([fd], [], [], left)
            if r:
                self.lc.handle()

    def request_config(self):
        req = self.rmd.config_request_t()
        req.utime = int(time.monotonic() * 1e6)
        self.lc.publish(self.a.prefix + "CONFIG_REQUEST", req.encode())

    # ---- commands --------------------------------------------------------

    def publish(self, enable, t):
        """One command_t for every driven motor: the sine at time t, or enable = 0."""
        rmd = self.rmd
        msg = rmd.command_t()
        msg.utime = int(time.monotonic() * 1e6)
        msg.seq = self.seq
        self.seq += 1
        msg.count = len(self.motors)
        w = 2 * math.pi * self.a.freq
        mit = self.a.mode == "mit"
        for k, m in enumerate(self.motors):
            c = msg.motor[k]
            c.index = m.index
            c.enable = enable
            c.mode = rmd.command_t.MODE_MIT if mit else rmd.command_t.MODE_POSITION
            c.position = m.center + self.a.amplitude * math.sin(w * t)
            if mit:
                c.velocity = self.a.amplitude * w * math.cos(w * t)
                c.kp = self.a.kp
                c.kd = self.a.kd
            # position mode: max_velocity 0 = the motor's configured velocity_max
        self.lc.publish(self.ch_command, msg.encode())

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
                    print(f"{PROG}: {m.name}: now {lc_name(ms.lifecycle)}", flush=True)
                m.lifecycle = ms.lifecycle
                m.was_enabled |= ms.lifecycle == self.rmd.state_t.LC_ENABLED
            if ms.lifecycle == self.rmd.state_t.LC_ENABLED and math.isfinite(ms.position):
                m.add_error(self.target(m, t) - ms.position)

    # ---- the run ---------------------------------------------------------

    def wait_config(self):
        end = time.monotonic() + CONFIG_WAIT_S
        while self.config is None and not self.stop:
            now = time.monotonic()
            if now >= end:
                die(f"no rmd.config_t on {self.a.prefix}CONFIG within {CONFIG_WAIT_S:.0f} s: "
                    f"is rmdd running, with --lcm-url {self.a.url} and prefix "
                    f"{self.a.prefix}?")
            self.request_config()
            self.handle_until(min(end, now + 0.25))

    def choose_motors(self):
        rmd = self.rmd
        c = self.config
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
        end = time.monotonic() + STATE_WAIT_S
        while self.state is None and time.monotonic() < end and not self.stop:
            self.handle_until(min(end, time.monotonic() + 0.05))
        if self.state is None:
            die(f"no rmd.state_t on {self.a.prefix}STATE within {STATE_WAIT_S:.0f} s")
        amp = self.a.amplitude
        for m in self.motors:
            p = self.state.motor[m.index].position if m.index < self.state.count else 0.0
            p = p if math.isfinite(p) else 0.0
            lo, hi = m.cfg.position_min + amp, m.cfg.position_max - amp
            if lo > hi:
                die(f"{m.name}: --amplitude {amp:g} does not fit its position limits "
                    f"{m.cfg.position_min:g}..{m.cfg.position_max:g} rad", 2)
            m.center = min(max(p, lo), hi)

    def disable_first(self):
        """enable = 0, then wait for READY: a motor back from a fault or loss needs it."""
        self.publish(False, 0.0)
        end = time.monotonic() + READY_WAIT_S
        ready = self.rmd.state_t.LC_READY
        while time.monotonic() < end and not self.stop:
            self.handle_until(min(end, time.monotonic() + 0.01))
            s = self.state
            if all(m.index < s.count and s.motor[m.index].lifecycle == ready
                   for m in self.motors):
                return
        for m in self.motors:
            lc = self.state.motor[m.index].lifecycle
            if lc != ready:
                print(f"{PROG}: {m.name}: {lc_name(lc)}, not ready: it may not follow",
                      flush=True)

    def print_window(self, t):
        for m in self.motors:
            print(f"[{t:6.1f} s] {m.name:<12} {self.a.mode:<8} tracking error "
                  f"{report(m.window, m)}", flush=True)
            m.window = [0.0, 0.0, 0]

    def run(self):
        a = self.a
        self.wait_config()
        if self.stop:
            return 0
        self.choose_motors()
        self.set_centers()
        names = " ".join(m.name for m in self.motors)
        print(f"{PROG}: {a.mode} mode on {len(self.motors)} motors: {names}; amplitude "
              f"{a.amplitude:g} rad, {a.freq:g} Hz, {a.rate:g} commands/s"
              + (f", kp {a.kp:g}, kd {a.kd:g}" if a.mode == "mit" else ""), flush=True)
        self.disable_first()
        period = 1.0 / a.rate
        self.t0 = time.monotonic()
        next_pub = self.t0
        next_print = self.t0 + 1.0
        last_states, last_look = self.n_states, self.t0
        status = 0
        while not self.stop:
            now = time.monotonic()
            t = now - self.t0
            if a.duration and t >= a.duration:
                break
            if now >= next_pub:
                self.publish(True, t)
                next_pub += period
                if next_pub <= now:  # late: skip, never catch up in a burst
                    next_pub = now + period
            if now >= next_print:
                self.print_window(t)
                next_print += 1.0
            if now - last_look >= STATE_WAIT_S:
                if self.n_states == last_states:
                    print(f"{PROG}: no state_t from rmdd for {STATE_WAIT_S:.0f} s: stopping",
                          file=sys.stderr, flush=True)
                    status = 1
                    break
                last_states, last_look = self.n_states, now
            self.handle_until(min(next_pub, next_print))
        self.shutdown()
        return status

    def shutdown(self):
        """enable = 0 for every driven motor (three times: UDP may drop one)."""
        for _ in range(3):
            self.publish(False, time.monotonic() - self.t0)
            time.sleep(0.005)
        print(f"{PROG}: stopped: enable = 0 sent to {len(self.motors)} motors", flush=True)
        for m in self.motors:
            print(f"{PROG}: whole run: {m.name:<12} {self.a.mode:<8} tracking error "
                  f"{report(m.total, m)}", flush=True)


def main():
    args = parse_args()
    lcm, rmd = import_modules()
    ctl = Controller(args, lcm, rmd)

    def on_signal(signum, frame):
        ctl.stop = True

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    return ctl.run()


if __name__ == "__main__":
    sys.exit(main())

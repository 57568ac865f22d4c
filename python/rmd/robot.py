# SPDX-License-Identifier: MIT
"""Several rmdd as one robot: rmd.Robot (docs/robot.md).

    import rmd

    with rmd.Robot(instances=["left_leg", "right_leg"]) as r:  # or prefixes=[...]
        r.enable(["left_knee", "right_knee"], rmd.command_t.MODE_TORQUE)
        r.set("left_knee", torque=0.5)
        r.spin(2.0)                              # one send() to every instance
        print(r.state["right_knee"].position, r.instance_of("right_knee"))

A robot is several daemons, each a robot.instance with a channel prefix of its
own, on one LCM network.  Robot opens one rmd.Client per instance (one
controller id for all of them) and shows them as one: motors by name (unique
across the robot: a clash raises RmdError naming both instances), one `state`
view, one send() and spin(), which instance a motor lives on.  With
`instances`, the prefixes come from the daemons' heartbeats (heartbeat_t on
RMD_ROBOT_HEARTBEAT carries each one's prefix).  stop() publishes the robot's
all-stop (robot_stop_t on RMD_ROBOT_STOP).

Clocks: each state_t carries its host's clock (host_utime); health_t's
peer[].offset_ns says how far each daemon believes its peers' clocks are from
its own.  `max_offset_ms()` is the largest any daemon reports: a controller
that compares states across hosts should refuse to run beyond what its
control can bear (docs/robot.md "Clocks").
"""

import os
import time

from .client import DEFAULT_URL, Client, RmdError

HEARTBEAT_CHANNEL = "RMD_ROBOT_HEARTBEAT"
STOP_CHANNEL = "RMD_ROBOT_STOP"


def discover(url=None, timeout=1.0):
    """{instance: prefix} of the daemons whose heartbeats arrive within `timeout` s."""
    import lcm
    from . import heartbeat_t

    found = {}
    lc = lcm.LCM(url or os.environ.get("LCM_DEFAULT_URL") or DEFAULT_URL)

    def on_hb(channel, data):
        try:
            hb = heartbeat_t.decode(data)
        except ValueError:
            return
        found.setdefault(hb.instance, hb.prefix)

    sub = lc.subscribe(HEARTBEAT_CHANNEL, on_hb)
    end = time.monotonic() + timeout
    try:
        while time.monotonic() < end:
            lc.handle_timeout(max(1, int((end - time.monotonic()) * 1000)))
    finally:
        lc.unsubscribe(sub)
    return found


class _StateView:
    """robot.state[name]: the newest motor_state_t of that motor, from its instance."""

    def __init__(self, robot):
        self._r = robot

    def __getitem__(self, name):
        c, i = self._r._where(name)
        if c.state is None or i >= c.state.count:
            raise KeyError(f"{name}: no state_t from {self._r.instance_of(name)} yet")
        return c.state.motor[i]

    def __contains__(self, name):
        return name in self._r._motors

    def __iter__(self):
        return iter(self._r._motors)

    def items(self):
        return [(n, self[n]) for n in self._r._motors]


class Robot:
    """Several rmdd (one Client each) as one robot.

    Robot(prefixes=None, instances=None, url=None, controller=None): prefixes,
    a list of channel prefixes; or instances, a list of robot.instance names
    whose prefixes connect() finds from their heartbeats.

    Attributes: clients {instance: Client}; state (a view: state[name] is the
    motor's motor_state_t); motors (every motor name, instance by instance).
    """

    def __init__(self, prefixes=None, instances=None, url=None, controller=None):
        if not prefixes and not instances:
            raise RmdError("Robot: give prefixes or instances")
        self.url = url or os.environ.get("LCM_DEFAULT_URL") or DEFAULT_URL
        self._prefixes = list(prefixes or [])
        self._instances = list(instances or [])
        self.controller = (int.from_bytes(os.urandom(8), "big", signed=True)
                           if controller is None else int(controller))
        self.clients = {}
        self._motors = {}  # name -> (instance, index)
        self.state = _StateView(self)

    # ---- opening -------------------------------------------------------------

    def connect(self, timeout=2.0):
        """Open and connect every instance; map the motors.  RmdError naming what is missing."""
        prefixes = list(self._prefixes)
        if self._instances:
            found = {}
            end = time.monotonic() + timeout
            while time.monotonic() < end and not all(i in found for i in self._instances):
                found.update(discover(self.url, min(0.5, max(0.05, end - time.monotonic()))))
            missing = [i for i in self._instances if i not in found]
            if missing:
                raise RmdError(f"no heartbeat from {', '.join(missing)} on {self.url} within "
                               f"{timeout:g} s (robot.instance set? docs/robot.md)")
            prefixes += [found[i] for i in self._instances]
        for p in prefixes:
            c = Client(self.url, p, controller=self.controller)
            c.connect(timeout)
            name = c.config.instance_name or p
            if name in self.clients:
                raise RmdError(f"two daemons are instance {name} (prefixes "
                               f"{self.clients[name].prefix} and {p})")
            self.clients[name] = c
        for inst, c in self.clients.items():
            for m in c.config.motor[:c.config.motor_count]:
                if m.name in self._motors:
                    raise RmdError(f"motor {m.name} is on instance {self._motors[m.name][0]} "
                                   f"and on {inst}: motor names must be unique across the "
                                   "robot (docs/robot.md)")
                self._motors[m.name] = (inst, m.index)
        for c in self.clients.values():
            c.beside = self._beside(c)
        return self

    def _beside(self, this):
        """While `this` client streams enable()/disable(), the others keep sending."""
        def others():
            for c in self.clients.values():
                if c is not this and c._cmd:
                    c.send()
        return others

    def __enter__(self):
        if not self.clients:
            self.connect()
        return self

    def __exit__(self, exc_type, exc, tb):
        self.close()
        return False

    def close(self):
        """Each client's close(): enable = 0 to what it enabled."""
        for c in self.clients.values():
            c.beside = None
            c.close()

    # ---- motors --------------------------------------------------------------

    @property
    def motors(self):
        return list(self._motors)

    def _where(self, name):
        try:
            inst, i = self._motors[name]
        except KeyError:
            raise RmdError(f"no motor {name} on this robot (motors: "
                           f"{', '.join(self._motors)})") from None
        return self.clients[inst], i

    def instance_of(self, name):
        """The robot.instance (else the prefix) of the daemon that drives motor `name`."""
        self._where(name)
        return self._motors[name][0]

    def client_of(self, name):
        return self._where(name)[0]

    def _by_client(self, names):
        groups = {}
        for n in names:
            c, i = self._where(n)
            groups.setdefault(id(c), (c, []))[1].append(i)
        return list(groups.values())

    def enable(self, names, mode, timeout=1.0):
        """Enable motors by name, instance by instance (the others keep being sent)."""
        for c, idx in self._by_client(names):
            c.enable(idx, mode, timeout=timeout)

    def disable(self, names=None):
        names = self.motors if names is None else names
        for c, idx in self._by_client(names):
            c.disable(idx)

    def set(self, name, **setpoints):
        c, i = self._where(name)
        c.set(i, **setpoints)

    def send(self):
        """One command_t to every instance that drives a motor."""
        for c in self.clients.values():
            if c._cmd:
                c.send()

    def poll(self, timeout=0.0):
        end = time.monotonic() + timeout
        n = 0
        for c in self.clients.values():
            n += c.poll(max(0.0, end - time.monotonic()) if not n else 0.0)
        return n

    def spin(self, seconds, rate_hz=200.0, before_send=None):
        """send() to every instance at rate_hz for `seconds`, poll() in between."""
        period = 1.0 / rate_hz
        t0 = time.monotonic()
        next_pub = t0
        n = 0
        while time.monotonic() - t0 < seconds:
            now = time.monotonic()
            if now >= next_pub:
                if before_send:
                    before_send(now - t0)
                self.send()
                n += 1
                next_pub = max(next_pub + period, now)
            for c in self.clients.values():
                c.poll(0.0)
            time.sleep(max(0.0, min(next_pub, t0 + seconds) - time.monotonic()))
        return n

    # ---- the robot -----------------------------------------------------------

    def stop(self, reason="rmd.Robot.stop()"):
        """The robot's all-stop: robot_stop_t on RMD_ROBOT_STOP (every daemon's safe action)."""
        from . import robot_stop_t

        msg = robot_stop_t()
        msg.who = f"python@{os.uname().nodename} pid {os.getpid()}"
        msg.reason = reason
        msg.t_ns = time.time_ns()
        c = next(iter(self.clients.values()))
        for _ in range(3):
            c.lc.publish(STOP_CHANNEL, msg.encode())
        return msg

    def max_offset_ms(self):
        """The largest clock offset any daemon reports for a peer, ms (None: none known)."""
        offs = [abs(p.offset_ns) / 1e6 for c in self.clients.values() if c.health
                for p in c.health.peer[:c.health.n_peers] if p.offset_valid]
        return max(offs) if offs else None


# SPDX-License-Identifier: MIT
"""A controller client for rmdd: rmd.Client.

    import rmd

    with rmd.Client() as c:                     # waits for rmdd's config_t
        m = c.index("motor1")                   # name -> index
        c.enable([m], rmd.command_t.MODE_POSITION)
        c.set(m, position=0.3)
        c.spin(2.0)                             # stream the setpoints for 2 s
        print(c.motor_state(m).position)
    # leaving the block sends enable = 0 to every motor the client enabled

What it does for you (docs/lcm.md is the contract):
  - asks for config_t (config_request_t on PREFIX + "CONFIG_REQUEST", again
    every 0.25 s) and says clearly when rmdd does not answer;
  - numbers its commands: seq starts at 0 (rmdd takes 0 as a restart, so a
    new client is never rejected for going back) and counts up; utime is
    time.monotonic() in microseconds;
  - sends every driven motor in each command_t: rmdd keeps only the newest
    command per cycle, so a message per motor would lose some;
  - identifies itself: command_t.controller is a random 64-bit id chosen
    when the client is made (`controller`); while it has motors enabled,
    rmdd takes commands from no other controller (docs/lcm.md "One
    controller at a time"); `takeover = True` takes them over from another;
  - enables the way rmdd requires: a motor back from LOST, FAULT or SAFE takes
    enable = 1 only after it has seen enable = 0 (rmdd keeps that enable = 0
    until its loop has acted on it), so enable() sends enable = 0 until
    state_t shows the motors READY, and then enable = 1;
  - on leaving a `with` block (or close()), sends enable = 0 to every motor it
    enabled;
  - notices a mixed stream: two rmdd on one URL and prefix (config_t and
    health_t carry each daemon's instance, host and pid).  Every call that
    reads LCM then raises MixedStreamError naming both, unless
    `allow_mixed` is set (docs/lcm.md "One daemon per prefix").

Mistakes it stops at once instead of leaving to rmdd's safety net:
  - a NaN or Inf setpoint: set() raises ValueError naming the motor and the
    field (rmdd would reject every command and its watchdog trip);
  - a motor it enabled going SAFE (the watchdog: commands stopped for longer
    than command_timeout_ms), LOST or FAULT: the next send() or spin()
    raises MotorStopped, saying which and why; the client sends enable = 0
    for it from then on and never enables it again until enable() is called
    (a send() after a pause sends at once: waiting for a fresh state_t would
    lengthen the silence that trips rmdd's watchdog, and an enable = 1 after
    a trip restarts nothing -- rmdd's latch wants enable = 0 first; the
    state_t that shows the trip makes the next send() raise);
  - another controller owning the motors: enable() raises NotOwner naming
    the owner's id (health_t.owner), not "motor1 is enabled"; so does
    send() once health_t shows this client's commands rejected for it (a
    takeover).

Threads: none.  The client is single-threaded: it reads LCM only inside its
own calls (poll(), spin(), connect(), enable(), disable()), so `state`,
`health` and `config` change only there.  Use a client from one thread, and
call poll() (or spin()) often: rmdd's watchdog wants a command at least every
command_timeout_ms (100 ms by default), and state_t arrives every cycle.
fileno() lets a select() loop wait for messages.
"""

import functools
import math
import os
import select
import time

DEFAULT_URL = "udpm://239.255.76.67:7667?ttl=0"
CONFIG_REQUEST_PERIOD_S = 0.25
POLL_MAX = 1000  # messages one poll() handles at most: a flood cannot hold it

SEND_GAP_S = 0.05  # sends further apart than this: a pause (a trip's likely cause)
SETPOINT_FIELDS = ("position", "velocity", "torque", "kp", "kd", "max_velocity")


class RmdError(Exception):
    """rmdd did not answer, or did not do what was asked."""


class MixedStreamError(RmdError):
    """Two rmdd publish on the client's URL and prefix: its commands drive both."""


class MotorStopped(RmdError):
    """A motor this client enabled left ENABLED for SAFE, LOST or FAULT.

    Raised by send() (so by spin()) once state_t shows it; the client then
    stops driving those motors (set() on them raises) and never enables
    them again by itself: call enable() once the cause is dealt with.
    `motors` is a list of (name, lifecycle name); `watchdog` is True when
    rmdd's watchdog had tripped (health_t.watchdog WD_TRIPPED): the client
    did not stream its commands every command_timeout_ms.
    """

    def __init__(self, msg, motors=(), watchdog=False):
        super().__init__(msg)
        self.motors = list(motors)
        self.watchdog = watchdog


class NotOwner(RmdError):
    """rmdd rejects this client's commands: another controller owns the motors.

    `owner` is that controller's command_t.controller id (health_t.owner).
    """

    def __init__(self, msg, owner=None):
        super().__init__(msg)
        self.owner = owner


@functools.lru_cache(maxsize=None)
def _lc_names():
    """{value: name} of state_t's LC_* constants (lcm_types/state_t.lcm, the one list)."""
    from . import state_t
    return {v: k[3:].lower() for k, v in vars(state_t).items()
            if k.startswith("LC_") and isinstance(v, int)}


def lifecycle_name(lc):
    """'ready', 'enabled', ... for a state_t lifecycle (LC_*)."""
    return _lc_names().get(lc, "unknown")


def _now_us():
    return int(time.monotonic() * 1e6)


class Client:
    """One controller of one rmdd (one LCM URL and channel prefix).

    Client(url, prefix) opens LCM and subscribes; connect() (or entering a
    `with` block) waits for config_t.  url None: $LCM_DEFAULT_URL, else
    DEFAULT_URL ("udpm://239.255.76.67:7667?ttl=0": this host only).

    Attributes, updated by the calls that read LCM:
      config    the newest rmd.config_t (None before connect())
      state     the newest rmd.state_t (None before the first)
      health    the newest rmd.health_t (None before the first, ~10 Hz)
      n_states  state_t messages received
      state_rx  time.monotonic() of the newest state_t (0.0: none yet)
      on_state  None, or a function called with each state_t as it arrives
      seq       the seq of the next command_t (0 for the first)
      controller  command_t.controller: this client's id (random unless given)
      takeover  command_t.takeover of the commands sent (False; a supervisor
                sets it to take the motors over from their owner, docs/lcm.md)
      instances {instance: (host, pid)} of every rmdd heard on the prefix
                (config_t, health_t); more than one: a mixed stream
      allow_mixed  False: a mixed stream raises MixedStreamError; True: only
                `instances` and `mixed` say so (a tool that watches both)
      mixed     None, or the message naming both daemons
      stopped   {index: why} of the motors this client enabled and stopped
                driving (MotorStopped, NotOwner) until enable() them again
      beside    None, or a function called after each command enable() and
                disable() stream (rmd.Robot sends the other instances' there,
                so that their watchdogs do not trip meanwhile)
    """

    def __init__(self, url=None, prefix="RMD_", on_state=None, controller=None):
        import lcm
        from . import (command_t, config_request_t, config_t, health_t, motor_command_t,
                       state_t)

        self._types = (command_t, config_request_t, config_t, health_t, state_t,
                       motor_command_t)
        self.controller = (int.from_bytes(os.urandom(8), "big", signed=True)
                           if controller is None else int(controller))
        self.takeover = False
        self.url = url or os.environ.get("LCM_DEFAULT_URL") or DEFAULT_URL
        self.prefix = prefix
        try:
            self.lc = lcm.LCM(self.url)
        except (IOError, OSError, RuntimeError) as e:
            raise RmdError(f"LCM {self.url}: {e} (multicast not routable? see docs/lcm.md, "
                           "\"A robot PC without a network\")") from None
        self.config = None
        self.state = None
        self.health = None
        self.n_states = 0
        self.state_rx = 0.0
        self.on_state = on_state
        self.seq = 0
        self.instances = {}
        self.allow_mixed = False
        self.mixed = None
        self.beside = None
        # index -> [enable, mode, position, velocity, torque, kp, kd, max_velocity]
        self._cmd = {}
        self._enabled = set()  # motors enable() enabled and disable() has not disabled
        self.stopped = {}  # index -> why: enabled, then SAFE/LOST/FAULT or taken over
        self._was_enabled = set()  # driven motors state_t has shown ENABLED
        self._newly_stopped = {}  # index -> (lifecycle name, the silence before it, s)
        self._report_only = None  # enable(): the motors whose stops its send()s raise
        self._last_send = time.monotonic()
        self._send_gap = 0.0  # the time between the last two sends, s
        self._subs = [
            self.lc.subscribe(prefix + "CONFIG", self._on_config),
            self.lc.subscribe(prefix + "STATE", self._on_state),
            self.lc.subscribe(prefix + "HEALTH", self._on_health),
        ]

    # ---- LCM ----------------------------------------------------------------

    def _heard(self, m):
        """Note the daemon that sent config_t or health_t m (its instance, host, pid)."""
        if m.instance in self.instances:
            return
        self.instances[m.instance] = (m.host, m.pid)
        if len(self.instances) > 1 and self.mixed is None:
            who = ", ".join(f"instance {i & (2**64 - 1):016x} on host {h}, pid {p}"
                            for i, (h, p) in self.instances.items())
            self.mixed = (f"two rmdd publish on {self.url} prefix {self.prefix}: {who}; "
                          "this client's commands drive both: stop one, or give one "
                          "another lcm.channel_prefix")

    def _check_mixed(self):
        if self.mixed is not None and not self.allow_mixed:
            raise MixedStreamError(self.mixed)

    def _on_config(self, channel, data):
        try:
            c = self._types[2].decode(data)
        except ValueError:
            return  # another type on the channel: not ours
        self._heard(c)
        # the first daemon's config stays: never silently switch to another's
        if self.config is None or c.instance == self.config.instance:
            self.config = c

    def _on_state(self, channel, data):
        try:
            s = self._types[4].decode(data)
        except ValueError:
            return
        self.state = s
        self.state_rx = time.monotonic()
        for i, e in self._cmd.items():
            if not e[0] or i >= s.count:
                continue
            lc = s.motor[i].lifecycle
            if lc == s.LC_ENABLED:
                self._was_enabled.add(i)
            elif lc in (s.LC_FAULT, s.LC_LOST, s.LC_SAFE) and i in self._was_enabled:
                # stop driving it now: the next send() says so, and carries
                # enable = 0 (rmdd's latch wants it before an enable = 1)
                e[0] = False
                self.stopped[i] = lifecycle_name(lc)
                self._enabled.discard(i)
                self._was_enabled.discard(i)
                # the silence: since the last send, or the pause that ended with it
                self._newly_stopped[i] = (lifecycle_name(lc),
                                          max(self.state_rx - self._last_send, self._send_gap))
        self.n_states += 1
        if self.on_state:
            self.on_state(s)

    def _on_health(self, channel, data):
        try:
            h = self._types[3].decode(data)
        except ValueError:
            return
        self._heard(h)
        if self.config is None or h.instance == self.config.instance:
            self.health = h

    def fileno(self):
        """LCM's socket: readable when a message waits (for select())."""
        return self.lc.fileno()

    def poll(self, timeout=0.0):
        """Handle the messages that arrive within `timeout` seconds (0: those waiting).

        Waits up to `timeout` for the first message, then handles those already
        waiting (at most POLL_MAX) and returns how many it handled.
        """
        n = 0
        fd = self.lc.fileno()
        end = time.monotonic() + max(0.0, timeout)
        while n < POLL_MAX:
            left = 0.0 if n else max(0.0, end - time.monotonic())
            r, _, _ = select.select([fd], [], [], left)
            if not r:
                break
            self.lc.handle()
            n += 1
        self._check_mixed()
        return n

    def wait(self, seconds):
        """Handle messages for `seconds` (a sleep that keeps state fresh)."""
        end = time.monotonic() + seconds
        while True:
            left = end - time.monotonic()
            if left <= 0:
                return
            self.poll(left)

    def close(self):
        """enable = 0 to every motor this client enabled, then close LCM."""
        if self.lc is None:
            return
        self._newly_stopped = {}  # leaving: nothing left to report
        try:
            if self._enabled and self.config is not None:
                self.disable(sorted(self._enabled))
        finally:
            for sub in self._subs:
                self.lc.unsubscribe(sub)
            self._subs = []
            self.lc = None

    def __enter__(self):
        if self.config is None:
            self.connect()
        return self

    def __exit__(self, exc_type, exc, tb):
        self.close()
        return False

    # ---- configuration ---------------------------------------------------------

    def connect(self, timeout=2.0):
        """Ask for config_t until it comes; returns it.  RmdError after `timeout` s."""
        end = time.monotonic() + timeout
        self.config = None
        while self.config is None:
            now = time.monotonic()
            if now >= end:
                raise RmdError(
                    f"no rmd.config_t on {self.prefix}CONFIG within {timeout:.0f} s: is rmdd "
                    f"running, with --lcm-url {self.url} and prefix {self.prefix}?")
            req = self._types[1]()
            req.utime = _now_us()
            self.lc.publish(self.prefix + "CONFIG_REQUEST", req.encode())
            again = min(end, now + CONFIG_REQUEST_PERIOD_S)
            while self.config is None and time.monotonic() < again:
                self.poll(again - time.monotonic())
        return self.config

    def _need_config(self):
        if self.config is None:
            raise RmdError("no config_t yet: call connect() first (or use `with`)")
        return self.config

    @property
    def period_s(self):
        """rmdd's loop period, seconds (config_t.period_us)."""
        return self._need_config().period_us * 1e-6

    @property
    def motors(self):
        """rmd.motor_config_t of every configured motor, by index."""
        c = self._need_config()
        return list(c.motor[:c.motor_count])

    def index(self, motor):
        """The index of a motor given by name (or by index, checked)."""
        c = self._need_config()
        for mc in c.motor[:c.motor_count]:
            if mc.name == motor or (isinstance(motor, int) and mc.index == motor):
                return mc.index
        names = " ".join(mc.name for mc in c.motor[:c.motor_count])
        raise RmdError(f"no motor {motor!r} in rmdd's configuration (motors: {names})")

    def name(self, motor):
        """A motor's name."""
        i = self.index(motor)
        return self.config.motor[i].name

    # ---- state ---------------------------------------------------------------

    def motor_state(self, motor):
        """The newest rmd.motor_state_t of a motor (name or index); None before any state_t."""
        i = self.index(motor)
        s = self.state
        if s is None or i >= s.count:
            return None
        return s.motor[i]

    def position_certain(self, motor):
        """Whether rmdd trusts the motor's position after a power cycle (state_t
        position_certain; docs/faults.md "Position uncertain after power-off").
        False before any state_t.  While False, position mode and MIT with kp > 0
        are refused: home() it."""
        ms = self.motor_state(motor)
        return bool(ms.position_certain) if ms is not None else False

    def home(self, motor, position=None):
        """Tell rmdd where a motor (name or index) is: at `position` rad (the
        reported frame, as state_t.position) now, or, with position None, that
        the position it reports is right (rmd.home_t on PREFIX "HOME";
        docs/lcm.md "Homing").  rmdd shifts its reported frame, never moves
        the motor, and refuses it while the motor is enabled (disable() it
        first).  Returns the message sent."""
        from . import home_t
        msg = home_t()
        msg.utime = _now_us()
        msg.controller = self.controller
        msg.index = self.index(motor)
        msg.as_reported = position is None
        msg.position = 0.0 if position is None else float(position)
        self.lc.publish(self.prefix + "HOME", msg.encode())
        return msg

    def lifecycle(self, motor):
        """The motor's lifecycle (state_t.LC_*) in the newest state_t; -1 before any."""
        ms = self.motor_state(motor)
        return ms.lifecycle if ms is not None else -1

    def wait_state(self, timeout=1.0):
        """Wait for a state_t newer than now; RmdError after `timeout` s."""
        n = self.n_states
        end = time.monotonic() + timeout
        while self.n_states == n:
            left = end - time.monotonic()
            if left <= 0:
                raise RmdError(f"no rmd.state_t on {self.prefix}STATE within {timeout:g} s")
            self.poll(left)
        return self.state

    # ---- commands --------------------------------------------------------------

    def set(self, motor, position=None, velocity=None, torque=None, kp=None, kd=None,
            max_velocity=None):
        """Change an enabled motor's setpoint; the next send() (or spin()) carries it.

        Only the fields given change.  SI units at the output shaft: rad, rad/s,
        N*m, N*m/rad, N*m*s/rad.  Which fields a mode uses: docs/lcm.md.
        """
        i = self.index(motor)
        name = self.config.motor[i].name
        if i not in self._cmd or i in self.stopped:
            why = self.stopped.get(i)
            raise RmdError(f"{name}: not enabled by this client"
                           + (f" ({why}: enable() it again)" if why else ""))
        e = self._cmd[i]
        new = {}
        for k, (field, v) in enumerate(zip(SETPOINT_FIELDS,
                                           (position, velocity, torque, kp, kd, max_velocity)), 2):
            if v is None:
                continue
            try:
                x = float(v)
            except (TypeError, ValueError):
                raise ValueError(f"{name}: {field} = {v!r} is not a number") from None
            if not math.isfinite(x):
                raise ValueError(
                    f"{name}: {field} = {x!r} is not finite (rmdd would reject the whole "
                    "command_t, every motor's, and its watchdog then make the motors safe)")
            new[k] = x
        for k, x in new.items():  # all or nothing
            e[k] = x

    def send(self):
        """Publish one command_t with every motor this client drives; returns it.

        seq counts from 0; utime is time.monotonic() in microseconds.
        MotorStopped when state_t shows a motor this client enabled in SAFE,
        LOST or FAULT (the client stops driving it: enable() it again);
        NotOwner when health_t shows rmdd rejecting this client's commands
        because another controller took the motors over (likewise).
        """
        if any(e[0] for e in self._cmd.values()):
            # what waits first: a trip among it stops driving the motors here.
            # After a pause this sends without waiting for a fresh state_t (a
            # wait would lengthen the silence into a trip); an enable = 1 that
            # follows a trip rmdd does not act on (the latch), and the state_t
            # that shows it makes the next send() raise
            while self.poll() >= POLL_MAX:
                pass
        self._check_stopped()
        now = time.monotonic()
        self._send_gap = now - self._last_send
        self._last_send = now
        command_t = self._types[0]
        msg = command_t()
        msg.utime = _now_us()
        msg.seq = self.seq
        self.seq += 1
        msg.controller = self.controller
        msg.takeover = bool(self.takeover)
        msg.count = len(self._cmd)
        msg.motor = []
        for i in sorted(self._cmd):
            e = self._cmd[i]
            c = self._types[5]()
            msg.motor.append(c)
            c.index = i
            c.enable = bool(e[0])
            c.mode = e[1]
            c.position, c.velocity, c.torque, c.kp, c.kd, c.max_velocity = e[2:]
        self.lc.publish(self.prefix + "COMMAND", msg.encode())
        return msg

    def _owned_by_other(self):
        h = self.health
        return h is not None and bool(h.owned) and h.owner != self.controller

    def _owner_text(self):
        h = self.health
        return (f"controller {h.owner:#x} owns the motors (health_t.owner; this client is "
                f"{self.controller:#x}), so rmdd rejects this client's commands: stop that "
                "controller, or set takeover = True to take the motors over (docs/lcm.md, "
                "\"One controller at a time\")")

    def _check_stopped(self):
        """MotorStopped for enabled motors that state_t shows SAFE, LOST or FAULT;
        NotOwner when health_t shows this client rejected for not owning them."""
        h = self.health
        if (h is not None and not self.takeover and self._owned_by_other()
                and h.intruder == self.controller):
            mine = sorted(i for i, e in self._cmd.items() if e[0])
            if mine:
                for i in mine:
                    self.stopped[i] = f"controller {h.owner:#x} owns it"
                    self._cmd[i][0] = False
                    self._enabled.discard(i)
                    self._was_enabled.discard(i)
                raise NotOwner(f"send: {self._owner_text()}",
                               h.owner)
        # those still driven (a caller may have dropped some meanwhile); while
        # enable() runs, only its motors: the others' stops wait for the next
        # send() after it, never lost
        only = self._report_only
        later = {} if only is None else {i: v for i, v in self._newly_stopped.items()
                                         if i in self._cmd and i not in only}
        bad = {i: v for i, v in self._newly_stopped.items() if i in self._cmd and i not in later}
        self._newly_stopped = later
        if not bad:
            return
        gap = max(g for _lc, g in bad.values())
        wd = any(lc == "safe" for lc, _g in bad.values()) and (
            (h is not None and h.watchdog == type(h).WD_TRIPPED) or gap > SEND_GAP_S)
        names = [(self.config.motor[i].name, bad[i][0]) for i in sorted(bad)]
        why = ", ".join(f"{n} is {lc}" for n, lc in names)
        if wd:
            why += (f": rmdd's watchdog tripped (this client sent nothing for {gap * 1e3:.0f} "
                    "ms; rmdd wants a command every command_timeout_ms: call spin() or "
                    "send() at least every period)")
        else:
            why += " (rmdd's log and docs/faults.md say why)"
        raise MotorStopped(f"motors stopped: {why}; this client sends enable = 0 for them "
                           "and will not enable them again by itself: call enable()",
                           names, wd)

    def spin(self, seconds, rate_hz=200.0, before_send=None):
        """Stream the setpoints for `seconds`: send() at `rate_hz`, poll() in between.

        before_send(t), if given, is called before each send with the seconds
        since spin() began, and may call set().  Returns the number of sends.
        """
        period = 1.0 / rate_hz
        t0 = time.monotonic()
        next_pub = t0
        n = 0
        while True:
            now = time.monotonic()
            if now - t0 >= seconds:
                return n
            if now >= next_pub:
                if before_send:
                    before_send(now - t0)
                self.send()
                n += 1
                next_pub += period
                if next_pub <= now:  # late: skip, never catch up in a burst
                    next_pub = now + period
            self.poll(max(0.0, min(next_pub, t0 + seconds) - time.monotonic()))

    def _all_in(self, motors, lc, since=None):
        s = self.state
        if s is None or (since is not None and self.state_rx < since):
            return False
        return all(i < s.count and s.motor[i].lifecycle == lc for i in motors)

    def enable(self, motors, mode, setpoints=None, timeout=1.0, strict=True):
        """Enable motors (names or indices) in a mode (command_t.MODE_*).

        First enable = 0, sent every cycle until state_t shows every one READY
        and at least two of rmdd's cycles have passed (a motor back from LOST,
        FAULT or SAFE needs it; rmdd would keep it even if enable = 1 followed
        at once, the wait is for state_t to show READY).  Then enable = 1,
        sent every cycle until state_t shows them ENABLED.

        setpoints: {motor: {"position": ..., ...}} to start from; by default a
        motor holds where it stands (position and MIT modes: its measured
        position) or gets 0 (torque, speed).  Then stream with set() and
        send()/spin(): rmdd's watchdog wants a command every
        command_timeout_ms.

        A motor this client has already enabled goes through enable = 0 too
        (its output is off for a few cycles).

        MotorStopped from enable() names only these motors: another motor
        this client drives that stops meanwhile is raised by the next send()
        or spin() after it (the client stops driving it at once all the same).

        strict (the default): a motor that does not become READY, then
        ENABLED, within `timeout` s each raises RmdError (after enable = 0 to
        the motors).  strict=False: returns a list of (name, lifecycle name)
        of those motors instead ([] when all are ENABLED), and enables them
        all the same.
        """
        c = self._need_config()
        idx = [self.index(m) for m in motors]
        setpoints = {self.index(k): v for k, v in (setpoints or {}).items()}
        bit = 1 << mode
        for i in idx:
            if not c.motor[i].modes & bit:
                raise RmdError(f"{c.motor[i].name}: does not take mode {mode} "
                               f"(config_t modes {c.motor[i].modes:#x})")
        if self.state is None:
            self.wait_state(timeout)
        command_t, state_t = self._types[0], self._types[4]
        period = min(max(self.period_s, 0.001), 0.02)
        for i in idx:
            self.stopped.pop(i, None)
            self._newly_stopped.pop(i, None)
            self._was_enabled.discard(i)
            ms = self.state.motor[i] if i < self.state.count else None
            pos = ms.position if ms is not None and math.isfinite(ms.position) else 0.0
            hold = pos if mode in (command_t.MODE_POSITION, command_t.MODE_MIT) else 0.0
            kp = kd = 0.0
            if mode == command_t.MODE_MIT:
                kp, kd = c.motor[i].kp_min, c.motor[i].kd_min
            self._cmd[i] = [False, mode, hold, 0.0, 0.0, kp, kd, 0.0]
            self.set(i, **setpoints.get(i, {}))

        def stream_until(done, since):
            end = time.monotonic() + timeout
            while True:
                self.send()
                if self.beside:
                    self.beside()
                if done(since):
                    return True
                if time.monotonic() >= end or (self._owned_by_other() and not self.takeover
                                               and self.health.intruder == self.controller):
                    return False
                self.wait(period)

        # a stop of another motor this client drives is raised by the next
        # send() after enable(), not here: these motors are enabled all the same
        self._report_only = set(idx)
        try:
            # enable = 0 until READY, in a state_t from after two cycles of it
            ready = stream_until(lambda since: self._all_in(idx, state_t.LC_READY, since),
                                 time.monotonic() + 2 * self.period_s)
            enabled = False
            if ready or not strict:
                for i in idx:
                    self._cmd[i][0] = True
                    self._enabled.add(i)
            if ready:
                enabled = stream_until(
                    lambda since: self._all_in(idx, state_t.LC_ENABLED, since), time.monotonic())
        finally:
            self._report_only = None
        if enabled:
            self._was_enabled.update(idx)
            return []
        if self._owned_by_other() and not self.takeover:
            for i in idx:  # rmdd took none of these commands: nothing to undo
                self._cmd.pop(i, None)
                self._enabled.discard(i)
            raise NotOwner(f"enable: {self._owner_text()}", self.health.owner)
        want, stage = (state_t.LC_ENABLED, "enabled") if ready else (state_t.LC_READY, "ready")
        bad = [(c.motor[i].name, lifecycle_name(self.lifecycle(i))
                + (" (position uncertain after a power cycle: home() it, docs/faults.md)"
                   if ready and not self.position_certain(i) else ""))
               for i in idx if self.lifecycle(i) != want]
        if strict:
            self.disable(idx)
            raise RmdError(f"enable: not {stage} within {timeout:g} s: "
                           + ", ".join(f"{n} is {lc}" for n, lc in bad))
        return bad

    def disable(self, motors=None, timeout=0.5):
        """enable = 0 for motors (default: every motor this client drives).

        Sent every cycle until state_t no longer shows them ENABLED or
        STOPPING (on their way to READY), within `timeout` s (at least
        three times: UDP may drop one); then the client stops sending them.
        """
        idx = sorted(self._cmd) if motors is None else [self.index(m) for m in motors]
        for i in idx:
            self._newly_stopped.pop(i, None)  # disabling them: nothing to report
            if i in self._cmd:
                self._cmd[i][0] = False
        state_t = self._types[4]
        period = min(max(self.period_s, 0.001), 0.02) if self.config else 0.005
        end = time.monotonic() + timeout
        t0 = time.monotonic()
        n = 0
        while True:
            self.send()
            if self.beside:
                self.beside()
            n += 1
            s = self.state
            off = s is not None and self.state_rx >= t0 + period and all(
                i >= s.count
                or s.motor[i].lifecycle not in (state_t.LC_ENABLED, state_t.LC_STOPPING)
                for i in idx)
            if (n >= 3 and off) or time.monotonic() >= end:
                break
            self.wait(period)
        for i in idx:
            self._cmd.pop(i, None)
            self._enabled.discard(i)
            self._was_enabled.discard(i)
        return n

#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""bench/soak.sh's generator, LCM traffic and judge (run with build/venv's Python).

  soak_lcm.py plan DIR SEED DURATION URL PREFIX TAP
      DIR/soak.yaml (3 sim buses, V3/MIT/V2 motors, every bus tapped to TAP)
      with a seeded fault table per bus, and DIR/schedule.json (the faults
      with their kinds, motors and windows in sim seconds).
  soak_lcm.py hostile DIR SEED DURATION
      hostile and flooding RMD_COMMAND / CONFIG_REQUEST traffic; counts by
      kind in DIR/hostile.json.
  soak_lcm.py drive DIR SEED DURATION
      a controller that comes and goes (enables, streams setpoints, some
      beyond the limits, a wild or stale stamp now and then, goes silent,
      returns) and a monitor of state_t / health_t; DIR/drive.json.
  soak_lcm.py judge DIR
      the fault table from what rmdd published, the wire checker's summary,
      rmdd's statistics and RSS samples: prints the table and the
      invariants, exit status 1 on any violation.

Every time is CLOCK_MONOTONIC (time.monotonic() here, state_t.utime and the
tap's stamps in rmdd); rmdd logs each sim bus's time 0, where its fault
windows start from.
"""
import json
import math
import os
import random
import re
import struct
import sys
import time

KT = "torque_constant_nm_a: 2.0"
MIT_RANGES = "mit: {t_min: -18, t_max: 18, kp_max: 200, kd_max: 4}"


def limits(pos=None, vel=10, torque=10):
    """A motor's limits: yaml."""
    p = "position_min_rad: %g, position_max_rad: %g, " % pos if pos else ""
    return "limits: {%svelocity_rad_s: %g, torque_nm: %g}" % (p, vel, torque)


MOTORS = [
    # name, bus, id, protocol, mode, the rest of its yaml
    ("v3_torque", "b0", 1, "v3", "torque", "%s, gear_ratio: 6, %s" % (KT, limits(torque=5))),
    ("v3_speed", "b0", 2, "v3", "speed", "%s, direction: -1, %s" % (KT, limits(vel=8))),
    ("mit_a", "b1", 1, "mit", "mit", "%s, %s" % (limits((-2, 2), 10, 8), MIT_RANGES)),
    ("mit_b", "b1", 2, "mit", "mit", "direction: -1, zero_offset_rad: 0.2, %s, %s"
     % (limits((-1.5, 1.5), 6, 6), MIT_RANGES)),
    # the V2 manual has no comm-loss command (0xB3): rmdd drives a V2 motor only
    # when its entry turns the protection off
    ("v2_pos", "b2", 1, "v2", "position", "%s, comm_loss_ms: 0, %s"
     % (KT, limits((-2.5, 2.5), 5))),
    ("v3_pos", "b2", 2, "v3", "position", "%s, direction: -1, zero_offset_rad: 0.3, %s"
     % (KT, limits((-2, 2.5), 6))),
]
BUSES = ["b0", "b1", "b2"]
RATE_HZ = 1000
STATE_EVERY_N = 5
MISSED_LOST = 10
COMMAND_TIMEOUT_MS = 200
STATUS_POLL_HZ = 10
REPROBE_S = 0.5  # docs/design.md: a LOST motor is re-probed every 500 ms
PER_FRAME = ["drop", "delay", "bad_dlc", "garbage", "wrong_id"]
WINDOW = ["disappear", "error_flag", "bus_off", "flood"]
KINDS = PER_FRAME + WINDOW
LEVEL2_BITS = [0x0004, 0x0008, 0x0040, 0x0100, 0x1000]  # V3 §2.12, cleared with the cause
LC = ["PROBE", "READY", "ENABLED", "FAULT", "LOST", "SAFE"]
LC_READY, LC_ENABLED, LC_FAULT, LC_LOST, LC_SAFE = 1, 2, 3, 4, 5
WARMUP_S = 6.0
# a reply later than this is a delayed one (undelayed: 0.6..1.6 ms here)
LATE_US = 1700
# a stall of the rt loop this long (periods) is the host's doing and can make a
# motor LOST by itself, with missed_replies_lost 10 and a few missed already
STALL_PERIODS = 6


def bounds():
    """The documented bounds (README, docs/design.md, docs/lcm.md), in seconds."""
    cycle = 1.0 / RATE_HZ
    pub = STATE_EVERY_N * cycle  # state_t's period: what the monitor can resolve
    epoch = 0.00001  # a sim bus's time 0 as rmdd logs it (%.6f s)
    return {
        # missed_replies_lost replies missed in a row: a reply is missed when the
        # next is due (one a cycle), so LOST within missed + 2 cycles
        "lost": (MISSED_LOST + 2) * cycle + pub + epoch,
        # FAULT when a status poll (status_poll_hz) reports the flags
        "fault": 1.0 / STATUS_POLL_HZ + 3 * cycle + pub + epoch,
        # READY again: a LOST motor is re-probed every 500 ms; a motor whose
        # comm-loss protection tripped meanwhile sends 0xF1 once a second and
        # is LOST again by it: two re-probe rounds and the 0xF1 period
        "recover_lost": 1.0 + 2 * REPROBE_S + 0.1 + pub + epoch,
        "recover_fault": 1.0 / STATUS_POLL_HZ + 3 * cycle + pub + epoch,
        # the host watchdog: safe action within command_timeout_ms + 1 cycle
        "watchdog": COMMAND_TIMEOUT_MS / 1000.0 + cycle + pub,
    }


# ---- plan -------------------------------------------------------------------

def plan(d, seed, duration, url, prefix, tap):
    rng = random.Random(seed)
    tail = max(8.0, 0.08 * duration)
    span = duration - WARMUP_S - tail
    n_slots = max(1, min(30, int(span // 6.0)))  # RMD_SIM_MAX_FAULTS per bus is 32
    slot = span / n_slots
    kinds = []
    while len(kinds) < n_slots * len(BUSES):
        k = KINDS[:]
        rng.shuffle(k)
        kinds += k
    faults = []
    for bi, bus in enumerate(BUSES):
        ids = [m[2] for m in MOTORS if m[1] == bus]
        for s in range(n_slots):
            kind = kinds[s * len(BUSES) + bi]
            t0 = WARMUP_S + s * slot + rng.uniform(0.3, 0.8)
            f = {"bus": bus, "kind": kind, "motor": rng.choice(ids)}
            if kind in PER_FRAME:
                dur = rng.uniform(1.0, 2.5)
                f["probability"] = round(rng.uniform(0.05, 0.2), 3)
                if kind == "delay":
                    f["delay_us"] = rng.randint(1200, 3000)
                elif kind == "bad_dlc":
                    f["param"] = rng.randint(0, 7)
                elif kind == "wrong_id":
                    f["param"] = rng.choice([i for i in ids if i != f["motor"]])
                elif kind == "garbage":
                    f["probability"] = round(rng.uniform(0.05, 0.1), 3)
            elif kind == "disappear":
                dur = rng.uniform(0.6, 2.0)
                f["param"] = rng.randint(0, 1)
            elif kind == "error_flag":
                dur = rng.uniform(0.6, 2.0)
                f["param"] = rng.choice(LEVEL2_BITS)
            elif kind == "bus_off":
                dur = rng.uniform(0.25, 0.8)
                f.pop("motor")
            else:  # flood: a foreign node above every RMD identifier
                dur = rng.uniform(1.0, 2.5)
                f.pop("motor")
                f["can_id"] = rng.randint(0x600, 0x6FF)
                f["period_us"] = rng.randint(2000, 5000)
            dur = min(dur, 0.4 * slot)
            f["start_s"] = round(t0, 3)
            f["end_s"] = round(t0 + dur, 3)
            faults.append(f)

    y = ["# bench/soak.sh: seed %d, %g s (generated by bench/soak_lcm.py plan)" % (seed, duration),
         "loop: {rate_hz: %d, rt_priority: 40}" % RATE_HZ,
         "safety: {comm_loss_ms: 100, missed_replies_lost: %d, command_timeout_ms: %d, "
         "safe_action: damp, lost_motor_action: motor}" % (MISSED_LOST, COMMAND_TIMEOUT_MS),
         "probe: {on_missing: refuse}",
         "lcm: {url: \"%s\", channel_prefix: \"%s\", state_every_n: %d}"
         % (url, prefix, STATE_EVERY_N),
         "buses:"]
    for bi, bus in enumerate(BUSES):
        y.append("  - name: %s" % bus)
        y.append("    type: sim")
        y.append("    sim:")
        y.append("      seed: %d" % (seed * 10 + bi + 1))
        y.append("      tap: \"%s\"" % tap)
        y.append("      faults:")
        for f in faults:
            if f["bus"] != bus:
                continue
            keys = [k for k in ("kind", "motor", "probability", "delay_us", "param", "can_id",
                                "period_us", "start_s", "end_s") if k in f]
            y.append("        - {%s}" % ", ".join("%s: %s" % (k, f[k]) for k in keys))
    y.append("motors:")
    for name, bus, mid, proto, mode, extra in MOTORS:
        y.append("  - {name: %s, bus: %s, id: %d, protocol: %s, mode: %s, status_poll_hz: %d, %s}"
                 % (name, bus, mid, proto, mode, STATUS_POLL_HZ, extra))
    with open(os.path.join(d, "soak.yaml"), "w") as fh:
        fh.write("\n".join(y) + "\n")
    with open(os.path.join(d, "schedule.json"), "w") as fh:
        json.dump({"seed": seed, "duration": duration, "faults": faults}, fh, indent=1)
    print("soak: %d faults on %d buses (%d a bus, one every %.1f s), seed %d"
          % (len(faults), len(BUSES), n_slots, slot, seed))


# ---- hostile ----------------------------------------------------------------

def _lcm():
    import lcm
    import rmd
    return lcm, rmd


def hostile(d, seed, duration):
    lcm, rmd = _lcm()
    url, prefix = os.environ["SOAK_URL"], os.environ["SOAK_PREFIX"]
    lc = lcm.LCM(url)
    rng = random.Random(seed ^ 0x5A5A)
    n = len(MOTORS)
    me = rng.getrandbits(63)
    sent = {}

    def cmd(count=1, index=0, enable=False, mode=0, vals=(0.0,) * 6, utime=None, seq=1):
        m = rmd.command_t()
        m.utime = int(time.monotonic() * 1e6) if utime is None else utime
        m.seq, m.controller, m.takeover = seq, me, False
        m.count = count
        m.motor = []
        for k in range(count):
            e = rmd.motor_command_t()
            e.index, e.enable, e.mode = index + k, enable, mode
            e.position, e.velocity, e.torque, e.kp, e.kd, e.max_velocity = vals
            m.motor.append(e)
        return m.encode()

    good = cmd()
    bad = float("nan"), float("inf"), float("-inf")

    def one():
        k = rng.choice(["decode_garbage", "decode_truncated", "decode_trailing", "decode_empty",
                        "count", "index", "index_twice", "nonfinite", "mode", "limit",
                        "config_request"])
        if k == "decode_garbage":
            data = bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 600)))
        elif k == "decode_truncated":
            data = good[:rng.randint(1, len(good) - 1)]
        elif k == "decode_trailing":
            data = good + bytes(rng.randint(1, 64))
        elif k == "decode_empty":
            data = b""
        elif k == "count":
            data = cmd(count=rng.choice([n + 1, 33]))
        elif k == "index":
            data = cmd(index=rng.choice([n, 31, 32767, -1]))
        elif k == "index_twice":
            m = rmd.command_t.decode(cmd(count=2))
            m.motor[1].index = m.motor[0].index
            data = m.encode()
        elif k == "nonfinite":
            v = [0.0] * 6
            v[rng.randrange(6)] = rng.choice(bad)
            data = cmd(index=rng.randrange(n), vals=tuple(v), mode=rng.randrange(4))
        elif k == "mode":
            data = cmd(index=rng.randrange(n), enable=True, mode=rng.choice([4, 7, 100, -1]))
        elif k == "limit":  # max_velocity < 0: rejected whatever the mode
            data = cmd(index=rng.randrange(n), vals=(0, 0, 0, 0, 0, -rng.uniform(0.1, 1e9)))
        else:
            lc.publish(prefix + "CONFIG_REQUEST", b"" if rng.random() < 0.5 else b"\x00" * 9)
            sent[k] = sent.get(k, 0) + 1
            return
        lc.publish(prefix + "COMMAND", data)
        sent[k] = sent.get(k, 0) + 1

    end = time.monotonic() + duration
    bursts = 0
    while time.monotonic() < end:
        # a trickle (~200/s), and now and then a burst of 200..1500 at ~50 k/s
        if rng.random() < 0.01:
            for k in range(rng.randint(200, 1500)):
                one()
                if k % 100 == 99:
                    time.sleep(0.002)
            bursts += 1
        else:
            one()
        time.sleep(0.005)
    with open(os.path.join(d, "hostile.json"), "w") as fh:
        json.dump({"sent": sent, "bursts": bursts}, fh)


# ---- drive: the controller and the monitor ----------------------------------

class Monitor:
    def __init__(self, n):
        self.n = n
        self.lc = [None] * n
        self.missed = [None] * n
        # (utime_s, motor, lifecycle, utime_s of the state_t before): it changed in
        # between (the two are a period apart unless rmdd's bridge was kept waiting)
        self.trans = []
        self.missed_ev = []  # (utime_s, motor, missed total) when it changed
        self.certain = [None] * n
        self.certain_ev = []  # (utime_s, motor, position_certain) when it changed
        self.late = []  # (utime_s, motor) of a reply later than LATE_US
        self.states = 0
        self.first_state = None
        self.last_state = None
        self.health = []  # (utime_s, watchdog, plan_misses, [bus states], cycles)
        self.last_health = None
        self.first_health = None
        self.max_state_gap = 0.0
        self.stalls = []  # (utime_s, s): state_t came this much later than its period
        self.accepted = []  # (utime_s, commands_accepted, cycles) of every health_t
        self.loop_stalls = []  # (from, to, periods skipped by the rt loop), from state_t
        self.last_cycle = 0

    def on_state(self, s):
        t = s.utime / 1e6
        prev = t if self.last_state is None else self.last_state
        if self.last_state is not None:
            # the loop's own record: a late tick skips periods, cycle counts on by one
            skipped = round((t - self.last_state) * RATE_HZ) - (s.cycle - self.last_cycle)
            if skipped >= STALL_PERIODS:
                self.loop_stalls.append((self.last_state, t, skipped))
        self.last_cycle = s.cycle
        if self.last_state is not None:
            self.max_state_gap = max(self.max_state_gap, t - self.last_state)
            late = t - self.last_state - STATE_EVERY_N / RATE_HZ
            if late > 0.0015:
                self.stalls.append((t, late))
        if self.first_state is None:
            self.first_state = t
        self.last_state = t
        self.states += 1
        for i in range(min(s.count, self.n)):
            m = s.motor[i]
            if m.lifecycle != self.lc[i]:
                self.lc[i] = m.lifecycle
                self.trans.append((t, i, m.lifecycle, prev))
            if m.reply_latency_us >= LATE_US and m.reply_age_cycles < STATE_EVERY_N:
                self.late.append((t, i))
            if m.position_certain != self.certain[i]:
                self.certain[i] = m.position_certain
                self.certain_ev.append((t, i, bool(m.position_certain)))
            if m.missed_replies != self.missed[i]:
                self.missed[i] = m.missed_replies
                self.missed_ev.append((t, i, m.missed_replies))

    def on_health(self, h):
        t = h.utime / 1e6
        buses = [h.bus[b].state for b in range(h.bus_count)]
        if not self.health or self.health[-1][1:4] != (h.watchdog, h.plan_misses, buses):
            self.health.append((t, h.watchdog, h.plan_misses, buses, h.cycles))
        self.accepted.append((t, h.commands_accepted, h.cycles))
        if self.first_health is None:
            self.first_health = h
        self.last_health = h


def health_dict(h):
    return {"utime": h.utime, "cycles": h.cycles, "overruns": h.overruns,
            "plan_misses": h.plan_misses, "safe_action_events": h.safe_action_events,
            "commands_accepted": h.commands_accepted, "commands_rejected": h.commands_rejected,
            "rejected_by_kind": list(h.rejected_by_kind), "commands_clamped": h.commands_clamped,
            "watchdog": h.watchdog,
            "bus": [{"name": h.bus[b].name, "state": h.bus[b].state,
                     "tx_frames": h.bus[b].tx_frames, "rx_frames": h.bus[b].rx_frames,
                     "rx_errors": h.bus[b].rx_errors} for b in range(h.bus_count)]}


def drive(d, seed, duration):
    lcm, rmd = _lcm()
    url, prefix = os.environ["SOAK_URL"], os.environ["SOAK_PREFIX"]
    rng = random.Random(seed ^ 0xC0C0)
    mon = Monitor(len(MOTORS))
    c = rmd.Client(url=url, prefix=prefix, on_state=mon.on_state)
    c.connect(timeout=10.0)
    orig_health = c._on_health

    def on_health(ch, data):
        orig_health(ch, data)
        if c.health is not None:
            mon.on_health(c.health)
    c.lc.unsubscribe(c._subs[2])
    c._subs[2] = c.lc.subscribe(prefix + "HEALTH", on_health)

    cfg = c.config
    modes = {"torque": rmd.command_t.MODE_TORQUE, "speed": rmd.command_t.MODE_SPEED,
             "position": rmd.command_t.MODE_POSITION, "mit": rmd.command_t.MODE_MIT}
    t_start = time.monotonic()
    t_end = t_start + duration
    events = []  # ("silent", last_send, return_time), ("stamp", t, kind)
    sends = [0]
    last_send = [time.monotonic()]
    gaps = []  # (from, to) of send gaps > a quarter of command_timeout_ms

    def note_send():
        now = time.monotonic()
        if now - last_send[0] > COMMAND_TIMEOUT_MS / 4000.0:
            gaps.append((last_send[0], now))
        last_send[0] = now
        sends[0] += 1

    def setpoints(t):
        for i, (name, bus, mid, proto, mode, extra) in enumerate(MOTORS):
            if i not in c._cmd or i in c.stopped:  # stopped: MotorStopped, NotOwner
                continue
            m = cfg.motor[i]
            over = 3.0 if rng.random() < 0.05 else 0.8  # now and then far beyond the limits
            a = math.sin(2 * math.pi * 0.3 * t + i)
            if mode == "torque":
                c.set(i, torque=over * m.torque_max * a)
            elif mode == "speed":
                c.set(i, velocity=over * m.velocity_max * a)
            elif mode == "position":
                c.set(i, position=over * max(abs(m.position_min), abs(m.position_max)) * a,
                      max_velocity=over * m.velocity_max)
            else:
                c.set(i, position=over * m.position_max * a, velocity=over * m.velocity_max * a,
                      torque=over * m.torque_max * a, kp=rng.uniform(m.kp_min, 0.5 * m.kp_max),
                      kd=rng.uniform(m.kd_min, 0.5 * m.kd_max))

    def wild_stamp():
        """One command of this controller with a far-off or stale stamp (REJ_STALE)."""
        msg = rmd.command_t()
        kind = rng.choice(["past", "int64_min", "future", "int64_max"])
        now = int(time.monotonic() * 1e6)
        msg.utime = {"past": now - 10 ** 6, "int64_min": -2 ** 63 + 1,
                     "future": now + 3600 * 10 ** 6, "int64_max": 2 ** 63 - 1}[kind]
        msg.seq, msg.controller, msg.takeover, msg.count, msg.motor = c.seq, c.controller, \
            False, 0, []
        c.lc.publish(prefix + "COMMAND", msg.encode())
        events.append(("stamp", time.monotonic(), kind))

    orig_send = c.send
    # rmdd's watchdog is per motor: the spans in which this controller's sends
    # carried a motor's command, (motor, first, last send), for the judge
    feeding, spans = {}, []

    def note_feed(now):
        cur = set(c._cmd) - set(c.stopped)
        for i in list(feeding):
            if i not in cur:
                spans.append((i,) + tuple(feeding.pop(i)))
        for i in cur:
            feeding.setdefault(i, [now, now])[1] = now

    def send():
        r = orig_send()
        note_send()
        note_feed(time.monotonic())
        return r
    c.send = send

    enables = 0
    while time.monotonic() < t_end - 3.0:
        all_idx = list(range(len(MOTORS)))
        t_en = time.monotonic()
        for i in all_idx:
            c._cmd.pop(i, None)
        # one enable per mode: the motors of each mode together
        for mode in sorted(set(m[4] for m in MOTORS)):
            idx = [i for i, m in enumerate(MOTORS) if m[4] == mode]
            try:
                c.enable(idx, modes[mode], timeout=0.5, strict=False)
            except rmd.RmdError as e:  # another motor lost while these were enabled
                events.append(("stopped", time.monotonic(), str(e)))
        enables += 1
        events.append(("enable", t_en, time.monotonic()))
        run = rng.uniform(2.0, 8.0)
        t0 = time.monotonic()
        while time.monotonic() - t0 < run and time.monotonic() < t_end - 3.0:
            if rng.random() < 0.01:
                wild_stamp()
            try:
                c.spin(0.05, rate_hz=200.0, before_send=lambda t: setpoints(time.monotonic()))
            except rmd.RmdError as e:  # MotorStopped: the client stops driving them
                events.append(("stopped", time.monotonic(), str(e)))
        r = rng.random()
        if r < 0.5:  # silent: the watchdog must take over
            quiet = rng.uniform(COMMAND_TIMEOUT_MS / 1000.0 * 1.5, 2.0)
            t_last = last_send[0]
            c.wait(quiet)
            events.append(("silent", t_last, time.monotonic()))
            last_send[0] = time.monotonic()  # not a gap of the streaming
        elif r < 0.8:  # a proper goodbye
            c.disable(timeout=0.3)
            c.wait(rng.uniform(0.1, 1.0))
            last_send[0] = time.monotonic()
    c.disable(timeout=0.5)
    c.wait(1.0)
    spans.extend((i,) + tuple(v) for i, v in feeding.items())
    out = {
        "sends": sends[0], "enables": enables, "events": events, "gaps": gaps,
        "trans": mon.trans, "missed": mon.missed_ev, "certain": mon.certain_ev, "late": mon.late, "health": mon.health,
        "states": mon.states, "first_state": mon.first_state, "last_state": mon.last_state,
        "max_state_gap": mon.max_state_gap, "stalls": mon.stalls, "accepted": mon.accepted,
        "loop_stalls": mon.loop_stalls, "fed": spans,
        "first_health": health_dict(mon.first_health) if mon.first_health else None,
        "last_health": health_dict(mon.last_health) if mon.last_health else None,
        "names": [m.name for m in cfg.motor],
    }
    with open(os.path.join(d, "drive.json"), "w") as fh:
        json.dump(out, fh)


# ---- judge ------------------------------------------------------------------

def judge(d):
    sch = json.load(open(os.path.join(d, "schedule.json")))
    dr = json.load(open(os.path.join(d, "drive.json")))
    ho = json.load(open(os.path.join(d, "hostile.json")))
    wire = open(os.path.join(d, "wire.txt")).read()
    log = open(os.path.join(d, "rmdd.log"), errors="replace").read()
    B = bounds()
    names = [m[0] for m in MOTORS]
    bus_motors = {b: [i for i, m in enumerate(MOTORS) if m[1] == b] for b in BUSES}
    idx = {(m[1], m[2]): i for i, m in enumerate(MOTORS)}
    viol = []

    def worst(row, key, v):
        row[key] = v if row[key] is None else max(row[key], v)

    # the sim buses' time 0, which rmdd logs (its fault windows count from there)
    epoch = {}
    for m in re.finditer(r"rmdd: bus (\S+): sim time 0 at ([0-9.]+) s of CLOCK_MONOTONIC", log):
        epoch[m.group(1)] = float(m.group(2))
    short = {m.group(1): int(m.group(2))
             for m in re.finditer(r"^wire: bus (\S+) .* short (\d+)", wire, re.M)}
    late = [tuple(x) for x in dr["late"]]
    trans = [tuple(x) for x in dr["trans"]]
    tprev = {(x[0], x[1]): x[3] for x in trans}
    pub = STATE_EVERY_N / RATE_HZ
    unresolved = [0]

    def timed(row, key, i, t, since):
        """A detection or recovery of motor i seen at t: its time since `since` goes into
        the table when state_t resolved it (the state before was a period earlier);
        returns the earliest it can have been, for the bounds."""
        lo = max(tprev.get((t, i), t), since)
        if t - lo <= 2 * pub + 0.001:
            worst(row, key, t - since)
        else:
            unresolved[0] += 1
        return lo - since
    missed = [tuple(x) for x in dr["missed"]]
    health = [tuple(x) for x in dr["health"]]

    def lc_at(i, t):
        """Lifecycle of motor i in the newest state_t at or before t."""
        v = None
        for tt, j, lc, _ in trans:
            if tt > t:
                break
            if j == i:
                v = lc
        return v

    def first_in(i, lcs, t0, t1):
        for tt, j, lc, _ in trans:
            if j == i and t0 <= tt <= t1 and lc in lcs:
                return tt
        return None

    stalls = [tuple(x) for x in dr["stalls"]]
    # The rt loop kept from running by the host (state_t: its tick moved on more
    # periods than its cycle count).  A stall of several periods misses replies
    # like a fault: the fault windows and silences it overlaps are not judged.
    loop_stalls = [tuple(x) for x in dr["loop_stalls"]]
    disturbed = [0]

    def stalled(a, b):
        return any(x <= b and a <= y for x, y, _ in loop_stalls)

    def hidden(a, b):
        """No state_t was published from a to b (a gap of the bridge spans them)."""
        return b <= a or any(t - g - pub <= a and t >= b for t, g in stalls)

    def settled(i, t0, t1):
        """First time >= t0 from which motor i is neither LOST nor FAULT nor PROBE up to t1."""
        cur = lc_at(i, t0)
        ok_from = t0 if cur not in (0, LC_FAULT, LC_LOST) else None
        for tt, j, lc, _ in trans:
            if j != i or tt < t0 or tt > t1:
                continue
            if lc in (0, LC_FAULT, LC_LOST):
                ok_from = None
            elif ok_from is None:
                ok_from = tt
        return ok_from

    rows = {k: {"injected": 0, "detected": 0, "recovered": 0, "det": None, "rec": None,
                "nodet": 0, "disturbed": 0} for k in KINDS}
    faults = sorted(sch["faults"], key=lambda f: (f["bus"], f["start_s"]))
    for n, f in enumerate(faults):
        b, k = f["bus"], f["kind"]
        e = epoch.get(b)
        row = rows[k]
        if e is None:
            viol.append("%s: rmdd did not log bus %s's sim time 0" % (k, b))
            continue
        t0, t1 = e + f["start_s"], e + f["end_s"]
        nxt = [g for g in faults[n + 1:] if g["bus"] == b]
        t_next = e + nxt[0]["start_s"] if nxt else dr["last_state"]
        targets = bus_motors[b] if "motor" not in f else [idx[(b, f["motor"])]]
        row["injected"] += 1
        if stalled(t0 - 0.05, t1 + 0.2):
            disturbed[0] += 1
            row["disturbed"] += 1
            continue
        what = "%s %s %s %.3f-%.3f s" % (k, b, names[targets[0]] if "motor" in f else "",
                                          f["start_s"], f["end_s"])
        if k in ("disappear", "bus_off", "error_flag"):
            want = (LC_FAULT,) if k == "error_flag" else (LC_LOST,)
            bd = B["fault"] if k == "error_flag" else B["lost"]
            br = B["recover_fault"] if k == "error_flag" else B["recover_lost"]
            dets = recs = 0
            for i in targets:
                td = first_in(i, want, t0, t1 + bd + 1.0)
                if td is None and hidden(t0 + bd, t1) and re.search(
                        r"\(%s\): %s" % (names[i], "fault" if k == "error_flag" else "lost"), log):
                    # no state_t was published while it was so; rmdd's log says it was
                    unresolved[0] += 1
                    dets += 1
                elif td is None:
                    viol.append("%s: %s never %s" % (what, names[i], LC[want[0]]))
                    continue
                else:
                    dets += 1
                    lo = timed(row, "det", i, td, t0)
                    if lo > bd:
                        viol.append("%s: %s %s after %.0f ms > %.0f ms"
                                    % (what, names[i], LC[want[0]], lo * 1e3, bd * 1e3))
                tr = settled(i, t1, t_next)
                lo = None if tr is None else timed(row, "rec", i, tr, t1)
                if lo is None or lo > br:
                    viol.append("%s: %s not back %s"
                                % (what, names[i], "by the next fault" if lo is None else
                                   "until %.0f ms > %.0f ms" % (lo * 1e3, br * 1e3)))
                    continue
                recs += 1
            row["detected"] += dets == len(targets)
            row["recovered"] += recs == len(targets)
            # health_t comes from the bridge too: judged when one was published inside
            if k == "bus_off" and any(t0 + 0.01 <= x[0] <= t1 for x in dr["accepted"]):
                off = [h for h in health if t0 <= h[0] <= t1 + 0.05 and
                       h[3][BUSES.index(b)] == 3]
                if not off:
                    viol.append("%s: health_t never showed the bus BUS_OFF" % what)
        else:
            # per-frame faults and floods: the motors stay in service; a frame lost,
            # late, cut short, garbled or on another id is a missed reply
            if k == "flood":
                detected = True  # counted on the wire: the foreign frames below
                dt = None
            elif k == "bad_dlc":
                # short replies on the wire, refused as undecodable (rmdd's statistics,
                # checked below); state_t does not show them
                detected = short.get(b, 0) > 0
                dt = None
            elif k == "delay":
                hits = [tt for tt, j in late if j in targets and t0 <= tt <= min(t_next, t1 + 2.0)]
                detected = bool(hits)
                dt = hits[0] - t0 if hits else None
            else:
                # (state_t may come late: its bridge is a normal thread on a busy host)
                hits = [tt for tt, j, v in missed
                        if j in targets and t0 <= tt <= min(t_next, t1 + 2.0)]
                detected = bool(hits)
                dt = hits[0] - t0 if hits else None
            if detected:
                row["detected"] += 1
                if dt is not None:
                    worst(row, "det", dt)
            else:
                row["nodet"] += 1
            # no motor lost or faulted by it, except a garbled frame that reads as 0xF1 or
            # as error flags: then back as after a LOST or FAULT
            allow = k == "garbage"
            rec_all = 0
            for i in bus_motors[b]:
                bad = [tt for tt, j, lc, _ in trans
                       if j == i and t0 <= tt <= t1 + B["lost"] and lc in (LC_FAULT, LC_LOST)]
                if bad and not allow:
                    viol.append("%s: %s became %s" % (what, names[i], LC[lc_at(i, bad[0])]))
                tr = settled(i, t1, t_next)
                lo = None if tr is None else timed(row, "rec", i, tr, t1)
                if lo is None or lo > B["recover_lost"]:
                    viol.append("%s: %s not in service after it" % (what, names[i]))
                else:
                    rec_all += 1
            row["recovered"] += rec_all == len(bus_motors[b])

    # per-frame windows with p >= 0.05 over >= 1 s meet hundreds of frames: all detected
    # (a window whose effect state_t did not show is counted as not detected in the
    # table; no bound is documented for it, so it is not a violation)
    m = re.search(r"violations (\d+), unparsed (\d+)", wire)
    foreign = sum(int(x) for x in re.findall(r"foreign (\d+)", wire))
    if rows["flood"]["injected"] and not foreign:
        viol.append("flood: no foreign frame on any wire")

    # (a short reply whose fields fit in its bytes, 0x80's say, decodes; the others not)
    undec = re.search(r"undecodable (\d+)", log[log.rfind("statistics (exit)"):])
    n_short = sum(short.values())
    if n_short and (undec is None or int(undec.group(1)) == 0):
        viol.append("bad_dlc: %d short replies on the wires, none refused as undecodable"
                    % n_short)

    # The host watchdog, judged on what rmdd received: health_t's commands_accepted
    # (~10 Hz; every accepted command is the controller's, the hostile ones are all
    # refused) brackets the last command rmdd took before a trip within one health
    # period, so a check fails only when rmdd surely tripped early or late, whatever
    # the LCM latency and lost datagrams of a busy machine.  The table's times are
    # from the controller's last send, for the reader.
    acc = [tuple(x[:2]) for x in dr["accepted"]]
    stalls = [tuple(x) for x in dr["stalls"]]
    cyc = 1.0 / RATE_HZ
    tmo = COMMAND_TIMEOUT_MS / 1000.0

    def last_accept(tt):
        """(lo, hi, sure): the last command accepted before tt was taken after lo; and
        when sure (no command was taken between the health_t before tt and the one
        after), at or before hi."""
        k = max((j for j, (t, _) in enumerate(acc) if t <= tt), default=None)
        if k is None:
            return None
        m = k
        while m > 0 and acc[m - 1][1] == acc[k][1]:
            m -= 1
        sure = k + 1 < len(acc) and acc[k + 1][1] == acc[k][1]
        return (acc[m - 1][0] if m > 0 else float("-inf")), acc[m][0], sure

    certain_ev = [tuple(x) for x in dr["certain"]]
    fed_spans = [tuple(x) for x in dr["fed"]]

    def uncertain_at(i, tt):
        """Whether motor i's position was uncertain in the state_t that showed tt."""
        ev = [c for t, j, c in certain_ev if j == i and t <= tt]
        return bool(ev) and not ev[-1]

    wd_checked = [0, 0]  # trips judged early-or-not, late-or-not
    refused_safe = 0  # SAFE for a setpoint refused on an uncertain position, not judged
    for tt, i, lc, _ in trans:
        if lc != LC_SAFE:
            continue
        prev = [x for x in trans if x[1] == i and x[0] < tt]
        if prev and prev[-1][2] in (LC_LOST, LC_FAULT):
            continue  # lost_motor_action: the safe action of a LOST motor
        if MOTORS[i][4] in ("position", "mit") and uncertain_at(i, tt):
            # after a power cycle outside its travel band (the MIT feedforward
            # drives it there): a setpoint that needs the position is refused,
            # and the motor made safe (docs/faults.md "Position uncertain after
            # power-off")
            refused_safe += 1
            continue
        b = last_accept(tt)
        if b is None:
            continue
        # the controller's last send that carried this motor (its own deadline):
        # a trip is early only if both it and some accepted command are recent
        fed = max((min(e, tt) for j, s0, e in fed_spans if j == i and s0 <= tt), default=None)
        if fed is None or tt - fed >= tmo - 2 * cyc:
            continue
        wd_checked[0] += 1
        if tt - b[0] < tmo - 2 * cyc:
            viol.append("watchdog: %s SAFE at %.3f s, %.0f ms after a command rmdd accepted"
                        % (names[i], tt - dr["first_state"], (tt - b[0]) * 1e3))
    wd = {"injected": 0, "detected": 0, "recovered": 0, "det": None, "rec": None}
    ev = dr["events"]
    enables = [x for x in ev if x[0] == "enable"]
    for x in ev:
        if x[0] != "silent":
            continue
        t_last, t_back = x[1], x[2]
        on = [i for i in range(len(MOTORS)) if lc_at(i, t_last) == LC_ENABLED]
        nx = [e for e in enables if e[1] >= t_back]
        if not on or not nx:
            continue  # nothing to stop, or silent to the end: nothing to judge
        if stalled(t_last - 0.05, nx[0][2] + 0.5):
            disturbed[0] += 1
            continue
        wd["injected"] += 1
        det = []
        for i in on:
            ts = first_in(i, (LC_SAFE, LC_LOST, LC_FAULT), t_last, t_back)
            if ts is None:
                # a violation when rmdd surely took its last command long enough before a
                # state_t that still showed the motor ENABLED
                b = last_accept(t_back)
                if b and b[2] and not hidden(b[1] + tmo + cyc + pub, t_back) and \
                        not stalled(b[1], t_back):
                    viol.append("watchdog: %s still ENABLED %.0f ms after rmdd's last command"
                                % (names[i], (t_back - b[1]) * 1e3))
            elif lc_at(i, ts) == LC_SAFE:
                det.append(ts - t_last)
                timed(wd, "det", i, ts, t_last)
                b = last_accept(ts)
                bound = tmo + cyc
                lo = tprev.get((ts, i), ts)  # the state before still showed it ENABLED
                if not b or not b[2] or stalled(b[1], lo):
                    continue
                wd_checked[1] += 1
                if lo - b[1] > bound:
                    viol.append("watchdog: %s SAFE %.0f ms after rmdd's last command > %.0f ms"
                                % (names[i], (lo - b[1]) * 1e3, bound * 1e3))
        if det:
            wd["detected"] += 1
        # back: the controller's next enable takes them (one that is LOST meanwhile waits)
        back = [first_in(i, (LC_ENABLED,), nx[0][1], nx[0][2] + 0.5) for i in on]
        # a motor LOST or FAULT meanwhile waits for an enable = 0 once READY (the edge
        # rule, docs/design.md); the client may have moved on to enable = 1 by then
        fine = [b for i, b in zip(on, back) if b is not None or
                lc_at(i, nx[0][1]) in (LC_LOST, LC_FAULT, 0) or
                any(j == i and nx[0][1] <= t <= nx[0][2] + 0.5 and
                    lc in (LC_LOST, LC_FAULT, 0) for t, j, lc, _ in trans)]
        if len(fine) == len(on):
            wd["recovered"] += 1
            for i, b in zip(on, back):
                if b is not None:
                    timed(wd, "rec", i, b, nx[0][1])
        else:
            viol.append("watchdog: not ENABLED again after the controller's return at %.3f s"
                        % (nx[0][1] - dr["first_state"]))

    # hostile LCM: every kind rejected as its kind; the controller's stamps too
    last = dr["last_health"]
    rej = last["rejected_by_kind"]
    REJ = ["decode", "count", "index", "nonfinite", "mode", "limit", "stale", "owner"]
    hk = {"decode": ["decode_garbage", "decode_truncated", "decode_trailing", "decode_empty"],
          "count": ["count"], "index": ["index", "index_twice"], "nonfinite": ["nonfinite"],
          "mode": ["mode"], "limit": ["limit"]}
    stamps = sum(1 for x in ev if x[0] == "stamp")
    lrows = []
    for r, kinds in hk.items():
        s = sum(ho["sent"].get(k, 0) for k in kinds)
        got = rej[REJ.index(r)]
        lrows.append(("lcm_" + r, s, got))
        if s and not got:
            viol.append("hostile %s: %d sent, none rejected as such" % (r, s))
        if got > s:
            viol.append("hostile %s: %d rejected, only %d sent" % (r, got, s))
    got = rej[REJ.index("stale")]
    lrows.append(("lcm_stale_stamp", stamps, got))
    if got > stamps:
        viol.append("REJ_STALE %d > %d wild stamps sent: good commands were refused"
                    % (got, stamps))
    if stamps and not got:
        viol.append("%d wild stamps, none rejected" % stamps)
    lrows.append(("lcm_config_request", ho["sent"].get("config_request", 0), None))

    # rmdd: alive, exit 0, its statistics
    st = open(os.path.join(d, "status.txt")).read().split()
    if st[0] != "0":
        viol.append("rmdd exited %s on SIGTERM (or died)" % st[0])
    blk = log[log.rfind("statistics (exit)"):] if "statistics (exit)" in log else ""
    g = lambda rx: (re.search(rx, blk) or [None, None])[1]
    cycles, secs = g(r"after [0-9.]+ s: (\d+) cycles"), g(r"after ([0-9.]+) s:")
    plan_misses, not_sent = g(r"plan misses (\d+)"), g(r"frames not sent (\d+)")
    if cycles is None:
        viol.append("no statistics at exit")
    else:
        ratio = int(cycles) / (float(secs) * RATE_HZ)
        if ratio < 0.95:
            viol.append("loop rate: %s cycles in %s s (%.1f %%)" % (cycles, secs, ratio * 100))
    # plan misses: none outside the bus-off windows (frames refused by a bus that is off)
    off = [(epoch[f["bus"]] + f["start_s"], epoch[f["bus"]] + f["end_s"] + 0.2)
           for f in faults if f["kind"] == "bus_off" and f["bus"] in epoch]
    # (an increase is known between two health_t: outside when that whole span is)
    prev, t_prev = (health[0][2], health[0][0]) if health else (0, 0.0)
    samples = [x[0] for x in dr["accepted"]]
    for h in health[1:]:
        t_before = max([t for t in samples if t < h[0]], default=t_prev)
        if h[2] > prev and not any(a <= h[0] and t_before <= bb for a, bb in off):
            viol.append("plan misses %d -> %d in %.3f..%.3f s, outside a bus-off"
                        % (prev, h[2], t_before - dr["first_state"], h[0] - dr["first_state"]))
        prev, t_prev = h[2], h[0]
    # state_t comes from the bridge, a normal thread: a busy host keeps it waiting (the
    # rt loop's own lateness is in its statistics); the gaps only widen the brackets

    # RSS after warm-up: least-squares slope
    rss = [tuple(map(float, ln.split())) for ln in open(os.path.join(d, "rss.txt"))
           if len(ln.split()) == 2]
    t_rss0 = rss[0][0] if rss else 0
    warm = max(30.0, 0.25 * sch["duration"])
    pts = [(t, v) for t, v in rss if t - t_rss0 >= warm]
    slope = 0.0
    if len(pts) >= 10:
        mt = sum(t for t, _ in pts) / len(pts)
        mv = sum(v for _, v in pts) / len(pts)
        slope = (sum((t - mt) * (v - mv) for t, v in pts) /
                 sum((t - mt) ** 2 for t, _ in pts))  # KiB/s
        span = pts[-1][0] - pts[0][0]
        # a leak grows with the traffic, steadily; what LCM's and malloc's buffers take
        # as a burst first reaches a new peak is a step, and is bounded
        if slope * 60 > 16 and slope * span > 4096:
            viol.append("RSS grows %.1f KiB/min after warm-up (%.0f KiB over %.0f s)"
                        % (slope * 60, slope * span, span))
    else:
        viol.append("RSS: %d samples after warm-up" % len(pts))

    # ---- the table
    print("fault kind          | injected | detected | recovered | worst detect | worst recover")
    print("--------------------+----------+----------+-----------+--------------+--------------")
    # (injected counts the windows judged; a loop stall's windows are counted below)
    ms = lambda v: "-" if v is None else "%.1f ms" % (v * 1e3)
    for k in KINDS:
        r = rows[k]
        if not r["injected"]:
            continue
        print("%-19s | %8d | %8d | %9d | %12s | %12s"
              % (k, r["injected"] - r["disturbed"], r["detected"], r["recovered"], ms(r["det"]),
                 ms(r["rec"])))
    print("%-19s | %8d | %8d | %9d | %12s | %12s"
          % ("controller_silent", wd["injected"], wd["detected"], wd["recovered"],
             ms(wd["det"]), ms(wd["rec"])))
    for name, s, got in lrows:
        print("%-19s | %8d | %8s | %9s | %12s | %12s"
              % (name, s, "-" if got is None else got, "-", "-", "-"))
    print("bounds: LOST %.0f ms, FAULT %.0f ms, back from LOST %.0f ms, from FAULT %.0f ms, "
          "watchdog %.0f ms" % (B["lost"] * 1e3, B["fault"] * 1e3, B["recover_lost"] * 1e3,
                                B["recover_fault"] * 1e3, B["watchdog"] * 1e3))
    print("wire: %s setpoints checked, %s outside the limits; %d foreign frames (floods)"
          % (re.search(r"setpoints (\d+)", wire).group(1) if m else "?",
             m.group(1) if m else "?", foreign))
    if m is None or int(m.group(1)) or int(m.group(2)):
        viol.append("wire checker: %s" % (m.group(0) if m else "no summary"))
    tx = sum(b["tx_frames"] for b in last["bus"])
    sent = re.search(r"\(sent (\d+)", wire)
    if sent:
        print("wire: %s frames sent seen on the tap, %d counted by rmdd (last health_t)"
              % (sent.group(1), tx))
        if int(sent.group(1)) < 0.99 * tx:
            viol.append("tap saw %s of %d frames sent: the check is incomplete"
                        % (sent.group(1), tx))
    print("loop: %s cycles in %s s, plan misses %s, frames not sent %s; state_t late by > 1.5 ms "
          "%d times (worst %.0f ms): %d times above not resolved to a state period, judged on "
          "their bracket" % (cycles, secs, plan_misses, not_sent, len(stalls),
                             max([g for _, g in stalls], default=0) * 1e3, unresolved[0]))
    lost = dr["sends"] - last["commands_accepted"]
    print("rt loop stalls by the host (>= %d periods skipped, from state_t): %d, worst %.0f ms; "
          "fault windows and silences they overlapped, not judged: %d"
          % (STALL_PERIODS, len(loop_stalls),
             max([x[2] for x in loop_stalls], default=0) / RATE_HZ * 1e3,
             disturbed[0]))
    print("controller: %d sends, %d enables, %d wild stamps; %d commands not accepted "
          "(lost on a busy host's LCM); watchdog trips judged: %d early-or-not, %d late-or-not; "
          "made safe for a setpoint refused on an uncertain position: %d"
          % (dr["sends"], dr["enables"], stamps, lost, wd_checked[0], wd_checked[1],
             refused_safe))
    print("lcm: commands accepted %d, rejected %d (%s), clamped %d; hostile bursts %d"
          % (last["commands_accepted"], last["commands_rejected"],
             " ".join("%s %d" % (REJ[k], rej[k]) for k in range(8) if rej[k]),
             last["commands_clamped"], ho["bursts"]))
    print("rss: %d samples, %.0f..%.0f KiB; after %.0f s of warm-up a fitted slope of %.2f KiB/min "
          "(limit: 16 KiB/min or 4 MiB over the run)"
          % (len(rss), min(v for _, v in rss) if rss else 0, max(v for _, v in rss) if rss else 0,
             warm, slope * 60))
    print("bad_dlc: %d short replies on the wires, %s refused by rmdd as undecodable"
          % (n_short, undec.group(1) if undec else "?"))
    for v in viol[:40]:
        print("VIOLATION: " + v)
    if len(viol) > 40:
        print("... %d violations in all" % len(viol))
    return 1 if viol else 0


def main():
    cmd = sys.argv[1]
    if cmd == "plan":
        plan(sys.argv[2], int(sys.argv[3]), float(sys.argv[4]), sys.argv[5], sys.argv[6],
             sys.argv[7])
    elif cmd == "hostile":
        hostile(sys.argv[2], int(sys.argv[3]), float(sys.argv[4]))
    elif cmd == "drive":
        drive(sys.argv[2], int(sys.argv[3]), float(sys.argv[4]))
    elif cmd == "judge":
        sys.exit(judge(sys.argv[2]))
    else:
        sys.exit("usage: see the top of %s" % sys.argv[0])


if __name__ == "__main__":
    main()

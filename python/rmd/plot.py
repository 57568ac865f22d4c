# SPDX-License-Identifier: MIT
"""rmd-plot: selected fields of rmdd over time, from a running daemon or a log.

    rmd-plot --field position --field velocity            # live window
    rmd-plot --log run.lcmlog --field position --out pos.png   # and the setpoints
    rmd-plot --log run.lcmlog --field torque --motor motor1 --csv torque.csv
    rmd-plot --seconds 5 --field health.wake_p99_us --field bus.load --out rt.png

FIELDS
  a state_t motor field, one line per motor (--motor NAME|INDEX narrows):
    position velocity torque current temperature voltage error_code
    lifecycle mode reply_latency_us reply_age_cycles missed_replies
  health.F, one line: cycles overruns plan_misses wake_min_us wake_avg_us
    wake_p99_us wake_max_us cycle_max_us watchdog safe_action_events
    commands_accepted commands_rejected commands_clamped
  bus.F, one line per bus: load tx_frames rx_frames tx_busy rx_errors
    bus_errors state

Time is seconds from the first message plotted, on rmdd's clock (the
messages' utime).  Motors are named by rmd.config_t when the log holds one
(or, live, rmdd answers the request for it), points from before it too;
else motorN by index.  position, velocity and torque come with the
controller's setpoints from command_t (dashed, "motor1.position.cmd"), for
the motors it enables in a mode that uses them, so tracking error shows.
health.* counters that only grow (cycles, wake_max_us, the totals) show
trends; wake_p99_us (the last 10 s), wake_avg_us and bus.load show a run's
real-time health.

--csv writes every point plotted as `t_s,series,value` rows (series as in
the legend: "motor1.position", "health.wake_max_us", "can0.load"), to check
or to read elsewhere.  --out FILE writes the figure (PNG, or what the suffix
says) without a display; without --out a live window follows rmdd, and a log
is shown in a window: these need a display ($DISPLAY), else rmd-plot says
"no display: use --out FILE" and exits 2.  matplotlib is needed to draw
(not for --csv alone): pip install matplotlib, or './python[plot]'.
"""

import argparse
import os
import signal
import sys
import time

from .client import DEFAULT_URL

MOTOR_FIELDS = (
    "position", "velocity", "torque", "current", "temperature", "voltage", "error_code",
    "lifecycle", "mode", "reply_latency_us", "reply_age_cycles", "missed_replies",
)
HEALTH_FIELDS = (
    "cycles", "overruns", "plan_misses", "wake_min_us", "wake_avg_us", "wake_p99_us",
    "wake_max_us", "cycle_max_us", "watchdog", "safe_action_events", "commands_accepted",
    "commands_rejected", "commands_clamped",
)
BUS_FIELDS = ("load", "tx_frames", "rx_frames", "tx_busy", "rx_errors", "bus_errors", "state")
UNITS = {
    "position": "rad", "velocity": "rad/s", "torque": "N*m", "current": "A",
    "temperature": "degC", "voltage": "V", "reply_latency_us": "us",
    "reply_age_cycles": "cycles", "load": "fraction",
}


class Usage(Exception):
    """A bad command line: said once, exit 2."""


MATPLOTLIB_HINT = ("rmd-plot draws with matplotlib, which is not installed: "
                   "pip install matplotlib (into the environment rmd is in), or, from "
                   "rmdd's source tree, pip install './python[plot]'; Debian: "
                   "apt install python3-matplotlib")


LCM_HINT = ("the LCM Python module (lcm) is not installed for " + sys.executable
            + ": pip install lcm (Debian 12 has no python3-lcm: python3 -m venv "
            "--system-site-packages ~/rmd-venv; ~/rmd-venv/bin/pip install lcm matplotlib; "
            "then RMD_PYTHON=~/rmd-venv/bin/python3 rmd-plot ...)")


def need_display():
    """Usage when a window cannot open: no X11 or Wayland display."""
    if sys.platform.startswith(("win", "darwin")):
        return
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise Usage("no display: use --out FILE (a PNG) or --csv FILE "
                    "($DISPLAY and $WAYLAND_DISPLAY are unset)")


def parse_field(spec):
    """'position' -> ('state', 'position'); 'health.x', 'bus.x' likewise."""
    kind, _, name = spec.partition(".") if "." in spec else ("state", "", spec)
    table = {"state": MOTOR_FIELDS, "health": HEALTH_FIELDS, "bus": BUS_FIELDS}.get(kind)
    if table is None or name not in table:
        raise Usage(f"unknown field {spec!r} (rmd-plot --help lists them)")
    return kind, name


# state_t fields a controller commands, and the command_t modes that use them
COMMANDED = {
    "position": (2, 3),  # MODE_POSITION, MODE_MIT
    "velocity": (1, 3),  # MODE_SPEED, MODE_MIT
    "torque": (0, 3),    # MODE_TORQUE, MODE_MIT
}


class Series:
    """Points per series, in arrival order, on rmdd's clock.

    A motor's series are kept by index and named when written or drawn, so
    the points that came before config_t are the motor's, under its name.
    The controller's setpoints (command_t) for position, velocity and torque
    are series of their own ("motor1.position.cmd"), on rmdd's clock: each
    at the utime of the newest state_t when it was heard.
    """

    def __init__(self, fields, motors, prefix):
        self.fields = fields
        self.motors = motors  # names or indices as given; empty: all
        self.prefix = prefix
        self.config = None
        self.instances = {}  # every rmdd heard: instance -> (host, pid)
        self.points = {}  # (kind, motor index | bus name | None, field, cmd) -> ([t_us], [v])
        self.t0_us = None
        self.state_utime = None  # the newest state_t's utime

    def motor_name(self, i):
        if self.config is not None and i < self.config.motor_count:
            return self.config.motor[i].name
        return f"motor{i}"

    def wanted(self, i):
        return not self.motors or self.motor_name(i) in self.motors or str(i) in self.motors

    def label(self, key):
        """The series' name: "motor1.position", "motor1.position.cmd", "health.x", "can0.load"."""
        kind, who, name, cmd = key
        if kind == "state":
            return f"{self.motor_name(who)}.{name}" + (".cmd" if cmd else "")
        return f"{'health' if kind == 'health' else who}.{name}"

    def shown(self):
        """(key, label, ts, vs) of the series to write or draw, in first-seen order."""
        for key, (ts, vs) in self.points.items():
            if key[0] == "state" and not self.wanted(key[1]):
                continue
            yield key, self.label(key), ts, vs

    def add(self, key, t_us, value):
        if self.t0_us is None:
            self.t0_us = t_us
        ts, vs = self.points.setdefault(key, ([], []))
        ts.append(t_us)
        vs.append(float(value))

    def on_message(self, channel, data):
        """One message of rmdd's (its channel without the prefix decides the type)."""
        import rmd

        if not channel.startswith(self.prefix):
            return
        what = channel[len(self.prefix):]
        try:
            if what == "CONFIG":
                c = rmd.config_t.decode(data)
                if self._first_daemon(c):
                    self.config = c
            elif what == "STATE":
                self._state(rmd.state_t.decode(data))
            elif what == "HEALTH":
                h = rmd.health_t.decode(data)
                if self._first_daemon(h):
                    self._health(h)
            elif what in ("COMMAND", "COMMAND_TAKEN"):
                # COMMAND_TAKEN: an incident recording's commands (rmdd took them)
                self._command(rmd.command_t.decode(data))
        except ValueError:
            pass  # another layout on our channel: not ours to plot

    def _first_daemon(self, m):
        """Whether config_t or health_t m is the first rmdd's; another one is said once."""
        if m.instance not in self.instances:
            self.instances[m.instance] = (m.host, m.pid)
            if len(self.instances) == 2:
                who = ", ".join(f"host {h} pid {p}" for h, p in self.instances.values())
                print(f"rmd-plot: two rmdd on prefix {self.prefix} ({who}): their state_t "
                      "mix in the plot; names and health are the first one's (docs/lcm.md, "
                      "\"One daemon per prefix\")", file=sys.stderr, flush=True)
        return m.instance == next(iter(self.instances))

    def _state(self, s):
        self.state_utime = s.utime
        for kind, name in self.fields:
            if kind != "state":
                continue
            for i in range(s.count):
                m = s.motor[i]
                self.add(("state", m.index, name, False), s.utime, getattr(m, name))

    def _command(self, c):
        if self.state_utime is None:
            return  # no rmdd clock to put it on yet
        for kind, name in self.fields:
            if kind != "state" or name not in COMMANDED:
                continue
            for m in c.motor[:c.count]:
                if m.enable and m.mode in COMMANDED[name]:
                    self.add(("state", m.index, name, True), self.state_utime, getattr(m, name))

    def _health(self, h):
        for kind, name in self.fields:
            if kind == "health":
                self.add(("health", None, name, False), h.utime, getattr(h, name))
            elif kind == "bus":
                for b in range(h.bus_count):
                    self.add(("bus", h.bus[b].name, name, False), h.utime,
                             getattr(h.bus[b], name))

    def rows(self):
        """(t_s, series, value) of every point, series in first-seen order."""
        for _key, name, ts, vs in self.shown():
            for t, v in zip(ts, vs):
                yield (t - self.t0_us) / 1e6, name, v


def read_log(path, series):
    """Every event of an lcm-logger log, or of an incident folder's window.lcmlog, through series."""
    import lcm

    if os.path.isdir(path):
        folder = path
        path = os.path.join(folder, "window.lcmlog")
        if not os.path.exists(path):
            raise Usage(f"{folder}: a folder without window.lcmlog: not an rmdd incident "
                        "recording (or one made before rmdd wrote them)")
    try:
        log = lcm.EventLog(path, "r")
    except (IOError, OSError) as e:
        raise Usage(f"{path}: {e}") from e
    for ev in log:
        series.on_message(ev.channel, ev.data)
    log.close()


def write_csv(path, series):
    out = sys.stdout if path == "-" else open(path, "w", encoding="utf-8")
    out.write("t_s,series,value\n")
    for t, name, v in series.rows():
        out.write(f"{t:.6f},{name},{v!r}\n")
    if out is not sys.stdout:
        out.close()


def draw(fig, axes, series, window_s=None):
    """One subplot per field, one line per series of that field."""
    for ax, (kind, name) in zip(axes, series.fields):
        ax.clear()
        colors = {}
        for key, sname, ts, vs in series.shown():
            if key[0] != kind or key[2] != name:
                continue
            t = [(x - series.t0_us) / 1e6 for x in ts]
            if window_s and t:
                keep = next((k for k, x in enumerate(t) if x >= t[-1] - window_s), 0)
                t, vs = t[keep:], vs[keep:]
            if key[3]:  # the setpoint: dashed, in its motor's colour
                ax.plot(t, vs, label=sname, linestyle="--", drawstyle="steps-post",
                        color=colors.get(key[1]))
            else:
                colors[key[1]] = ax.plot(t, vs, label=sname)[0].get_color()
        unit = UNITS.get(name, "us" if name.endswith("_us") else None)
        ax.set_ylabel(f"{name} ({unit})" if unit else name)
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper left", fontsize="small")
    axes[-1].set_xlabel("s (rmdd's clock)")
    fig.tight_layout()


def need_window(plt):
    """Usage when matplotlib has no interactive backend (it fell back to Agg)."""
    if plt.get_backend().lower() in ("agg", "pdf", "ps", "svg", "cairo", "template"):
        raise Usage(f"no display: matplotlib's backend is {plt.get_backend()} (no GUI "
                    "toolkit such as tkinter): use --out FILE")


def figure(series):
    import matplotlib.pyplot as plt

    n = len(series.fields)
    fig, axes = plt.subplots(n, 1, sharex=True, figsize=(9, 2.6 * n + 0.6), squeeze=False)
    return plt, fig, [a[0] for a in axes]


def live(args, series):
    """Listen to rmdd: for --seconds into --out/--csv, or a window until closed."""
    import select

    import lcm

    import rmd

    url = args.lcm_url or os.environ.get("LCM_DEFAULT_URL") or DEFAULT_URL
    try:
        lc = lcm.LCM(url)
    except (IOError, OSError, RuntimeError) as e:
        raise Usage(f"LCM: cannot open {url}: {e}") from e
    lc.subscribe(f"{args.prefix}(STATE|HEALTH|CONFIG|COMMAND)", series.on_message)
    req = rmd.config_request_t()

    def pump(seconds):
        end = time.monotonic() + seconds
        while True:
            left = end - time.monotonic()
            if left <= 0:
                return
            if series.config is None:
                req.utime = int(time.monotonic() * 1e6)
                lc.publish(f"{args.prefix}CONFIG_REQUEST", req.encode())
            if select.select([lc.fileno()], [], [], min(left, 0.05))[0]:
                lc.handle()

    if args.out or args.csv:
        pump(args.seconds)
        if not series.points:
            raise Usage(f"nothing from rmdd on {url} (prefix {args.prefix}) in "
                        f"{args.seconds:g} s: is it running?")
        return None
    plt, fig, axes = figure(series)
    need_window(plt)
    from matplotlib.animation import FuncAnimation

    def update(_frame):
        pump(0.05)
        if series.points:
            draw(fig, axes, series, args.window)

    anim = FuncAnimation(fig, update, interval=100, cache_frame_data=False)
    plt.show()
    return anim


def main(argv=None):
    # `rmd-plot --csv - | head` ends quietly when head has read enough
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    p = argparse.ArgumentParser(
        prog="rmd-plot", description=__doc__.split("\n", 2)[2],
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--log", metavar="FILE", help="an lcm-logger log, or an incident folder "
                   "(its window.lcmlog); default: a running rmdd")
    p.add_argument("--field", "-f", action="append", metavar="F",
                   help="what to plot (repeat; default: position)")
    p.add_argument("--motor", "-m", action="append", metavar="NAME",
                   help="only these motors, by name or index (repeat)")
    p.add_argument("--out", "-o", metavar="FILE", help="write the figure (e.g. x.png), no window")
    p.add_argument("--csv", metavar="FILE", help="write the points as t_s,series,value (- stdout)")
    p.add_argument("--lcm-url", metavar="URL", help="live: rmdd's LCM URL "
                   "(default $LCM_DEFAULT_URL, else " + DEFAULT_URL + ")")
    p.add_argument("--prefix", default="RMD_", help="rmdd's channel prefix (default RMD_)")
    p.add_argument("--seconds", type=float, default=5.0,
                   help="live with --out or --csv: listen this long (default 5)")
    p.add_argument("--window", type=float, default=10.0,
                   help="live window: seconds shown (default 10)")
    args = p.parse_args(argv)
    try:
        series = Series([parse_field(f) for f in (args.field or ["position"])],
                        args.motor or [], args.prefix)
        if not (args.out or args.csv):
            need_display()  # before listening or reading: say it now
        if args.out:
            import matplotlib

            matplotlib.use("Agg")  # no display needed
        if args.log:
            read_log(args.log, series)
            if not any(True for _ in series.shown()):
                raise Usage(f"{args.log}: no {args.prefix}STATE/HEALTH message with "
                            "those fields" + (" and motors" if args.motor else ""))
        else:
            keep = live(args, series)  # noqa: F841  (the live window's animation)
            if not (args.out or args.csv):
                return 0
        if args.csv:
            write_csv(args.csv, series)
        if args.out or args.log and not args.csv:
            plt, fig, axes = figure(series)
            draw(fig, axes, series)
            if args.out:
                fig.savefig(args.out, dpi=100)
            else:
                need_window(plt)
                plt.show()
    except Usage as e:
        print(f"rmd-plot: {e}", file=sys.stderr)
        return 2
    except ImportError as e:
        if (e.name or "").split(".")[0] == "matplotlib":
            print(f"rmd-plot: {MATPLOTLIB_HINT}", file=sys.stderr)
        elif e.name == "lcm":
            print(f"rmd-plot: {LCM_HINT}", file=sys.stderr)
        else:
            print(f"rmd-plot: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())

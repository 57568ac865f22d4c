# SPDX-License-Identifier: MIT
"""rmd-view: a MuJoCo model posed by rmdd's state_t: live, from an LCM log, or an incident.

    rmd-view examples/physics/leg.xml --config examples/physics/leg.yaml         # live, a window
    rmd-view leg.xml --config leg.yaml --log run.lcmlog --png frames/            # PNG frames
    rmd-view leg.xml --joints hip=hip_joint,knee=knee_joint --log INCIDENT_DIR --png out/

The joints that rmdd's motors drive take each state_t's positions (the
output shaft, rad; a slide joint 1 m per rad, as the simulator maps it):
the map is the rmdd configuration's sim.physics.joints (--config), or
--joints MOTOR=JOINT,... (MOTOR a name from config_t or --config's
motors[], or an index).  The model's other joints move passively: between
two frames the world is stepped for the time between them with the mapped
joints held where state_t says, so a body on an unmapped rail or a free
base settles under gravity and its contacts (--no-settle: they stay at the
model's start).  The same works for a real robot's joints from the real
daemon.

Sources: live over LCM (--lcm-url, --prefix; the default), an lcm-logger log or
an incident recording (--log: a .lcmlog or an incident folder, as
rmd-export reads them).  Output: a window where there is a display
($DISPLAY or $WAYLAND_DISPLAY, and no --png), else PNG frames into a folder
(--png DIR: frame-000000.png, ..., one per --every seconds of rmdd's time),
rendered offscreen with EGL (MUJOCO_GL=egl: Mesa's, Debian 12 packages
libegl1 libegl-mesa0 libgl1-mesa-dri).  Needs the mujoco package:
pip install './python[view]' from rmdd's source tree.
"""

import argparse
import math
import os
import signal
import struct
import sys
import time
import zlib

from .client import DEFAULT_URL
from .export import Failure, events, log_path

PROG = "rmd-view"


def write_png(path, rgb):
    """An RGB image (rows of bytes, height x width x 3 uint8) as a PNG file."""
    h, w = rgb.shape[0], rgb.shape[1]
    raw = b"".join(b"\x00" + rgb[y].tobytes() for y in range(h))

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))


def config_joints(path):
    """({motor name: joint}, [motor names by index]) from an rmdd configuration."""
    try:
        import yaml
    except ImportError as e:
        raise Failure("--config needs PyYAML: pip install './python[view]'") from e
    try:
        with open(path, encoding="utf-8") as f:
            doc = yaml.safe_load(f) or {}
    except OSError as e:
        raise Failure(f"{path}: {e.strerror}") from e
    except yaml.YAMLError as e:
        raise Failure(f"{path}: not YAML: {e}") from e
    names = [m.get("name") for m in doc.get("motors") or [] if isinstance(m, dict)]
    joints = ((doc.get("sim") or {}).get("physics") or {}).get("joints") or {}
    if not isinstance(joints, dict) or not joints:
        raise Failure(f"{path}: no sim.physics.joints to pose the model by (or give --joints)")
    return {str(k): str(v) for k, v in joints.items()}, names


def parse_joints(text):
    """'hip=hip_joint,knee=knee_joint' -> {motor: joint}."""
    out = {}
    for item in text.split(","):
        motor, sep, joint = item.partition("=")
        if not sep or not motor.strip() or not joint.strip():
            raise Failure(f"--joints {text}: MOTOR=JOINT[,MOTOR=JOINT...] "
                          f"({item!r} is not)")
        if motor.strip() in out:
            raise Failure(f"--joints {text}: motor {motor.strip()} mapped twice")
        out[motor.strip()] = joint.strip()
    return out


class Pose:
    """The model, its data, and the mapped joints' qpos addresses by motor index."""

    def __init__(self, mujoco, path, settle):
        self.mj = mujoco
        try:
            self.m = mujoco.MjModel.from_xml_path(path)
        except ValueError as e:
            raise Failure(f"{path}: {str(e).strip()}") from e
        self.d = mujoco.MjData(self.m)
        mujoco.mj_forward(self.m, self.d)
        self.settle = settle
        self.by_index = {}  # motor index -> (qpos address, dof address)
        self.t_us = None

    def map(self, joints, names):
        """joints {motor: joint name}; names [motor names by index] (may be short)."""
        mj, seen = self.mj, {}
        for motor, joint in joints.items():
            if motor.isdigit():
                index = int(motor)
            elif motor in names:
                index = names.index(motor)
            else:
                raise Failure(f"motor {motor!r}: not one of rmdd's motors "
                              f"({', '.join(n for n in names if n) or 'none known'})")
            j = mj.mj_name2id(self.m, mj.mjtObj.mjOBJ_JOINT, joint)
            if j < 0:
                have = [mj.mj_id2name(self.m, mj.mjtObj.mjOBJ_JOINT, k) or "(unnamed)"
                        for k in range(self.m.njnt)]
                raise Failure(f"the model has no joint {joint!r} (its joints: "
                              f"{', '.join(have) or 'none'})")
            if int(self.m.jnt_type[j]) not in (int(mj.mjtJoint.mjJNT_HINGE),
                                               int(mj.mjtJoint.mjJNT_SLIDE)):
                raise Failure(f"joint {joint!r} is neither a hinge nor a slide")
            if j in seen:
                raise Failure(f"joint {joint!r} mapped twice ({seen[j]} and {motor})")
            seen[j] = motor
            self.by_index[index] = (self.m.jnt_qposadr[j], self.m.jnt_dofadr[j])
            # while the passive joints settle, a mapped joint is a stiff, damped
            # spring at state_t's position (integrated implicitly): it carries
            # what rests on it
            self.m.jnt_stiffness[j] = 1e4
            self.m.dof_damping[self.m.jnt_dofadr[j]] = 200.0
        self.m.opt.integrator = mj.mjtIntegrator.mjINT_IMPLICITFAST

    def hold(self, state, exact):
        """The mapped joints at state's positions: their springs', and exact: theirs too."""
        for i, (qa, da) in self.by_index.items():
            if i < state.count and math.isfinite(state.motor[i].position):
                self.m.qpos_spring[qa] = state.motor[i].position
                if exact:
                    self.d.qpos[qa] = state.motor[i].position
                    self.d.qvel[da] = 0.0

    def apply(self, state):
        """Pose the model by one state_t; the passive joints follow for the time since the last."""
        dt = 0.0 if self.t_us is None else (state.utime - self.t_us) * 1e-6
        self.t_us = state.utime
        if self.settle:
            # the first pose: a second for the passive joints to come to rest
            dt = 1.0 if dt <= 0.0 and self.d.time == 0.0 else min(max(dt, 0.0), 0.5)
            self.hold(state, self.d.time == 0.0)
            for _ in range(int(dt / self.m.opt.timestep)):
                self.mj.mj_step(self.m, self.d)
        self.hold(state, True)
        self.mj.mj_forward(self.m, self.d)


def camera(mj, m):
    """A camera looking at the whole model from its side (-y), a little above."""
    cam = mj.MjvCamera()
    cam.lookat[:] = m.stat.center
    cam.distance = 1.6 * m.stat.extent
    cam.azimuth = 90.0
    cam.elevation = -8.0
    return cam


def states_from_log(path, state_type):
    fp = state_type._get_packed_fingerprint()
    for _t, _channel, data in events(path):
        if data[:8] == fp:
            try:
                yield state_type.decode(data)
            except (ValueError, struct.error):
                continue


def names_from_log(path, config_type):
    fp = config_type._get_packed_fingerprint()
    for _t, _channel, data in events(path):
        if data[:8] == fp:
            c = config_type.decode(data)
            return [m.name for m in c.motor[:c.motor_count]]
    return []


def main(argv=None):
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n", 2)[2],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model", metavar="MODEL.xml", help="the MJCF model")
    p.add_argument("--config", metavar="RMDD.yaml",
                   help="the joint map (sim.physics.joints) and the motors' order")
    p.add_argument("--joints", metavar="MOTOR=JOINT,...", help="the joint map, given here")
    p.add_argument("--log", metavar="LOG", help="an lcm-logger log or an incident folder "
                   "(default: live over LCM)")
    p.add_argument("--png", metavar="DIR", help="write PNG frames into DIR (no window)")
    p.add_argument("--every", type=float, default=0.04, metavar="S",
                   help="seconds of rmdd's time between frames (default 0.04)")
    p.add_argument("--frames", type=int, default=0, metavar="N",
                   help="stop after N frames (default 0: the log's end, or Ctrl-C)")
    p.add_argument("--size", default="640x480", metavar="WxH", help="PNG size (default 640x480)")
    p.add_argument("--no-settle", dest="settle", action="store_false",
                   help="leave the unmapped joints at the model's start")
    p.add_argument("--lcm-url", "--url", dest="url", metavar="URL",
                   default=os.environ.get("LCM_DEFAULT_URL", DEFAULT_URL),
                   help="live: rmdd's LCM URL (default $LCM_DEFAULT_URL, else %s)" % DEFAULT_URL)
    p.add_argument("--prefix", default="RMD_", help="rmdd's channel prefix (default RMD_)")
    a = p.parse_args(argv)
    try:
        w, h = (int(x) for x in a.size.lower().split("x"))
        assert 16 <= w <= 8192 and 16 <= h <= 8192
    except (ValueError, AssertionError):
        p.error(f"--size {a.size}: WIDTHxHEIGHT, 16..8192 each")
    if not a.config and not a.joints:
        p.error("the joint map: --config RMDD.yaml (its sim.physics.joints) or --joints")
    window = not a.png and bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    if not a.png and not window:
        p.error("no display here: give --png DIR for PNG frames")
    if not window:
        os.environ.setdefault("MUJOCO_GL", "egl")
    try:
        try:
            import mujoco
        except ImportError as e:
            raise Failure(f"the mujoco package is not installed for {sys.executable}: "
                          "pip install './python[view]' from rmdd's source tree") from e
        import rmd

        joints, names = config_joints(a.config) if a.config else ({}, [])
        if a.joints:
            joints = parse_joints(a.joints)
        log = log_path(a.log) if a.log else None
        if log and not names:
            names = names_from_log(log, rmd.config_t)
        client = None
        if not log:
            client = rmd.Client(a.url, a.prefix)
            if not names or not a.config:
                c = client.connect(2.0)
                names = [m.name for m in c.motor[:c.motor_count]]
        pose = Pose(mujoco, a.model, a.settle)
        pose.map(joints, names)
        return run(a, mujoco, rmd, pose, log, client, window, w, h)
    except Failure as e:
        print(f"{PROG}: {e}", file=sys.stderr)
        return 1
    except rmd.RmdError as e:
        print(f"{PROG}: {e}", file=sys.stderr)
        return 1
    except OSError as e:
        print(f"{PROG}: {e.filename or ''}: {e.strerror}", file=sys.stderr)
        return 1


def run(a, mujoco, rmd, pose, log, client, window, w, h):
    stop = []
    signal.signal(signal.SIGINT, lambda *_: stop.append(1))
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    if window:
        import mujoco.viewer
        view = mujoco.viewer.launch_passive(pose.m, pose.d)
        out = lambda n: view.sync() if view.is_running() else stop.append(1)  # noqa: E731
    else:
        os.makedirs(a.png, exist_ok=True)
        # the offscreen buffer must hold the picture (the model's <visual><global offwidth>)
        pose.m.vis.global_.offwidth = max(pose.m.vis.global_.offwidth, w)
        pose.m.vis.global_.offheight = max(pose.m.vis.global_.offheight, h)
        renderer = mujoco.Renderer(pose.m, h, w)
        cam = camera(mujoco, pose.m)

        def out(n):
            renderer.update_scene(pose.d, camera=cam)
            write_png(os.path.join(a.png, f"frame-{n:06d}.png"), renderer.render())

    if log:
        source = states_from_log(log, rmd.state_t)
    else:
        def live():
            while not stop:
                n = client.n_states
                client.poll(0.05)
                if client.n_states != n:
                    yield client.state
        source = live()
    n, next_us = 0, None
    for s in source:
        if stop:
            break
        if next_us is not None and s.utime < next_us:
            continue
        next_us = s.utime + int(a.every * 1e6)
        pose.apply(s)
        out(n)
        n += 1
        if a.frames and n >= a.frames:
            break
    if client:
        client.close()
    where = f" into {a.png}" if a.png else ""
    print(f"{PROG}: {n} frame{'s' if n != 1 else ''}{where}", file=sys.stderr)
    return 0 if n else 1


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""rmd-ros2's bytes read and written by rosbags, independently of Cyclone DDS.

rosbags (PyPI) carries ROS 2's own message definitions per release
(rosbags.typesys Stores.ROS2_HUMBLE, ROS2_JAZZY) and its own CDR coder; it
shares no code with Cyclone DDS or with rmd-ros2's IDL.  tests/ros2/test_ros2.c
runs it on the serialized samples it took off the wire (dds_takecdr).

  ros2_cdr.py joint-state FILE...    each FILE one serialized sample (CDR
      encapsulation header first): decoded with both stores, then encoded
      again, which must give FILE's bytes exactly; one line per sample:
        js SEC NANOSEC FRAME_ID N NAME POSITION VELOCITY EFFORT ...
  ros2_cdr.py diagnostics FILE...    likewise diagnostic_msgs/msg/DiagnosticArray:
        da SEC NANOSEC N, then per status: st LEVEL NAME|MESSAGE|HARDWARE_ID|K=V;K=V
  ros2_cdr.py command OUT SEC NAME POSITION [NAME POSITION]...
      a sensor_msgs/msg/JointState as topic_based_ros2_control publishes it
      (position, velocity and effort for every name; velocity and effort 0),
      serialized by rosbags into OUT

Exit status 0, or 1 with one line saying what differs.
"""
import sys

import numpy as np
from rosbags.typesys import Stores, get_typestore

STORES = [get_typestore(Stores.ROS2_HUMBLE), get_typestore(Stores.ROS2_JAZZY)]
JS = "sensor_msgs/msg/JointState"
DA = "diagnostic_msgs/msg/DiagnosticArray"


def fail(why):
    print(f"ros2_cdr: {why}", file=sys.stderr)
    sys.exit(1)


def decode(path, typename):
    data = open(path, "rb").read()
    if data[:2] != b"\x00\x01":
        fail(f"{path}: encapsulation {data[:4].hex()}, not CDR little-endian (00 01)")
    msgs = []
    for ts in STORES:
        msg = ts.deserialize_cdr(data, typename)
        again = bytes(ts.serialize_cdr(msg, typename))
        # A writer may pad the sample to 4 bytes and say how many in the
        # options' last two bits (DDS-XTypes 1.3 7.6.3.1.2); the rest must be equal.
        pad = data[3] & 3
        body = data[: len(data) - pad]
        if again != data and (again[4:] != body[4:] or again[:2] != data[:2]):
            fail(f"{path}: rosbags encodes the sample it decoded as {len(again)} bytes "
                 f"{again.hex()}, the wire had {len(data)} bytes {data.hex()}")
        msgs.append(msg)
    return msgs[0]


def num(v):
    return repr(float(v))


def joint_state(paths):
    for p in paths:
        m = decode(p, JS)
        n = len(m.name)
        if not (len(m.position) == len(m.velocity) == len(m.effort) == n):
            fail(f"{p}: {n} names, {len(m.position)}/{len(m.velocity)}/{len(m.effort)} values")
        cols = [f"{m.name[i]} {num(m.position[i])} {num(m.velocity[i])} {num(m.effort[i])}"
                for i in range(n)]
        frame = m.header.frame_id or "-"
        print(f"js {m.header.stamp.sec} {m.header.stamp.nanosec} {frame} {n} " + " ".join(cols))


def diagnostics(paths):
    for p in paths:
        m = decode(p, DA)
        print(f"da {m.header.stamp.sec} {m.header.stamp.nanosec} {len(m.status)}")
        for s in m.status:
            kv = ";".join(f"{v.key}={v.value}" for v in s.values)
            print(f"st {s.level} {s.name}|{s.message}|{s.hardware_id}|{kv}")


def command(out, sec, pairs):
    ts = STORES[0]
    t = ts.types
    names = pairs[0::2]
    pos = np.array([float(x) for x in pairs[1::2]], dtype=np.float64)
    zeros = np.zeros(len(names), dtype=np.float64)
    msg = t[JS](
        header=t["std_msgs/msg/Header"](
            stamp=t["builtin_interfaces/msg/Time"](sec=int(sec), nanosec=0), frame_id=""),
        name=list(names), position=pos, velocity=zeros, effort=zeros.copy())
    with open(out, "wb") as f:
        f.write(bytes(ts.serialize_cdr(msg, JS)))


def main(argv):
    if len(argv) >= 2 and argv[0] == "joint-state":
        joint_state(argv[1:])
    elif len(argv) >= 2 and argv[0] == "diagnostics":
        diagnostics(argv[1:])
    elif len(argv) >= 5 and argv[0] == "command" and len(argv[3:]) % 2 == 0:
        command(argv[1], argv[2], argv[3:])
    else:
        fail("usage: ros2_cdr.py joint-state FILE... | diagnostics FILE... | "
             "command OUT SEC NAME POSITION...")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

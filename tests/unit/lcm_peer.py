#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The far end of tests/unit/test_lcm_link.c: PyPI's lcm (1.5.x) over udpm.

    lcm_peer.py send URL CHANNEL SIZE SEED
        publish one message of SIZE bytes, pattern(SIZE, SEED)
    lcm_peer.py recv URL CHANNEL COUNT SECONDS
        subscribe to CHANNEL, print "ready", then one line a message,
        "CHANNEL SIZE FNV" (FNV-1a 64 of its bytes, hex), until COUNT came
        or SECONDS passed

Either first prints "lcm VERSION" (the package's, from its metadata).  The
pattern and the hash are the suite's (test_lcm_link.c: pattern(), fnv()).
"""
import importlib.metadata
import sys
import time

import lcm


def pattern(size, seed):
    return bytes((i * 7 + seed * 13 + (i >> 8)) & 0xFF for i in range(size))


def fnv(data):
    h = 0xCBF29CE484222325
    for b in data:
        h = ((h ^ b) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return h


def main(argv):
    print("lcm", importlib.metadata.version("lcm"), flush=True)
    mode, url, channel = argv[1], argv[2], argv[3]
    lc = lcm.LCM(url)
    if mode == "send":
        lc.publish(channel, pattern(int(argv[4]), int(argv[5])))
        return 0
    count, end = int(argv[4]), time.monotonic() + float(argv[5])
    got = []

    def on_msg(ch, data):
        got.append(ch)
        print(ch, len(data), "%016x" % fnv(data), flush=True)

    lc.subscribe(channel, on_msg)
    print("ready", flush=True)
    while len(got) < count and time.monotonic() < end:
        lc.handle_timeout(50)
    return 0 if len(got) == count else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))

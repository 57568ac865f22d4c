#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Write the seed corpora (tests/fuzz/corpus/) and dictionaries (tests/fuzz/dict/).

    tests/fuzz/seeds.py [ROOT]

Frames: every "ID#DATA" vector of the suites (the manuals' worked examples
in tests/unit/test_codec.c, test_mit.c, test_rs485.c, test_candump.c, ...)
and tests/data/candump-sample.log; text: the candump sample's lines and
the suites' candump strings; files: examples/*.yaml, tests/data/**/*.yaml,
examples/rmd-sim.conf.  Each seed is named by its SHA-1, as libFuzzer names
what it finds, so rerunning adds nothing twice.  Regression inputs (crashes
found, see README.md) are committed by hand beside them and never removed.
Dictionaries: the command bytes and identifiers of the protocols, the keys
and words of the loaders' schemas (string literals of their sources), and
the syntax of candump, YAML and rmd-sim's files.
"""
import glob
import hashlib
import os
import re
import struct
import sys

ROOT = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "..")
OUT = os.path.join(ROOT, "tests", "fuzz", "corpus")
FRAME = re.compile(r"\b([0-9A-Fa-f]{3})#((?:[0-9A-Fa-f]{2}\.?){0,8})(?![0-9A-Fa-f])")


def put(harness, data):
    d = os.path.join(OUT, harness)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, hashlib.sha1(data).hexdigest()), "wb") as f:
        f.write(data)


def read(path):
    with open(path, "rb") as f:
        return f.read()


def sources():
    files = sorted(glob.glob(os.path.join(ROOT, "tests", "unit", "test_*.c")))
    files += sorted(glob.glob(os.path.join(ROOT, "tests", "system", "test_*.c")))
    files.append(os.path.join(ROOT, "tests", "data", "candump-sample.log"))
    return files


def frames():
    seen = set()
    for path in sources():
        for m in FRAME.finditer(read(path).decode("utf-8", "replace")):
            can_id = int(m.group(1), 16)
            data = bytes.fromhex(m.group(2).replace(".", ""))
            if (can_id, data) not in seen:
                seen.add((can_id, data))
                yield can_id, data


def crc16(buf):
    crc = 0xFFFF
    for b in buf:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return crc


def rs485(rid, data):
    head = bytes([0x3E, rid, 8]) + data.ljust(8, b"\0")[:8]
    return head + struct.pack("<H", crc16(head))


def frame_seeds():
    for can_id, data in frames():
        body = struct.pack("<HB", can_id, len(data)) + data.ljust(8, b"\0")
        motor = can_id & 0x1F or 1
        proto = 2 if can_id >= 0x400 else (1 if can_id == 0x140 + motor else 0)
        # codec: [0] proto | dir << 2 (2: from the identifier), [1] cmd, id, DLC, data
        for p in (0, 1, 2):
            put("codec", bytes([p | 2 << 2, data[0] if data else 0]) + body)
        put("codec", bytes([proto | 1 << 2 | 0x10, data[0] if data else 0]) + body)
        # mit: [0] selector (default ranges), id, DLC, data
        put("mit", bytes([motor << 3]) + body)
        # sim_motor: protocol and id, then one frame record (act 0, 1 ms)
        if 0x140 < can_id <= 0x160 or can_id in (0x280, 0x300) or 0x400 < can_id <= 0x420:
            put("sim_motor", bytes([proto | (motor - 1) << 2, 0, 10]) + body)
        # rs485: the frame on the line, as a motor's reply and behind noise
        if 0x240 < can_id <= 0x260 and len(data) == 8:
            put("rs485", rs485(can_id - 0x240, data))
            put("rs485", b"\x00\x3E\xFF" + rs485(can_id - 0x240, data))
            # bus_rs485: send the request this answers, then the answer, then time
            req = struct.pack("<HB", 0x140 + can_id - 0x240, 8) + bytes([data[0]]) + bytes(7)
            put("bus_rs485", b"\x00" + b"\x00" + req + b"\x02" + bytes([can_id - 0x240]) + data
                + b"\x03\x0a")


def sim_motor_seeds():
    def rec(act, dt, can_id, data):
        return bytes([act, dt]) + struct.pack("<HB", can_id, 8) + bytes(data).ljust(8, b"\0")
    release = rec(0, 1, 0x141, [0x77])
    # V3: brake released, torque, speed, position, status polls as time passes
    put("sim_motor", bytes([0]) + release + rec(0, 10, 0x141, [0xA1, 0, 0, 0, 100, 0])
        + rec(0, 50, 0x141, [0x9A]) + rec(0, 10, 0x141, [0xA2, 0, 0, 0, 0x10, 0x27])
        + rec(0, 200, 0x141, [0x9C]) + rec(0, 10, 0x141, [0xA4, 0, 0xF4, 1, 0xA0, 0x8C])
        + rec(0, 255, 0x141, [0x92]) + rec(3, 1, 0, []) + rec(0, 1, 0x141, [0x60]))
    # V3: comm-loss protection 100 ms, then silence: 0xF1 comes
    put("sim_motor", bytes([0]) + rec(0, 1, 0x141, [0xB3, 0, 0, 0, 100]) + release
        + rec(0, 255, 0x999, []) + rec(0, 255, 0x999, []) + rec(0, 1, 0x141, [0x9A]))
    # V2 motor 1: torque, multi-motor 0x280, error report
    put("sim_motor", bytes([1]) + rec(0, 1, 0x141, [0xA1, 0, 0, 0, 100])
        + rec(0, 10, 0x280, [100, 0, 0, 0]) + rec(2, 10, 0, [0x04]) + rec(0, 10, 0x141, [0x9A]))
    # MIT motor 1: release, MIT requests (V3 §5.2 example), status
    put("sim_motor", bytes([2]) + release
        + rec(0, 1, 0x401, [0xE6, 0x66, 0x82, 0xE0, 0x52, 0x33, 0x3B, 0x55])
        + rec(0, 100, 0x401, [0x80, 0, 0x80, 0x0F, 0xFF, 0x19, 0x98, 0x00])
        + rec(0, 100, 0x141, [0x9C]))


def text_seeds():
    lines = read(os.path.join(ROOT, "tests", "data", "candump-sample.log")).splitlines()
    for line in lines:
        if line.strip() and not line.startswith(b"#"):
            put("candump", line + b"\n")
    for m in re.finditer(rb'\{ "[^"]*", "((?:[^"\\]|\\.)*)"',
                         read(os.path.join(ROOT, "tests", "unit", "test_candump.c"))):
        put("candump", m.group(1).decode("unicode_escape").encode("latin-1"))


def file_seeds():
    yamls = glob.glob(os.path.join(ROOT, "examples", "*.yaml"))
    yamls += glob.glob(os.path.join(ROOT, "tests", "data", "**", "*.yaml"), recursive=True)
    for path in sorted(yamls):
        put("config_yaml", read(path))
    put("sim_config", read(os.path.join(ROOT, "examples", "rmd-sim.conf")))
    put("sim_config", b"serial = /dev/ttyUSB0\nmotors = 1,3\n[motor 3]\nprotocol = mit\n"
        b"mit_ranges = 12.5,45,24,500,5\nfault = drop:3:0.5\n")


def bridge_seeds():
    def command(utime, seq, entries):
        rec = bytes([0]) + struct.pack("<qqB", utime, seq, len(entries))
        for index, enable, mode, vals in entries:
            rec += bytes([index & 0xFF, enable, mode]) + struct.pack("<6d", *vals)
        return rec
    torque = (0, 1, 0, (0.0, 0.0, 1.5, 0.0, 0.0, 0.0))
    mit = (1, 1, 3, (0.5, 1.0, 0.2, 50.0, 1.0, 0.0))
    pos = (2, 1, 2, (2.0, 0.0, 0.0, 0.0, 0.0, 3.0))
    put("bridge", command(1000, 1, [torque]) + command(2000, 2, [torque, mit, pos]))
    put("bridge", command(0, 0, []) + command(5, 1, [mit]) + command(3, 1, [mit]))
    # a raw datagram: too short, then one with a wrong fingerprint
    put("bridge", b"\x01\x04abcd" + b"\x01\x10" + bytes(16))
    # small seq/utime steps (tag bit 1) after a full-width start
    put("bridge", command(10**9, 7, [pos]) + bytes([2, 10, 1, 1]) + bytes([0]) * 1)


def udpm_seeds():
    # records of fuzz_udpm.c: 0 raw, 1 fragment from fields, 2 short message, 3 honest sender
    def raw(sender, data):
        return bytes([sender]) + struct.pack("<H", len(data)) + data

    def frag(sender, seqno, size, off, no, count, ch, dlen):
        return bytes([0x40 | sender, seqno]) + struct.pack("<HHBBBH", size, off, no, count, ch,
                                                            dlen)

    def short(sender, ch, dlen):
        return bytes([0x80 | sender, ch]) + struct.pack("<H", dlen)

    def honest(length, frag_size, how, again, skip, shuffle=b""):
        return bytes([0xC0]) + struct.pack("<HHBQQ", length - 1, frag_size - 64, how, again,
                                           skip) + shuffle

    lc02 = struct.pack(">II", 0x4C433032, 7) + b"RMD_COMMAND\0" + bytes(range(40))
    lc03 = struct.pack(">IIIIHH", 0x4C433033, 9, 6, 0, 0, 2) + b"CH\0\xaa\xbb\xcc"
    lc03b = struct.pack(">IIIIHH", 0x4C433033, 9, 6, 3, 1, 2) + b"\xdd\xee\xff"
    put("udpm", raw(0, lc02) + raw(1, lc03) + raw(2, lc03b) + raw(1, lc03b))
    put("udpm", short(0, 0, 100) + short(1, 3, 0) + short(2, 4, 10) + short(3, 6, 10))
    # two fragments of 100 + 100 bytes, in order, a repeat, then out of order from another sender
    put("udpm", frag(0, 1, 200, 0, 0, 2, 0, 88) + frag(0, 1, 200, 88, 1, 2, 0, 112) +
        frag(1, 2, 200, 88, 1, 2, 0, 112) + frag(1, 2, 200, 88, 1, 2, 0, 112) +
        frag(1, 2, 200, 0, 0, 2, 0, 88))
    # LCM's split: 5000 bytes in 1423-byte fragments (macOS) in order, reversed, shuffled with
    # repeats, with one left out; 65536 bytes in Linux's 65487 does not fit the input's room
    put("udpm", honest(5000, 1423, 0, 0, 0) + honest(5000, 1423, 1, 0, 0) +
        honest(3000, 500, 2, 0x15, 0, bytes([3, 1, 4, 1, 5, 9, 2])) +
        honest(3000, 500, 4, 0, 0x4))
    put("udpm", honest(65536, 1423, 0, 0, 0) + honest(60000, 8000, 2, 0xFF, 0, bytes(8)))


def dict_write(name, entries):
    d = os.path.join(ROOT, "tests", "fuzz", "dict")
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name + ".dict"), "w") as f:
        f.write("# %s: written by tests/fuzz/seeds.py\n" % name)
        for e in sorted(set(entries)):
            f.write('"%s"\n' % "".join(
                c if 0x20 <= ord(c) < 0x7F and c not in '"\\' else "\\x%02X" % ord(c)
                for c in e))


def literals(paths, pattern=r'"([a-z][a-z0-9_-]{2,})"'):
    out = set()
    for path in paths:
        out |= set(re.findall(pattern, read(os.path.join(ROOT, path)).decode()))
    return out


def dicts():
    cmds = set()
    for path in ("src/proto/codec_v2.c", "src/proto/codec_v3.c"):
        cmds |= {int(x, 16) for x in re.findall(r"^\s*\{ 0x([0-9A-Fa-f]{2}),",
                                                read(os.path.join(ROOT, path)).decode(),
                                                re.M)}
    ids = [0x141, 0x142, 0x160, 0x241, 0x242, 0x260, 0x280, 0x300, 0x401, 0x420, 0x501,
           0x520]
    le16 = [chr(i & 0xFF) + chr(i >> 8) for i in ids]
    cmd_bytes = [chr(c) for c in cmds] + [chr(0xF1)]
    dict_write("codec", le16 + [chr(c) + "\x00" * 7 for c in cmds])
    dict_write("mit", le16 + ["\x00\x00\x00\x00\x00\x00\xF0\x7F", "12.5,45,24,500,5", ","])
    dict_write("sim_motor", le16 + [chr(8) + c for c in cmd_bytes])
    dict_write("udpm", ["LC02", "LC03", "RMD_COMMAND\x00", "RMD_CONFIG_REQUEST\x00",
                        "\x00\x00\xFF\xFF", "\x00\x01\x00\x00", "\xFF\xFF\xFF\xFF"])
    dict_write("rs485", ["\x3E", "\xCD", "\x3E\x01\x08", "\x3E\xCD\x08"])
    dict_write("bus_rs485", ["\x3E", "\xCD", "\x3E\x01\x08", "\x3E\xCD\x08",
                             "\x41\x01\x08", "\x80\x02\x08", "\x00\x03\x08"])
    dict_write("candump", ["can0", "vcan0", "#", "##", "R", "T", "[8]", "[08]", "RX - -",
                           "TX F -", "(1700000000.000000)", "(000.000123)", "  '", "'", ".",
                           "7FF", "241", "80000000", "20000000", "40000000"])
    yaml = literals(["src/config/config_yaml.c", "src/config/config.c", "src/sim/sim_params.c",
                     "src/sim/sim_faults.c", "src/config/yaml_schema.c"])
    dict_write("config_yaml", [k + ":" for k in yaml] + list(yaml) + [
        ": ", "- ", "\n  ", "\n    - ", "&a ", "*a", "<<: ", "!!str ", "!!int ", "---\n",
        "...\n", "{", "}", "[", "]", "'", '"', "|\n", ">\n", "~", "null", ".nan", ".inf",
        "-.inf", "0x", "1e308", "-1", "4294967296", "18446744073709551616", "#"])
    sim = literals(["src/tools/rmd-sim/config.c", "src/sim/sim_params.c",
                    "src/sim/sim_faults.c"])
    dict_write("sim_config", [k + " = " for k in sim] + list(sim) + [
        "[global]", "[motor 1]", "[motor 32]", " # ", "=", ":", ",", "1-3", "v2", "v3",
        "mit", "nan", "inf", "1e308", "-1", "0x", "18446744073709551616"])


frame_seeds()
sim_motor_seeds()
text_seeds()
file_seeds()
bridge_seeds()
udpm_seeds()
dicts()

# SPDX-License-Identifier: MIT
"""Read rmd-export's outputs back with the tools' own libraries and judge them
against the LCM log they came from (run by tests/docs/scenarios/logs.sh with
build/venv's Python, where `make python-venv` installed './python[plot,mcap,test]'):

  export_check.py mcap LOG OUT.mcap   the mcap library's reader: one schema per
      rmdd type, each a valid draft-07 JSON Schema that every message passes;
      one channel per LCM channel; as many messages per channel as the log
      has events of rmdd's types there (lcm.EventLog, each decoded by the type
      its channel name says), log and publish time = the event's timestamp,
      every value equal to the LCM message's (NaN as null)
  export_check.py csv LOG OUT.csv MOTOR...   Python's csv module: one row per
      state_t, t_s from the first state_t's utime, a column per motor (by
      config_t's names, given here) and field, each cell the state_t's value
  export_check.py foxglove LCM_URL WS_URL SECONDS   rmd-foxglove's server as
      Foxglove meets it (the `websockets` library speaking Foxglove's
      WebSocket protocol, foxglove.sdk.v1): serverInfo, an advertised channel
      per LCM channel with its rmd type's JSON Schema, a subscription to
      RMD_STATE and RMD_HEALTH; every message received in SECONDS passes its
      schema and equals, field by field, a message heard on LCM_URL directly
      (matched by utime), and 98 % of the state_t published while subscribed
      arrive (run rmd-foxglove with --max-rate 0)

Exit 0 when all holds, else 1 with the first difference.
"""

import csv
import json
import math
import struct
import sys
import threading
import time

import jsonschema
import lcm
from mcap.reader import make_reader
from websockets.sync.client import connect

import rmd

# what each LCM channel of rmdd carries (docs/lcm.md), independently of rmd-export
CHANNEL_TYPES = {"STATE": rmd.state_t, "HEALTH": rmd.health_t, "CONFIG": rmd.config_t,
                 "COMMAND": rmd.command_t, "COMMAND_TAKEN": rmd.command_t, "HOME": rmd.home_t,
                 "CONFIG_REQUEST": rmd.config_request_t}


def fail(why):
    print(f"export_check: {why}", file=sys.stderr)
    sys.exit(1)


def lcm_events(path, prefix="RMD_"):
    """(timestamp_us, channel, message) of the log's rmdd messages."""
    for ev in lcm.EventLog(path, "r"):
        cls = CHANNEL_TYPES.get(ev.channel[len(prefix):]) if ev.channel.startswith(prefix) else None
        if cls is None:
            continue
        try:
            yield ev.timestamp, ev.channel, cls.decode(ev.data)
        except ValueError:
            continue  # e.g. an empty CONFIG_REQUEST-like message


def same(lcm_value, json_value, where):
    """lcm_value (a decoded LCM message or part) equals json_value, NaN as None."""
    if isinstance(lcm_value, float):
        if not math.isfinite(lcm_value):
            if json_value is not None:
                fail(f"{where}: {lcm_value} in the log, {json_value!r} in the MCAP (want null)")
        elif json_value != lcm_value:
            fail(f"{where}: {lcm_value!r} in the log, {json_value!r} in the MCAP")
    elif isinstance(lcm_value, (list, tuple)):
        if not isinstance(json_value, list) or len(json_value) != len(lcm_value):
            fail(f"{where}: {len(lcm_value)} entries in the log, {json_value!r} in the MCAP")
        for i, (a, b) in enumerate(zip(lcm_value, json_value)):
            same(a, b, f"{where}[{i}]")
    elif hasattr(lcm_value, "__slots__"):
        if sorted(json_value) != sorted(lcm_value.__slots__):
            fail(f"{where}: fields {sorted(json_value)} in the MCAP, {lcm_value.__slots__} in LCM")
        for k in lcm_value.__slots__:
            same(getattr(lcm_value, k), json_value[k], f"{where}.{k}")
    elif json_value != lcm_value or type(json_value) is not type(lcm_value):
        fail(f"{where}: {lcm_value!r} in the log, {json_value!r} in the MCAP")


def check_mcap(log, out):
    want = list(lcm_events(log))
    if len(want) < 10:
        fail(f"{log}: only {len(want)} rmdd messages: the test made too short a log")
    with open(out, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        schemas = summary.schemas
        names = sorted(s.name for s in schemas.values())
        if len(names) != len(set(names)):
            fail(f"{out}: a type has two schemas: {names}")
        validators = {}
        for sid, s in schemas.items():
            if s.encoding != "jsonschema":
                fail(f"{out}: schema {s.name} encoded {s.encoding}, not jsonschema")
            doc = json.loads(s.data)
            jsonschema.Draft7Validator.check_schema(doc)
            validators[sid] = jsonschema.Draft7Validator(doc)
        topics = sorted(c.topic for c in summary.channels.values())
        if topics != sorted({ch for _t, ch, _m in want}):
            fail(f"{out}: channels {topics}, the log has {sorted({ch for _t, ch, _m in want})}")
        n = 0
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            if n >= len(want):
                fail(f"{out}: more messages than the log's {len(want)}")
            t_us, lcm_channel, lcm_msg = want[n]
            where = f"{out}: message {n} ({channel.topic})"
            if channel.topic != lcm_channel:
                fail(f"{where}: on {channel.topic}, the log's event {n} is on {lcm_channel}")
            if schema.name != "rmd." + type(lcm_msg).__name__ or channel.message_encoding != "json":
                fail(f"{where}: schema {schema.name}, encoding {channel.message_encoding}")
            if message.log_time != t_us * 1000 or message.publish_time != t_us * 1000:
                fail(f"{where}: log_time {message.log_time}, publish_time "
                     f"{message.publish_time}, the event's timestamp {t_us} us")
            value = json.loads(message.data)
            errors = [e.message for e in validators[schema.id].iter_errors(value)]
            if errors:
                fail(f"{where}: does not pass its schema: {errors[:3]}")
            same(lcm_msg, value, where)
            n += 1
        if n != len(want):
            fail(f"{out}: {n} messages, the log has {len(want)} of rmdd's types")
    print(f"export_check: {out}: {n} messages, {len(schemas)} schemas, {len(topics)} channels: "
          "as in the log")


def check_csv(log, out, motors):
    states = [m for _t, _ch, m in lcm_events(log) if isinstance(m, rmd.state_t)]
    with open(out, newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    if len(rows) != len(states) or len(rows) < 10:
        fail(f"{out}: {len(rows)} rows, the log has {len(states)} state_t")
    fields = ("position", "velocity", "torque", "temperature", "lifecycle", "missed_replies")
    for n, (row, s) in enumerate(zip(rows, states)):
        t = (s.utime - states[0].utime) / 1e6
        if abs(float(row["t_s"]) - t) > 1e-6:
            fail(f"{out}: row {n}: t_s {row['t_s']}, the state_t's utime gives {t}")
        for i, name in enumerate(motors):
            m = next(x for x in s.motor[:s.count] if x.index == i)
            for field in fields:
                cell, want = float(row[f"{name}.{field}"]), float(getattr(m, field))
                if not (cell == want or math.isnan(cell) and math.isnan(want)):
                    fail(f"{out}: row {n}: {name}.{field} {cell}, the state_t has {want}")
    print(f"export_check: {out}: {len(rows)} rows, motors {', '.join(motors)}: as in the log")


def check_foxglove(lcm_url, ws_url, seconds):
    heard, lock, done = {}, threading.Lock(), threading.Event()
    lc = lcm.LCM(lcm_url)

    def keep(channel, data):
        msg = CHANNEL_TYPES[channel[len("RMD_"):]].decode(data)
        with lock:
            heard[(channel, msg.utime)] = msg

    for ch in ("RMD_STATE", "RMD_HEALTH"):
        lc.subscribe(ch, keep)

    def listen():
        while not done.is_set():
            lc.handle_timeout(50)

    t = threading.Thread(target=listen, daemon=True)
    t.start()
    got = []
    with connect(ws_url, subprotocols=["foxglove.sdk.v1"], open_timeout=10) as ws:
        info = json.loads(ws.recv(timeout=10))
        if info.get("op") != "serverInfo":
            fail(f"{ws_url}: first message {info}, not serverInfo")
        channels, validators, subs = {}, {}, {}
        deadline = time.monotonic() + 10
        while not {"RMD_STATE", "RMD_HEALTH"} <= set(channels) and time.monotonic() < deadline:
            m = ws.recv(timeout=10)
            if isinstance(m, bytes):
                continue
            m = json.loads(m)
            for c in m.get("channels", []) if m.get("op") == "advertise" else []:
                if c["encoding"] != "json" or c["schemaEncoding"] != "jsonschema":
                    fail(f"{ws_url}: channel {c['topic']}: {c['encoding']}/{c['schemaEncoding']}")
                doc = json.loads(c["schema"])
                jsonschema.Draft7Validator.check_schema(doc)
                channels[c["topic"]] = c
                validators[c["id"]] = (c["topic"], c["schemaName"], jsonschema.Draft7Validator(doc))
        for topic in ("RMD_STATE", "RMD_HEALTH"):
            if topic not in channels:
                fail(f"{ws_url}: no {topic} advertised in 10 s (got {sorted(channels)})")
            want = "rmd." + CHANNEL_TYPES[topic[len("RMD_"):]].__name__
            if channels[topic]["schemaName"] != want:
                fail(f"{ws_url}: {topic}'s schema {channels[topic]['schemaName']}, not {want}")
            subs[len(subs) + 1] = channels[topic]["id"]
        ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": sid, "channelId": cid} for sid, cid in subs.items()]}))
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            try:
                m = ws.recv(timeout=max(0.01, end - time.monotonic()))
            except TimeoutError:
                break
            if isinstance(m, bytes) and m[:1] == b"\x01":
                sid, log_time = struct.unpack_from("<IQ", m, 1)
                got.append((subs[sid], log_time, json.loads(m[13:])))
    time.sleep(0.3)  # what the server sent last, heard on LCM as well
    done.set()
    t.join()
    counts = {}
    for cid, _log_time, value in got:
        topic, _name, validator = validators[cid]
        where = f"{ws_url}: {topic} utime {value.get('utime')}"
        errors = [e.message for e in validator.iter_errors(value)]
        if errors:
            fail(f"{where}: does not pass its schema: {errors[:3]}")
        with lock:
            lcm_msg = heard.get((topic, value["utime"]))
        if lcm_msg is None:
            fail(f"{where}: no such message heard on LCM")
        same(lcm_msg, value, where)
        counts[topic] = counts.get(topic, 0) + 1
    if counts.get("RMD_STATE", 0) < 10 or not counts.get("RMD_HEALTH"):
        fail(f"{ws_url}: received {counts} in {seconds} s: too few")
    # every state_t rmdd published while subscribed reached the viewer (--max-rate 0)
    span = [u for cid, _t, v in got for u in [v["utime"]] if validators[cid][0] == "RMD_STATE"]
    with lock:
        states = sum(1 for ch, u in heard if ch == "RMD_STATE" and min(span) <= u <= max(span))
    if counts["RMD_STATE"] < 0.98 * states:
        fail(f"{ws_url}: {counts['RMD_STATE']} state_t received, {states} published on LCM in "
             "the same time")
    print(f"export_check: {ws_url}: {counts} received, each as on LCM ({states} state_t published "
          "meanwhile)")


if __name__ == "__main__":
    if len(sys.argv) >= 4 and sys.argv[1] == "mcap":
        check_mcap(sys.argv[2], sys.argv[3])
    elif len(sys.argv) == 5 and sys.argv[1] == "foxglove":
        check_foxglove(sys.argv[2], sys.argv[3], float(sys.argv[4]))
    elif len(sys.argv) >= 5 and sys.argv[1] == "csv":
        check_csv(sys.argv[2], sys.argv[3], sys.argv[4:])
    else:
        fail("usage: export_check.py mcap LOG OUT.mcap | csv LOG OUT.csv MOTOR...")

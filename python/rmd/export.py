# SPDX-License-Identifier: MIT
"""rmd-export: an rmdd LCM log, or an incident recording, as MCAP or a wide CSV.

    rmd-export run.lcmlog -o run.mcap          # Foxglove, PlotJuggler
    rmd-export /var/lib/rmdd/incidents/20261124-024241-610-lost -o lost.mcap
    rmd-export run.lcmlog -o run.csv           # one column per series

LOG is a log lcm-logger wrote, or an incident folder (its window.lcmlog).
What is written follows -o's suffix (.mcap or .csv), or --format.

MCAP: every message of an rmdd type (state_t, health_t, config_t,
command_t, ... told apart by their LCM fingerprints, whatever the prefix)
as JSON, with a JSON Schema per type ("jsonschema" encoding, made from
lcm_types/*.lcm with their comments); one MCAP channel per LCM channel
("RMD_STATE"), log and publish time the time lcm-logger (or rmdd's
recorder) logged it.  Doubles that are NaN or infinite are null (JSON has
neither).  Messages of other types are left out and counted.

CSV (wide): one row per state_t, "t_s" (seconds on rmdd's clock, the
messages' utime, from the first state_t) then a column per motor and field,
"knee_l.position", "knee_l.velocity", ... (names from the log's config_t,
else motorN); an empty cell where a state_t has no entry for that motor.
rmd-plot --csv writes the long form (t_s,series,value).

The log is read as it streams (twice for the CSV: once for the columns),
never whole into memory.  Needs the mcap library for MCAP:
pip install './python[mcap]' from rmdd's source tree.  docs/logs.md.
"""

import argparse
import json
import math
import os
import signal
import struct
import sys

from .plot import MOTOR_FIELDS

LCM_MAGIC = b"\xed\xa1\xda\x01"  # the first bytes of every LCM log event (lcm eventlog.c)


class Failure(Exception):
    """What was wrong, said once; exit 1."""


def log_path(path):
    """The .lcmlog to read: path, or an incident folder's window.lcmlog; checked."""
    if os.path.isdir(path):
        inner = os.path.join(path, "window.lcmlog")
        if not os.path.exists(inner):
            raise Failure(f"{path}: a folder without window.lcmlog: not an rmdd incident "
                          "recording (or one made before rmdd wrote them)")
        path = inner
    try:
        with open(path, "rb") as f:
            head = f.read(4)
    except OSError as e:
        raise Failure(f"{path}: {e.strerror}") from e
    if not head:
        raise Failure(f"{path}: empty: no LCM events")
    if head != LCM_MAGIC:
        raise Failure(f"{path}: not an LCM log (it does not start with an LCM event: "
                      f"bytes {head.hex()}, not {LCM_MAGIC.hex()})")
    return path


def events(path):
    """(timestamp_us, channel, data) of every event, streamed (a log cut
    short, as by a power loss, gives the events it holds)."""
    import lcm

    log = lcm.EventLog(path, "r")
    try:
        for ev in log:
            yield ev.timestamp, ev.channel, ev.data
    finally:
        log.close()


def rmd_types():
    """{packed fingerprint: (type name, class)} of every rmd LCM type."""
    import rmd
    from rmd._schemas import SCHEMAS

    return {getattr(rmd, n)._get_packed_fingerprint(): (n, getattr(rmd, n)) for n in SCHEMAS}


def as_json(value):
    """An LCM message (or part of one) as JSON-ready values: NaN and infinities None."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, (list, tuple)):
        return [as_json(v) for v in value]
    if hasattr(value, "__slots__"):
        return {k: as_json(getattr(value, k)) for k in value.__slots__}
    if isinstance(value, bytes):
        return list(value)
    return value


def write_mcap(path, out):
    """Every rmd message of log path into MCAP file out; returns (written, {channel: skipped})."""
    from mcap.writer import CompressionType, Writer

    from rmd._schemas import SCHEMAS

    import rmd

    types = rmd_types()
    schema_ids, channel_ids = {}, {}
    written, skipped = 0, {}
    with open(out, "wb") as f:
        w = Writer(f, compression=CompressionType.ZSTD)
        w.start(profile="", library=f"rmd-export {rmd.__version__}")
        for t_us, channel, data in events(path):
            known = types.get(data[:8])
            if known is None:
                skipped[channel] = skipped.get(channel, 0) + 1
                continue
            name, cls = known
            try:
                msg = cls.decode(data)
            except (ValueError, struct.error) as e:
                skipped[channel] = skipped.get(channel, 0) + 1
                print(f"rmd-export: {path}: a {name} on {channel} at {t_us} us does not "
                      f"decode ({e}): left out", file=sys.stderr)
                continue
            if name not in schema_ids:
                schema_ids[name] = w.register_schema(
                    name=f"rmd.{name}", encoding="jsonschema",
                    data=json.dumps(SCHEMAS[name]).encode())
            key = (channel, name)
            if key not in channel_ids:
                channel_ids[key] = w.register_channel(
                    topic=channel, message_encoding="json", schema_id=schema_ids[name],
                    metadata={"lcm_type": f"rmd.{name}"})
            t_ns = t_us * 1000
            w.add_message(channel_id=channel_ids[key], log_time=t_ns, publish_time=t_ns,
                          data=json.dumps(as_json(msg), allow_nan=False).encode())
            written += 1
        w.finish()
    return written, skipped


def wide_columns(path, types):
    """The wide CSV's motors, from a first pass: [(index, name)], by index."""
    config, indices = None, set()
    for _t, _channel, data in events(path):
        known = types.get(data[:8])
        if known is None or known[0] not in ("state_t", "config_t"):
            continue
        try:
            msg = known[1].decode(data)
        except (ValueError, struct.error):
            continue
        if known[0] == "config_t":
            config = config or msg
        else:
            indices.update(m.index for m in msg.motor[:msg.count])
    names = {}
    if config is not None:
        names = {m.index: m.name for m in config.motor[:config.motor_count]}
    return [(i, names.get(i, f"motor{i}")) for i in sorted(indices)]


def write_wide_csv(path, out):
    """One row per state_t of log path into out (a CSV); returns the rows written."""
    import csv

    types = rmd_types()
    motors = wide_columns(path, types)
    if not motors:
        raise Failure(f"{path}: no state_t in it: nothing for a CSV")
    import rmd

    state = rmd.state_t
    fingerprint = state._get_packed_fingerprint()
    rows, t0 = 0, None
    with open(out, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["t_s"] + [f"{name}.{field}" for _i, name in motors for field in MOTOR_FIELDS])
        for _t, _channel, data in events(path):
            if data[:8] != fingerprint:
                continue
            try:
                s = state.decode(data)
            except (ValueError, struct.error):
                continue
            t0 = s.utime if t0 is None else t0
            by_index = {m.index: m for m in s.motor[:s.count]}
            row = [f"{(s.utime - t0) / 1e6:.6f}"]
            for i, _name in motors:
                m = by_index.get(i)
                row += ["" if m is None else repr(getattr(m, field)) for field in MOTOR_FIELDS]
            w.writerow(row)
            rows += 1
    return rows


def main(argv=None):
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    p = argparse.ArgumentParser(
        prog="rmd-export", description=__doc__.split("\n", 2)[2],
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("log", metavar="LOG", help="an lcm-logger log, or an incident folder")
    p.add_argument("-o", "--out", metavar="FILE", required=True,
                   help="the file to write (.mcap or .csv)")
    p.add_argument("--format", choices=("mcap", "csv"),
                   help="what to write (default: from -o's suffix)")
    args = p.parse_args(argv)
    fmt = args.format or {".mcap": "mcap", ".csv": "csv"}.get(
        os.path.splitext(args.out)[1].lower())
    if fmt is None:
        p.error(f"{args.out}: say --format mcap or --format csv (the suffix is neither "
                ".mcap nor .csv)")
    try:
        path = log_path(args.log)
        if fmt == "mcap":
            written, skipped = write_mcap(path, args.out)
            if not written:
                os.unlink(args.out)
                raise Failure(f"{path}: no message of an rmdd type in it"
                              + (f" (channels {', '.join(sorted(skipped))})" if skipped else ""))
            print(f"rmd-export: {args.out}: {written} messages", file=sys.stderr)
            if skipped:
                print("rmd-export: left out (not rmdd types): " + ", ".join(
                    f"{n} on {c}" for c, n in sorted(skipped.items())), file=sys.stderr)
        else:
            rows = write_wide_csv(path, args.out)
            print(f"rmd-export: {args.out}: {rows} rows", file=sys.stderr)
    except Failure as e:
        print(f"rmd-export: {e}", file=sys.stderr)
        return 1
    except OSError as e:
        print(f"rmd-export: {e.filename or args.out}: {e.strerror}", file=sys.stderr)
        return 1
    except ImportError as e:
        if (e.name or "").split(".")[0] == "mcap":
            print("rmd-export: MCAP needs the mcap library, which is not installed for "
                  f"{sys.executable}: pip install mcap (from rmdd's source tree: pip install "
                  "'./python[mcap]')", file=sys.stderr)
        else:
            print(f"rmd-export: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())

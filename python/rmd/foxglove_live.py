# SPDX-License-Identifier: MIT
"""rmd-foxglove: rmdd's LCM messages, live, in Foxglove.

    rmd-foxglove                          # ws://127.0.0.1:8765, LCM's default URL
    rmd-foxglove --host 0.0.0.0 --port 8765 --lcm-url 'udpm://239.255.76.67:7667?ttl=1'

A Foxglove WebSocket server (the Foxglove SDK's, foxglove-sdk on PyPI) that
republishes every LCM message of an rmdd type it hears (state_t, health_t,
config_t, command_t, ... told apart by their fingerprints, whatever the
prefix) as JSON with its JSON Schema, on a Foxglove channel named as the
LCM channel: the same encoding, schemas and channel names as rmd-export's
MCAP (docs/logs.md), so a layout made on a log works live.  In Foxglove:
Open connection, Foxglove WebSocket, ws://HOST:PORT.

--max-rate HZ keeps each channel at most that often (default 250: a 1 kHz
state_t as JSON is more than a browser plots; 0 sends every message); the
messages left out are counted and said at exit.  It listens on 127.0.0.1
unless told --host: the server has no authentication.  Not rt: it runs
beside rmdd, like rmd-plot.  Needs './python[foxglove]'.
"""

import argparse
import json
import signal
import struct
import sys
import time

from .export import as_json, rmd_types


class Bridge:
    """LCM messages of rmdd types onto Foxglove channels, one per (channel, type)."""

    def __init__(self, foxglove, max_rate):
        from rmd._schemas import SCHEMAS

        self.fg = foxglove
        self.schemas = SCHEMAS
        self.types = rmd_types()
        self.min_gap_ns = int(1e9 / max_rate) if max_rate > 0 else 0
        self.channels = {}
        self.last_ns = {}
        self.sent = 0
        self.thinned = {}
        self.undecoded = {}

    def channel(self, name, type_name):
        key = (name, type_name)
        ch = self.channels.get(key)
        if ch is None:
            schema = self.fg.Schema(name=f"rmd.{type_name}", encoding="jsonschema",
                                    data=json.dumps(self.schemas[type_name]).encode())
            ch = self.fg.Channel(name, schema=schema, message_encoding="json",
                                 metadata={"lcm_type": f"rmd.{type_name}"})
            self.channels[key] = ch
        return ch

    def take(self, name, data):
        known = self.types.get(data[:8])
        if known is None:
            return
        now = time.time_ns()
        if self.min_gap_ns and now - self.last_ns.get(name, -self.min_gap_ns) < self.min_gap_ns:
            self.thinned[name] = self.thinned.get(name, 0) + 1
            return
        type_name, cls = known
        try:
            msg = cls.decode(data)
        except (ValueError, struct.error):
            self.undecoded[name] = self.undecoded.get(name, 0) + 1
            return
        self.last_ns[name] = now
        payload = json.dumps(as_json(msg), allow_nan=False).encode()
        self.channel(name, type_name).log(payload, log_time=now)
        self.sent += 1


def main(argv=None):
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    p = argparse.ArgumentParser(
        prog="rmd-foxglove", description=__doc__.split("\n", 2)[2],
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--lcm-url", metavar="URL", default=None,
                   help="LCM to listen on (default: $LCM_DEFAULT_URL, else LCM's default)")
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (127.0.0.1)")
    p.add_argument("--port", type=int, default=8765, help="WebSocket port (8765, Foxglove's)")
    p.add_argument("--max-rate", type=float, default=250.0, metavar="HZ",
                   help="at most this many messages a second per channel (250; 0: all)")
    args = p.parse_args(argv)
    if not 0 <= args.port <= 65535:
        p.error(f"--port {args.port}: not a port (0..65535)")
    if args.max_rate < 0:
        p.error(f"--max-rate {args.max_rate:g}: not a rate (0 or more)")
    try:
        import foxglove
    except ImportError:
        print("rmd-foxglove: needs the Foxglove SDK, which is not installed for "
              f"{sys.executable}: pip install foxglove-sdk (from rmdd's source tree: pip "
              "install './python[foxglove]')", file=sys.stderr)
        return 1
    import lcm

    try:
        lc = lcm.LCM(args.lcm_url) if args.lcm_url else lcm.LCM()
    except (RuntimeError, OSError) as e:
        print(f"rmd-foxglove: LCM {args.lcm_url or '(default)'}: {e}", file=sys.stderr)
        return 1
    bridge = Bridge(foxglove, args.max_rate)
    try:
        server = foxglove.start_server(name="rmdd", host=args.host, port=args.port)
    except Exception as e:  # the SDK raises its own error types
        print(f"rmd-foxglove: cannot listen on {args.host}:{args.port}: {e}", file=sys.stderr)
        return 1
    lc.subscribe(".*", lambda channel, data: bridge.take(channel, data))
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    print(f"rmd-foxglove: serving on ws://{args.host}:{server.port} (Foxglove: Open connection, "
          "Foxglove WebSocket)", file=sys.stderr, flush=True)
    try:
        while not stop:
            try:
                lc.handle_timeout(200)
            except OSError:
                if not stop:  # a SIGTERM can interrupt the wait: that is the stop
                    raise
    except KeyboardInterrupt:
        pass
    finally:
        server.stop()
    thinned = sum(bridge.thinned.values())
    print(f"rmd-foxglove: {bridge.sent} messages sent"
          + (f", {thinned} left out by --max-rate" if thinned else "")
          + "".join(f"; {n} on {c} did not decode" for c, n in sorted(bridge.undecoded.items())),
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

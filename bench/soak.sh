#!/bin/sh
# The soak of issue 10: rmdd on simulated motors for DURATION seconds, under
# seeded random faults of every kind the simulator has, hostile and flooding
# LCM traffic, and a controller that comes and goes; every invariant is
# checked throughout and a table of the faults is printed (bench/README.md,
# "Soak").
#
#   bench/soak.sh 120                 # 2 minutes (CI)
#   SEED=4242 bench/soak.sh 600       # repeat a run: the seed is printed
#   KEEP=1 bench/soak.sh 120          # keep the work directory (logs, tap summary)
#
# Parts:
#   bench/soak_lcm.py plan     the config (3 sim buses, V3, MIT and V2 motors) and
#                              each bus's fault table, from SEED
#   build/bench/soak_wire      reads the buses' wire tap (sim.tap, one file) after
#                              the run and checks every setpoint rmdd sent against
#                              the limits
#   bench/soak_lcm.py hostile  malformed, wrong-size, NaN/Inf, out-of-range
#                              commands and config requests, in bursts
#   bench/soak_lcm.py drive    the controller (enables, streams, goes silent,
#                              returns) and the monitor of state_t and health_t
#   /proc/PID/status           rmdd's VmRSS once a second
#   bench/soak_lcm.py judge    the table and the verdict
#
# Needs root (SCHED_FIFO: rmdd --require-rt), multicast on loopback (docs/lcm.md),
# `make` and `make python-venv`.  Exit status 0: every invariant held; 1: a
# violation (each is printed); 2: could not run.
set -u
cd "$(dirname "$0")/.."

DURATION=${1:-${DURATION:-120}}
BUILD=${BUILD:-build}
RMDD=${RMDD:-$BUILD/rmdd}
WIRE=${WIRE:-$BUILD/bench/soak_wire}
PY=${PY:-$BUILD/venv/bin/python3}
SEED=${SEED:-$(od -An -N2 -tu2 /dev/urandom | tr -d ' ')}

for f in "$RMDD" "$WIRE" "$PY"; do
	[ -x "$f" ] || { echo "soak: no $f (make; make python-venv)"; exit 2; }
done
case $DURATION in
'' | *[!0-9]*) echo "soak: DURATION must be whole seconds, not \"$DURATION\""; exit 2 ;;
esac
[ "$DURATION" -ge 60 ] || { echo "soak: DURATION at least 60 s (warm-up and fault slots)"; exit 2; }

dir=$(mktemp -d /tmp/rmdd-soak.XXXXXX)
pids=
cleanup() {
	for p in $pids ${BENCH_PID:-}; do kill "$p" 2>/dev/null; done
	[ -n "${KEEP:-}" ] || rm -rf "$dir"
}
trap cleanup EXIT
trap 'exit 2' INT TERM

# A group and port of its own, so other LCM users of this host (tests,
# another soak) and this one never hear each other.
port=$((7700 + $$ % 200))
export SOAK_URL="udpm://239.255.76.$((68 + $$ % 100)):$port?ttl=0"
export SOAK_PREFIX="SOAK$$_"

echo "soak: seed $SEED, $DURATION s, work directory $dir (SEED=$SEED $0 $DURATION repeats it)"
# The tap is a regular file, read once rmdd has exited: a FIFO's reader,
# descheduled while it holds the pipe's lock, makes the loop's write() wait
# (bench/README.md, "The wire tap").  About 45 MB a minute.
"$PY" bench/soak_lcm.py plan "$dir" "$SEED" "$DURATION" "$SOAK_URL" "$SOAK_PREFIX" \
	"$dir/wire.candump" || exit 2

. bench/lib.sh
bench_rmdd_start "$RMDD" "$dir/rmdd.log" --config "$dir/soak.yaml" --require-rt
rmdd_pid=$BENCH_PID

# VmRSS (KiB) once a second, on the machine's monotonic clock
(
	while kill -0 $rmdd_pid 2>/dev/null; do
		r=$(sed -n 's/^VmRSS:[^0-9]*\([0-9]*\).*/\1/p' /proc/$rmdd_pid/status 2>/dev/null)
		[ -n "$r" ] && echo "$(cut -d' ' -f1 /proc/uptime) $r"
		sleep 1
	done
) >"$dir/rss.txt" &
pids="$pids $!"

"$PY" bench/soak_lcm.py hostile "$dir" "$SEED" "$DURATION" &
hostile_pid=$!
pids="$pids $hostile_pid"
"$PY" bench/soak_lcm.py drive "$dir" "$SEED" "$DURATION"
drive_rc=$?
wait $hostile_pid
hostile_rc=$?

alive=1
kill -0 $rmdd_pid 2>/dev/null || alive=0
kill -TERM $rmdd_pid 2>/dev/null
wait $rmdd_pid
echo "$? $alive" >"$dir/status.txt"
[ $alive = 1 ] || echo "soak: rmdd was not running at the end (crashed?)" >>"$dir/status.txt"
"$WIRE" "$dir/soak.yaml" "$dir/wire.candump" >"$dir/wire.txt" 2>&1

cat "$dir/wire.txt" | grep -v "^wire: bus " | sed 's/^/  /'
echo "--- faults (seed $SEED, $DURATION s)"
status=0
if [ $drive_rc != 0 ] || [ $hostile_rc != 0 ]; then
	echo "soak: FAIL: the controller exited $drive_rc, the hostile sender $hostile_rc"
	status=1
fi
if [ -s "$dir/drive.json" ] && [ -s "$dir/hostile.json" ]; then
	"$PY" bench/soak_lcm.py judge "$dir" || status=1
	[ $alive = 1 ] || status=1
else
	status=1
fi
if [ $status = 0 ]; then
	rm -f "$dir/wire.candump"
	echo "soak: PASS (seed $SEED, $DURATION s)"
else
	KEEP=1
	echo "soak: FAIL (seed $SEED, $DURATION s); rmdd's log and the rest in $dir"
fi
exit $status

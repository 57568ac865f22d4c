#!/bin/sh
# Issue 11 point 2: system calls per cycle of rmdd's loop on SocketCAN,
# counted, not estimated: 9 V3 motors (rmd-sim) on vcan0..vcan2 at 1 kHz,
# every motor READY (one status read a motor a cycle), every system call
# entry of the process's threads counted by the kernel (a tracefs
# histogram on raw_syscalls:sys_enter, keyed by thread and call) for
# WINDOW seconds; the cycles of that window are the loop thread's
# clock_nanosleep calls (one a cycle).
# The same run measures the baseline BASE (bench/lib.sh) first.
#
#   bench/syscalls.sh            # on this host when it has vcan, else in the QEMU guest (tests/vm)
#
# Prints per cycle: every system call of the loop thread by name, the
# total, and per bus; writes bench/results/syscalls.txt and .png.
# Target (issue 11): <= 2 per bus (one sendmmsg, one recvmmsg), plus the
# timer wait (clock_nanosleep), plus at most one wake of the bridge
# (an eventfd write).  The figures are per cycle run (a cycle skipped by an
# overrun makes no calls).
# Environment: BUILD (build), BASE (8c261d5; none: no baseline), WINDOW (5 s),
# PER_BUS (motors a bus, 1..3; 3), RATE (Hz, 1000), OUT.  With PER_BUS or
# RATE other than 3 and 1000 the files are syscalls-PER_BUS[-RATE].*: a bus
# whose replies are in well before the next tick is one whose state is
# published as soon as they are (issue 23), a full one (three at 1 kHz)
# one the next tick publishes.  (The emulated guest's rmd-sim answers
# about 1 ms late: there the early publish needs a lower RATE.)
set -eu
cd "$(dirname "$0")/.."
. bench/lib.sh
BUILD=${BUILD:-build}
WINDOW=${WINDOW:-5}
PER_BUS=${RMD_BENCH_PER_BUS:-${PER_BUS:-3}}
RATE=${RMD_BENCH_RATE:-${RATE:-1000}}
case "$PER_BUS" in 1 | 2 | 3) ;; *) echo "syscalls: PER_BUS is 1, 2 or 3, not $PER_BUS"; exit 2 ;; esac
case "$RATE" in '' | *[!0-9]*) echo "syscalls: RATE is a whole number of Hz, not $RATE"; exit 2 ;; esac
name=syscalls
[ "$PER_BUS" = 3 ] && [ "$RATE" = 1000 ] || name=syscalls-$PER_BUS
[ "$RATE" = 1000 ] || name=$name-$RATE
OUT=${OUT:-bench/results}

if [ -z "${RMD_BENCH_IN_VM:-}" ]; then
	mkdir -p "$OUT"
	base_dir=
	[ "$BASE" != none ] && base_dir=$(bench_base build/rmdd build/rmd-sim)
	RMD_BENCH_IN_VM=1 RMD_BENCH_BASE_DIR=$base_dir RMD_BENCH_WINDOW=$WINDOW RMD_BENCH_OUT=$OUT RMD_BENCH_PER_BUS=$PER_BUS RMD_BENCH_RATE=$RATE \
		tests/vm/vm-run --vcan 3 --timeout 900 -- "$0"
	rc=$?
	[ $rc -eq 0 ] || exit $rc
	data=$OUT/$name.dat
	if py=$(bench_plot); then
		"$py" - "$data" "$OUT/$name.png" "$BASE" <<'PY'
import sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
rows = [l.split() for l in open(sys.argv[1]) if l.strip()]
builds = [b for b in ("base", "this") if any(r[0] == b for r in rows)]
names = sorted({r[1] for r in rows if r[1] != "total"})
fig, ax = plt.subplots(figsize=(7, 4))
w = 0.8 / len(builds)
for k, b in enumerate(builds):
    v = {r[1]: float(r[2]) for r in rows if r[0] == b}
    ax.bar([i + k * w for i in range(len(names))], [v.get(n, 0) for n in names], w,
           label=("baseline " + sys.argv[3]) if b == "base" else "this build")
ax.set_xticks([i + w * (len(builds) - 1) / 2 for i in range(len(names))])
ax.set_xticklabels(names, rotation=20)
ax.set_ylabel("calls per cycle (loop thread)")
ax.set_title("rmdd loop: system calls per cycle, 3 SocketCAN buses x 3 motors")
ax.grid(True, axis="y", alpha=0.3)
ax.legend()
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=100)
PY
		echo "syscalls: wrote $OUT/$name.txt and $OUT/$name.png"
	fi
	exit 0
fi

# ---- in the guest (or on a host with vcan) ----
OUT=$RMD_BENCH_OUT
WINDOW=$RMD_BENCH_WINDOW
mkdir -p "$OUT"
work=/dev/shm/rmdd-bench-syscalls
rm -rf "$work"
mkdir -p "$work"
cfg=$work/vcan.yaml
{
	echo "loop: {rate_hz: $RATE, rt_priority: 40}"
	cat <<'YAML'
safety: {comm_loss_ms: 200, missed_replies_lost: 50}
probe: {on_missing: start}
buses:
  - {name: vcan0, type: socketcan}
  - {name: vcan1, type: socketcan}
  - {name: vcan2, type: socketcan}
motors:
YAML
	for b in 0 1 2; do
		for id in $(seq "$PER_BUS"); do
			echo "  - {name: m$b$id, bus: vcan$b, id: $id, mode: torque, torque_constant_nm_a: 2}"
		done
	done
} >"$cfg"

# tracefs: a histogram of system call entries by thread and call (the
# kernel counts; the threads are not stopped as under strace)
T=/sys/kernel/tracing
[ -d $T/events ] || mount -t tracefs nodev $T 2>/dev/null || true
E=$T/events/raw_syscalls/sys_enter
[ -w "$E/trigger" ] || { echo "syscalls: no tracefs histogram triggers here ($E)"; exit 2; }
HIST='hist:keys=common_pid,id.syscall:vals=hitcount:size=4096'

# measure BUILD_DIR LABEL: appends "LABEL name per_cycle" rows to $work/rows
measure() {
	dir=$1
	label=$2
	log=$work/$label.log
	sims=
	for b in 0 1 2; do
		"$dir/rmd-sim" --can vcan$b --motors 1-"$PER_BUS" >"$work/sim$b.log" 2>&1 &
		sims="$sims $!"
	done
	sleep 1
	"$dir/rmdd" --config "$cfg" --lcm-url memq:// 2>"$log" &
	pid=$!
	i=0
	while ! grep -q "rmdd: running:" "$log" 2>/dev/null; do
		i=$((i + 1))
		[ $i -lt 300 ] && kill -0 $pid 2>/dev/null || { cat "$log"; kill $sims; exit 1; }
		sleep 0.1
	done
	sleep 2
	# the loop: the SCHED_FIFO thread (the baseline's has no name)
	tid=
	for t in /proc/$pid/task/*; do
		[ "$(awk '{print $41}' "$t/stat")" = 1 ] && tid=$(basename "$t")
	done
	[ -n "$tid" ] || { echo "syscalls: no loop thread in $pid"; kill $pid $sims; exit 1; }
	echo "$HIST" >"$E/trigger"
	sleep "$WINDOW"
	cp "$E/hist" "$work/$label.hist" 2>/dev/null || true
	echo "!$HIST" >"$E/trigger" 2>/dev/null || true
	# tid -> thread name
	for t in /proc/$pid/task/*; do
		echo "$(basename "$t") $(cat "$t/comm")"
	done >"$work/$label.threads"
	kill -TERM $pid
	wait $pid || true
	kill $sims 2>/dev/null || true
	wait 2>/dev/null || true
	sed -n 's/.*common_pid: *\([0-9]*\), *id: *sys_\([a-z0-9_]*\).*hitcount: *\([0-9]*\).*/\1 \2 \3/p' \
		"$work/$label.hist" >"$work/$label.calls"
	# cycles in the window: each ends in one clock_nanosleep of the loop thread
	n=$(awk -v tid="$tid" '$1 == tid && $2 == "clock_nanosleep" { print $3 }' "$work/$label.calls")
	[ -n "$n" ] && [ "$n" -gt 0 ] || { echo "syscalls: no cycles counted"; exit 1; }
	# "{ common_pid: 158, id: sys_recvmmsg [299] } hitcount: 1234" -> "tid name count"
	echo "--- $label ($dir): loop thread $tid, $n cycles in ${WINDOW} s"
	awk -v n="$n" -v l="$label" -v tid="$tid" '$1 == tid { t += $3; printf "%s %s %.2f\n", l, $2, $3 / n }
		END { printf "%s total %.2f\n", l, t / n }' "$work/$label.calls" >>"$work/rows"
	awk -v n="$n" 'NR == FNR { name[$1] = $2; next }
		($1 in name) { c[name[$1] " " $2] += $3; th[name[$1]] += $3; t += $3 }
		END { for (k in th) printf "  %-14s %-18s %8.2f calls a cycle\n", k, "(all)", th[k] / n
		      for (k in c) { split(k, p, " "); printf "  %-14s %-18s %8.2f\n", p[1], p[2], c[k] / n }
		      printf "  %-14s %-18s %8.2f calls a cycle\n", "process", "(all threads)", t / n }' \
		"$work/$label.threads" "$work/$label.calls" >"$work/$label.process"
}

: >"$work/rows"
[ -n "${RMD_BENCH_BASE_DIR:-}" ] && measure "$RMD_BENCH_BASE_DIR/build" base
measure "$BUILD" this

txt=$OUT/$name.txt
{
	echo "# bench/syscalls.sh, $(date -u +%Y-%m-%d), $(uname -r), 3 SocketCAN buses (vcan) x $PER_BUS V3 motors (rmd-sim), READY, $RATE Hz"
	echo "# loop thread, calls per cycle (tracefs sys_enter histogram over ${WINDOW} s; a cycle = one clock_nanosleep)"
	printf '%-18s %8s %8s %7s\n' syscall this base ratio
	awk '{ v[$1 " " $2] = $3; n[$2] = 1 }
	END {
		for (k in n) {
			a = ("this " k) in v ? v["this " k] : 0
			b = ("base " k) in v ? v["base " k] : "-"
			r = (b != "-" && b > 0) ? sprintf("%.2f", a / b) : "-"
			printf "%-18s %8.2f %8s %7s\n", k, a, b, r
		}
	}' "$work/rows" | sort
	awk '$1 == "this" && $2 == "total" { printf "%-18s %8.2f   (3 buses)\n", "per bus (total/3)", $3 / 3 }' "$work/rows"
	for l in base this; do
		[ -f "$work/$l.process" ] && { echo "# whole process ($l)"; cat "$work/$l.process"; }
	done
} >"$txt"
cp "$work/rows" "$OUT/$name.dat"
cat "$txt"

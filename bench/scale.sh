#!/bin/sh
# Issue 11: rmdd from 3 to 32 motors at 1 kHz (`rmdd --sim N`: V3 torque
# motors, three a simulated 1 Mbit/s bus, so 32 motors use 11 buses), each
# for DURATION seconds at SCHED_FIFO: plan misses, overruns, and the CPU of
# the loop thread and of the whole process (/proc/PID/task/*/stat).  The
# same run measures the baseline BASE (bench/lib.sh) first.  The highest
# sustainable rate of a configuration is the planner's to say
# (`rmdd --check-config`: bus time, not CPU, is the limit at 1 kHz).
#
#   bench/scale.sh                   # root (SCHED_FIFO)
#
# Environment: BUILD (build), BASE (8c261d5; none), DURATION (10 s),
# COUNTS ("3 6 12 18 24 32"), OUT (bench/results).
set -eu
cd "$(dirname "$0")/.."
. bench/lib.sh
bench_init scale
DURATION=${DURATION:-10}
hz=$(getconf CLK_TCK)

# run BUILD_DIR LABEL N: appends "LABEL N loop% proc% misses overruns cycles"
run() {
	log=$work/$2-$3.log
	bench_rmdd_start "$1/rmdd" "$log" --sim "$3" --require-rt --lcm-url memq://
	pid=$BENCH_PID
	sleep 1
	t0=$(cat /proc/$pid/task/*/stat | awk '{ t += $14 + $15; if ($41 == 1) l += $14 + $15 } END { print l, t }')
	sleep "$DURATION"
	t1=$(cat /proc/$pid/task/*/stat | awk '{ t += $14 + $15; if ($41 == 1) l += $14 + $15 } END { print l, t }')
	kill -TERM $pid
	wait $pid || true
	misses=$(sed -n 's/.*plan misses \([0-9]*\).*/\1/p' "$log" | tail -n 1)
	over=$(sed -n 's/.*loop: overruns \([0-9]*\).*/\1/p' "$log" | tail -n 1)
	cyc=$(bench_cycles "$log")
	# bus load: the busiest bus's measured load over the run and the plan's worst cycle
	sed -n 's/.*  bus [^ ]* (.*): load [0-9]*% (last window), \([0-9]*\)% (run); plan \([0-9]*\)% worst.*/\1 \2/p' "$log" |
		awk -v l="$2" -v n="$3" '{ if ($1 > r) r = $1; if ($2 > w) w = $2 } END { print l, n, r + 0, w + 0 }' >>"$work/load"
	echo "$2 $3 $t0 $t1 $misses $over $cyc" | awk -v hz="$hz" -v d="$DURATION" \
		'{ printf "%s %s %.1f %.1f %s %s %s\n", $1, $2, 100 * ($5 - $3) / hz / d, 100 * ($6 - $4) / hz / d, $7, $8, $9 }' >>"$work/rows"
}

: >"$work/rows"
: >"$work/load"
if [ "$BASE" != none ]; then
	bdir=$(bench_base build/rmdd)
	for n in $COUNTS; do run "$bdir/build" base "$n"; done
fi
for n in $COUNTS; do run "$BUILD" this "$n"; done

txt=$OUT/scale.txt
{
	echo "# bench/scale.sh, $(date -u +%Y-%m-%d), $(uname -r), rmdd --sim N at 1 kHz, ${DURATION} s each"
	echo "# CPU % of one CPU: loop thread / whole process; plan misses and overruns (whole run)"
	printf '%7s %12s %12s %7s %14s %14s\n' motors "loop this" "loop base" ratio "misses t/b" "overruns t/b"
	awk '{ k = $2; v[$1, k, "l"] = $3; v[$1, k, "p"] = $4; v[$1, k, "m"] = $5; v[$1, k, "o"] = $6; n[k] = 1 }
	END {
		for (k in n) {
			b = ((("base", k, "l") in v) ? v["base", k, "l"] : "-")
			r = (b != "-" && b > 0) ? sprintf("%.2f", v["this", k, "l"] / b) : "-"
			printf "%7d %5.1f/%5.1f %5s/%5s %7s %6s/%6s %6s/%6s\n", k, v["this", k, "l"], v["this", k, "p"],
				b, ((("base", k, "p") in v) ? v["base", k, "p"] : "-"), r,
				v["this", k, "m"], ((("base", k, "m") in v) ? v["base", k, "m"] : "-"),
				v["this", k, "o"], ((("base", k, "o") in v) ? v["base", k, "o"] : "-")
		}
	}' "$work/rows" | sort -n
} >"$txt"
cp "$work/rows" "$OUT/scale.dat"
cat "$txt"
bench_plot_png scale "$txt" "$OUT/scale.png" "$work/rows" "$BASE" <<'PY'
rows = [l.split() for l in open(sys.argv[2]) if l.strip()]
fig, ax = plt.subplots(figsize=(6, 4))
for b, style, label in (("base", "s--", "baseline " + sys.argv[3]), ("this", "o-", "this build")):
    r = sorted((int(x[1]), float(x[2])) for x in rows if x[0] == b)
    if r:
        ax.plot([n for n, _ in r], [v for _, v in r], style, label=label + ": loop thread")
ax.set_xlabel("motors (rmdd --sim N, 1 kHz)")
ax.set_ylabel("% of one CPU")
ax.set_ylim(bottom=0)
ax.set_title("rmdd loop thread CPU vs motors")
ax.grid(True, alpha=0.3)
ax.legend()
PY

# The bus-load figure: the busiest bus's load, measured over the run and as planned.
cp "$work/load" "$OUT/scale-bus-load.dat"
bench_plot_png scale "$txt" "$OUT/scale-bus-load.png" "$work/load" <<'PY'
rows = [l.split() for l in open(sys.argv[2]) if l.strip()]
fig, ax = plt.subplots(figsize=(6, 4))
r = sorted((int(x[1]), float(x[2]), float(x[3])) for x in rows if x[0] == "this")
ax.plot([n for n, _, _ in r], [m for _, m, _ in r], "o-", label="measured over the run (health_t)")
ax.plot([n for n, _, _ in r], [w for _, _, w in r], "s--", label="planned worst cycle (--check-config)")
ax.set_xlabel("motors (rmdd --sim N, 1 kHz, 3 a bus)")
ax.set_ylabel("busiest bus's load, % of 1 Mbit/s")
ax.set_ylim(0, 100)
ax.set_title("bus load vs motors")
ax.grid(True, alpha=0.3)
ax.legend()
PY

#!/bin/sh
# Issue 11 point 5: rmdd's wake-up lateness against cyclictest's on the
# same machine in the same run: rmdd on examples/sim-12.yaml at SCHED_FIFO
# 40, and cyclictest -t1 -p 39 -i 1000 (one priority below, the same
# period), both for DURATION seconds.  Both histograms have 1 us buckets
# [k, k+1) us up to 1000 us (rmdd: struct rmd_loop_wake_hist, printed in
# its statistics; cyclictest: -h 1000), later wake-ups are overflows, and
# rmdd counts a stall's skipped periods as lateness as cyclictest does.
# The baseline is cyclictest: the figures are printed as ratios to it.
#
#   bench/latency-vs-cyclictest.sh      # root (SCHED_FIFO); needs rt-tests
#
# Environment: BUILD (build), DURATION (30 s), CONFIG, OUT (bench/results).
set -eu
cd "$(dirname "$0")/.."
. bench/lib.sh
DURATION=${DURATION:-30}
CONFIG=${CONFIG:-examples/sim-12.yaml}
command -v cyclictest >/dev/null 2>&1 || { echo "latency-vs-cyclictest: needs cyclictest (apt-get install rt-tests)"; exit 2; }
bench_init lat

bench_rmdd_start "$BUILD/rmdd" "$work/rmdd.log" --config "$CONFIG" --require-rt --lcm-url memq://
pid=$BENCH_PID
cyclictest -m -t1 -p 39 -i 1000 -D "$DURATION" -q -h 1000 >"$work/ct.log" 2>&1 &
ct=$!
sleep "$DURATION"
wait $ct || true
kill -TERM $pid
wait $pid || true

# "k count" lines, 1 us buckets; "over N"
sed -n 's/.*loop: wake-up us:count //p' "$work/rmdd.log" | tr ' ' '\n' | tr ':' ' ' | grep . >"$work/rmdd.hist" || true
sed -n 's/.*wake-ups, \([0-9]*\) at 1000 us or later.*/over \1/p' "$work/rmdd.log" | tail -n 1 >>"$work/rmdd.hist"
awk '/^[0-9]+ +[0-9]+/ { if ($2 > 0) print $1 + 0, $2 + 0 } /^# Histogram Overflows:/ { print "over", $4 + 0 }' "$work/ct.log" >"$work/ct.hist"

pct() { # file: prints "n p50 p99 p999 max" (us; max: the highest bucket, or ">1000")
	awk '$1 == "over" { over = $2; next } { c[$1] = $2; n += $2; if ($1 > mx) mx = $1 }
	END {
		n += over
		if (!n) { print 0, 0, 0, 0, 0; exit }
		split("0.5 0.99 0.999", q, " ")
		s = 0; k = 1; out = ""
		for (b = 0; b < 1000 && k <= 3; b++) { s += c[b]; while (k <= 3 && s >= q[k] * n) { out = out " " b + 1; k++ } }
		while (k <= 3) { out = out " 1000+"; k++ }
		print n out, (over ? "1000+" : mx + 1)
	}' "$1"
}
set -- $(pct "$work/rmdd.hist")
r_n=$1 r50=$2 r99=$3 r999=$4 rmax=$5
set -- $(pct "$work/ct.hist")
c_n=$1 c50=$2 c99=$3 c999=$4 cmax=$5
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { if (a ~ /\+/ || b ~ /\+/ || b == 0) print "-"; else printf "%.2f", a / b }'; }
txt=$OUT/latency-vs-cyclictest.txt
{
	echo "# bench/latency-vs-cyclictest.sh, $(date -u +%Y-%m-%d), $(uname -r), ${DURATION} s, $CONFIG"
	echo "# wake-up lateness, us (upper bound of the 1 us bucket); rmdd FIFO 40, cyclictest FIFO 39, 1 ms period"
	printf '%-10s %9s %11s %7s\n' "" rmdd cyclictest ratio
	printf '%-10s %9s %11s\n' samples "$r_n" "$c_n"
	printf '%-10s %9s %11s %7s\n' p50 "$r50" "$c50" "$(ratio "$r50" "$c50")"
	printf '%-10s %9s %11s %7s\n' p99 "$r99" "$c99" "$(ratio "$r99" "$c99")"
	printf '%-10s %9s %11s %7s\n' p99.9 "$r999" "$c999" "$(ratio "$r999" "$c999")"
	printf '%-10s %9s %11s %7s\n' max "$rmax" "$cmax" "$(ratio "$rmax" "$cmax")"
	grep -E "overruns|plan misses" "$work/rmdd.log" | tail -n 1 | sed 's/^<[0-9]>rmdd:  */# rmdd: /'
} >"$txt"
cat "$txt"
cp "$work/rmdd.hist" "$OUT/latency-rmdd.hist"
cp "$work/ct.hist" "$OUT/latency-cyclictest.hist"
bench_plot_png latency-vs-cyclictest "$txt" "$OUT/latency-vs-cyclictest.png" "$work/rmdd.hist" "$work/ct.hist" <<'PY'
def load(p):
    h = {}
    for l in open(p):
        a, b = l.split()
        if a != "over":
            h[int(a)] = int(b)
    return h
fig, ax = plt.subplots(figsize=(7, 4))
for p, label in ((sys.argv[2], "rmdd loop (FIFO 40)"), (sys.argv[3], "cyclictest (FIFO 39)")):
    h = load(p)
    if h:
        xs = sorted(h)
        ax.step(xs, [h[x] for x in xs], where="post", label=label)
ax.set_yscale("log")
ax.set_xlabel("wake-up lateness, us (1 us buckets)")
ax.set_ylabel("wake-ups")
ax.set_title("wake-up lateness: rmdd vs cyclictest, same run")
ax.grid(True, alpha=0.3)
ax.legend()
PY

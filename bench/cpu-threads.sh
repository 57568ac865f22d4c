#!/bin/sh
# Issue 11 point 4: CPU time of rmdd's threads, the loop thread against the
# rest of the process (the bridge, the monitor, the incident writer, main;
# a baseline before the bridge read udpm itself also has LCM's receive
# thread, which keeps the name rmdd and runs at SCHED_FIFO), from
# /proc/PID/task/*/stat (utime + stime) over DURATION seconds of
# examples/sim-12.yaml at 1 kHz with a controller streaming commands
# (examples/sine_controller, when built) and LCM on UDP multicast
# (udpm: the bridge encodes and sends every state).  The same run measures
# the baseline BASE (bench/lib.sh) first.  Target: the process beyond the
# loop thread uses no more CPU than the loop thread.
#
#   bench/cpu-threads.sh            # root (SCHED_FIFO), or LimitRTPRIO
#
# Environment: BUILD (build), BASE (8c261d5; none: no baseline), DURATION
# (20 s), CONFIG (examples/sim-12.yaml), LCM_URL (udpm://239.255.76.67:7667?ttl=0), OUT.
set -eu
cd "$(dirname "$0")/.."
. bench/lib.sh
bench_init cpu
DURATION=${DURATION:-20}
CONFIG=${CONFIG:-examples/sim-12.yaml}
LCM_URL=${LCM_URL:-udpm://239.255.76.67:7667?ttl=0}
hz=$(getconf CLK_TCK)

# ticks of thread $1/$2 (utime + stime); comm may not hold spaces
ticks() {
	awk '{ print $14 + $15 }' "/proc/$1/task/$2/stat" 2>/dev/null || echo 0
}

# run BUILD_DIR LABEL
run() {
	dir=$1
	label=$2
	log=$work/$label.log
	bench_rmdd_start "$dir/rmdd" "$log" --config "$CONFIG" --lcm-url "$LCM_URL"
	pid=$BENCH_PID
	ctl=
	if [ -x "$BUILD/sine_controller" ]; then
		"$BUILD/sine_controller" --mode mit --url "$LCM_URL" >/dev/null 2>&1 &
		ctl=$!
	fi
	sleep 1
	: >"$work/$label.t0"
	for t in /proc/$pid/task/*; do
		t=$(basename "$t")
		echo "$t $(cat /proc/$pid/task/$t/comm) $(awk '{print $41}' /proc/$pid/task/$t/stat) $(ticks $pid $t)" >>"$work/$label.t0"
	done
	sleep "$DURATION"
	: >"$work/$label.t1"
	while read -r t comm pol t0; do
		echo "$t $comm $pol $t0 $(ticks $pid $t)" >>"$work/$label.t1"
	done <"$work/$label.t0"
	[ -n "$ctl" ] && { kill $ctl 2>/dev/null || true; } # it may have ended (memq://)
	kill -TERM $pid
	wait $pid || true
	# the loop: the thread named rmd-loop (the bridge, and in older builds
	# LCM's receive thread, run at SCHED_FIFO too, policy 1); a build from
	# before the threads had names (e.g. the default BASE) ran its loop in
	# the main thread "rmdd", its only one at SCHED_FIFO
	awk -v hz="$hz" -v d="$DURATION" -v l="$label" '
		{ n++; name[n] = $2; pol[n] = $3; pct[n] = 100 * ($5 - $4) / hz / d
		  if ($2 == "rmd-loop") named = 1 }
		END {
			for (i = 1; i <= n; i++) {
				is_loop = named ? name[i] == "rmd-loop" : (name[i] == "rmdd" && pol[i] == 1)
				if (is_loop) loop += pct[i]; else rest += pct[i]
				printf "%s thread %s(%s) %.1f\n", l, name[i], is_loop ? "loop" : pol[i] == 1 ? "fifo" : "other", pct[i]
			}
			printf "%s loop %.1f\n%s rest %.1f\n", l, loop, l, rest
		}' "$work/$label.t1" >>"$work/rows"
}

: >"$work/rows"
if [ "$BASE" != none ]; then
	bdir=$(bench_base build/rmdd)
	run "$bdir/build" base
fi
run "$BUILD" this

txt=$OUT/cpu-threads.txt
{
	echo "# bench/cpu-threads.sh, $(date -u +%Y-%m-%d), $CONFIG, $LCM_URL, ${DURATION} s, controller: $([ -x "$BUILD/sine_controller" ] && echo sine_controller || echo none)"
	echo "# CPU % of one CPU (utime + stime from /proc/PID/task/*/stat); BASE=$BASE"
	printf '%-28s %7s %7s %7s\n' "" this base ratio
	awk '$2 == "loop" || $2 == "rest" { v[$1 " " $2] = $3 }
	END {
		split("loop rest", ks, " ")
		for (i = 1; i <= 2; i++) {
			k = ks[i]
			a = v["this " k]; b = ("base " k) in v ? v["base " k] : "-"
			r = (b != "-" && b > 0) ? sprintf("%.2f", a / b) : "-"
			printf "%-28s %7.1f %7s %7s\n", (k == "loop" ? "loop thread" : "rest of the process"), a, b, r
		}
		printf "%-28s %7.2f\n", "rest / loop (target <= 1)", v["this rest"] / (v["this loop"] > 0 ? v["this loop"] : 1)
	}' "$work/rows"
	echo "# threads"
	grep ' thread ' "$work/rows" | awk '{ printf "  %-5s %-28s %6.1f %%\n", $1, $3, $4 }'
} >"$txt"
cat "$txt"
bench_plot_png cpu-threads "$txt" "$OUT/cpu-threads.png" "$work/rows" "$BASE" <<'PY'
v = {}
for l in open(sys.argv[2]):
    p = l.split()
    if len(p) == 3 and p[1] in ("loop", "rest"):
        v[(p[0], p[1])] = float(p[2])
builds = [b for b in ("base", "this") if (b, "loop") in v]
fig, ax = plt.subplots(figsize=(5, 4))
x = range(len(builds))
ax.bar(x, [v[(b, "loop")] for b in builds], 0.5, label="loop thread")
ax.bar(x, [v[(b, "rest")] for b in builds], 0.5, bottom=[v[(b, "loop")] for b in builds],
       label="rest of the process")
ax.set_xticks(list(x))
ax.set_xticklabels(["baseline " + sys.argv[3] if b == "base" else "this build" for b in builds])
ax.set_ylabel("% of one CPU")
ax.set_title("rmdd CPU by thread (sim-12, 1 kHz, udpm)")
ax.legend()
PY

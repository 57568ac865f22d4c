#!/bin/sh
# Issue 23 point 1: the control delay.  A controller that answers each
# state_t at once (bench/delay_controller.c: a C program at SCHED_FIFO
# below rmdd's LCM bridge, on udpm over loopback) drives real rmdd on a sim
# bus; the figure is the time from the start of a motor's reply on the
# wire to the start of the frame that carries the controller's response to
# it, p50/p99/max, at 1 kHz, 500 Hz and 250 Hz with 1 and 2 motors on the
# bus (and 3 at 500 Hz), quiet and beside CPU hogs (stress-ng --cpu NCPU,
# or busy shell loops).  The baseline is a build of BASE (default 94f2f9f,
# main before the change), run in the same script with the same controller
# and configuration, one run after the other.
#
# How a delay is taken (bench/delay_controller.c, "match"):
#   - the controller answers each state_t with a speed setpoint of tag *
#     0.01 deg/s, tag = 1 + state_t.cycle % 1000, which rmdd rounds to the
#     raw value tag in the 0xA2 frame (int32 at bytes 4..7); it logs, per
#     state and motor, the motor's rx_time_ns;
#   - the sim bus's tap (buses[].sim.tap, candump -l) stamps every frame
#     at its end of frame, in CLOCK_MONOTONIC us, the clock rx_time_ns
#     reads (for the sim bus rx_time_ns is the reply's end of frame, ns);
#   - each reply counts once, in the first state that carries it: its
#     frame is the motor's 0x240 + ID reply stamped at rx_time_ns; the
#     response is the first 0x140 + ID frame after it that is a 0xA2 with
#     that state's tag;
#   - both frames are taken at their start: stamp - wire time to the end of
#     frame, from the frame's exact bits with stuffing
#     (rmd_can_frame_bits() less the 3-bit interframe space) at the bus's
#     1 Mbit/s, as the sim wire itself times them;
#   - replies whose response never went out (the next state's command
#     came first and superseded it) are counted, not timed.
# Stamps are whole microseconds: a delay is within 1 us.
#
# Goal (issue 23): on the sim bus with 1 or 2 motors a bus at 1 kHz (3 at
# 500 Hz), this build's p99 <= half a period ("goal" column; the other rows
# are for information).
#
#   bench/control-delay.sh             # root (SCHED_FIFO), multicast on lo
#   RUN_S=2 LOADS=quiet CASES="1000:1" bench/control-delay.sh   # a quick look
#
# Environment: BUILD (build), BASE (94f2f9f), RUN_S (seconds recorded a
# run, 5), CASES ("RATE:MOTORS ...", default "1000:1 1000:2 500:1 500:2
# 500:3 250:1 250:2"), LOADS ("quiet hogs"), PORT (the LCM port, 7800 +
# pid % 100), OUT (bench/results).  Writes $OUT/control-delay.txt and .png.
# The run takes about (RUN_S + 4) s x 2 builds x cases x loads: ~4 min.
set -eu
cd "$(dirname "$0")/.."
BASE=${BASE:-94f2f9f}
. bench/lib.sh
BUILD=${BUILD:-build}
RUN_S=${RUN_S:-5}
CASES=${CASES:-1000:1 1000:2 500:1 500:2 500:3 250:1 250:2}
LOADS=${LOADS:-quiet hogs}
PORT=${PORT:-$((7800 + $$ % 100))}
LOOP_PRIO=40
CTL_PRIO=$((LOOP_PRIO - 2)) # below the bridge (loop - 1, rmdd's default)
URL="udpm://239.255.76.67:$PORT?ttl=0"

[ "$(id -u)" = 0 ] || { echo "control-delay: needs root (SCHED_FIFO)"; exit 2; }
bench_init control-delay
make -j2 "$BUILD/rmdd" "$BUILD/bench/delay_controller" >/dev/null
ctl=$BUILD/bench/delay_controller
base_dir=$(bench_base build/rmdd) || { echo "control-delay: cannot build $BASE"; exit 1; }
this_rev=$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src include || echo +)
ncpu=$(nproc)

# cfg RATE MOTORS FILE TAP: MOTORS V3 speed motors on one 1 Mbit/s sim bus
cfg() {
	{
		echo "loop: {rate_hz: $1, rt_priority: $LOOP_PRIO}"
		echo "incidents: {enabled: false}"
		echo "lcm: {url: \"$URL\"}"
		echo "buses:"
		echo "  - {name: sim0, type: sim, bitrate: 1000000, sim: {seed: 1, tap: $4}}"
		echo "motors:"
		i=1
		while [ $i -le "$2" ]; do
			echo "  - {name: m$i, bus: sim0, id: $i, mode: speed, torque_constant_nm_a: 2.0}"
			i=$((i + 1))
		done
	} >"$3"
}

# hogs_start: one busy process per CPU at normal priority; their pids in $hogs
hogs_start() {
	if command -v stress-ng >/dev/null 2>&1; then
		stress-ng --cpu "$ncpu" --timeout 3600 >/dev/null 2>&1 &
		hogs=$!
	else
		hogs=
		for _ in $(seq "$ncpu"); do
			sh -c 'while :; do :; done' &
			hogs="$hogs $!"
		done
	fi
	sleep 1
}

# run LOAD RATE MOTORS WHICH(this|base): the delays (us, sorted) in $work/LOAD-RATE-MOTORS.WHICH
run() {
	tag=$1-$2-$3.$4
	[ "$4" = base ] && rmdd=$base_dir/build/rmdd || rmdd=$BUILD/rmdd
	cfg "$2" "$3" "$work/$tag.yaml" "$work/$tag.tap"
	bench_rmdd_start "$rmdd" "$work/$tag.rmdd" --config "$work/$tag.yaml" --require-rt
	rc=0
	"$ctl" run --url "$URL" --seconds "$RUN_S" --rt-priority $CTL_PRIO \
		--out "$work/$tag.ctl" 2>"$work/$tag.ctlerr" || rc=$?
	kill -TERM "$BENCH_PID"
	wait "$BENCH_PID" || true
	if [ $rc != 0 ]; then
		cat "$work/$tag.ctlerr" "$work/$tag.rmdd"
		echo "control-delay: $tag: the controller failed"
		exit 1
	fi
	"$ctl" match "$work/$tag.ctl" "$work/$tag.tap" 2>"$work/$tag.match" |
		awk '{ print $2 }' | sort -n >"$work/$tag" || true
	# what the match counted, and the loop's overruns, for the table
	sed -n 's/.*counted \([0-9]*\), superseded[^0-9]*\([0-9]*\),.*/\1 \2/p' "$work/$tag.match" \
		>"$work/$tag.n"
	sed -n 's/.*loop: overruns \([0-9]*\),.*/\1/p' "$work/$tag.rmdd" | tail -n 1 \
		>"$work/$tag.over"
	rm -f "$work/$tag.tap"
}

# stats FILE: "p50 p99 max" of sorted values (us)
stats() {
	awk '{ v[NR] = $1 } END {
		if (!NR) { print "- - -"; exit }
		i50 = int(0.5 * NR + 0.999999); i99 = int(0.99 * NR + 0.999999)
		printf "%.0f %.0f %.0f\n", v[i50], v[i99], v[NR] }' "$1"
}

ratio() {
	awk -v a="$1" -v b="$2" 'BEGIN { if (a == "-" || b == "-" || b == 0) print "-"; else printf "%.2f", a / b }'
}

for load in $LOADS; do
	hogs=
	[ "$load" = hogs ] && hogs_start
	for c in $CASES; do
		rate=${c%:*}
		m=${c#*:}
		run "$load" "$rate" "$m" base
		run "$load" "$rate" "$m" this
	done
	# shellcheck disable=SC2086
	[ -n "$hogs" ] && kill $hogs 2>/dev/null && wait $hogs 2>/dev/null || true
done

txt=$OUT/control-delay.txt
{
	echo "# bench/control-delay.sh, $(date -u +%Y-%m-%d), this $this_rev, base $BASE, $(uname -r), $ncpu CPUs, $RUN_S s a run"
	echo "# reply start on the sim wire -> start of the frame carrying the controller's response (us);"
	echo "# rmdd loop FIFO $LOOP_PRIO, bridge $((LOOP_PRIO - 1)), controller $CTL_PRIO, udpm on loopback; 1 sim bus at 1 Mbit/s, V3 speed motors"
	echo "# goal: this p99 <= half a period at 1 kHz with 1-2 motors and at 500 Hz with 3"
	printf '%-5s %4s %2s | %5s %5s %5s | %5s %5s %5s | %5s %5s | %5s %-4s | %s\n' load rate m \
		"b p50" "b p99" "b max" "t p50" "t p99" "t max" "r p50" "r p99" "T/2" goal \
		"n b/t, superseded b/t, overruns b/t"
	for load in $LOADS; do
		for c in $CASES; do
			rate=${c%:*}
			m=${c#*:}
			k=$work/$load-$rate-$m
			set -- $(stats "$k.base")
			b50=$1 b99=$2 bmax=$3
			set -- $(stats "$k.this")
			t50=$1 t99=$2 tmax=$3
			half=$((500000 / rate))
			goal=-
			if [ "$rate:$m" = 1000:1 ] || [ "$rate:$m" = 1000:2 ] || [ "$rate:$m" = 500:3 ]; then
				goal=$([ "$t99" != - ] && [ "$t99" -le "$half" ] && echo pass || echo FAIL)
			fi
			set -- $(cat "$k.base.n") $(cat "$k.this.n")
			printf '%-5s %4s %2s | %5s %5s %5s | %5s %5s %5s | %5s %5s | %5s %-4s | %s/%s, %s/%s, %s/%s\n' \
				"$load" "$rate" "$m" "$b50" "$b99" "$bmax" "$t50" "$t99" "$tmax" \
				"$(ratio "$t50" "$b50")" "$(ratio "$t99" "$b99")" "$half" "$goal" \
				"${1:-0}" "${3:-0}" "${2:-0}" "${4:-0}" "$(cat "$k.base.over")" "$(cat "$k.this.over")"
		done
	done
	echo "# b: base ($BASE), t: this ($this_rev); r: this / base; T/2: half a period (us)"
	echo "# n: replies timed; superseded: replies whose response never went out (a newer command did)"
	echo "# overruns: rmdd's loop overruns in the run (the machine's scheduling)"
} >"$txt"
cat "$txt"

# the plot: one panel a rate and load, a CDF a motor count and build
: >"$work/series"
for load in $LOADS; do
	for c in $CASES; do
		for w in base this; do
			echo "$load ${c%:*} ${c#*:} $w $work/$load-${c%:*}-${c#*:}.$w" >>"$work/series"
		done
	done
done
bench_plot_png control-delay "$txt" "$OUT/control-delay.png" "$work/series" "$BASE" "$this_rev" <<'PY'
rows = [l.split() for l in open(sys.argv[2]) if l.strip()]
loads = list(dict.fromkeys(r[0] for r in rows))
rates = sorted({int(r[1]) for r in rows}, reverse=True)
fig, axs = plt.subplots(len(loads), len(rates), figsize=(4.2 * len(rates), 3.4 * len(loads)),
                        squeeze=False)
colors = {1: "tab:blue", 2: "tab:orange", 3: "tab:green"}
for i, load in enumerate(loads):
    for j, rate in enumerate(rates):
        ax = axs[i][j]
        for r in rows:
            if r[0] != load or int(r[1]) != rate:
                continue
            v = [float(x) for x in open(r[4]) if x.strip()]
            if not v:
                continue
            m, which = int(r[2]), r[3]
            label = "%d motor%s, %s" % (m, "s" if m > 1 else "",
                                        sys.argv[3] + " (base)" if which == "base" else sys.argv[4])
            ax.plot(v, [(k + 1) / len(v) for k in range(len(v))],
                    "--" if which == "base" else "-", color=colors.get(m, "grey"), label=label)
        ax.axvline(5e5 / rate, color="grey", linestyle=":", label="half a period")
        ax.axvline(1e6 / rate, color="grey", linestyle="-.", label="one period")
        ax.set_xlim(left=0)
        ax.set_title("%d Hz, %s" % (rate, load), fontsize=10)
        ax.set_xlabel("reply start -> response frame start, us")
        ax.set_ylabel("fraction")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=6, loc="lower right")
PY

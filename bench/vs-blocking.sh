#!/bin/sh
# Issue 11 point 7: rmdd against what common RMD drivers do (e.g.
# 2b-t/myactuator_rmd): a strictly sequential loop that sends one motor its
# request, blocks until that motor's reply (or a timeout), then serves the
# next (bench/blocking_driver.c).  Both drive the same simulated motors with
# the same request, the one rmdd sends a READY motor every cycle (V3 §2.13
# 0x9C status 2, 8 bytes each way, built by the project's codec), every motor
# once a cycle, and report the achieved control rate: full cycles a second
# at 0 missed replies.
#   sim:  the in-process sim bus (1 Mbit/s wire with bit-stuffed frame
#         times, motors answering 500 +- 100 us after a request), measured
#         on the wall clock;
#   vcan: rmd-sim on vcan0..vcan3 (tests/vm/vm-run: on this host when its
#         kernel can make vcan links, else in the QEMU guest); the blocking
#         driver uses a plain CAN_RAW socket, write() then poll() + read().
# Motor counts COUNTS_VB (1 3 6 12) on 1 bus and on 4 buses (motor i on bus
# i mod 4).  The blocking driver runs as fast as it can, at SCHED_FIFO 40
# like rmdd's loop: on 1 bus with one thread (as those drivers do), and on
# the 4 buses with one thread a bus and a barrier a cycle ("threads").
# rmdd's rate is searched: the planner's highest loop.rate_hz
# (`rmdd --check-config`, at most 2000), then DURATION seconds at that rate,
# 5 % lower after two runs at a rate missed a reply or the plan; reported
# is the rate it ran and the cycles a second it measured (overruns, the
# machine's scheduling, skip periods).  Host transmit queues hold 64
# frames, as README.md has users set them (`txqueuelen: 64` on the sim
# buses, `vm-run --txqueuelen 64`): 12 requests on one bus overflow the
# default 10.
#
#   bench/vs-blocking.sh               # root (SCHED_FIFO)
#   VCAN=0 bench/vs-blocking.sh        # the sim part only (SIMBUS=0: vcan only)
#   ROWS=bench/results/vs-blocking.dat bench/vs-blocking.sh   # table and plot again
#
# Environment: BUILD (build), DURATION (5 s a run), COUNTS_VB ("1 3 6 12"),
# VCAN (1), SIMBUS (1), TRIES (8: rmdd runs a configuration at most; then
# the last run is reported, marked), TRIES_VCAN (2: in an emulated guest
# the machine, not the rate, misses), OUT (bench/results).  Writes $OUT/vs-blocking.txt and .png.
set -eu
cd "$(dirname "$0")/.."
. bench/lib.sh
BUILD=${BUILD:-build}
DURATION=${DURATION:-5}
COUNTS_VB=${COUNTS_VB:-1 3 6 12}
VCAN=${VCAN:-1}
SIMBUS=${SIMBUS:-1}
TRIES=${TRIES:-8}
TRIES_VCAN=${TRIES_VCAN:-2}
OUT=${OUT:-bench/results}

# cfg KIND N NB RATE FILE: N V3 motors on NB buses of KIND (sim | socketcan)
cfg() {
	{
		echo "loop: {rate_hz: $4, rt_priority: 40}"
		echo "incidents: {enabled: false}"
		echo "probe: {on_missing: start}"
		echo "buses:"
		b=0
		while [ $b -lt "$3" ]; do
			if [ "$1" = sim ]; then
				echo "  - {name: s$b, type: sim, sim: {seed: $((b + 1)), txqueuelen: 64}}"
			else
				echo "  - {name: vcan$b, type: socketcan}"
			fi
			b=$((b + 1))
		done
		echo "motors:"
		i=0
		while [ $i -lt "$2" ]; do
			bus=$((i % $3))
			[ "$1" = sim ] && bn=s$bus || bn=vcan$bus
			echo "  - {name: m$i, bus: $bn, id: $((i / $3 + 1)), mode: torque, torque_constant_nm_a: 2}"
			i=$((i + 1))
		done
	} >"$5"
}

# The highest rate_hz 1..2000 whose plan fits (rmdd --check-config): KIND N NB.
# Searched on the host (a program started in the guest is slow), kept in $work/plan.
plan_max() {
	hit=$(awk -v k="$1 $2 $3" '$1 " " $2 " " $3 == k { print $4 }' "$work/plan" 2>/dev/null || true)
	[ -n "$hit" ] && { echo "$hit"; return 0; }
	lo=1
	hi=2000
	while [ $lo -lt $hi ]; do
		mid=$(((lo + hi + 1) / 2))
		cfg "$1" "$2" "$3" $mid "$work/plan.yaml"
		if "$BUILD/rmdd" --check-config "$work/plan.yaml" >/dev/null 2>&1; then
			lo=$mid
		else
			hi=$((mid - 1))
		fi
	done
	echo "$1 $2 $3 $lo" >>"$work/plan"
	echo $lo
}

fifo() {
	if command -v chrt >/dev/null 2>&1; then chrt -f 40 "$@"; else "$@"; fi
}

# rmdd_rate KIND N NB: appends "KIND rmdd N NB rate_hz measured_hz plan_max tries missed"
rmdd_rate() {
	pmax=$(plan_max "$1" "$2" "$3")
	rate=$pmax
	tries=0
	fails=0
	while :; do
		tries=$((tries + 1))
		cfg "$1" "$2" "$3" "$rate" "$work/rmdd.yaml"
		log=$work/rmdd-$1-$2-$3-$rate.log
		bench_rmdd_start "$BUILD/rmdd" "$log" --config "$work/rmdd.yaml" --require-rt \
			--lcm-url memq://
		sleep "$DURATION"
		kill -TERM $BENCH_PID
		wait $BENCH_PID || true
		missed=$(sed -n 's/.*replies: matched [0-9]*, missed \([0-9]*\),.*/\1/p' "$log" | tail -n 1)
		pm=$(sed -n 's/.*plan misses \([0-9]*\).*/\1/p' "$log" | tail -n 1)
		hz=$(sed -n 's/.*Hz (\([0-9.]*\) Hz measured).*/\1/p' "$log" | tail -n 1)
		if [ "${missed:-1}" = 0 ] && [ "${pm:-1}" = 0 ]; then
			echo "$1 rmdd $2 $3 $rate $hz $pmax $tries 0" >>"$work/rows"
			return 0
		fi
		over=$(sed -n 's/.*loop: overruns \([0-9]*\),.*/\1/p' "$log" | tail -n 1)
		echo "vs-blocking: rmdd $1 $2 motors / $3 buses at $rate Hz: missed ${missed:-?}," \
			"plan misses ${pm:-?}, overruns ${over:-?}" >>"$work/retries"
		# out of tries: the last run, marked
		if [ $tries -ge "$TRIES" ]; then
			echo "$1 rmdd $2 $3 $rate ${hz:-0} $pmax $tries $((${missed:-0} + ${pm:-0}))" >>"$work/rows"
			return 0
		fi
		# a second run at the same rate first: an overrun (the machine's) can cost a reply
		fails=$((fails + 1))
		[ $fails -lt 2 ] && continue
		fails=0
		rate=$((rate * 95 / 100))
	done
}

# blocking_rate KIND N NB [--threads]: appends "KIND blocking|threads N NB - measured_hz missed -"
blocking_rate() {
	cfg "$1" "$2" "$3" 1000 "$work/blk.yaml"
	label=blocking
	[ $# -gt 3 ] && label=threads
	line=$(fifo "$BUILD/bench/blocking_driver" "$work/blk.yaml" "$DURATION" ${4:+"$4"} || true)
	echo "$line" >>"$work/blocking.log"
	hz=$(echo "$line" | sed -n 's/.* rate_hz \([0-9.]*\) .*/\1/p')
	ms=$(echo "$line" | sed -n 's/.* missed \([0-9]*\) .*/\1/p')
	echo "$1 $label $2 $3 - ${hz:-0} ${ms:-?} -" >>"$work/rows"
}

# The bus counts of N motors: 1, and 4 (or N when fewer)
layouts() {
	echo 1
	[ "$1" -gt 1 ] && { [ "$1" -lt 4 ] && echo "$1" || echo 4; }
	return 0
}

# measure KIND: every count, both drivers, 1 and 4 buses
measure() {
	for n in $COUNTS_VB; do
		nb=$(layouts "$n" | tail -n 1)
		blocking_rate "$1" "$n" 1
		rmdd_rate "$1" "$n" 1
		if [ "$nb" -gt 1 ]; then
			blocking_rate "$1" "$n" "$nb" --threads
			rmdd_rate "$1" "$n" "$nb"
		fi
	done
}

# ---- in the guest (or on a host with vcan): rmd-sim on vcan0..3 ----
if [ -n "${RMD_BENCH_IN_VM:-}" ]; then
	work=$RMD_BENCH_WORK
	DURATION=$RMD_BENCH_DURATION
	TRIES=$RMD_BENCH_TRIES
	COUNTS_VB=$RMD_BENCH_COUNTS
	: >"$work/rows"
	: >"$work/blocking.log"
	: >"$work/retries"
	# every id 1..12 on each interface: a configuration uses those it names
	sims=
	for b in 0 1 2 3; do
		"$BUILD/rmd-sim" --can vcan$b --motors 1-12 -q >"$work/sim$b.log" 2>&1 &
		sims="$sims $!"
	done
	sleep 1
	measure socketcan
	kill $sims
	exit 0
fi

# ---- on this host ----
bench_init vs-blocking
: >"$work/rows"
: >"$work/blocking.log"
: >"$work/retries"
[ -x "$BUILD/bench/blocking_driver" ] || { echo "vs-blocking: no $BUILD/bench/blocking_driver (make)"; exit 2; }
if [ -n "${ROWS:-}" ]; then
	cp "$ROWS" "$work/rows"
	SIMBUS=0
	VCAN=0
fi
[ "$SIMBUS" = 1 ] && measure sim
if [ "$VCAN" = 1 ]; then
	mkdir -p "$work/vm"
	for n in $COUNTS_VB; do
		for nb in $(layouts "$n"); do plan_max socketcan "$n" "$nb" >/dev/null; done
	done
	cp "$work/plan" "$work/vm/plan"
	: >"$work/vm/rows"
	: >"$work/vm/retries"
	: >"$work/vm/blocking.log"
	# vm-run passes BUILD and RMD_* on
	RMD_BENCH_IN_VM=1 RMD_BENCH_WORK=$work/vm BUILD=$BUILD RMD_BENCH_DURATION=$DURATION \
		RMD_BENCH_TRIES=$TRIES_VCAN RMD_BENCH_COUNTS="$COUNTS_VB" tests/vm/vm-run --vcan 4 --txqueuelen 64 --timeout 2400 -- "$0" ||
		echo "vs-blocking: the vcan part failed (exit $?); its rows so far are kept"
	cat "$work/vm/rows" >>"$work/rows"
	cat "$work/vm/retries" >>"$work/retries"
	cat "$work/vm/blocking.log" >>"$work/blocking.log" 2>/dev/null || true
fi

txt=$OUT/vs-blocking.txt
# the runs' own lines, kept beside the .dat for a re-plot (ROWS=)
if [ -n "${ROWS:-}" ]; then
	cat "${ROWS%.dat}.runs" >"$work/runs" 2>/dev/null || : >"$work/runs"
else
	{
		echo "# the blocking driver's runs:"
		sed 's/^/#   /' "$work/blocking.log"
		echo "# rmdd's runs that missed (each rate is run twice before it is lowered by 5 %):"
		sed 's/^vs-blocking: /#   /' "$work/retries"
	} >"$work/runs"
fi
{
	echo "# bench/vs-blocking.sh, $(date -u +%Y-%m-%d), $(git rev-parse --short HEAD), $(uname -r), ${DURATION} s a run"
	echo "# full control cycles a second (every motor one 0x9C request and its reply), 0 missed replies"
	printf "%-9s %6s %5s %9s %9s %12s %7s %7s\n" wire motors buses blocking threads "rmdd (rate)" \
		r/blk r/thr
	awk '$2 == "blocking" { b[$1, $3] = $6 ($7 != "0" ? "*" : "") }
	$2 == "threads" { t[$1, $3] = $6 ($7 != "0" ? "*" : "") }
	$2 == "rmdd" { k[++n] = $1 " " $3 " " $4; r[n] = $6; p[n] = $5; x[n] = ($9 != "0" ? "*" : " ") }
	END {
		for (i = 1; i <= n; i++) {
			split(k[i], a, " ")
			bb = ((a[1], a[2]) in b) ? b[a[1], a[2]] : "-"
			tt = (a[3] > 1 && (a[1], a[2]) in t) ? t[a[1], a[2]] : "-"
			# a ratio only where neither run missed replies
			ok = x[i] == " "
			rb = (ok && bb !~ /[-*]/ && bb > 0) ? sprintf("%.2f", r[i] / bb) : "-"
			rt = (ok && tt !~ /[-*]/ && tt > 0) ? sprintf("%.2f", r[i] / tt) : "-"
			printf "%-9s %6d %5d %9s %9s %5.0f%s(%4d) %7s %7s\n", a[1], a[2], a[3], bb, tt, r[i], x[i], p[i], rb, rt
		}
	}' "$work/rows" | sort -k1,1 -k2n -k3n
	echo "# blocking: one thread over every motor (the motors on 1 bus; on 4 buses it is the same"
	echo "#   sequence); threads: one blocking thread a bus, on the row's buses, a barrier a cycle"
	echo "# rmdd: cycles a second measured at the highest rate_hz with 0 missed replies and 0 plan"
	echo "#   misses (in brackets; the planner's maximum unless a run missed); r/blk, r/thr: ratios"
	echo "# *: replies were missed in that run (the blocking driver: its 5 ms timeout; rmdd: out of"
	echo "#   TRIES runs, the last one's rate); no ratio then"
	cat "$work/runs"
} >"$txt"
cp "$work/rows" "$OUT/vs-blocking.dat"
cp "$work/runs" "$OUT/vs-blocking.runs"
cat "$txt"
bench_plot_png vs-blocking "$txt" "$OUT/vs-blocking.png" "$work/rows" <<'PY'
rows = [l.split() for l in open(sys.argv[2]) if l.strip()]
wires = [w for w in ("sim", "socketcan") if any(r[0] == w for r in rows)]
fig, axs = plt.subplots(1, len(wires), figsize=(6 * len(wires), 4), squeeze=False)
series = (("blocking", False, "s--", "blocking driver, 1 thread"),
          ("threads", True, "^--", "blocking driver, a thread a bus"),
          ("rmdd", False, "o-", "rmdd, 1 bus"), ("rmdd", True, "D-", "rmdd, 4 buses (3 for 3)"))
for ax, w in zip(axs[0], wires):
    for d, multi, st, label in series:
        # (motors, rate, missed): hollow markers for runs that missed replies
        pts = sorted((int(r[2]), float(r[5]), (r[8] if d == "rmdd" else r[6]) != "0") for r in rows
                     if r[0] == w and r[1] == d and (int(r[3]) > 1) == multi)
        if pts:
            ax.plot([p[0] for p in pts], [p[1] for p in pts], st, label=label)
            bad = [p for p in pts if p[2]]
            if bad:
                ax.plot([p[0] for p in bad], [p[1] for p in bad], st[0], ms=11, mfc="none",
                        color="red")
    ax.set_xticks(sorted({int(r[2]) for r in rows}))
    ax.set_xlabel("motors")
    ax.set_ylabel("full control cycles / s (0 missed replies)")
    ax.set_yscale("log")
    ax.set_title({"sim": "in-process sim bus (1 Mbit/s wire model)",
                  "socketcan": "rmd-sim over vcan"}[w] + "; red ring: replies missed", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
PY

#!/bin/sh
# Issue 29 point 6: what the physics costs, for the leg of examples/physics/.
#  1. the rig (bench/physics_rtf.c): the leg's two motors on the model, one
#     0xA1 per motor per 1 ms cycle with its reply, as fast as the machine
#     steps them: the real-time factor (simulated seconds per CPU second)
#     at sim.physics.rate_hz 1000, 2000 (the default) and 4000, with the
#     physics and without it (the same motors turning their own inertia);
#  2. beside the loop: rmdd on examples/physics/leg.yaml at 1 kHz with
#     build/leg_stand standing the leg, DURATION seconds, and the same
#     file without sim.physics (its motors on their own inertia): the loop
#     thread's CPU (rmd-loop, which steps the sim bus and so the model),
#     the loop's rate against 1000 Hz (the real-time factor of the whole
#     chain), its wake-up latency and overruns from rmdd's statistics.
#
#   bench/physics-rtf.sh            # root (SCHED_FIFO), or LimitRTPRIO
#
# Environment: BUILD (build), DURATION (10 s), SECONDS_SIM (20: the rig's
# simulated seconds per rate), LCM_URL (udpm://239.255.76.67:7667?ttl=0), OUT.
set -eu
cd "$(dirname "$0")/.."
. bench/lib.sh
bench_init physics-rtf
DURATION=${DURATION:-10}
SECONDS_SIM=${SECONDS_SIM:-20}
LCM_URL=${LCM_URL:-udpm://239.255.76.67:7667?ttl=0}
hz=$(getconf CLK_TCK)
for p in "$BUILD/bench/physics_rtf" "$BUILD/rmdd" "$BUILD/leg_stand" "$BUILD/lib/rmd-physics.so"; do
	[ -e "$p" ] || { echo "physics-rtf: no $p (make; libmujoco-dev for the module)"; exit 1; }
done
export RMD_PHYSICS_MODULE="${RMD_PHYSICS_MODULE:-$PWD/$BUILD/lib/rmd-physics.so}"

txt=$OUT/physics-rtf.txt
{
	echo "# bench/physics-rtf.sh, $(date -u +%Y-%m-%d), $(nproc) CPUs, examples/physics/leg.xml"
	echo "# 1. the rig: real-time factor (simulated s per CPU s) and CPU per simulated s"
	printf '%-10s %10s %12s %14s %16s\n' rate_hz rtf rtf_without cpu_ms_per_s cpu_ms_without
	for rate in 1000 2000 4000; do
		"$BUILD/bench/physics_rtf" examples/physics/leg.xml hip_joint,knee_joint "$rate" 1 \
			"$SECONDS_SIM" 0.5 | awk -v r="$rate" '/^motors/ {
			for (i = 1; i < NF; i += 2) v[$i] = $(i + 1)
			printf "%-10s %10s %12s %14.1f %16.1f\n", r, v["rtf"], v["rtf_without"],
				v["cpu_us_per_sim_s"] / 1000, v["cpu_us_per_sim_s_without"] / 1000 }'
	done
} >"$txt"

# the loop thread's ticks (utime + stime)
loop_ticks() {
	t=$(bench_tid "$1" rmd-loop) || { echo 0; return; }
	awk '{ print $14 + $15 }' "/proc/$1/task/$t/stat"
}

# run CONFIG LABEL: one line of the loop's figures
run() {
	log=$work/$2.log
	bench_rmdd_start "$BUILD/rmdd" "$log" --config "$1" --lcm-url "$LCM_URL"
	pid=$BENCH_PID
	"$BUILD/leg_stand" --url "$LCM_URL" >"$work/$2.ctl" 2>&1 &
	ctl=$!
	sleep 3 # stood up
	a=$(loop_ticks $pid)
	sleep "$DURATION"
	b=$(loop_ticks $pid)
	kill -INT $ctl
	wait $ctl || true
	kill -INT $pid
	wait $pid || true
	awk -v l="$2" -v cpu="$(echo "$a $b $hz $DURATION" | awk '{ printf "%.1f", 100 * ($2 - $1) / $3 / $4 }')" '
		/statistics \(exit\)/ { match($0, /\(([0-9.]+) Hz measured\)/); hzm = substr($0, RSTART + 1, RLENGTH - 14) }
		/loop: wake-up latency/ { for (i = 1; i <= NF; i++) { if ($i == "p99") p99 = $(i + 1); if ($i == "max") mx = $(i + 1) } }
		/loop: overruns/ { ov = $4; sub(",", "", ov) }
		END { printf "%-16s %8s %10s %8.3f %8s %8s %9s\n", l, cpu, hzm, hzm / 1000, p99, mx, ov }' "$log"
}

sed '/^sim:$/,$d' examples/physics/leg.yaml >"$work/leg-no-physics.yaml"
{
	echo "# 2. beside the loop: rmdd at 1 kHz, build/leg_stand standing the leg, ${DURATION} s"
	printf '%-16s %8s %10s %8s %8s %8s %9s\n' "" loop_cpu% loop_hz rtf p99_us max_us overruns
	run examples/physics/leg.yaml "with physics"
	run "$work/leg-no-physics.yaml" "without"
} >>"$txt"
cat "$txt"

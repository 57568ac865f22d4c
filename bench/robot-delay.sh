#!/bin/sh
# Issue 30 point 6: a robot controller's reply-to-response delay across
# hosts.  Two rmdd, robot PCs A and B (prefixes A_ and B_), each on its own
# simulated bus at RATE Hz, are driven by a controller on PC C: each PC a
# network namespace on one bridge (bench/netns_rig: tests/harness/netns.h),
# LCM udpm with ttl=1 across the veths.  The controller is
# bench/delay_controller, one per daemon, both in C: each answers every
# state_t at once, so every daemon's commands arrive at RATE Hz, and the
# figure is bench/control-delay.sh's: from the start of a motor's reply on
# the sim wire to the start of the frame that carries the controller's
# response to it (delay_controller match on the bus's tap).  Across hosts
# that adds two network crossings (state_t out, command_t back) to the
# control delay of one host.
#
# The baseline, in the same run: the same two daemons and two controllers
# all in namespace A, on the same URL (loopback), one run before.  The
# ratio (cross / same) is what the network between PCs costs.
#
#   bench/robot-delay.sh                 # root (namespaces, SCHED_FIFO)
#   RUN_S=2 LOADS=quiet bench/robot-delay.sh
#
# Environment: BUILD (build), RUN_S (seconds recorded a run, 5), RATE
# (500), MOTORS (motors a daemon, 1), LOADS ("quiet hogs": hogs = one busy
# process per CPU beside it), PORT (7900 + pid % 100), OUT (bench/results).
# Writes $OUT/robot-delay.txt.  Takes about (RUN_S + 4) s x 2 x loads.
set -eu
cd "$(dirname "$0")/.."
. bench/lib.sh
bench_init robot-delay
RUN_S=${RUN_S:-5}
RATE=${RATE:-500}
MOTORS=${MOTORS:-1}
LOADS=${LOADS:-quiet hogs}
PORT=${PORT:-$((7900 + $$ % 100))}
LOOP_PRIO=40
CTL_PRIO=$((LOOP_PRIO - 2)) # below the bridge (loop - 1, rmdd's default)
URL="udpm://239.255.76.67:$PORT?ttl=1"

[ "$(id -u)" = 0 ] || { echo "robot-delay: needs root (namespaces, SCHED_FIFO)"; exit 2; }
make -j2 "$BUILD/rmdd" "$BUILD/bench/delay_controller" "$BUILD/bench/netns_rig" >/dev/null
ctl=$BUILD/bench/delay_controller

# The namespaces stay up while fd 3 (the rig's stdin) is open.
mkfifo "$work/rig.in"
"$BUILD/bench/netns_rig" a b c <"$work/rig.in" >"$work/rig.out" 2>&1 &
rig=$!
exec 3>"$work/rig.in"
trap 'exec 3>&-; wait $rig 2>/dev/null || true; rm -rf "$work"' EXIT
i=0
until grep -qx up "$work/rig.out"; do
	i=$((i + 1))
	if [ $i -ge 300 ] || ! kill -0 $rig 2>/dev/null; then
		cat "$work/rig.out"
		echo "robot-delay: the namespaces did not come up"
		exit 1
	fi
	sleep 0.1
done
ns() { awk -v h="$1" '$1 == h { print $2 }' "$work/rig.out"; }
NS_A=$(ns a)
NS_B=$(ns b)
NS_C=$(ns c)

# cfg PREFIX FILE TAP: MOTORS V3 speed motors on one 1 Mbit/s sim bus with its tap
cfg() {
	{
		echo "loop: {rate_hz: $RATE, rt_priority: $LOOP_PRIO}"
		echo "incidents: {enabled: false}"
		echo "lcm: {url: \"$URL\", channel_prefix: $1}"
		echo "buses:"
		echo "  - {name: sim0, type: sim, bitrate: 1000000, sim: {seed: 1, tap: $3}}"
		echo "motors:"
		m=1
		while [ $m -le "$MOTORS" ]; do
			echo "  - {name: m$m, bus: sim0, id: $m, mode: speed, torque_constant_nm_a: 2.0}"
			m=$((m + 1))
		done
	} >"$2"
}

# run LOAD WHERE: rmdd A_ in A and B_ in B (WHERE cross; same: both in A)
# and their two controllers in C (same: in A); delays into $work/LOAD-WHERE.{a,b}
run() {
	tag=$1-$2
	if [ "$2" = cross ]; then set -- "$NS_A" "$NS_B" "$NS_C"; else set -- "$NS_A" "$NS_A" "$NS_A"; fi
	pids=
	for h in a b; do
		[ $h = a ] && where=$1 || where=$2
		P=$(echo $h | tr a-z A-Z)_
		cfg "$P" "$work/$tag.$h.yaml" "$work/$tag.$h.cd"
		bench_rmdd_start ip "$work/$tag.$h.rmdd" netns exec "$where" "$BUILD/rmdd" \
			--config "$work/$tag.$h.yaml" --require-rt
		pids="$pids $BENCH_PID"
	done
	cpids=
	for h in a b; do
		P=$(echo $h | tr a-z A-Z)_
		ip netns exec "$3" "$ctl" run --url "$URL" --prefix "$P" --seconds "$RUN_S" \
			--rt-priority $CTL_PRIO --out "$work/$tag.$h.ctl" 2>"$work/$tag.$h.ctlerr" &
		cpids="$cpids $!"
	done
	rc=0
	for p in $cpids; do wait "$p" || rc=1; done
	# shellcheck disable=SC2086
	kill -TERM $pids
	for p in $pids; do wait "$p" || true; done
	if [ $rc != 0 ]; then
		cat "$work/$tag".*.ctlerr "$work/$tag".*.rmdd
		echo "robot-delay: $tag: a controller failed"
		exit 1
	fi
	for h in a b; do
		"$ctl" match "$work/$tag.$h.ctl" "$work/$tag.$h.cd" 2>"$work/$tag.$h.match" |
			awk '{ print $2 }' | sort -n >"$work/$tag.$h" || true
		sed -n 's/.*counted \([0-9]*\), superseded[^0-9]*\([0-9]*\),.*/\1 \2/p' \
			"$work/$tag.$h.match" >"$work/$tag.$h.n"
		rm -f "$work/$tag.$h.cd"
	done
}

for load in $LOADS; do
	hogs=
	[ "$load" = hogs ] && bench_hogs_start 3600
	run "$load" same
	run "$load" cross
	# shellcheck disable=SC2086
	[ -n "$hogs" ] && kill $hogs 2>/dev/null && wait $hogs 2>/dev/null || true
done

txt=$OUT/robot-delay.txt
rev=$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src include bench tests/harness || echo +)
{
	echo "# bench/robot-delay.sh, $(date -u +%Y-%m-%d), $rev, $(uname -r), $(nproc) CPUs, $RUN_S s a run"
	echo "# reply start on the sim wire -> start of the frame carrying the controller's response (us);"
	echo "# 2 rmdd (A_, B_) at $RATE Hz, $MOTORS V3 speed motor(s) each, a controller each at FIFO $CTL_PRIO;"
	echo "# same: daemons and controllers in one namespace (loopback); cross: A, B, C namespaces on a bridge"
	printf '%-5s %-6s | %5s %5s %5s | %5s %5s %5s | %5s %5s | %s\n' load daemon \
		"s p50" "s p99" "s max" "x p50" "x p99" "x max" "r p50" "r p99" "n same/cross, superseded same/cross"
	for load in $LOADS; do
		for h in a b; do
			set -- $(bench_stats "$work/$load-same.$h")
			s50=$1 s99=$2 smax=$3
			set -- $(bench_stats "$work/$load-cross.$h")
			x50=$1 x99=$2 xmax=$3
			set -- $(cat "$work/$load-same.$h.n" "$work/$load-cross.$h.n" 2>/dev/null)
			printf '%-5s %-6s | %5s %5s %5s | %5s %5s %5s | %5s %5s | %s/%s, %s/%s\n' \
				"$load" "$(echo $h | tr a-z A-Z)_" "$s50" "$s99" "$smax" "$x50" "$x99" "$xmax" \
				"$(bench_ratio "$x50" "$s50")" "$(bench_ratio "$x99" "$s99")" \
				"${1:-0}" "${3:-0}" "${2:-0}" "${4:-0}"
		done
	done
	echo "# s: same namespace, x: across hosts; r: cross / same"
	echo "# n: replies timed; superseded: replies whose response never went out (a newer command did)"
} >"$txt"
cat "$txt"

# Shared by the bench/ scripts (sourced, POSIX sh).
#
# bench_base TARGETS...   build the baseline revision $BASE (default
#                         8c261d5, the main branch before issue 11) into
#                         /tmp/rmdd-bench-base-$BASE (kept for the next
#                         script of the same run) and print that directory;
#                         TARGETS are make targets (build/rmdd, ...).
# bench_plot              the Python with matplotlib (Debian's python3-matplotlib), or
#                         nothing: the scripts then write their text reports only.
# bench_init NAME         the prologue of a script: BUILD (build) and OUT
#                         (bench/results) defaults, OUT made, and a work
#                         directory $work removed when the script exits.
# bench_hogs_start [SECONDS]
#                         one busy process per CPU at normal priority
#                         (stress-ng --cpu NCPU, else shell loops) for at
#                         most SECONDS (600); their pids in $hogs.
# bench_plot_png NAME TXT PNG ARGS...
#                         the epilogue: plot with the Python on stdin (it
#                         finds sys, plt and PNG = sys.argv[1], ARGS in
#                         sys.argv[2:], and makes fig), save PNG and say
#                         what was written.
# bench_stats FILE        "p50 p99 max" of FILE's sorted values, one a line ("- - -": none).
# bench_ratio A B         A / B to two decimals ("-" when either is "-" or B is 0).
BASE=${BASE:-8c261d5}
# The motor counts the scaling benches sweep (insn-per-cycle.sh, scale.sh).
COUNTS=${COUNTS:-3 6 12 18 24 32}

bench_base() {
	dir=/tmp/rmdd-bench-base-$BASE
	if [ ! -f "$dir/Makefile" ]; then
		mkdir -p "$dir"
		git archive "$BASE" | tar -x -C "$dir" || return 1
	fi
	make -C "$dir" -j2 "$@" >"$dir/build.log" 2>&1 || {
		cat "$dir/build.log" >&2
		return 1
	}
	echo "$dir"
}

bench_plot() {
	for py in /usr/bin/python3 python3; do
		if "$py" -c 'import matplotlib' 2>/dev/null; then
			echo "$py"
			return 0
		fi
	done
	return 1
}

bench_init() {
	BUILD=${BUILD:-build}
	OUT=${OUT:-bench/results}
	mkdir -p "$OUT"
	work=$(mktemp -d "/tmp/rmdd-bench-$1.XXXXXX")
	trap 'rm -rf "$work"' EXIT
}

bench_plot_png() {
	name=$1
	txt=$2
	png=$3
	shift 3
	if ! py=$(bench_plot); then
		cat >/dev/null
		echo "$name: wrote $txt (no plot: apt-get install python3-matplotlib)"
		return 0
	fi
	{
		printf '%s\n' 'import sys' 'import matplotlib' 'matplotlib.use("Agg")' \
			'import matplotlib.pyplot as plt'
		cat
		printf '%s\n' 'fig.tight_layout()' 'fig.savefig(sys.argv[1], dpi=100)'
	} >"$work/plot.py"
	"$py" "$work/plot.py" "$png" "$@"
	echo "$name: wrote $txt and $png"
}

# The TID of the thread of process $1 whose comm is $2, or nothing.
bench_tid() {
	for t in /proc/"$1"/task/*; do
		[ "$(cat "$t/comm" 2>/dev/null)" = "$2" ] && { basename "$t"; return 0; }
	done
	return 1
}

# Cycles rmdd reported in its last "statistics (WHY) ... N cycles" line of log $1.
bench_cycles() {
	sed -n 's/.*statistics (.*) after .* s: \([0-9]*\) cycles.*/\1/p' "$1" | tail -n 1
}

# Start rmdd (ARGS) with its stderr in LOG and wait until it says it runs;
# its pid in BENCH_PID.  bench_rmdd_start RMDD LOG ARGS...
bench_rmdd_start() {
	rmdd=$1
	log=$2
	shift 2
	"$rmdd" "$@" 2>"$log" &
	BENCH_PID=$!
	i=0
	while ! grep -q "rmdd: running:" "$log" 2>/dev/null; do
		i=$((i + 1))
		if [ $i -ge 300 ] || ! kill -0 $BENCH_PID 2>/dev/null; then
			cat "$log"
			echo "bench: rmdd did not start: $rmdd $*"
			exit 1
		fi
		sleep 0.1
	done
}

bench_hogs_start() {
	if command -v stress-ng >/dev/null 2>&1; then
		stress-ng --cpu "$(nproc)" --timeout "${1:-600}" >/dev/null 2>&1 &
		hogs=$!
	else
		hogs=
		for _ in $(seq "$(nproc)"); do
			sh -c 'while :; do :; done' &
			hogs="$hogs $!"
		done
	fi
	sleep 1
}

bench_stats() {
	awk '{ v[NR] = $1 } END {
		if (!NR) { print "- - -"; exit }
		i50 = int(0.5 * NR + 0.999999); i99 = int(0.99 * NR + 0.999999)
		printf "%.0f %.0f %.0f\n", v[i50], v[i99], v[NR] }' "$1"
}

bench_ratio() {
	awk -v a="$1" -v b="$2" 'BEGIN { if (a == "-" || b == "-" || b == 0) print "-"; else printf "%.2f", a / b }'
}

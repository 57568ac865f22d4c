#!/bin/sh
# Issue 11 point 1: instructions per cycle of rmdd's loop (callgrind Ir,
# user space, rmd_loop_cycle() minus the simulated bus and motors; see
# bench/insn-count.sh), for examples/sim-12.yaml with every motor ENABLED
# and with every motor READY, and for `--sim N` (N V3 torque motors, three
# a bus) from 3 to 32 motors: the per-motor slope.  These run with the
# incident recorder off; one more row, sim-12 ENABLED with the recorder on
# as rmdd sets it up by default (incidents.enabled), gives the recorder's
# own cost a cycle (the baseline had no recorder: "-").  Each figure is printed
# with the same figure of a baseline built from BASE in the same run (the
# rig, bench/insn_rig.c, is compiled against both).
#
#   bench/insn-per-cycle.sh                  # BASE=8c261d5 (before issue 11)
#   BASE=none bench/insn-per-cycle.sh        # this build only
#
# Writes bench/results/insn-per-cycle.txt and .png (instructions vs motor
# count; the plot needs python3-matplotlib).  Environment: BUILD (build),
# BASE (a git revision, default 8c261d5), CYCLES (1000), COUNTS ("3 6 12 18
# 24 32"), OUT (bench/results).
set -eu
cd "$(dirname "$0")/.."
. bench/lib.sh
bench_init insn
CYCLES=${CYCLES:-1000}
RIG=$BUILD/bench/insn_rig
command -v valgrind >/dev/null 2>&1 || { echo "insn-per-cycle: needs valgrind"; exit 2; }
[ -x "$RIG" ] || { echo "insn-per-cycle: no $RIG (make)"; exit 2; }

base_rig=
base_incidents=0
if [ "$BASE" != none ]; then
	echo "insn-per-cycle: building the baseline $BASE"
	dir=$(bench_base build/librmd.a)
	cc -O2 -g -std=gnu11 -I"$dir/include" -I"$dir/src" -I"$dir/build/gen" -Itests \
		-o "$dir/insn_rig" bench/insn_rig.c tests/harness/clock.c \
		tests/harness/loop_io.c "$dir/build/librmd.a" \
		$(pkg-config --libs libmodbus yaml-0.1 lcm libsystemd 2>/dev/null) -lm
	base_rig=$dir/insn_rig
	[ -f "$dir/include/rmd/incident.h" ] && base_incidents=1
fi

txt=$OUT/insn-per-cycle.txt
data=$OUT/insn-per-cycle.dat
: >"$data"
{
	echo "# bench/insn-per-cycle.sh, $(date -u +%Y-%m-%d), $(git rev-parse --short HEAD) vs ${BASE}"
	echo "# instructions a cycle (callgrind Ir, loop minus simulated bus and motors), $CYCLES cycles"
	printf '%-26s %10s %10s %7s\n' config this base ratio
} >"$txt"
row() { # name, rig args...
	name=$1
	shift
	a=$(bench/insn-count.sh "$RIG" "$@" "$CYCLES")
	b=-
	r=-
	# a baseline without an incident recorder has no figure with it
	if [ -n "$base_rig" ] && { [ "$1" != --incidents ] || [ "$base_incidents" = 1 ]; }; then
		b=$(bench/insn-count.sh "$base_rig" "$@" "$CYCLES")
		r=$(awk -v a="$a" -v b="$b" 'BEGIN { printf "%.2f", a / b }')
	fi
	printf '%-26s %10s %10s %7s\n' "$name" "$a" "$b" "$r" >>"$txt"
	echo "$name $a $b" >>"$data"
}
row sim-12-enabled examples/sim-12.yaml enabled
row sim-12-ready examples/sim-12.yaml ready
row sim-12-enabled-incidents --incidents examples/sim-12.yaml enabled
for n in $COUNTS; do
	row "sim-$n-v3-torque-enabled" --sim "$n" enabled
done
# per-motor slope: least squares over the --sim rows
awk '/^sim-[0-9]+-v3/ { split($1, p, "-"); n = p[2]; k++; x[k] = n; y[k] = $2; z[k] = $3 }
END {
	for (i = 1; i <= k; i++) { sx += x[i]; sy += y[i]; sz += z[i]; sxx += x[i] * x[i]; sxy += x[i] * y[i]; sxz += x[i] * z[i] }
	d = k * sxx - sx * sx
	a = (k * sxy - sx * sy) / d
	line = sprintf("%-26s %10.0f", "per-motor slope", a)
	if (z[1] != "-") { b = (k * sxz - sx * sz) / d; line = line sprintf(" %10.0f %7.2f", b, a / b) }
	print line
}' "$data" >>"$txt"
awk '$1 == "sim-12-enabled" { off = $2 } $1 == "sim-12-enabled-incidents" { on = $2 }
END { printf "%-26s %10d   (sim-12-enabled-incidents - sim-12-enabled)\n", "incident recorder", on - off }' \
	"$data" >>"$txt"
cat "$txt"

bench_plot_png insn-per-cycle "$txt" "$OUT/insn-per-cycle.png" "$data" "$BASE" <<'PY'
rows = [l.split() for l in open(sys.argv[2]) if l.strip()]
sc = [(int(r[0].split("-")[1]), r[1], r[2]) for r in rows if r[0].endswith("-v3-torque-enabled")]
fig, ax = plt.subplots(figsize=(6, 4))
ax.plot([n for n, _, _ in sc], [int(a) for _, a, _ in sc], "o-", label="this build")
if sc and sc[0][2] != "-":
    ax.plot([n for n, _, _ in sc], [int(b) for _, _, b in sc], "s--", label="baseline " + sys.argv[3])
ax.set_xlabel("motors (--sim N: V3 torque, 3 a bus, all enabled)")
ax.set_ylabel("instructions per cycle (callgrind Ir)")
ax.set_title("rmdd loop: instructions per cycle vs motors")
ax.set_ylim(bottom=0)
ax.grid(True, alpha=0.3)
ax.legend()
PY
exit 0

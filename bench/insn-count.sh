#!/bin/sh
# Instructions per cycle of rmdd's loop (callgrind Ir, user space: the
# loop's cycle as the rt thread runs it, the rig's rig_cycle() (a baseline
# rig's rmd_loop_cycle()), minus the simulated bus and motors --
# callgrind stops counting inside the sim bus's send and receive).
#
#   bench/insn-count.sh RIG ARGS...     prints one integer: Ir per measured cycle
#
# RIG is a build of bench/insn_rig.c; ARGS are the rig's (a config or
# --sim N, enabled|ready, cycles).  Used by bench/insn-per-cycle.sh and
# bench/insn-guard.sh.  Needs valgrind.
set -eu
rig=$1
shift
out=$(mktemp /tmp/rmdd-insn.XXXXXX)
trap 'rm -f "$out" "$out".*' EXIT
valgrind --tool=callgrind --callgrind-out-file="$out" --collect-atstart=no \
	--toggle-collect=rmd_loop_cycle --toggle-collect=rig_cycle --toggle-collect=sim_send --toggle-collect=sim_recv \
	"$rig" "$@" >"$out.rig" 2>"$out.err" || {
	cat "$out.rig" "$out.err" >&2
	echo "insn-count: the rig failed: $rig $*" >&2
	exit 1
}
# the dump the rig asked for after its measured cycles ("measured")
dump=$(grep -l '^desc: Trigger: Client Request: measured' "$out".* 2>/dev/null | head -n 1)
[ -n "$dump" ] || { echo "insn-count: no measured dump (valgrind/callgrind.h missing at build?)" >&2; exit 1; }
ir=$(sed -n 's/^summary: //p' "$dump")
cycles=$(sed -n 's/.*measured_cycles \([0-9]*\).*/\1/p' "$out.rig")
[ -n "$ir" ] && [ -n "$cycles" ] || { echo "insn-count: no figures" >&2; exit 1; }
echo $(((ir + cycles / 2) / cycles))

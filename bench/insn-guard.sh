#!/bin/sh
# CI-sized bench/insn-per-cycle.sh (issue 11): fails when the loop's
# instructions per cycle for a reference configuration rise more than
# 5 % above the figure committed in bench/insn-guard.ref.  Callgrind counts
# instructions, not time: the figure is exact for a given compiler and C
# library, so this is not a timing test.  A count that FELL by more than
# 5 % passes with a note: commit the new figure (bench/insn-guard.sh
# --update) so the guard holds the gain.
#
#   bench/insn-guard.sh             check (make test runs it)
#   bench/insn-guard.sh --update    write the measured figures into the ref file
#
# Environment: BUILD (build), RIG ($BUILD/bench/insn_rig).  Without
# valgrind the check is skipped with one loud line (apt-get install valgrind).
set -eu
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
RIG=${RIG:-$BUILD/bench/insn_rig}
REF=bench/insn-guard.ref
TOLERANCE_PCT=5

if ! command -v valgrind >/dev/null 2>&1; then
	echo "insn-guard: SKIPPED: valgrind is not installed (apt-get install valgrind)"
	exit 0
fi
[ -x "$RIG" ] || { echo "insn-guard: no $RIG (make)"; exit 2; }

update=0
[ "${1:-}" = "--update" ] && update=1
status=0
new=$(mktemp /tmp/rmdd-insn-guard.XXXXXX)
trap 'rm -f "$new"' EXIT
# name  config  state  cycles
while read -r name config state cycles ref; do
	case "$name" in '' | '#'*) echo "$name $config $state $cycles $ref" >>"$new"; continue ;; esac
	ir=$(bench/insn-count.sh "$RIG" "$config" "$state" "$cycles")
	echo "$name $config $state $cycles $ir" >>"$new"
	limit=$((ref + ref * TOLERANCE_PCT / 100))
	if [ "$ir" -gt "$limit" ]; then
		echo "insn-guard: FAIL: $name: $ir instructions a cycle > $limit ($ref committed + $TOLERANCE_PCT %)"
		status=1
	elif [ $((ir + ir * TOLERANCE_PCT / 100)) -lt "$ref" ]; then
		echo "insn-guard: $name: $ir instructions a cycle, $ref committed: lower; bench/insn-guard.sh --update keeps the gain"
	else
		echo "insn-guard: $name: $ir instructions a cycle (committed $ref, limit $limit): ok"
	fi
done <"$REF"
if [ $update -eq 1 ]; then
	cp "$new" "$REF"
	echo "insn-guard: $REF updated"
	exit 0
fi
exit $status

#!/bin/sh
# Run test binaries, keep going after a failure, and close with one
# summary line that CI reads:
#   tests: N passed, N failed
#
#   tests/run-tests.sh [--vcan SUITE...] [--systemd SUITE...] -- SUITE...
#
# SUITEs after "--" run here.  SUITEs after --vcan need real SocketCAN with
# vcan0..vcan2: they run through tests/vm/vm-run (on this host when its
# kernel has vcan, else in a QEMU guest booting Debian's kernel); when
# neither is possible they are skipped with one loud line saying why.
# SUITEs after --systemd need systemd as PID 1 and vcan0: they run in the
# guest booted with systemd as init (vm-run --systemd), or are skipped alike.
#
# A suite that runs longer than RMD_SUITE_TIMEOUT seconds (default 600) is
# killed and counted as failed: a hang must never stall CI.
# --tally FILE (internal): write "passed failed" to FILE instead of the line.
set -u
limit=${RMD_SUITE_TIMEOUT:-600}
here=$(dirname "$0")
vcan=""
systemd=""
tally=""
while [ $# -gt 0 ]; do
	case "$1" in
	--vcan | --systemd)
		group=$1
		shift
		while [ $# -gt 0 ] && [ "$1" != "--" ] && [ "$1" != "--vcan" ] &&
			[ "$1" != "--systemd" ]; do
			if [ "$group" = --vcan ]; then vcan="$vcan $1"; else systemd="$systemd $1"; fi
			shift
		done
		;;
	--tally)
		tally=$2
		shift 2
		;;
	--)
		shift
		break
		;;
	*) break ;;
	esac
done

# rmdd records incidents under $XDG_STATE_HOME/rmdd/incidents when nothing
# else says where: the suites' daemons write into a folder of this run.
state_home=$(mktemp -d /tmp/rmd-tests-state.XXXXXX)
export XDG_STATE_HOME="$state_home"
trap 'rm -rf "$state_home"' EXIT

passed=0
failed=0
bad=""
for t in "$@"; do
	out=$(mktemp)
	timeout -k 10 "$limit" "$t" >"$out" 2>&1
	rc=$?
	[ "$rc" -eq 124 ] && echo "$(basename "$t"): killed after ${limit} s" >>"$out"
	cat "$out"
	# cmocka: "[  PASSED  ] 12 test(s)." and "[  FAILED  ] 1 test(s), listed below:"
	p=$(sed -n 's/^\[  PASSED  \] \([0-9]*\) test(s)\./\1/p' "$out" | tail -n 1)
	f=$(sed -n 's/^\[  FAILED  \] \([0-9]*\) test(s), listed below:/\1/p' "$out" | tail -n 1)
	passed=$((passed + ${p:-0}))
	failed=$((failed + ${f:-0}))
	if [ "$rc" -ne 0 ]; then
		bad="$bad $(basename "$t")"
		[ -z "$f" ] && failed=$((failed + 1))
	fi
	rm -f "$out"
done

# in_vm LABEL VM-RUN-OPTIONS... -- SUITE...: the suites in one guest, their
# tally added to this run's.
in_vm()
{
	label=$1
	shift
	t=$(mktemp /tmp/rmd-tally.XXXXXX)
	opts=""
	while [ "$1" != "--" ]; do
		opts="$opts $1"
		shift
	done
	shift
	# shellcheck disable=SC2086 # the option and suite lists are meant to split
	"$here/vm/vm-run" $opts --timeout $((limit * 3)) -- "$here/run-tests.sh" --tally "$t" -- "$@"
	rc=$?
	if read -r p f <"$t" 2>/dev/null; then
		passed=$((passed + p))
		failed=$((failed + f))
	fi
	if [ "$rc" -ne 0 ]; then
		bad="$bad $label(rc=$rc)"
		[ -s "$t" ] || failed=$((failed + 1))
	fi
	rm -f "$t"
}

if [ -n "$vcan" ]; then
	echo "== SocketCAN suites on vcan:$vcan"
	# shellcheck disable=SC2086 # the suite list is meant to split
	! "$here/vm/vm-available" || in_vm vcan-suites --vcan 3 -- $vcan
fi
if [ -n "$systemd" ]; then
	echo "== suites under systemd as PID 1:$systemd"
	# shellcheck disable=SC2086 # the suite list is meant to split
	! "$here/vm/vm-available" --systemd || in_vm systemd-suites --systemd --vcan 1 -- $systemd
fi

if [ -n "$tally" ]; then
	echo "$passed $failed" >"$tally"
else
	[ -n "$bad" ] && echo "failing suites:$bad"
	echo "tests: $passed passed, $failed failed"
fi
[ "$failed" -eq 0 ] && [ -z "$bad" ]

#!/usr/bin/env bash
# Run test binaries, keep going after a failure, and close with one
# summary line that CI reads, then every skipped test and why:
#   tests: N passed, N failed, N skipped
#     skipped: SUITE TEST: REASON
# (a suite run through vm-run: "vcan-suites: SUITE TEST: REASON", or
# systemd-suites).
#
#   tests/run-tests.sh [--vcan SUITE...] [--systemd SUITE...] -- SUITE...
#
# SUITEs after "--" run here.  SUITEs after --vcan need real SocketCAN with
# vcan0..vcan2: they run through tests/vm/vm-run (on this host when its
# kernel has vcan, else in a QEMU guest booting Debian's kernel); when
# neither is possible they are skipped with one loud line saying why, and
# each counts as one skipped.
# SUITEs after --systemd need systemd as PID 1 and vcan0: they run in the
# guest booted with systemd as init (vm-run --systemd), or are skipped alike.
#
# A test that skipped in one place but ran in another (a SocketCAN test
# skipped on a host without it and run in the guest, or the reverse) ran:
# it is counted where it ran and listed once as "ran in the other place",
# never as skipped.  "N skipped" counts the tests that ran nowhere.
#
# A skipped test is one cmocka (or tests/docs/check-docs) lists as
# "[  SKIPPED ] NAME"; its reason is the last line it printed before that
# saying "SKIP", "skipped:" or "busy machine:", else "skip" or "judged",
# else its last line, else the suite's own "SKIP" line.  Outside CI skips are counted and listed.  With
# CI=true a skip no pattern in tests/expected-skips matches is a failure.
#
# A suite that runs longer than RMD_SUITE_TIMEOUT seconds (default 600) is
# killed and counted as failed: a hang must never stall CI.
# --tally FILE (internal): write "passed failed skipped", the skip lines and
# "ran SUITE TEST" lines to FILE instead of the summary.
set -euo pipefail
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
# One line per skipped test: "SUITE TEST: REASON"; one per test that ran: "SUITE TEST".
skips=$(mktemp /tmp/rmd-skips.XXXXXX)
ran=$(mktemp /tmp/rmd-ran.XXXXXX)
trap 'rm -rf "$state_home" "$skips" "$ran"' EXIT

# ran_in SUITE LOG: "SUITE TEST" for each test of one suite's output that ran (passed or failed).
ran_in()
{
	# not anchored: a line a test printed without its newline (cmocka cuts
	# print_message() at 1 kB) runs into cmocka's "[       OK ] name"
	sed -n 's/.*\[\(       OK \|  FAILED  \)\] \([A-Za-z0-9_]*\)$/\2/p' "$2" | sed "s/^/$1 /"
}

# skipped_in SUITE LOG: the skip lines of one suite's output.
skipped_in()
{
	awk -v suite="$1" '
	function clean(s) {
		sub(/^[ \t*]*(\[ SKIPPED  \])?[ \t*]*/, "", s)
		sub(/^(SKIP(PING)?|[Ss]kipped):[ \t]*/, "", s)
		sub(/[ \t*]+$/, "", s)
		return s
	}
	# the last line of the test that matches re, cleaned
	function last(re,  i) {
		for (i = n; i >= 1; i--)
			if (block[i] ~ re)
				return clean(block[i])
		return ""
	}
	# cmocka: "[ RUN      ] name" ... "[  SKIPPED ] name", then a list at the end
	/^\[ RUN      \] / { cur = substr($0, 14); n = 0; inside = 1; next }
	/^\[  SKIPPED \] [0-9]+ test\(s\), listed below:/ { next }
	/^\[  SKIPPED \] / {
		t = substr($0, 14)
		sub(/ .*/, "", t)
		if (!(t in why)) {
			order[++k] = t
			if (!inside || t != cur)
				n = 0
			why[t] = last("SKIP|[Ss]kipped:|busy machine:")
			if (why[t] == "")
				why[t] = last("[Ss]kip|judged")
			if (why[t] == "")
				why[t] = last("")
		}
		inside = 0
		next
	}
	/^\[( RUN      |       OK |  FAILED  |  PASSED  |  ERROR   |==========)\]/ { inside = 0; next }
	/^[ \t]*$/ { next }
	inside { block[++n] = $0; next }
	/SKIP/ && suite_why == "" { suite_why = clean($0) }
	END {
		for (i = 1; i <= k; i++) {
			t = order[i]
			r = why[t] != "" ? why[t] : suite_why != "" ? suite_why : "(no reason printed)"
			print suite " " t ": " r
		}
	}' "$2"
}

passed=0
failed=0
bad=""
for t in "$@"; do
	out=$(mktemp)
	rc=0
	timeout -k 10 "$limit" "$t" >"$out" 2>&1 || rc=$?
	[ "$rc" -ne 124 ] || echo "$(basename "$t"): killed after ${limit} s" >>"$out"
	cat "$out"
	# cmocka: "[  PASSED  ] 12 test(s)." and "[  FAILED  ] 1 test(s), listed below:"
	p=$(sed -n 's/^\[  PASSED  \] \([0-9]*\) test(s)\./\1/p' "$out" | tail -n 1)
	f=$(sed -n 's/^\[  FAILED  \] \([0-9]*\) test(s), listed below:/\1/p' "$out" | tail -n 1)
	passed=$((passed + ${p:-0}))
	failed=$((failed + ${f:-0}))
	if [ "$rc" -ne 0 ]; then
		bad="$bad $(basename "$t")"
		[ -n "$f" ] || failed=$((failed + 1))
	fi
	skipped_in "$(basename "$t")" "$out" >>"$skips"
	ran_in "$(basename "$t")" "$out" >>"$ran"
	rm -f "$out"
done

# in_vm LABEL VM-RUN-OPTIONS... -- SUITE...: the suites in one guest, their
# tally added to this run's.
in_vm()
{
	local label=$1 t opts="" rc=0 p f
	shift
	t=$(mktemp /tmp/rmd-tally.XXXXXX)
	while [ "$1" != "--" ]; do
		opts="$opts $1"
		shift
	done
	shift
	# shellcheck disable=SC2086 # the option and suite lists are meant to split
	"$here/vm/vm-run" $opts --timeout $((limit * 3)) -- "$here/run-tests.sh" --tally "$t" -- "$@" ||
		rc=$?
	if read -r p f _ <"$t" 2>/dev/null; then
		passed=$((passed + p))
		failed=$((failed + f))
		tail -n +2 "$t" | grep -v '^ran ' | sed "s/^/$label: /" >>"$skips" || true
		sed -n 's/^ran //p' "$t" >>"$ran"
	fi
	if [ "$rc" -ne 0 ]; then
		bad="$bad $label(rc=$rc)"
		[ -s "$t" ] || failed=$((failed + 1))
	fi
	rm -f "$t"
}

# vm_group LABEL VM-AVAILABLE-OPTION VM-RUN-OPTIONS... -- SUITE...: in_vm, or
# when no guest can run them, each suite one skip with vm-available's reason.
vm_group()
{
	local label=$1 avail=$2 why s
	shift 2
	# shellcheck disable=SC2086 # no option is none
	if why=$("$here/vm/vm-available" $avail 2>&1); then
		in_vm "$label" "$@"
		return
	fi
	echo "$why" >&2
	while [ "$1" != "--" ]; do shift; done
	shift
	for s in "$@"; do
		echo "$label: $(basename "$s") (whole suite): ${why#SKIP: }" >>"$skips"
	done
}

if [ -n "$vcan" ]; then
	echo "== SocketCAN suites on vcan:$vcan"
	# shellcheck disable=SC2086 # the suite list is meant to split
	vm_group vcan-suites "" --vcan 3 -- $vcan
fi
if [ -n "$systemd" ]; then
	echo "== suites under systemd as PID 1:$systemd"
	# shellcheck disable=SC2086 # the suite list is meant to split
	vm_group systemd-suites --systemd --systemd --vcan 1 -- $systemd
fi

if [ -n "$tally" ]; then
	{
		echo "$passed $failed $(wc -l <"$skips")"
		cat "$skips"
		sed 's/^/ran /' "$ran"
	} >"$tally"
	if [ "$failed" -eq 0 ] && [ -z "$bad" ]; then exit 0; fi
	exit 1
fi

# A skip whose test ran in the other place (host or guest) is not a skip.
elsewhere=$(mktemp /tmp/rmd-elsewhere.XXXXXX)
nowhere=$(mktemp /tmp/rmd-nowhere.XXXXXX)
trap 'rm -rf "$state_home" "$skips" "$ran" "$elsewhere" "$nowhere"' EXIT
awk -v ranf="$ran" -v elsewhere="$elsewhere" 'FILENAME == ranf { ran[$0] = 1; next }
	{ line = $0; sub(/^[a-z]+-suites: /, "", line); split(line, w, /[ :]/)
	  if ((w[1] " " w[2]) in ran) print > elsewhere; else print }' "$ran" "$skips" >"$nowhere"
skipped=$(wc -l <"$nowhere")

# CI: every skip must be one tests/expected-skips expects (its patterns,
# extended regular expressions, without its comments and blank lines).
unexpected=""
if [ "${CI:-}" = true ] && [ "$skipped" -gt 0 ]; then
	unexpected=$(grep -v -E -f <(grep -v -E '^[[:space:]]*(#|$)' "$here/expected-skips") "$nowhere" ||
		true)
fi

[ -z "$bad" ] || echo "failing suites:$bad"
echo "tests: $passed passed, $failed failed, $skipped skipped"
sed 's/^/  skipped: /' "$nowhere"
[ ! -s "$elsewhere" ] || echo "  ($(wc -l <"$elsewhere") skipped in one place ran in the other: the host or the guest)"
sed 's/^/  ran in the other place: /' "$elsewhere"
if [ -n "$unexpected" ]; then
	echo "CI=true: these skips are not in tests/expected-skips, so they fail the run:"
	echo "$unexpected" | sed 's/^/  unexpected skip: /'
fi
if [ "$failed" -eq 0 ] && [ -z "$bad" ] && [ -z "$unexpected" ]; then exit 0; fi
exit 1

#!/bin/sh
# Run every test binary given on the command line, keep going after a
# failure, and close with one summary line that CI reads:
#   tests: N passed, N failed
# A suite that runs longer than RMD_SUITE_TIMEOUT seconds (default 600) is
# killed and counted as failed: a hang must never stall CI.
set -u
limit=${RMD_SUITE_TIMEOUT:-600}
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
[ -n "$bad" ] && echo "failing suites:$bad"
echo "tests: $passed passed, $failed failed"
[ "$failed" -eq 0 ]

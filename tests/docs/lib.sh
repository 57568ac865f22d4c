# Sourced by tests/docs/scenarios/*.sh (run by tests/docs/check-docs).

# wait_for FILE REGEX SECONDS: until a line of FILE matches, else fail
# showing FILE.
wait_for() {
	n=$(($3 * 10))
	while [ $n -gt 0 ]; do
		grep -q -E "$2" "$1" 2>/dev/null && return 0
		sleep 0.1
		n=$((n - 1))
	done
	echo "no /$2/ in $1 within $3 s:"
	cat "$1" 2>/dev/null
	return 1
}

# stop PID [SIGNAL]: signal it (INT), wait; fail unless it exits 0.
stop() {
	kill -"${2:-INT}" "$1"
	if wait "$1"; then
		return 0
	else
		rc=$?
		echo "pid $1 exited $rc after SIG${2:-INT}"
		return 1
	fi
}

# ran_until_stopped STATUS: a `timeout -s INT` run ended by its timeout (124)
# or by itself with 0.
ran_until_stopped() {
	[ "$1" -eq 0 ] || [ "$1" -eq 124 ]
}

# skip WHY: exit 77 (check-docs reports the scenario as skipped, with WHY).
skip() {
	echo "$1"
	exit 77
}

# scan_until N COMMAND...: run a scan (rmdctl scan ...) until it finds N
# motors, up to 4 tries: a busy machine (an emulated guest) can miss
# answers in one pass; each retry says so.  Its last output stays in scan.out.
scan_until() {
	want=$1
	shift
	for try in 1 2 3 4; do
		"$@" > scan.out 2>&1 || true
		cat scan.out
		[ "$(grep -c -E '^ *[0-9]+ ' scan.out)" -ge "$want" ] && return 0
		echo "scan_until: try $try found fewer than $want motors; again (a slow machine?)"
	done
	return 1
}

# no_answer FILE: FILE has rmdctl's word that a motor's answer did not come
# in time: its per-try timeout is 5 ms, and a busy machine (an emulated
# guest beside other work) can hold rmd-sim or rmdctl off for longer than
# its tries (issue 10).
no_answer() {
	grep -q -E "did not answer|no motor answered|only echoed" "$1"
}

# answered COMMAND: run COMMAND (one string, as typed: redirections and
# pipes included); when rmdctl said a motor's answer did not come in time,
# run it again, up to 4 tries, each said on a line that starts "busy
# machine:".  Any other failure fails at once.  Idle, the first try passes.
answered() {
	for try in 1 2 3 4; do
		rc=0
		eval "$1" 2> answered.err || rc=$?
		cat answered.err >&2
		if ! no_answer answered.err; then
			[ $rc -eq 0 ] && return 0
			echo "\`$1\` exited $rc"
			return 1
		fi
		echo "busy machine: \`$1\` (try $try): a motor's answer did not come in time; again"
	done
	return 1
}

# tty_answer REGEX ANSWER COMMAND: run COMMAND (one string) on a terminal
# (script(1) gives it a pty), wait until its output matches REGEX (its
# question), then type ANSWER; its output stays in tty.out.  Bounded: a
# question that never comes, or a command that never ends, fails.  A run
# where a motor's answer did not come in time goes again (answered()).
tty_answer() {
	for try in 1 2 3 4; do
		tty_answer_once "$@" && return 0
		no_answer tty.out || return 1
		echo "busy machine: \`$3\` (try $try): a motor's answer did not come in time; again"
	done
	return 1
}

tty_answer_once() {
	rm -f tty.out
	# the FIFO on a tmpfs: the guest's 9p /tmp cannot hold one
	fifo=$(mktemp -u /dev/shm/rmd-tty.XXXXXX)
	mkfifo "$fifo"
	timeout -k 5 120 script -qec "$3" /dev/null < "$fifo" > tty.out 2>&1 &
	tp=$!
	exec 7> "$fifo"
	rm -f "$fifo"
	if ! wait_for tty.out "$1" 60; then
		exec 7>&-
		kill $tp 2>/dev/null
		return 1
	fi
	echo "$2" >&7
	if wait $tp; then rc=0; else rc=$?; fi
	exec 7>&-
	cat tty.out
	[ $rc -eq 0 ] || { echo "\`$3\` exited $rc"; return 1; }
}

# wait_until SECONDS COMMAND...: until COMMAND succeeds (tried every 0.1 s),
# else fail saying so.
wait_until() {
	n=$(($1 * 10))
	shift
	while [ $n -gt 0 ]; do
		"$@" && return 0
		sleep 0.1
		n=$((n - 1))
	done
	echo "\`$*\` did not succeed in time"
	return 1
}

# cpu_wait_us: how long tasks on this machine have waited for a CPU so far,
# µs (the kernel's pressure stall information: /proc/pressure/cpu, "some"
# total); nothing when the kernel does not say.
cpu_wait_us() {
	sed -n 's/^some .*total=\([0-9]*\)$/\1/p' /proc/pressure/cpu 2>/dev/null
}

# paced SECONDS OUT REGEX COMMAND...: run COMMAND for SECONDS, stopped with
# SIGINT as Ctrl-C stops it (it must end 0, by itself or by the signal),
# its output in OUT, which must have a line matching REGEX.  A busy machine
# may not let it get that far in SECONDS (issue 10): when the kernel says
# tasks waited for a CPU for a tenth of the run or more (or cannot say), it
# runs again with twice the time, at most 3 times, said on a line that
# starts "busy machine:".  On an idle machine a run without REGEX fails.
paced() {
	secs=$1
	out=$2
	re=$3
	shift 3
	for try in 1 2 3 4; do
		w0=$(cpu_wait_us)
		t0=$(date +%s%N)
		rc=0
		timeout -k 10 -s INT "$secs" "$@" > "$out" 2>&1 || rc=$?
		ran_until_stopped $rc || { cat "$out"; echo "\`$*\` exited $rc"; return 1; }
		grep -q -E "$re" "$out" && return 0
		run_ms=$((($(date +%s%N) - t0) / 1000000))
		w1=$(cpu_wait_us)
		waited_ms=$(((${w1:-0} - ${w0:-0}) / 1000))
		if [ $try -eq 4 ] || { [ -n "$w0" ] && [ $((waited_ms * 10)) -lt $run_ms ]; }; then
			cat "$out"
			echo "no /$re/ in the output of \`$*\` after $secs s (tasks waited $waited_ms ms for a CPU in its $run_ms ms)"
			return 1
		fi
		note="tasks waited $waited_ms ms for a CPU in its $run_ms ms"
		[ -n "$w0" ] || note="the kernel does not say how busy it is"
		echo "busy machine: no /$re/ in $secs s of \`$*\`; $note; again with $((secs * 2)) s"
		secs=$((secs * 2))
	done
}

# legs_yaml [URL]: legs.yaml, two motors on the simulated bus (knee_l in
# torque mode, hip_l in position), on LCM URL when given (a scenario's
# private port: other tests and a developer's rmdd use 7667).
legs_yaml() {
	{
		[ -z "${1:-}" ] || echo "lcm: {url: \"$1\"}"
		cat <<EOY
buses:
  - {name: sim0, type: sim}
motors:
  - {name: knee_l, bus: sim0, id: 1, mode: torque, torque_constant_nm_a: 2.0}
  - {name: hip_l, bus: sim0, id: 2, mode: position, torque_constant_nm_a: 2.0}
EOY
	} > legs.yaml
}

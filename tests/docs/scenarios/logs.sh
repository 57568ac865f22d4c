# where: host
# docs/logs.md: an lcm-logger log and an incident recording of `rmdd`
# turned into MCAP and a wide CSV as shown, each read back with the tools'
# own libraries (tests/system/export_check.py: mcap's reader, jsonschema,
# Python's csv) and judged against the LCM log it came from; then the
# errors a user meets (a file that is no log, a folder that is no incident).
. "$RMD_REPO/tests/docs/lib.sh"
[ -x ~/rmd-venv/bin/rmd-export ] || skip "no rmd-export in build/venv: make python-venv"
check() { ~/rmd-venv/bin/python3 "$RMD_REPO/tests/system/export_check.py" "$@"; }

# a private LCM port: other tests and a developer's rmdd use 7667
url='udpm://239.255.76.67:7694?ttl=0'
legs_yaml "$url"
lcm-logger --lcm-url="$url" -c 'RMD_.*' run1.lcmlog > logger.out 2>&1 &
lp=$!
sleep 0.5
rmdd --config legs.yaml > rmdd.log 2>&1 &
pid=$!
wait_for rmdd.log 'running' 20
sleep 1.5
stop $pid
stop $lp

~/rmd-venv/bin/rmd-export run1.lcmlog -o run1.mcap
check mcap run1.lcmlog run1.mcap
~/rmd-venv/bin/rmd-export run1.lcmlog -o run1.csv
head -c 300 run1.csv; echo
check csv run1.lcmlog run1.csv knee_l hip_l

# an incident recording (its window.lcmlog): a motor lost on the sim bus
cat > c.yaml <<EOY
safety: {missed_replies_lost: 10, lost_motor_action: motor}
probe: {on_missing: start}
incidents: {dir: "$PWD/incidents", seconds_before: 1, seconds_after: 0.3}
buses:
  - name: sim0
    type: sim
    sim:
      seed: 7
      faults:
        - {kind: disappear, motor: 2, start_s: 1.5, end_s: 30, param: 1}
motors:
  - {name: a, bus: sim0, id: 1, mode: torque, torque_constant_nm_a: 2.0}
  - {name: b, bus: sim0, id: 2, mode: position, torque_constant_nm_a: 2.0}
EOY
rmdd --config c.yaml --lcm-url memq:// > rmdd2.log 2>&1 &
pid=$!
wait_for rmdd2.log 'incident recorded in .*-lost' 20
stop $pid
dir=$(ls -d incidents/*-lost | head -n 1)
(
	cd "$dir"
	~/rmd-venv/bin/rmd-export . -o lost.mcap
	check mcap window.lcmlog lost.mcap
	~/rmd-venv/bin/rmd-export . -o lost.csv
	check csv window.lcmlog lost.csv a b
)

# errors: exit 1, one line naming the file and what is wrong, no traceback
fails() {
	rc=0
	~/rmd-venv/bin/rmd-export "$1" -o out.mcap 2> err.out || rc=$?
	cat err.out
	[ $rc -eq 1 ] && grep -q "^rmd-export: $1: $2" err.out && ! grep -q Traceback err.out
}
printf 'x%.0s' $(seq 64) > junk.lcmlog
fails junk.lcmlog 'not an LCM log'
fails missing.lcmlog 'No such file or directory'
fails incidents 'a folder without window.lcmlog'
: > empty.lcmlog
fails empty.lcmlog 'empty'

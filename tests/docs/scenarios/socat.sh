# where: host
# docs/rmd-sim.md: simulated motors on a serial line (a socat pty pair), and
# one rmdd.yaml for rmd-sim and rmdd on it.
. "$RMD_REPO/tests/docs/lib.sh"
command -v socat > /dev/null || skip "no socat (sudo make deps installs it)"
[ ! -e /tmp/rmd-host ] || skip "/tmp/rmd-host exists: another run uses the docs' pty names"
socat pty,raw,echo=0,link=/tmp/rmd-host pty,raw,echo=0,link=/tmp/rmd-motors &
so=$!
n=50; while [ ! -e /tmp/rmd-motors ] && [ $n -gt 0 ]; do sleep 0.1; n=$((n - 1)); done
rmd-sim --serial /tmp/rmd-motors --motors 1-4 > sim.log 2>&1 &
sim=$!
wait_for sim.log 'ready' 30
scan_until 4 rmdctl scan --bus /tmp/rmd-host --baud 115200
stop $sim

# One file for rmdd and rmd-sim (docs/rmd-sim.md): rmd-sim simulates the
# motors of examples/rs485-rig.yaml's bus on the other end of the line, and
# rmdd brings them up from the same file.
rmd-sim --config examples/rs485-rig.yaml --serial /tmp/rmd-motors > rig-sim.log 2>&1 &
sim=$!
wait_for rig-sim.log 'ready' 30
grep -q 'rs485-rig.yaml: bus rs0, motors 1 pan, 2 tilt' rig-sim.log
rmdd --config examples/rs485-rig.yaml > rig-rmdd.log 2>&1 &
rd=$!
wait_for rig-rmdd.log 'running:' 60
grep -q "bus rs0: its sim: sections are rmd-sim's" rig-rmdd.log
grep -q 'motor 2 (tilt): X4V2' rig-rmdd.log
stop $rd
stop $sim
kill $so; wait $so || true

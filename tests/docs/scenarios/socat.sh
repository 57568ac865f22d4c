# where: host
# docs/rmd-sim.md: simulated motors on a serial line (a socat pty pair).
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
kill $so; wait $so || true

# where: host
# README.md, examples/README.md, docs/lcm.md: the example controllers against
# rmdd on the simulated motors of examples/sim-sine.yaml.
. "$RMD_REPO/tests/docs/lib.sh"
[ -x ~/rmd-venv/bin/python3 ] || skip "no build/venv: make python-venv"

rmdd --config examples/sim-sine.yaml &
pid=$!
sleep 0.5
# the same lines as the docs write them
rc=0; timeout -k 10 -s INT 4 build/sine_controller --mode mit --kp 20 --kd 1 > c1.out 2>&1 || rc=$?; ran_until_stopped $rc
rc=0; timeout -k 10 -s INT 4 build/sine_controller --mode position > c2.out 2>&1 || rc=$?; ran_until_stopped $rc
grep -q 'tracking error rms' c1.out
grep -q 'tracking error rms' c2.out
stop $pid

build/rmdd --config examples/sim-sine.yaml &
pid=$!
sleep 0.5
rc=0; timeout -k 10 -s INT 4 ~/rmd-venv/bin/python3 examples/sine.py --mode position > p1.out 2>&1 || rc=$?; cat p1.out; ran_until_stopped $rc
rc=0; timeout -k 10 -s INT 4 ~/rmd-venv/bin/python3 examples/sine.py --mode mit > p2.out 2>&1 || rc=$?; cat p2.out; ran_until_stopped $rc
rc=0; timeout -k 10 -s INT 4 ~/rmd-venv/bin/python3 examples/sine.py --mode mit --kp 20 --kd 1 > p3.out 2>&1 || rc=$?; ran_until_stopped $rc
for f in p1.out p2.out p3.out; do grep -q -i 'tracking error' $f; done
stop $pid

# examples/README.md: rmdd in the foreground, stopped with Ctrl-C
rc=0; timeout -k 10 -s INT 2 build/rmdd --config examples/sim-sine.yaml > fg.out 2>&1 || rc=$?
ran_until_stopped $rc
wait_for fg.out 'cycles' 1

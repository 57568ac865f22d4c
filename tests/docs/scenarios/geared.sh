# where: host
# python/README.md's Python example, verbatim, on a geared joint that rmdd
# cannot trust after power-on (examples/sim-geared.yaml): --check-config
# names it first, the example homes it, then drives it in position mode;
# and unchanged on rmdd --sim, whose motors need no homing (issue 31).
. "$RMD_REPO/tests/docs/lib.sh"
[ -x ~/rmd-venv/bin/python3 ] || skip "no build/venv: make python-venv"

# the example as the README shows it: its first ```python block (the
# second is rmd.Robot's, for several daemons: test_python_client:test_robot_one_view)
python3 - python/README.md > first.py <<'PY'
import re, sys
blocks = re.findall(r"^```python\n(.*?)^```$", open(sys.argv[1]).read(), re.M | re.S)
assert blocks, "no python block"
sys.stdout.write(blocks[0])
PY
grep -q 'c.home(m, position=HOME_RAD)' first.py

rmdd --check-config examples/sim-geared.yaml > check.out 2>&1
grep -F 'motors[0]: warning: motor1 (mode position, gear_ratio 9) will be position uncertain' check.out
if grep -F 'motor2' check.out | grep -q warning; then echo "motor2 warned"; exit 1; fi

rmdd --config examples/sim-geared.yaml > rmdd.log 2>&1 &
pid=$!
rmdctl top --once --wait 30 > /dev/null
grep -F '(motor1): position uncertain' rmdd.log
# Enter for its prompt: the simulated joint is at 0 rad, where HOME_RAD says
echo | ~/rmd-venv/bin/python3 first.py > first.out 2>&1 || { cat first.out; exit 1; }
cat first.out
grep -q 'press Enter' first.out
wait_for rmdd.log '\(motor1\): homed: position certain' 5
# it reached the setpoint (0.3 rad) in position mode
python3 -c 'import sys; p = float(open("first.out").read().split()[-1]); sys.exit(abs(p - 0.3) > 0.05)'
stop $pid

# on rmdd --sim the motors keep their count: no prompt, the same result
rmdd --sim > sim.log 2>&1 &
pid=$!
rmdctl top --once --wait 30 > /dev/null
~/rmd-venv/bin/python3 first.py < /dev/null > sim.out 2>&1 || { cat sim.out; exit 1; }
if grep -q 'press Enter' sim.out; then echo "homing asked on rmdd --sim"; exit 1; fi
python3 -c 'import sys; p = float(open("sim.out").read().split()[-1]); sys.exit(abs(p - 0.3) > 0.05)'
stop $pid

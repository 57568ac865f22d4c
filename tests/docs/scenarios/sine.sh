# where: host
# README.md, examples/README.md, docs/lcm.md: the example controllers against
# rmdd on the simulated motors of examples/sim-sine.yaml.
. "$RMD_REPO/tests/docs/lib.sh"
[ -x ~/rmd-venv/bin/python3 ] || skip "no build/venv: make python-venv"

rmdd --config examples/sim-sine.yaml &
pid=$!
# rmdd answers on LCM (config, health and state): the controllers' 2 s wait starts after it
rmdctl top --once --wait 30 > /dev/null
# the same lines as the docs write them, each for 4 s (more on a busy machine: paced)
paced 4 c1.out 'tracking error rms' build/sine_controller --mode mit --kp 20 --kd 1
paced 4 c2.out 'tracking error rms' build/sine_controller --mode position
stop $pid

build/rmdd --config examples/sim-sine.yaml &
pid=$!
rmdctl top --once --wait 30 > /dev/null
paced 4 p1.out '[Tt]racking error' ~/rmd-venv/bin/python3 examples/sine.py --mode position
cat p1.out
paced 4 p2.out '[Tt]racking error' ~/rmd-venv/bin/python3 examples/sine.py --mode mit
cat p2.out
paced 4 p3.out '[Tt]racking error' ~/rmd-venv/bin/python3 examples/sine.py --mode mit --kp 20 --kd 1
stop $pid

# examples/README.md: rmdd in the foreground, stopped with Ctrl-C
paced 2 fg.out 'cycles' build/rmdd --config examples/sim-sine.yaml

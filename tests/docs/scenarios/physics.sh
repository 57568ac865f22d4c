# where: host
# docs/physics.md "The whole loop": the leg of examples/physics/ on rmdd's
# sim bus, stood and hopped by its C and Python controllers as the doc
# writes them, recorded with lcm-logger, and drawn by rmd-view from the log.
. "$RMD_REPO/tests/docs/lib.sh"
[ -e build/lib/rmd-physics.so ] || skip "no build/lib/rmd-physics.so: built without libmujoco-dev"
[ -x ~/rmd-venv/bin/rmd-view ] || skip "no rmd-view in build/venv: make python-venv"

build/rmdd --config examples/physics/leg.yaml > rmdd.log 2>&1 &
pid=$!
wait_for rmdd.log 'running' 30
lcm-logger --lcm-url='udpm://239.255.76.67:7667?ttl=0' -c 'RMD_.*' run.lcmlog > logger.out 2>&1 &
logger=$!
# stands up (1.5 s), stands (1 s), three hops (1.7 s each), then stands until stopped
paced 12 c.out 'leg_stand: standing$' build/leg_stand --hops 3 || { grep -v 'wake-up us' rmdd.log; exit 1; }
cat c.out
grep -q 'leg_stand: hop 3' c.out
grep -q 'leg_stand: stopped: enable = 0 sent' c.out
paced 12 p.out 'leg_hop.py: standing$' ~/rmd-venv/bin/python3 examples/physics/leg_hop.py --hops 3
cat p.out
grep -q 'leg_hop.py: stopped: enable = 0 sent' p.out
stop $logger
stop $pid
~/rmd-venv/bin/rmd-view examples/physics/leg.xml --config examples/physics/leg.yaml --log run.lcmlog --png frames/ --every 0.5
n=$(ls frames | grep -c '^frame-[0-9]*\.png$')
echo "rmd-view: $n frames"
[ "$n" -gt 20 ]

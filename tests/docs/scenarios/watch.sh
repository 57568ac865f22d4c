# where: host
# README.md, python/README.md, docs/lcm.md: rmdctl top and rmd-plot
# against running daemons and an lcm-logger log.
. "$RMD_REPO/tests/docs/lib.sh"
[ -x ~/rmd-venv/bin/rmd-plot ] || skip "no rmd-plot in build/venv: make python-venv"
png() { [ "$(head -c 8 "$1" | od -An -tx1 | tr -d ' \n')" = 89504e470d0a1a0a ] || { echo "$1 is no PNG"; exit 1; }; }

legs_yaml
# the log starts first, so that it holds rmdd's config_t (motor names)
lcm-logger --lcm-url='udpm://239.255.76.67:7667?ttl=0' -c 'RMD_.*' run.lcmlog > logger.out 2>&1 &
lp=$!
sleep 0.5
rmdd --config legs.yaml > rmdd.log 2>&1 &
pid=$!
wait_for rmdd.log 'running' 20

paced 2 top.out knee_l rmdctl top
rmdctl top --once > once.out
grep -q hip_l once.out
rmdctl top --json > rmdd.json
python3 -c 'import json; d = json.load(open("rmdd.json")); assert [m["name"] for m in d["motors"]] == ["knee_l", "hip_l"], d["motors"]'

# another daemon: its own URL and channel prefix
cat > arm.yaml <<EOY
lcm: {url: "udpm://239.255.76.67:7667?ttl=1", channel_prefix: "ARM_"}
buses:
  - {name: sim1, type: sim}
motors:
  - {name: wrist, bus: sim1, id: 1, mode: torque, torque_constant_nm_a: 2.0}
EOY
rmdd --config arm.yaml > arm.log 2>&1 &
arm=$!
wait_for arm.log 'running' 20
paced 3 arm.out wrist rmdctl top --lcm-url 'udpm://239.255.76.67:7667?ttl=1' --prefix ARM_
head -5 arm.out
stop $arm

# rmd-plot: the log, then the live daemon
stop $lp
~/rmd-venv/bin/rmd-plot --log run.lcmlog --field torque --motor knee_l --out torque.png
png torque.png
~/rmd-venv/bin/rmd-plot --log run.lcmlog --field position --csv pos.csv
head -3 pos.csv; [ "$(wc -l < pos.csv)" -gt 100 ]
rm torque.png
~/rmd-venv/bin/rmd-plot --log run.lcmlog --field torque --out torque.png
png torque.png
cp run.lcmlog run1.lcmlog
~/rmd-venv/bin/rmd-plot --log run1.lcmlog --field position --field health.wake_p99_us --out run1.png
png run1.png
~/rmd-venv/bin/rmd-plot --seconds 10 --field health.wake_p99_us --field bus.load --out rt.png
png rt.png
if command -v xvfb-run > /dev/null; then
	rc=0; timeout -k 10 -s INT 10 xvfb-run -a ~/rmd-venv/bin/rmd-plot --field position --field velocity > live.out 2>&1 || rc=$?
	cat live.out; ran_until_stopped $rc
fi
stop $pid

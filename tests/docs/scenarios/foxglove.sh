# where: host
# docs/logs.md "Live in Foxglove": rmd-foxglove beside rmdd on the simulated
# bus, connected to as Foxglove connects (tests/system/export_check.py
# foxglove: the websockets library speaking Foxglove's WebSocket protocol);
# every message received passes its schema and equals one heard on LCM.
# Then its errors: a port in use, a bad option.
. "$RMD_REPO/tests/docs/lib.sh"
[ -x ~/rmd-venv/bin/rmd-foxglove ] || skip "no rmd-foxglove in build/venv: make python-venv"

# a private LCM port and WebSocket port: other tests and a developer's rmdd use 7667 and 8765
url='udpm://239.255.76.67:7695?ttl=0'
port=$((20000 + $$ % 20000))
legs_yaml "$url"
rmdd --config legs.yaml > rmdd.log 2>&1 &
pid=$!
wait_for rmdd.log 'running' 20
~/rmd-venv/bin/rmd-foxglove --lcm-url "$url" --port $port --max-rate 0 > fox.log 2>&1 &
fox=$!
wait_for fox.log 'serving on' 20
~/rmd-venv/bin/python3 "$RMD_REPO/tests/system/export_check.py" foxglove "$url" \
	"ws://127.0.0.1:$port" 2
# the same port again: one line saying so, exit 1
rc=0
~/rmd-venv/bin/rmd-foxglove --lcm-url "$url" --port $port > busy.out 2>&1 || rc=$?
cat busy.out
[ $rc -eq 1 ] && grep -q "^rmd-foxglove: cannot listen on 127.0.0.1:$port" busy.out
kill $fox
wait $fox || true
cat fox.log
stop $pid
rc=0
~/rmd-venv/bin/rmd-foxglove --port 70000 > bad.out 2>&1 || rc=$?
cat bad.out
[ $rc -eq 2 ] && grep -q -- '--port 70000: not a port' bad.out

# where: host
# docs/lcm.md, examples/README.md: lcm-spy with rmdd's types (rmd-spy, and
# the java line it stands for), under a virtual display.
. "$RMD_REPO/tests/docs/lib.sh"
command -v xvfb-run > /dev/null || skip "no xvfb-run (sudo make deps installs xvfb)"
make lcm-java
rmdd --sim > rmdd.log 2>&1 &
pid=$!
wait_for rmdd.log 'running' 20
ntypes=$(ls "$RMD_REPO"/lcm_types/*.lcm | wc -l)
spy() { # OUT COMMAND...: it finds every rmd type and is still up 3 s later
	out=$1; shift
	xvfb-run -a "$@" > "$out" 2>&1 &
	sp=$!
	wait_for "$out" "Found $ntypes LCM types" 30
	sleep 3
	kill -0 $sp || { cat "$out"; echo "$* died"; exit 1; }
	pkill -TERM -P $sp || true; kill $sp 2>/dev/null || true; wait $sp || true
	! grep -q 'Could not create the Java Virtual Machine' "$out"
}
spy s1.out src/tools/rmd-spy/rmd-spy --lcm-url='udpm://239.255.76.67:7667?ttl=0' > /dev/null
spy s2.out src/tools/rmd-spy/rmd-spy > /dev/null
spy s3.out java -Djava.net.preferIPv4Stack=true -cp /usr/share/java/lcm.jar:/usr/share/java/jchart2d.jar:build/rmd_types.jar lcm.spy.Spy --lcm-url='udpm://239.255.76.67:7667?ttl=0' > /dev/null
stop $pid

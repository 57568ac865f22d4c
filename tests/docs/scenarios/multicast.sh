# where: host
# README.md, examples/README.md, docs/lcm.md, docs/troubleshooting.md: a
# machine without a multicast route (here: a network namespace with only
# lo), where rmdd cannot start its LCM, and the two commands that fix it.
. "$RMD_REPO/tests/docs/lib.sh"
[ "$(id -u)" -eq 0 ] || skip "needs root for a network namespace (unshare -n)"
unshare -n true 2>/dev/null || skip "unshare -n is not allowed here"
cat > inner.sh <<'EOS'
. "$RMD_REPO/tests/docs/lib.sh"
ip link set lo up
rc=0; timeout 10 rmdd --sim > before.log 2>&1 || rc=$?
cat before.log
[ $rc -eq 1 ] || { echo "rmdd --sim exited $rc without a multicast route (expected 1)"; exit 1; }
grep -q 'LCM' before.log
sudo ip link set lo multicast on
sudo ip route add 224.0.0.0/4 dev lo src 127.0.0.1
rmdd --sim > after.log 2>&1 &
pid=$!
wait_for after.log "running" 20
grep running after.log
stop $pid
EOS
unshare -n sh -eu inner.sh < /dev/null

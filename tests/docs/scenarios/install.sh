# where: host
# README.md's first line and docs/lcm.md's sysctl lines, in a private mount
# namespace whose /usr/local and /etc are overlays: what `make install`
# and the sysctl file write stays in the test.
. "$RMD_REPO/tests/docs/lib.sh"
[ "$(id -u)" -eq 0 ] || skip "needs root for a mount namespace (unshare -m)"
unshare -m true 2>/dev/null || skip "unshare -m is not allowed here"
ov=$(mktemp -d /tmp/rmd-docs-ov.XXXXXX)
cat > inner.sh <<EOS
. "$RMD_REPO/tests/docs/lib.sh"
for d in /usr/local /etc; do
	n=\$(echo \$d | tr / _)
	mkdir -p $ov/\$n.u $ov/\$n.w
	mount -t overlay overlay -o lowerdir=\$d,upperdir=$ov/\$n.u,workdir=$ov/\$n.w \$d
done
make && sudo make install
PATH=/usr/local/bin:\$PATH
command -v rmdd
rmdd --sim > installed.log 2>&1 &
pid=\$!
wait_for installed.log 'running' 20
stop \$pid
test -f /etc/rmdd/rmdd.yaml
old=\$(sysctl -n net.core.rmem_max)
sudo sysctl -w net.core.rmem_max=8388608
echo net.core.rmem_max=8388608 | sudo tee /etc/sysctl.d/60-lcm.conf
sysctl -w net.core.rmem_max=\$old
EOS
unshare -m sh -eu inner.sh < /dev/null
rm -rf "$ov"

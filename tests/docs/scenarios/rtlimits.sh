# where: host
# docs/troubleshooting.md "Real-time limits": a user without real-time
# limits gets rmdd's two start lines; the section's three lines, run as
# written for that user, give a new session of it rtprio 49 and memlock
# unlimited, and rmdd's start then says neither line.  The user is nobody,
# and the lines change a copy of /etc in a mount namespace of their own:
# the machine's /etc stays as it was.
. "$RMD_REPO/tests/docs/lib.sh"
[ "$(id -u)" -eq 0 ] || skip "needs root for a mount namespace over /etc (unshare -m)"
unshare -m true 2>/dev/null || skip "unshare -m is not allowed here"
command -v runuser >/dev/null 2>&1 || skip "no runuser (util-linux)"
id nobody >/dev/null 2>&1 || skip "no user nobody to run rmdd as"
# pam_limits raises a session's hard limits: root needs CAP_SYS_RESOURCE for that
sh -c 'ulimit -H -r 49' 2>/dev/null ||
	skip "root may not raise a hard limit here (no CAP_SYS_RESOURCE): pam_limits cannot apply limits.d in this container"
# rmdd as nobody writes its incident recordings here (systemd's StateDirectory=)
state=$(mktemp -d /tmp/rmdd-rtlimits.XXXXXX)
chmod 1777 "$state"
cat > inner.sh <<'EOS'
. "$RMD_REPO/tests/docs/lib.sh"
mount --make-rprivate /
cp -a /etc etc
mount --bind "$PWD/etc" /etc
rmdd=$(command -v rmdd)
as_user() { runuser -u nobody -- env STATE_DIRECTORY="$state" "$@"; }
# a session of nobody, as a login or ssh starts one (pam_limits): rmdd runs 8 s
rmdd_as_user() {
	rc=0
	as_user timeout -s INT 8 "$rmdd" --sim --lcm-url memq:// > "$1" 2>&1 || rc=$?
	cat "$1"
	ran_until_stopped $rc
	grep -q 'running:' "$1"
}
echo "before: rtprio $(as_user sh -c 'ulimit -r'), memlock $(as_user sh -c 'ulimit -l')"
rmdd_as_user before.log
grep -q 'no real-time priority: SCHED_FIFO refused' before.log
grep -q 'no memory lock: mlockall failed' before.log
USER=nobody
sudo groupadd -f realtime
sudo usermod -aG realtime "$USER"
printf '@realtime - rtprio 49\n@realtime - memlock unlimited\n' | sudo tee /etc/security/limits.d/90-rmdd-realtime.conf
[ "$(as_user sh -c 'ulimit -r')" = 49 ]
[ "$(as_user sh -c 'ulimit -l')" = unlimited ]
rmdd_as_user after.log
if grep -E 'no real-time priority|no memory lock' after.log; then
	echo "rmdd still says it has no real-time limits"
	exit 1
fi
EOS
rc=0
state="$state" unshare -m sh -eu inner.sh < /dev/null || rc=$?
rm -rf "$state"
exit $rc

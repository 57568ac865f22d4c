// SPDX-License-Identifier: MIT
/*
 * rmdd.service under a real systemd (issue 10, "a real systemd"): the unit as
 * `make install` writes it, run by systemd as PID 1, on rmd-sim's motors on
 * vcan0.  `make test` runs this suite in the QEMU guest booted with systemd
 * as init (tests/vm/vm-run --systemd); anywhere else every test skips saying
 * why.  The guest's root is an overlay of the host's with a tmpfs on top, so
 * installing into / there touches nothing on the host.
 *
 * Set-up: the tree `make install DESTDIR=$BUILD/systemd-root PREFIX=/usr`
 * made (RMD_SYSTEMD_ROOT) is copied into /, this suite's rmdd.yaml replaces
 * /etc/rmdd/rmdd.yaml, rmd-sim simulates motors 1-3 on vcan0 and candump
 * logs vcan0.  Then, in order, on that one hardened unit:
 *   security  `systemd-analyze security rmdd.service` (the loaded unit, not
 *             the offline file) rates its exposure 2.1 or lower;
 *   start     `systemctl start` returns (Type=notify: after READY=1), the
 *             unit is active with a STATUS= text; the daemon runs as a
 *             dynamic user, not root, in group dialout (serial adapters),
 *             holding CAP_NET_ADMIN alone, with its memory locked and a thread at
 *             SCHED_FIFO (the filter and namespaces let real time through),
 *             and publishes state_t over LCM multicast (IPAddressAllow=);
 *   watchdog  it stays up, same process, no restart, through 3 WatchdogSec
 *             periods: WATCHDOG=1 feeds systemd;
 *   stall     SIGSTOP: systemd's watchdog fires ("Watchdog timeout" in the
 *             journal, not before WatchdogSec) and restarts it: NRestarts+1;
 *   kill9     SIGKILL: restarted, NRestarts+1;
 *   stop      `systemctl stop`: inactive, Result=success, and candump shows
 *             each motor's 0x80 (motor shutdown) after the stop began.
 * Then instances (rmdd@.service, docs/systemd.md "Instances"), after the
 * stop:
 *   instances rmdd@a (motors 1-3 on vcan0, and a sim bus) and rmdd@b (a
 *             sim bus) run at once, each on /etc/rmdd/NAME.yaml with its own
 *             channel prefix; rmdd@c on vcan0 too is refused while rmdd@a
 *             holds it (the instances see each other's bus locks); each
 *             records its sim motor's disappearance under its own
 *             /var/lib/rmdd-NAME/incidents; stopping rmdd@b leaves /run/rmdd
 *             and rmdd@a's lock on vcan0, held, and rmdd@a running.
 * Times are deadlines for slow emulated guests, never margins: the only
 * bound judged is the watchdog's lower one, WatchdogSec, which no slowness
 * shortens.
 */
#define _GNU_SOURCE
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <grp.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <linux/capability.h>

#include "rmd/time.h"
#include "harness/lcm_loopback.h"
#include "harness/proc.h"
#include "harness/sleeper.h"
#include "harness/suite.h"

#define START_MS 120000	 /* systemctl start: bring-up in an emulated guest */
#define RESTART_MS 90000 /* a watchdog or kill restart, bring-up included */
#define SIM_READY_MS 60000
#define SETUP_MS 180000 /* copying the installed tree (over 9p, in a busy guest) */
#define LCM_WAIT_MS 30000
#define NMOTORS 3

static struct {
	const char *skip; /* why every test skips, or NULL */
	bool broken;	  /* the set-up failed: the tests fail */
	char build[160], root[200], rmdsim[240];
	char dir[64], logpath[96], url[96];
	struct kid *sim, *candump;
	long watchdog_ms;
} S;

/* ---- commands ------------------------------------------------------------------- */

/* sh -c cmd, to its end (limit_ms); the run is the caller's to free. */
static void sh(struct run *r, const char *cmd, int limit_ms)
{
	const char *args[] = { "-c", cmd, NULL };
	const struct run_opts o = { .limit_ms = limit_ms };

	run_prog(r, "/bin/sh", args, &o);
}

/* sh -c cmd, which must exit 0. */
static void sh_ok(const char *cmd, int limit_ms)
{
	struct run r = { 0 };

	sh(&r, cmd, limit_ms);
	if (r.status != 0)
		fail_msg("`%s`: exit %d\n%s%s", cmd, r.status, r.out, r.err);
	run_free(&r);
}

/* `systemctl show -p prop --value unit` into buf (trailing newline cut). */
static const char *prop_of(const char *unit, const char *name, char *buf, size_t size)
{
	char cmd[160];
	struct run r = { 0 };

	snprintf(cmd, sizeof(cmd), "systemctl show -p %s --value %s", name, unit);
	sh(&r, cmd, 30000);
	if (r.status != 0)
		fail_msg("`%s`: exit %d\n%s", cmd, r.status, r.err);
	snprintf(buf, size, "%s", r.out);
	buf[strcspn(buf, "\n")] = '\0';
	run_free(&r);
	return buf;
}

/* prop_of() rmdd.service. */
static const char *prop(const char *name, char *buf, size_t size)
{
	return prop_of("rmdd.service", name, buf, size);
}

static long prop_long(const char *name)
{
	char buf[64];

	return strtol(prop(name, buf, sizeof(buf)), NULL, 10);
}

/* A time span as `systemctl show` prints it ("2s", "1min 30s", "500ms") in ms. */
static long prop_ms(const char *name)
{
	static const struct {
		const char *unit;
		double ms;
	} units[] = { { "us", 1e-3 }, { "ms", 1 }, { "min", 60e3 }, { "s", 1e3 }, { "h", 3600e3 } };
	char buf[64], *p = buf, *end;
	double ms = 0;

	prop(name, buf, sizeof(buf));
	while (*p) {
		double v = strtod(p, &end);
		size_t i;

		if (end == p)
			fail_msg("%s=%s: not a time span", name, buf);
		for (i = 0; i < sizeof(units) / sizeof(units[0]); i++)
			if (strncmp(end, units[i].unit, strlen(units[i].unit)) == 0)
				break;
		if (i == sizeof(units) / sizeof(units[0]))
			fail_msg("%s=%s: unknown unit", name, buf);
		ms += v * units[i].ms;
		p = end + strlen(units[i].unit);
		while (*p == ' ')
			p++;
	}
	return (long)ms;
}

/*
 * What systemd said about rmdd and rmdd's last lines, printed on stderr
 * whole (a failure message would cut them); "" to end the message with.
 */
static const char *journal(void)
{
	struct run sd = { 0 }, own = { 0 };

	sh(&sd, "journalctl -o short-monotonic --no-pager -n 40 UNIT=rmdd.service", 30000);
	sh(&own, "journalctl -o short-monotonic --no-pager -n 15 _SYSTEMD_UNIT=rmdd.service",
	   30000);
	fprintf(stderr, "---- systemd about rmdd.service:\n%s%s---- rmdd's last lines:\n%s%s----\n",
		sd.out, sd.err, own.out, own.err);
	run_free(&sd);
	run_free(&own);
	return "(journal above)";
}

/* rmdd's MainPID, which must be a process (kill(0, ...) would hit the test). */
static long main_pid(void)
{
	long pid = prop_long("MainPID");

	if (pid <= 0)
		fail_msg("rmdd.service has no main process\n%s", journal());
	return pid;
}

static void expect_active(const char *when)
{
	char state[64];

	if (strcmp(prop("ActiveState", state, sizeof(state)), "active") != 0)
		fail_msg("%s: rmdd.service is %s, not active\n%s", when, state, journal());
}

/*
 * Wait until systemd has restarted rmdd once more than `restarts` times
 * before, into a new process that is active; the new MainPID.
 */
static long wait_restarted(long restarts, long old_pid, const char *why)
{
	int64_t deadline = rmd_now_ns() + (int64_t)RESTART_MS * 1000000;
	char state[64];
	long n = 0, pid = 0;

	while (rmd_now_ns() < deadline) {
		n = prop_long("NRestarts");
		pid = prop_long("MainPID");
		prop("ActiveState", state, sizeof(state));
		if (n > restarts && pid > 0 && pid != old_pid && strcmp(state, "active") == 0)
			break;
		usleep(200 * 1000);
	}
	if (n != restarts + 1 || pid == old_pid || strcmp(state, "active") != 0)
		fail_msg(
			"after %s: NRestarts %ld (was %ld), MainPID %ld (was %ld), %s within %d ms\n%s",
			why, n, restarts, pid, old_pid, state, RESTART_MS, journal());
	return pid;
}

/* ---- set-up ------------------------------------------------------------------ */

static const char *no_systemd(void)
{
	char comm[32] = "";
	FILE *f = fopen("/proc/1/comm", "r");

	if (f) {
		if (!fgets(comm, sizeof(comm), f))
			comm[0] = '\0';
		fclose(f);
	}
	if (strncmp(comm, "systemd", 7) != 0 || access("/run/systemd/system", F_OK) != 0)
		return "PID 1 is not systemd (make test runs this suite in the guest booted with "
		       "systemd: tests/vm/vm-run --systemd)";
	if (getuid() != 0)
		return "not root";
	if (access("/sys/class/net/vcan0", F_OK) != 0)
		return "no vcan0 (tests/vm/vm-run --systemd --vcan 1 creates it)";
	return NULL;
}

static const char config_fmt[] =
	"# test_systemd: rmdd.service on rmd-sim's motors 1-3 on vcan0, in the guest.\n"
	"loop:\n"
	"  rate_hz: 100\n"
	"  rt_priority: 40\n"
	"safety:\n"
	"  comm_loss_ms: 500\n"
	"  missed_replies_lost: 50\n"
	"  command_timeout_ms: 1000\n"
	"  shutdown_action: stop\n"
	"probe:\n"
	"  on_missing: start\n"
	"lcm:\n"
	"  url: \"%s\"\n"
	"  channel_prefix: \"RMD_\"\n"
	"  state_every_n: 10\n"
	"buses:\n"
	"  - {name: vcan0, type: socketcan}\n"
	"motors:\n"
	"  - {name: m1, bus: vcan0, id: 1, mode: position, torque_constant_nm_a: 2, gear_ratio: 6}\n"
	"  - {name: m2, bus: vcan0, id: 2, mode: position, torque_constant_nm_a: 2, gear_ratio: 6}\n"
	"  - {name: m3, bus: vcan0, id: 3, mode: position, torque_constant_nm_a: 2, gear_ratio: 6}\n";

static int group_setup(void **state)
{
	const char *b = getenv("BUILD"), *root = getenv("RMD_SYSTEMD_ROOT");
	char cmd[512], cfg[2048];
	FILE *f;

	(void)state;
	S.skip = no_systemd();
	if (S.skip) {
		fprintf(stderr, "SKIP: test_systemd: %s\n", S.skip);
		return 0;
	}
	S.broken = true; /* until the end of this function */
	snprintf(S.build, sizeof(S.build), "%s", b && *b ? b : "build");
	if (root && *root)
		snprintf(S.root, sizeof(S.root), "%s", root);
	else
		snprintf(S.root, sizeof(S.root), "%s/systemd-root", S.build);
	snprintf(S.rmdsim, sizeof(S.rmdsim), "%s/usr/bin/rmd-sim", S.root);
	if (access(S.rmdsim, X_OK) != 0) {
		fprintf(stderr, "test_systemd: %s missing: run `make test` (it installs there)\n",
			S.rmdsim);
		return 0;
	}
	snprintf(S.dir, sizeof(S.dir), "/dev/shm/rmd-systemd-%d", (int)getpid());
	snprintf(S.logpath, sizeof(S.logpath), "%s/candump.log", S.dir);
	/* the default group (the unit's IPAddressAllow=), a port of this run */
	snprintf(S.url, sizeof(S.url), "udpm://239.255.76.67:%d?ttl=0",
		 20000 + (int)(getpid() % 20000));
	if (mkdir(S.dir, 0755) != 0)
		return 0;

	/*
	 * The installed tree into the guest's (overlay) root.  No daemon-reload:
	 * rmdd.service was never loaded, and systemd finds a new unit file when a
	 * command first names it.
	 */
	snprintf(cmd, sizeof(cmd), "cp -a '%s'/. /", S.root);
	sh_ok(cmd, SETUP_MS);
	snprintf(cfg, sizeof(cfg), config_fmt, S.url);
	f = fopen("/etc/rmdd/rmdd.yaml", "w");
	if (!f || fputs(cfg, f) < 0 || fclose(f) != 0)
		return 0;

	S.candump = kid_spawn(
		"candump", (const char *const[]){ "candump", "-L", "-r", "4194304", "vcan0", NULL },
		S.logpath, 0);
	S.sim = kid_spawn("rmd-sim vcan0",
			  (const char *const[]){ S.rmdsim, "--can", "vcan0", "--motors", "1,2,3",
						 NULL },
			  NULL, 0);
	kid_wait_output(S.sim, ": ready", SIM_READY_MS, NULL);
	S.broken = false;
	return 0;
}

static int group_teardown(void **state)
{
	(void)state;
	if (!S.skip) {
		struct run r = { 0 };

		sh(&r, "systemctl stop rmdd.service 'rmdd@*.service'", 120000);
		run_free(&r);
	}
	kid_kill_all();
	if (S.dir[0])
		rm_tree(S.dir);
	return 0;
}

static void need_setup(void)
{
	if (S.skip)
		skip();
	if (S.broken)
		fail_msg("set-up failed (see above)");
}

/* The tests after test_start judge against its WatchdogSec. */
static void need_watchdog(void)
{
	need_setup();
	if (S.watchdog_ms <= 0)
		fail_msg("test_start did not read WatchdogSec (run the suite whole)");
}

/* ---- the tests ------------------------------------------------------------- */

static void test_security(void **state)
{
	struct run r = { 0 };
	const char *at;
	double exposure;

	(void)state;
	need_setup();
	sh(&r, "systemd-analyze security --no-pager rmdd.service", 60000);
	at = strstr(r.out, "Overall exposure level for rmdd.service:");
	if (r.status != 0 || !at)
		fail_msg("systemd-analyze security: exit %d\n%s%s", r.status, r.out, r.err);
	exposure = strtod(at + strlen("Overall exposure level for rmdd.service:"), NULL);
	fprintf(stderr, "test_systemd: systemd-analyze security rmdd.service: exposure %.1f\n",
		exposure);
	/*
	 * 2.0 until issue 33.4: CAP_NET_ADMIN, and PrivateUsers=no for it to
	 * reach the host's interfaces, add 0.5 (rmdd.service.in says why)
	 */
	if (!(exposure <= 2.1))
		fail_msg("exposure %.1f > 2.1:\n%s", exposure, r.out);
	run_free(&r);
}

/* The highest scheduling policy among pid's threads (1 = SCHED_FIFO). */
static int thread_policy_fifo(long pid)
{
	char path[320], line[1024];
	struct dirent *e;
	DIR *d;
	int fifo = 0;

	snprintf(path, sizeof(path), "/proc/%ld/task", pid);
	d = opendir(path);
	if (!d)
		return -1;
	while ((e = readdir(d))) {
		FILE *f;
		char *p;
		int field = 2;

		if (e->d_name[0] == '.')
			continue;
		snprintf(path, sizeof(path), "/proc/%ld/task/%s/stat", pid, e->d_name);
		f = fopen(path, "r");
		if (!f)
			continue;
		if (fgets(line, sizeof(line), f) && (p = strrchr(line, ')'))) {
			/* field 41 of stat(5) is policy; p points at the end of field 2 */
			for (p++; *p && field < 41; p++)
				if (*p == ' ')
					field++;
			if (strtol(p, NULL, 10) == 1)
				fifo = 1;
		}
		fclose(f);
	}
	closedir(d);
	return fifo;
}

/* The text after key on its line of /proc/pid/status, without the newline, into buf; or NULL. */
static const char *status_line(long pid, const char *key, char *buf, size_t size)
{
	char path[64], line[256];
	const char *found = NULL;
	FILE *f;

	snprintf(path, sizeof(path), "/proc/%ld/status", pid);
	f = fopen(path, "r");
	if (!f)
		return NULL;
	while (!found && fgets(line, sizeof(line), f))
		if (strncmp(line, key, strlen(key)) == 0) {
			snprintf(buf, size, "%s", line + strlen(key));
			buf[strcspn(buf, "\n")] = '\0';
			found = buf;
		}
	fclose(f);
	return found;
}

/* A line of /proc/pid/status as a number (VmLck: kB, Uid: the real one), or -1. */
static long status_field(long pid, const char *key)
{
	char text[256];

	return status_line(pid, key, text, sizeof(text)) ? strtol(text, NULL, 10) : -1;
}

/* The Groups: line of /proc/pid/status (static buffer; "" when unread). */
static const char *groups_of(long pid)
{
	static char groups[256];

	return status_line(pid, "Groups:", groups, sizeof(groups)) ?: "";
}

/* pid's effective capabilities (/proc/pid/status CapEff:, hex), or all ones when unread. */
static uint64_t cap_eff(long pid)
{
	char text[256];

	return status_line(pid, "CapEff:", text, sizeof(text)) ? strtoull(text, NULL, 16) :
								 UINT64_MAX;
}

/* Whether pid's supplementary groups hold dialout (serial adapters' group). */
static bool has_dialout(long pid)
{
	const struct group *g = getgrnam("dialout");
	char want[32], have[300];

	if (!g)
		fail_msg("no group dialout on this system");
	snprintf(want, sizeof(want), " %u ", (unsigned)g->gr_gid);
	snprintf(have, sizeof(have), " %s ", groups_of(pid));
	for (char *t = have; *t; t++)
		if (*t == '\t')
			*t = ' ';
	return strstr(have, want) != NULL;
}

/*
 * docs/troubleshooting.md "Reading the log", its commands as written: the
 * statistics SIGUSR1 asks for reach the journal, -p warning keeps only
 * warnings and errors (journald took rmdd's <N> prefixes as priorities),
 * and -f follows.
 */
static void read_the_log_as_documented(void)
{
	struct run r = { 0 };
	int64_t deadline = rmd_now_ns() + (int64_t)START_MS * 1000000;
	bool seen = false;

	sh_ok("systemctl kill -s USR1 rmdd", 30000);
	while (!seen && rmd_now_ns() < deadline) {
		sh(&r, "journalctl -u rmdd", 30000);
		seen = r.status == 0 && strstr(r.out, "statistics (SIGUSR1)");
		if (!seen && !strstr(r.out, "running:"))
			fail_msg("`journalctl -u rmdd`: exit %d, no 'running:' line\n%s%s",
				 r.status, r.out, r.err);
		run_free(&r);
		if (!seen)
			usleep(200000);
	}
	if (!seen)
		fail_msg("`systemctl kill -s USR1 rmdd`: no statistics in the journal\n%s",
			 journal());
	sh(&r, "journalctl -u rmdd -p warning", 30000);
	if (r.status != 0 || strstr(r.out, "running:") || strstr(r.out, "statistics (SIGUSR1)"))
		fail_msg("`journalctl -u rmdd -p warning`: exit %d, info lines in it:\n%s",
			 r.status, r.out);
	run_free(&r);
	sh(&r, "timeout 3 journalctl -u rmdd -f", 30000);
	if (r.status != 124 || !strstr(r.out, "rmdd"))
		fail_msg("`journalctl -u rmdd -f`: exit %d (124: still following), output:\n%s",
			 r.status, r.out);
	run_free(&r);
}

static void test_start(void **state)
{
	struct run r = { 0 };
	struct lcm_rx rx = { 0 };
	char text[256];
	int64_t deadline;
	long pid;
	lcm_t *lcm;

	(void)state;
	need_setup();
	sh(&r, "systemctl start rmdd.service", START_MS);
	if (r.status != 0)
		fail_msg("systemctl start rmdd: exit %d\n%s%s", r.status, r.err, journal());
	run_free(&r);
	expect_active("after systemctl start");
	if (!prop("StatusText", text, sizeof(text))[0])
		fail_msg("no STATUS= text\n%s", journal());
	fprintf(stderr, "test_systemd: StatusText=%s\n", text);
	S.watchdog_ms = prop_ms("WatchdogUSec");
	if (S.watchdog_ms <= 0)
		fail_msg("rmdd.service has no WatchdogSec=");
	fprintf(stderr, "test_systemd: WatchdogSec=%ld ms\n", S.watchdog_ms);

	pid = main_pid();
	if (status_field(pid, "Uid:") <= 0)
		fail_msg("rmdd (pid %ld) runs as uid %ld, not a dynamic user", pid,
			 status_field(pid, "Uid:"));
	if (status_field(pid, "VmLck:") <= 0)
		fail_msg(
			"rmdd (pid %ld) has no memory locked (VmLck %ld kB): mlockall refused?\n%s",
			pid, status_field(pid, "VmLck:"), journal());
	fprintf(stderr,
		"test_systemd: rmdd runs as uid %ld, %ld kB locked, cgroup memory %s, "
		"groups:%s\n",
		status_field(pid, "Uid:"), status_field(pid, "VmLck:"),
		prop("MemoryCurrent", text, sizeof(text)), groups_of(pid));
	if (!has_dialout(pid))
		fail_msg("rmdd (pid %ld) lacks group dialout (SupplementaryGroups=): no serial "
			 "adapters\n%s",
			 pid, journal());
	if (thread_policy_fifo(pid) != 1)
		fail_msg("no thread of rmdd (pid %ld) runs at SCHED_FIFO\n%s", pid, journal());
	/* the one capability (an e-stop's interface restart), and no other */
	if (cap_eff(pid) != UINT64_C(1) << CAP_NET_ADMIN)
		fail_msg("rmdd (pid %ld) holds capabilities %#llx, not CAP_NET_ADMIN alone "
			 "(AmbientCapabilities=)\n%s",
			 pid, (unsigned long long)cap_eff(pid), journal());

	/* state_t over LCM: IPAddressAllow= lets the multicast group through */
	lcm = lcm_create(S.url);
	if (!lcm)
		fail_msg("lcm_create(%s) failed", S.url);
	lcm_rx_listen(&rx, lcm, "RMD_");
	deadline = rmd_now_ns() + (int64_t)LCM_WAIT_MS * 1000000;
	while (rx.n_states == 0 && rmd_now_ns() < deadline)
		lcm_handle_timeout(lcm, 200);
	lcm_rx_free(&rx);
	lcm_destroy(lcm);
	if (rx.n_states == 0)
		fail_msg("no RMD_STATE on %s within %d ms\n%s", S.url, LCM_WAIT_MS, journal());
	read_the_log_as_documented();
}

/*
 * rmdd's main thread (SCHED_OTHER) pings every WatchdogSec/2.  A guest so
 * starved that a thread of that class wakes WatchdogSec/2 late may miss the
 * deadline with nothing wrong in rmdd: a reference sleeper at normal
 * priority measures that in each window, and a restart in such a window
 * proves nothing; the window is tried again (WINDOWS in all).
 */
#define WINDOWS 3

static void test_watchdog_fed(void **state)
{
	struct sleeper ref = { 0 };
	long pid = 0, restarts = 0;
	int64_t until, worst_ms = 0;
	int w;

	(void)state;
	need_watchdog();
	assert_int_equal(sleeper_start(&ref, 50 * 1000000, 0), 0);
	for (w = 0; w < WINDOWS; w++) {
		bool restarted = false;

		if (w > 0) /* after an inconclusive restart: wait until it is up again */
			wait_restarted(restarts, pid, "a restart in a starved window");
		pid = main_pid();
		restarts = prop_long("NRestarts");
		sleeper_mark(&ref);
		until = rmd_now_ns() + 3 * S.watchdog_ms * 1000000 + 500000000;
		while (rmd_now_ns() < until && !restarted) {
			restarted = prop_long("MainPID") != pid ||
				    prop_long("NRestarts") != restarts;
			usleep(250 * 1000);
		}
		worst_ms = sleeper_worst_ns(&ref) / 1000000;
		if (!restarted)
			break;
		if (worst_ms < S.watchdog_ms / 2) {
			sleeper_stop(&ref);
			fail_msg(
				"rmdd restarted while running normally, in a window where a "
				"normal-priority thread woke at most %lld ms late (WatchdogSec=%ld "
				"ms)\n%s",
				(long long)worst_ms, S.watchdog_ms, journal());
		}
		fprintf(stderr,
			"test_systemd: restarted in a window where the guest starved a normal "
			"thread for %lld ms (>= WatchdogSec/2): inconclusive, trying again\n",
			(long long)worst_ms);
	}
	sleeper_stop(&ref);
	if (w == WINDOWS) {
		fprintf(stderr,
			"SKIP: test_watchdog_fed: the guest starved normal threads for "
			"WatchdogSec/2 or more in each of %d windows\n",
			WINDOWS);
		skip();
	}
	expect_active("3 WatchdogSec periods");
	fprintf(stderr,
		"test_systemd: up through 3 WatchdogSec periods, same process (reference "
		"thread at most %lld ms late)\n",
		(long long)worst_ms);
}

static void test_stall_restarts(void **state)
{
	struct run r = { 0 };
	long pid, restarts;
	int64_t t0, took_ms;

	(void)state;
	need_watchdog();
	pid = main_pid();
	restarts = prop_long("NRestarts");
	t0 = rmd_now_ns();
	if (kill((pid_t)pid, SIGSTOP) != 0)
		fail_msg("SIGSTOP %ld: %s", pid, strerror(errno));
	wait_restarted(restarts, pid, "SIGSTOP");
	took_ms = (rmd_now_ns() - t0) / 1000000;
	fprintf(stderr, "test_systemd: SIGSTOP -> restarted and active in %lld ms\n",
		(long long)took_ms);
	if (took_ms < S.watchdog_ms)
		fail_msg("restarted %lld ms after SIGSTOP, before WatchdogSec (%ld ms)",
			 (long long)took_ms, S.watchdog_ms);
	sh(&r, "journalctl -u rmdd.service -o cat --no-pager | grep -c 'Watchdog timeout'", 30000);
	if (r.status != 0)
		fail_msg("no \"Watchdog timeout\" in rmdd's journal\n%s", journal());
	run_free(&r);
}

static void test_kill9_restarts(void **state)
{
	long pid, restarts;

	(void)state;
	need_setup();
	pid = main_pid();
	restarts = prop_long("NRestarts");
	if (kill((pid_t)pid, SIGKILL) != 0)
		fail_msg("SIGKILL %ld: %s", pid, strerror(errno));
	wait_restarted(restarts, pid, "SIGKILL");
}

static void test_stop_stops_motors(void **state)
{
	struct run r = { 0 };
	char res[64], state_s[64], frame[32], *log = NULL;
	struct stat st;
	size_t from, len = 0;
	FILE *f;

	(void)state;
	need_setup();
	expect_active("before systemctl stop");
	if (stat(S.logpath, &st) != 0)
		fail_msg("%s: %s", S.logpath, strerror(errno));
	from = (size_t)st.st_size;
	sh(&r, "systemctl stop rmdd.service", 60000);
	if (r.status != 0)
		fail_msg("systemctl stop rmdd: exit %d\n%s", r.status, r.err);
	run_free(&r);
	if (strcmp(prop("ActiveState", state_s, sizeof(state_s)), "inactive") != 0 ||
	    strcmp(prop("Result", res, sizeof(res)), "success") != 0)
		fail_msg("after systemctl stop: %s, Result=%s\n%s", state_s, res, journal());

	/* candump writes what it saw by now within moments: poll its log */
	for (int64_t deadline = rmd_now_ns() + 10000000000LL; rmd_now_ns() < deadline;) {
		bool all = true;

		free(log);
		log = NULL;
		f = fopen(S.logpath, "r");
		if (f) {
			fseek(f, (long)from, SEEK_SET);
			if (getdelim(&log, &len, '\0', f) < 0) {
				free(log);
				log = strdup("");
			}
			fclose(f);
		}
		for (unsigned id = 1; log && id <= NMOTORS; id++) {
			snprintf(frame, sizeof(frame), " vcan0 %03X#80", 0x140 + id);
			all = all && strstr(log, frame);
		}
		if (all)
			break;
		usleep(200 * 1000);
	}
	for (unsigned id = 1; id <= NMOTORS; id++) {
		snprintf(frame, sizeof(frame), " vcan0 %03X#80", 0x140 + id);
		if (!log || !strstr(log, frame))
			fail_msg(
				"no shutdown frame%s for motor %u in candump after systemctl stop:\n%s",
				frame, id, log ? log : "(no log)");
	}
	free(log);
}

/* The configuration of instance name: prefix P_, a sim bus whose motor 1 disappears, and vcan0's. */
static void write_instance(const char *name, const char *prefix, bool vcan)
{
	char path[64], cfg[2048];
	FILE *f;

	snprintf(path, sizeof(path), "/etc/rmdd/%s.yaml", name);
	snprintf(
		cfg, sizeof(cfg),
		"# test_systemd: instance %s\n"
		"loop: {rate_hz: 100, rt_priority: 40}\n"
		"safety: {comm_loss_ms: 500, missed_replies_lost: 5, lost_motor_action: motor,\n"
		"         command_timeout_ms: 1000, shutdown_action: stop}\n"
		"probe: {on_missing: start}\n"
		/* no recording of an overrun of the slow guest's: the lost motor's is the one */
		"incidents: {seconds_before: 0.5, seconds_after: 0.2, overrun_burst: 1000000}\n"
		"lcm: {url: \"%s\", channel_prefix: \"%s\", state_every_n: 10}\n"
		"buses:\n"
		"  - {name: sim0, type: sim, sim: {seed: 1, faults: [\n"
		"      {kind: disappear, motor: 9, start_s: 2.0, end_s: 2.5, param: 1}]}}\n"
		"%s"
		"motors:\n"
		"  - {name: %s_s9, bus: sim0, id: 9, mode: position, torque_constant_nm_a: 2}\n"
		"%s",
		name, S.url, prefix, vcan ? "  - {name: vcan0, type: socketcan}\n" : "", name,
		vcan ? "  - {name: m1, bus: vcan0, id: 1, mode: position, torque_constant_nm_a: 2, "
		       "gear_ratio: 6}\n"
		       "  - {name: m2, bus: vcan0, id: 2, mode: position, torque_constant_nm_a: 2, "
		       "gear_ratio: 6}\n"
		       "  - {name: m3, bus: vcan0, id: 3, mode: position, torque_constant_nm_a: 2, "
		       "gear_ratio: 6}\n" :
		       "");
	f = fopen(path, "w");
	if (!f || fputs(cfg, f) < 0 || fclose(f) != 0)
		fail_msg("%s: %s", path, strerror(errno));
}

/* What systemd and the instance said, on stderr whole; "" for a failure message's end. */
static const char *journal_of(const char *unit)
{
	char cmd[160];
	struct run r = { 0 };

	snprintf(cmd, sizeof(cmd), "journalctl -o short-monotonic --no-pager -n 30 -u %s", unit);
	sh(&r, cmd, 30000);
	fprintf(stderr, "---- journal of %s:\n%s%s----\n", unit, r.out, r.err);
	run_free(&r);
	return "(journal above)";
}

static void expect_active_unit(const char *unit, const char *when)
{
	char state[64];

	if (strcmp(prop_of(unit, "ActiveState", state, sizeof(state)), "active") != 0)
		fail_msg("%s: %s is %s, not active\n%s", when, unit, state, journal_of(unit));
}

/* True when a process holds an exclusive flock(2) on path (rmdd's bus lock). */
static bool lock_held(const char *path)
{
	int fd = open(path, O_RDONLY | O_CLOEXEC);
	bool held;

	if (fd < 0)
		return false;
	held = flock(fd, LOCK_SH | LOCK_NB) < 0 && errno == EWOULDBLOCK;
	close(fd);
	return held;
}

/* Wait for a recording in /var/lib/rmdd-NAME/incidents (its sim motor's disappearance). */
static void expect_incident(const char *name)
{
	int64_t deadline = rmd_now_ns() + (int64_t)LCM_WAIT_MS * 1000000;
	char dir[64], names[4][DIR_NAME_MAX], unit[32];
	unsigned n = 0;

	snprintf(dir, sizeof(dir), "/var/lib/rmdd-%s/incidents", name);
	snprintf(unit, sizeof(unit), "rmdd@%s.service", name);
	while ((n = dir_sorted(dir, "0123456789", names, 4)) == 0 && rmd_now_ns() < deadline)
		usleep(200 * 1000);
	if (n == 0)
		fail_msg("no recording in %s within %d ms\n%s", dir, LCM_WAIT_MS, journal_of(unit));
	assert_has(names[0], "-lost", dir);
}

/* After test_instances, whatever failed: no instance left running (nor rmdd@c restarting). */
static int instances_teardown(void **state)
{
	struct run r = { 0 };

	(void)state;
	if (!S.skip) {
		sh(&r, "systemctl stop 'rmdd@*.service'; systemctl reset-failed 'rmdd@*.service'",
		   120000);
		run_free(&r);
	}
	return 0;
}

static void test_instances(void **state)
{
	struct run r = { 0 };
	char buf[64];

	(void)state;
	need_setup();
	write_instance("a", "A_", true);
	write_instance("b", "B_", false);
	write_instance("c", "C_", true);
	sh_ok("systemctl start rmdd@a.service rmdd@b.service", START_MS);
	expect_active_unit("rmdd@a.service", "after systemctl start");
	expect_active_unit("rmdd@b.service", "after systemctl start");
	assert_string_equal(prop_of("rmdd@a.service", "StateDirectory", buf, sizeof(buf)),
			    "rmdd-a");
	if (!lock_held("/run/rmdd/rmdd-bus-vcan0.lock"))
		fail_msg("rmdd@a holds no lock on vcan0 in /run/rmdd\n%s",
			 journal_of("rmdd@a.service"));

	/* another instance on vcan0: refused, it sees rmdd@a's lock */
	sh(&r, "systemctl start rmdd@c.service", START_MS);
	if (r.status == 0)
		fail_msg("rmdd@c started on vcan0 beside rmdd@a\n%s", journal_of("rmdd@c.service"));
	run_free(&r);
	sh(&r, "journalctl --no-pager -u rmdd@c.service", 120000);
	assert_has(r.out, "vcan0 is in use by another rmdd", "rmdd@c's journal");
	run_free(&r);
	sh_ok("systemctl stop rmdd@c.service; systemctl reset-failed rmdd@c.service || true",
	      120000);

	expect_incident("a");
	expect_incident("b");

	sh_ok("systemctl stop rmdd@b.service", 120000);
	expect_active_unit("rmdd@a.service", "after systemctl stop rmdd@b");
	if (access("/run/rmdd", F_OK) != 0 || !lock_held("/run/rmdd/rmdd-bus-vcan0.lock"))
		fail_msg("stopping rmdd@b took rmdd@a's lock on vcan0 with it");
	sh_ok("systemctl stop rmdd@a.service", 120000);
	if (lock_held("/run/rmdd/rmdd-bus-vcan0.lock"))
		fail_msg("vcan0's lock still held after every rmdd stopped");
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_security),
		cmocka_unit_test(test_start),
		cmocka_unit_test(test_watchdog_fed),
		cmocka_unit_test(test_stall_restarts),
		cmocka_unit_test(test_kill9_restarts),
		cmocka_unit_test(test_stop_stops_motors),
		cmocka_unit_test_teardown(test_instances, instances_teardown),
	};

	if (getenv("RMD_TEST_FILTER"))
		cmocka_set_test_filter(getenv("RMD_TEST_FILTER"));
	signal(SIGPIPE, SIG_IGN);
	return cmocka_run_group_tests(tests, group_setup, group_teardown);
}

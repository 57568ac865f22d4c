// SPDX-License-Identifier: MIT
/*
 * rmdd end to end: real processes and real signals.  Runs the built daemon
 * ($RMDD, else $BUILD/rmdd, else build/rmdd) on built-in simulated motors
 * with LCM on memq:// (no network needed) and checks
 *   - systemd's protocol through a fake NOTIFY_SOCKET: READY=1, STATUS=,
 *     WATCHDOG=1 every WATCHDOG_USEC/2, and no WATCHDOG=1 once the rt loop
 *     stalls (RMDD_TEST_STALL_AFTER_MS stops the loop thread; the main
 *     thread keeps running and must notice the frozen heartbeat);
 *   - SIGTERM and SIGINT: exit 0 with the statistics; SIGUSR1: the
 *     statistics, and the daemon keeps running; SIGHUP: ignored;
 *   - configuration, plan, bus and bring-up errors: exit 1 with the
 *     message; a bad command line: exit 2;
 *   - a process started at SCHED_FIFO (CPUSchedulingPolicy=) keeps only
 *     the rt loop thread real-time;
 *   - a lost motor is logged once, with its bus, id and name;
 *   - without the privilege for SCHED_FIFO and mlockall (RLIMIT_RTPRIO and
 *     RLIMIT_MEMLOCK 0, CAP_SYS_NICE and CAP_IPC_LOCK dropped from the
 *     bounding set before exec): one warning and running, or exit 1 with
 *     --require-rt.
 * Every wait is poll(2) on a pipe or socket with a deadline, never sleep().
 */
/* ASan intercepts mlockall() and makes it succeed without locking anything. */
#if defined(__SANITIZE_ADDRESS__)
#define MLOCK_IS_NOOP 1
#else
#define MLOCK_IS_NOOP 0
#endif
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <dirent.h>
#include <linux/capability.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/un.h>
#include <sys/wait.h>

#include <cmocka.h>

#include "harness/proc.h"

#define OUT_MAX (256 * 1024)
#define EXIT_NO_CAPS 77 /* the child could not drop its capabilities */

static char rmdd[4096];
static char rmdd_test[4096]; /* rmdd with its test hooks (RMDD_TEST_STALL_AFTER_MS) */
static char tmpdir[256];
/* The daemon a test runs, killed by the per-test teardown if a failure left it running. */
static pid_t live_pid;

struct proc {
	pid_t pid;
	int fd; /* the child's stdout and stderr */
	bool eof;
	size_t len;
	char out[OUT_MAX];
};

struct spawn_opts {
	const char *notify_socket; /* NOTIFY_SOCKET */
	const char *watchdog_usec; /* WATCHDOG_USEC, with WATCHDOG_PID = the child */
	const char *watchdog_pid;  /* WATCHDOG_PID as given (a mismatch) */
	const char *stall_ms;	   /* RMDD_TEST_STALL_AFTER_MS */
	bool no_rt;		   /* take away the real-time privileges */
	int fifo_prio;		   /* start at SCHED_FIFO (CPUSchedulingPolicy=); 0: no */
	const char *env_extra;	   /* "NAME=VALUE" put in the environment last */
	bool plain_log;		   /* no JOURNAL_STREAM: rmdd logs as on a pipe */
};

static int64_t now_ms(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

/* In the child: no SCHED_FIFO, no mlockall, even as root. */
static void drop_rt(void)
{
	struct rlimit zero = { 0, 0 };

	if (setrlimit(RLIMIT_RTPRIO, &zero) < 0 || setrlimit(RLIMIT_MEMLOCK, &zero) < 0)
		_exit(EXIT_NO_CAPS);
	/* exec recomputes root's capabilities from the bounding set */
	if (prctl(PR_CAPBSET_DROP, CAP_SYS_NICE, 0, 0, 0) < 0 ||
	    prctl(PR_CAPBSET_DROP, CAP_IPC_LOCK, 0, 0, 0) < 0)
		_exit(EXIT_NO_CAPS);
	prctl(PR_CAP_AMBIENT, PR_CAP_AMBIENT_CLEAR_ALL, 0, 0, 0);
}

/* In the child: the environment and scheduling a test asked for (so: its spawn_opts). */
static void child_env(const void *ctx)
{
	const struct spawn_opts *so = ctx;
	char pid[32];

	unsetenv("NOTIFY_SOCKET");
	unsetenv("WATCHDOG_USEC");
	unsetenv("WATCHDOG_PID");
	unsetenv("RMDD_TEST_STALL_AFTER_MS");
	/* as under journald: the checks read the <N> levels, unless a test asks for plain text */
	if (!so || !so->plain_log)
		journal_stream_env(NULL);
	if (!so)
		return;
	if (so->notify_socket)
		setenv("NOTIFY_SOCKET", so->notify_socket, 1);
	if (so->watchdog_usec) {
		setenv("WATCHDOG_USEC", so->watchdog_usec, 1);
		snprintf(pid, sizeof(pid), "%d", (int)getpid());
		setenv("WATCHDOG_PID", so->watchdog_pid ? so->watchdog_pid : pid, 1);
	}
	if (so->stall_ms)
		setenv("RMDD_TEST_STALL_AFTER_MS", so->stall_ms, 1);
	if (so->env_extra)
		putenv((char *)so->env_extra);
	if (so->no_rt)
		drop_rt();
	if (so->fifo_prio) {
		struct sched_param sp = { .sched_priority = so->fifo_prio };

		if (sched_setscheduler(0, SCHED_FIFO, &sp) < 0)
			_exit(EXIT_NO_CAPS);
	}
}

/* Start rmdd with args (NULL-terminated), output to p->fd. */
static void spawn(struct proc *p, const struct spawn_opts *so, const char *const *args)
{
	memset(p, 0, sizeof(*p));
	p->pid = spawn_piped(so && so->stall_ms ? rmdd_test : rmdd, args, &p->fd, child_env, so);
	live_pid = p->pid;
}

/* Read what is there, waiting at most timeout_ms.  False at EOF. */
static bool pump(struct proc *p, int timeout_ms)
{
	struct pollfd pfd = { .fd = p->fd, .events = POLLIN };
	ssize_t r;

	if (p->eof)
		return false;
	if (poll(&pfd, 1, timeout_ms) <= 0)
		return true;
	r = read(p->fd, p->out + p->len, OUT_MAX - 1 - p->len);
	if (r <= 0) {
		p->eof = true;
		return false;
	}
	p->len += (size_t)r;
	p->out[p->len] = '\0';
	return true;
}

/* Wait until the output holds `needle`.  Fails the test after timeout_ms. */
static void wait_for(struct proc *p, const char *needle, int timeout_ms)
{
	int64_t end = now_ms() + timeout_ms;

	while (!strstr(p->out, needle)) {
		int64_t left = end - now_ms();

		if (left <= 0 || !pump(p, (int)left))
			fail_msg("no \"%s\" from rmdd within %d ms; its output:\n%s", needle,
				 timeout_ms, p->out);
	}
}

/* Read to EOF and reap.  Returns the exit status (128 + signal when killed). */
static int finish(struct proc *p, int timeout_ms)
{
	int64_t end = now_ms() + timeout_ms;
	int ws;

	while (!p->eof) {
		int64_t left = end - now_ms();

		if (left <= 0) {
			kill(p->pid, SIGKILL);
			waitpid(p->pid, &ws, 0);
			live_pid = 0;
			close(p->fd);
			fail_msg("rmdd did not exit within %d ms; its output:\n%s", timeout_ms,
				 p->out);
		}
		pump(p, (int)left);
	}
	close(p->fd);
	assert_int_equal(waitpid(p->pid, &ws, 0), p->pid);
	live_pid = 0;
	return WIFEXITED(ws) ? WEXITSTATUS(ws) : 128 + WTERMSIG(ws);
}

/* rmdd started (spawn()) and up: its "running:" line within 5 s. */
static void spawn_running(struct proc *p, const struct spawn_opts *so, const char *const *args)
{
	spawn(p, so, args);
	wait_for(p, "<5>rmdd: running:", 5000);
}

/* SIGTERM: rmdd stops within 5 s, exit status 0. */
static void stop_ok(struct proc *p)
{
	kill(p->pid, SIGTERM);
	assert_int_equal(finish(p, 5000), 0);
}

/* Run to the end; returns the exit status. */
static int run(struct proc *p, const char *const *args)
{
	spawn(p, NULL, args);
	return finish(p, 10000);
}

static void expect_in(const struct proc *p, const char *needle)
{
	if (!strstr(p->out, needle))
		fail_msg("expected \"%s\" in rmdd's output:\n%s", needle, p->out);
}

static unsigned count_of(const char *hay, const char *needle)
{
	unsigned n = 0;

	for (const char *s = hay; (s = strstr(s, needle)); s += strlen(needle))
		n++;
	return n;
}

static void write_file(const char *path, const char *text)
{
	FILE *f = fopen(path, "w");

	assert_non_null(f);
	fputs(text, f);
	assert_int_equal(fclose(f), 0);
}

/* tmpdir/name holding text; its path into path (512 bytes). */
static void config_file(char *path, const char *name, const char *text)
{
	snprintf(path, 512, "%s/%s", tmpdir, name);
	write_file(path, text);
}

/* config_file(), and rmdd's arguments to run on it on an in-process LCM (until the next call). */
static const char *const *config_args(const char *name, const char *text)
{
	static char path[512];
	static const char *args[] = { "--config", path, "--lcm-url", "memq://", NULL };

	config_file(path, name, text);
	return args;
}

/* spawn_running() without options on the configuration text (config file name). */
static void spawn_config(struct proc *p, const char *name, const char *text)
{
	spawn_running(p, NULL, config_args(name, text));
}

/* rmdd on the configuration text (config file name) refuses to start: exit status 1. */
static void refused(struct proc *p, const char *name, const char *text)
{
	assert_int_equal(run(p, config_args(name, text)), 1);
}

static const char *const SIM3[] = { "--sim", "3", "--lcm-url", "memq://", NULL };

/* ---- command line and configuration errors ----------------------------------- */

static void test_usage_errors(void **state)
{
	static struct proc p;
	static const char *const bogus[] = { "--bogus", NULL };
	static const char *const sim0[] = { "--sim", "0", NULL };
	static const char *const sim40[] = { "--sim=40", NULL };
	static const char *const both[] = { "--sim", "--config", "x.yaml", NULL };
	static const char *const extra[] = { "--sim", "3", "extra", NULL };
	static const char *const help[] = { "--help", NULL };

	(void)state;
	assert_int_equal(run(&p, bogus), 2);
	expect_in(&p, "usage: rmdd");
	assert_int_equal(run(&p, sim0), 2);
	expect_in(&p, "--sim 0: the motor count is 1..32");
	assert_int_equal(run(&p, sim40), 2);
	assert_int_equal(run(&p, both), 2);
	expect_in(&p, "exclude each other");
	assert_int_equal(run(&p, extra), 2);
	expect_in(&p, "unexpected argument \"extra\"");
	assert_int_equal(run(&p, help), 0);
	expect_in(&p, "SIGUSR1");
}

static void test_no_default_config(void **state)
{
	static struct proc p;
	static const char *const none[] = { NULL };

	(void)state;
	if (access("/etc/rmdd/rmdd.yaml", F_OK) == 0) {
		fprintf(stderr, "SKIP: /etc/rmdd/rmdd.yaml exists, rmdd would run it\n");
		skip();
	}
	assert_int_equal(run(&p, none), 2);
	expect_in(&p, "<3>rmdd: no configuration: /etc/rmdd/rmdd.yaml does not exist");
	expect_in(&p, "--sim");
}

static void test_bad_config(void **state)
{
	static struct proc p;
	char path[512];
	const char *args[] = { "--config", path, NULL };

	(void)state;
	config_file(path, "bad.yaml", "loop:\n  rate_hz: 1000\n  bogus_key: 3\n");
	assert_int_equal(run(&p, args), 1);
	expect_in(&p, "<3>rmdd: ");
	expect_in(&p, "bad.yaml:3:");
	expect_in(&p, "bogus_key");

	snprintf(path, sizeof(path), "%s/does-not-exist.yaml", tmpdir);
	assert_int_equal(run(&p, args), 1);
	expect_in(&p, "does-not-exist.yaml");
}

static void test_infeasible_plan(void **state)
{
	static struct proc p;

	(void)state;
	refused(&p, "five.yaml",
		"loop: {rate_hz: 1000}\n"
		"buses:\n"
		"  - {name: s0, type: sim}\n"
		"motors:\n"
		"  - {name: a, bus: s0, id: 1, mode: torque, torque_constant_nm_a: 2}\n"
		"  - {name: b, bus: s0, id: 2, mode: torque, torque_constant_nm_a: 2}\n"
		"  - {name: c, bus: s0, id: 3, mode: torque, torque_constant_nm_a: 2}\n"
		"  - {name: d, bus: s0, id: 4, mode: torque, torque_constant_nm_a: 2}\n"
		"  - {name: e, bus: s0, id: 5, mode: torque, torque_constant_nm_a: 2}\n");
	expect_in(&p, "s0: 5 motors at 1000 Hz need");
	expect_in(&p, "the cycle is 1000 µs");
	expect_in(&p, "--check-config");
	/* nothing was started */
	assert_null(strstr(p.out, "running:"));
}

static void test_bus_error_names_the_bus(void **state)
{
	static struct proc p;

	(void)state;
	refused(&p, "nocan.yaml",
		"buses:\n"
		"  - {name: s0, type: sim}\n"
		"  - {name: rmdtest9, type: socketcan}\n"
		"motors:\n"
		"  - {name: a, bus: s0, id: 1, mode: torque, torque_constant_nm_a: 2}\n"
		"  - {name: b, bus: rmdtest9, id: 1, mode: torque, torque_constant_nm_a: 2}\n");
	/* file:line of the bus entry, its name and kind, the transport's fix */
	expect_in(&p, "nocan.yaml:3: bus rmdtest9 (socketcan): ");
	expect_in(&p, "rmdtest9");
}

static void test_missing_motor_refused(void **state)
{
	static struct proc p;

	(void)state;
	refused(&p, "missing.yaml",
		"probe: {on_missing: refuse}\n"
		"buses:\n"
		"  - name: s0\n"
		"    type: sim\n"
		"    sim:\n"
		"      faults:\n"
		"        - {kind: disappear, motor: 2, start_s: 0, param: 0}\n"
		"motors:\n"
		"  - {name: a, bus: s0, id: 1, mode: torque, torque_constant_nm_a: 2}\n"
		"  - {name: knee, bus: s0, id: 2, mode: torque, torque_constant_nm_a: 2}\n");
	expect_in(&p, "<4>rmdd:   s0: motor 2 (knee): missing");
	expect_in(&p, "1 motor(s) missing and probe.on_missing is refuse");
	assert_null(strstr(p.out, "running:"));
}

/* ---- signals -------------------------------------------------------------------- */

/* How many of pid's threads run SCHED_FIFO (at priority prio, when prio > 0). */
static unsigned fifo_threads(pid_t pid, int prio)
{
	char dir[64];
	struct dirent *e;
	unsigned n = 0;
	DIR *d;

	snprintf(dir, sizeof(dir), "/proc/%d/task", (int)pid);
	d = opendir(dir);
	if (!d)
		return 0;
	while ((e = readdir(d))) {
		struct sched_param sp;
		pid_t tid = (pid_t)atoi(e->d_name);

		if (tid > 0 && sched_getscheduler(tid) == SCHED_FIFO &&
		    sched_getparam(tid, &sp) == 0 && (prio <= 0 || sp.sched_priority == prio))
			n++;
	}
	closedir(d);
	return n;
}

static bool has_fifo_thread(pid_t pid, int prio)
{
	return fifo_threads(pid, prio) > 0;
}

static void expect_statistics(const struct proc *p, const char *why)
{
	char head[64];

	snprintf(head, sizeof(head), "<6>rmdd: statistics (%s) after ", why);
	expect_in(p, head);
	expect_in(p, "  loop: wake-up latency min ");
	expect_in(p, " p99 ");
	expect_in(p, "  loop: overruns ");
	expect_in(p, ", plan misses ");
	expect_in(p, "  bus sim0 (sim, 1000000 bit/s, 3 motors): load ");
	expect_in(p, "  motor motor3 (sim0 id 3, v3): ready; reply latency min ");
	expect_in(p, "; missed ");
	expect_in(p, "  lcm: commands accepted 0");
}

static void stop_with(int sig, const char *name)
{
	static struct proc p;
	char line[64];

	static const char *const args[] = { "--sim", "3", "--lcm-url", "memq://", "-v", NULL };

	spawn(&p, NULL, args);
	wait_for(&p, "<5>rmdd: running: 3 motor(s) on 1 bus(es) at 1000 Hz", 5000);
	/* the rt loop thread at the configuration's priority (default 40) */
	if (geteuid() == 0)
		assert_true(has_fifo_thread(p.pid, 40));
	/* the first STATUS summary comes after a second: health is in by then */
	wait_for(&p, "<7>rmdd: status: 3 motors: enabled 0, ready 3; loop ", 5000);
	kill(p.pid, sig);
	assert_int_equal(finish(&p, 5000), 0);
	snprintf(line, sizeof(line), "<5>rmdd: %s: stopping every motor", name);
	expect_in(&p, line);
	expect_statistics(&p, "exit");
	expect_in(&p, "every motor was sent stop (0x80)");
	assert_null(strstr(p.out, "no real-time priority"));
	assert_null(strstr(p.out, "no memory lock"));
}

/*
 * rmdd running on sim bus s0 with motors a, b and knee_l (IDs 1..3), the
 * third of which disappears (sim fault `window`: its start_s, end_s and
 * param), lost after `lost` missed replies in a row; config file name.
 */
static void knee_disappears(struct proc *p, const char *name, unsigned lost, const char *window)
{
	static char text[1024];

	snprintf(text, sizeof(text),
		 "safety: {missed_replies_lost: %u}\n"
		 "buses:\n"
		 "  - name: s0\n"
		 "    type: sim\n"
		 "    sim:\n"
		 "      faults:\n"
		 "        - {kind: disappear, motor: 3, %s}\n"
		 "motors:\n"
		 "  - {name: a, bus: s0, id: 1, mode: torque, torque_constant_nm_a: 2}\n"
		 "  - {name: b, bus: s0, id: 2, mode: torque, torque_constant_nm_a: 2}\n"
		 "  - {name: knee_l, bus: s0, id: 3, mode: torque, torque_constant_nm_a: 2}\n",
		 lost, window);
	spawn_config(p, name, text);
}

/*
 * loop.keep_cpus_awake (default true): while rmdd runs, the kernel's PM QoS
 * CPU wake-up latency target (what /dev/cpu_dma_latency reads back) is
 * 0 us; after it exits the target is what it was before; with false rmdd
 * leaves it alone.  Needs read access to the device (root).
 */
static int32_t cpu_latency_target(void)
{
	int32_t v = -1;
	int fd = open("/dev/cpu_dma_latency", O_RDONLY | O_CLOEXEC);

	if (fd < 0)
		return -1;
	if (read(fd, &v, sizeof(v)) != (ssize_t)sizeof(v))
		v = -1;
	close(fd);
	return v;
}

/* Whether process pid has /dev/cpu_dma_latency open (its request stands while it does). */
static bool holds_cpu_latency(pid_t pid)
{
	char dir[64], fd_path[PATH_MAX + 80], target[PATH_MAX];
	struct dirent *e;
	bool found = false;
	DIR *d;

	snprintf(dir, sizeof(dir), "/proc/%ld/fd", (long)pid);
	d = opendir(dir);
	assert_non_null(d);
	while (!found && (e = readdir(d))) {
		ssize_t n;

		snprintf(fd_path, sizeof(fd_path), "%s/%s", dir, e->d_name);
		n = readlink(fd_path, target, sizeof(target) - 1);
		if (n > 0) {
			target[n] = '\0';
			found = !strcmp(target, "/dev/cpu_dma_latency");
		}
	}
	closedir(d);
	return found;
}

/*
 * The machine's target is the least of every open request: another rmdd
 * running here (a developer's, rmdd.service) holds it at 0 already, and
 * then rmdd's own request is judged by its open device alone.
 */
static void test_cpus_kept_awake(void **state)
{
	static struct proc p;
	static const char *const args[] = { "--sim", "1", "--lcm-url", "memq://", NULL };
	int32_t before = cpu_latency_target();

	(void)state;
	if (before < 0) {
		fprintf(stderr, "SKIP: /dev/cpu_dma_latency not readable here (%s)\n",
			strerror(errno));
		skip();
	}
	if (before == 0)
		fprintf(stderr, "another process holds the CPU wake-up latency at 0 us: rmdd's "
				"request is judged by its open /dev/cpu_dma_latency alone\n");
	spawn_running(&p, NULL, args);
	assert_true(holds_cpu_latency(p.pid));
	assert_int_equal(cpu_latency_target(), 0);
	assert_null(strstr(p.out, "CPU wake-up latency not held"));
	kill(p.pid, SIGINT);
	assert_int_equal(finish(&p, 5000), 0);
	assert_int_equal(cpu_latency_target(), before);

	spawn_running(&p, NULL,
		      config_args("awake.yaml", "loop: {rate_hz: 500, keep_cpus_awake: false}\n"
						"buses: [{name: s0, type: sim}]\n"
						"motors: [{name: a, bus: s0, id: 1, mode: torque,"
						" torque_constant_nm_a: 2}]\n"));
	assert_false(holds_cpu_latency(p.pid));
	assert_int_equal(cpu_latency_target(), before);
	kill(p.pid, SIGINT);
	assert_int_equal(finish(&p, 5000), 0);
}

static void test_sigterm(void **state)
{
	(void)state;
	stop_with(SIGTERM, strsignal(SIGTERM));
}

static void test_sigint(void **state)
{
	(void)state;
	stop_with(SIGINT, strsignal(SIGINT));
}

static void test_sigusr1_and_sighup_keep_running(void **state)
{
	static const char *const args[] = { "--sim", "3", "--lcm-url", "memq://", "-v", NULL };
	static struct proc p;
	int ws;

	(void)state;

	spawn_running(&p, NULL, args);
	/* the first STATUS summary comes after a second: health is in by then */
	wait_for(&p, "<7>rmdd: status: ", 5000);
	kill(p.pid, SIGUSR1);
	wait_for(&p, "  lcm: commands accepted", 5000);
	expect_statistics(&p, "SIGUSR1");
	assert_int_equal(waitpid(p.pid, &ws, WNOHANG), 0);
	kill(p.pid, SIGHUP);
	wait_for(&p, "SIGHUP ignored", 5000);
	kill(p.pid, SIGUSR1);
	/* a second block of statistics: the daemon still answers */
	{
		int64_t end = now_ms() + 5000;

		while (count_of(p.out, "statistics (SIGUSR1)") < 2 && now_ms() < end)
			pump(&p, 100);
		assert_int_equal(count_of(p.out, "statistics (SIGUSR1)"), 2);
	}
	assert_int_equal(waitpid(p.pid, &ws, WNOHANG), 0);
	stop_ok(&p);
	expect_statistics(&p, "exit");
}

/* knee_l back; rmdd stops; what happened to it (`what`: "lost") logged once, of it alone. */
static void knee_back(struct proc *p, const char *what)
{
	char knee[64], a[64];

	wait_for(p, "<5>rmdd: s0: motor 3 (knee_l): back (lost -> stopping)", 5000);
	stop_ok(p);
	/* logged on change: once each */
	snprintf(knee, sizeof(knee), "(knee_l): %s", what);
	snprintf(a, sizeof(a), "(a): %s", what);
	assert_int_equal(count_of(p->out, knee), 1);
	assert_null(strstr(p->out, a));
}

static void test_lost_motor_logged_with_context(void **state)
{
	static struct proc p;

	(void)state;
	knee_disappears(&p, "lose.yaml", 10, "start_s: 0.3, end_s: 0.6, param: 0");
	wait_for(&p, "<4>rmdd: s0: motor 3 (knee_l): lost (10 missed replies in a row", 5000);
	knee_back(&p, "lost");
}

/*
 * A short power cycle (docs/faults.md "A short power cycle"): motor 3
 * loses power for 50 ms, fewer replies than missed_replies_lost, and
 * boots at once; the log says it rebooted, how it was seen, and that it
 * is treated as lost and back; then back.  50 ms, not 5: a loaded machine
 * that holds rmdd off for a few ms still sends into the window.
 */
static void test_short_power_cycle_logged(void **state)
{
	static struct proc p;

	(void)state;
	knee_disappears(&p, "glitch.yaml", 200, "start_s: 0.5, end_s: 0.55, param: 1");
	wait_for(&p, "<4>rmdd: s0: motor 3 (knee_l): rebooted (runtime ", 5000);
	wait_for(&p, "ms: 0xB1); treated as lost and back", 5000);
	knee_back(&p, "rebooted");
}

/*
 * An e-stop on two sim buses (bus_power from 0.5 s to 1.0 s): the journal
 * says that nobody acknowledges, what was done with the frames each bus
 * held (s0 flushes; s1 refuses, as SocketCAN without CAP_NET_ADMIN, and
 * says what stays queued and what to do), and the motors come back.  The
 * lines docs/troubleshooting.md "E-stop" quotes.
 */
static void test_estop_logged(void **state)
{
	static struct proc p;

	(void)state;
	spawn_config(&p, "estop.yaml",
		     "buses:\n"
		     "  - name: s0\n"
		     "    type: sim\n"
		     "    sim:\n"
		     "      faults: [{kind: bus_power, start_s: 0.5, end_s: 1.0}]\n"
		     "  - name: s1\n"
		     "    type: sim\n"
		     "    sim:\n"
		     "      refuse_flush: true\n"
		     "      faults: [{kind: bus_power, start_s: 0.5, end_s: 1.0}]\n"
		     "motors:\n"
		     "  - {name: knee, bus: s0, id: 1, mode: torque, torque_constant_nm_a: 2}\n"
		     "  - {name: hip, bus: s1, id: 1, mode: torque, torque_constant_nm_a: 2}\n");
	wait_for(&p,
		 "<3>rmdd: s0: no node acknowledges (the motors' power is off: an e-stop?): no "
		 "frame that acts on a motor is written to it; its motors are lost, and each "
		 "moves again only after it answered, echoed 0x80 and 0x78 and its 0xB3 "
		 "(docs/faults.md \"E-stop\")",
		 5000);
	wait_for(&p, "<5>rmdd: s0: the frames it still held are dropped (up to ", 5000);
	wait_for(&p,
		 "<3>rmdd: s1: the frames it holds could not be dropped (Operation not "
		 "permitted): up to ",
		 5000);
	wait_for(&p,
		 ", written before the bus was found unacknowledged, go out when power returns (no "
		 "motor was driven); stop rmdd before power returns (its transport's queue goes "
		 "with it) (docs/faults.md \"E-stop\")",
		 5000);
	wait_for(&p, "<4>rmdd: s0: motor 1 (knee): lost", 5000);
	wait_for(&p, "<5>rmdd: s0: error active again", 5000);
	wait_for(&p, "<5>rmdd: s0: motor 1 (knee): back (lost -> stopping)", 5000);
	wait_for(&p, "<5>rmdd: s1: motor 1 (hip): back (lost -> stopping)", 5000);
	stop_ok(&p);
	assert_int_equal(count_of(p.out, "no node acknowledges"), 2);
}

/*
 * Motors missing at bring-up, found later, whose firmware is V4: a v3
 * entry and a `protocol: auto` one (taken for V3).  Each is left out
 * with a warning that says what to set; the run goes on.
 */
static void test_found_late_other_dialect(void **state)
{
	static struct proc p;

	(void)state;
	spawn_config(&p, "late.yaml",
		     "probe: {on_missing: start}\n"
		     "buses:\n"
		     "  - name: s0\n"
		     "    type: sim\n"
		     "    sim:\n"
		     "      faults:\n"
		     "        - {kind: disappear, motor: 2, start_s: 0, end_s: 1.0}\n"
		     "        - {kind: disappear, motor: 3, start_s: 0, end_s: 1.0}\n"
		     "motors:\n"
		     "  - {name: a, bus: s0, id: 1, mode: torque, torque_constant_nm_a: 2}\n"
		     "  - {name: knee, bus: s0, id: 2, mode: torque, torque_constant_nm_a: 2,"
		     " sim: {firmware: v4}}\n"
		     "  - {name: hip, bus: s0, id: 3, protocol: auto, mode: torque,"
		     " torque_constant_nm_a: 2, sim: {firmware: v4}}\n");
	wait_for(&p,
		 "<4>rmdd: s0: motor 2 (knee): answered at last: its firmware 2025070202 is v4, "
		 "but its protocol is v3; left out (set protocol: v4, or auto)",
		 5000);
	wait_for(&p,
		 "<4>rmdd: s0: motor 3 (hip): answered at last: its firmware 2025070202 is v4, "
		 "but with protocol: auto a motor missing at bring-up is taken for v3",
		 5000);
	stop_ok(&p);
	assert_null(strstr(p.out, "(knee): back"));
	assert_null(strstr(p.out, "(hip): back"));
}

/*
 * Started at SCHED_FIFO, as CPUSchedulingPolicy=fifo does: only the rt loop
 * and the LCM bridge (one below it, lcm.rt_priority's default) are
 * real-time; main, the monitor and the incident writer inherit nothing.
 */
static void test_started_fifo_only_the_loop_stays(void **state)
{
	static struct proc p;
	struct spawn_opts so = { .fifo_prio = 40 };
	int st;

	(void)state;
	spawn(&p, &so, SIM3);
	while (!p.eof && !strstr(p.out, "running:"))
		pump(&p, 5000);
	if (p.eof) {
		st = finish(&p, 1000);
		if (st == EXIT_NO_CAPS) {
			fprintf(stderr, "SKIP: cannot start a process at SCHED_FIFO here\n");
			skip();
		}
		fail_msg("rmdd exited (%d):\n%s", st, p.out);
	}
	assert_int_equal(sched_getscheduler(p.pid), SCHED_OTHER);
	assert_int_equal(fifo_threads(p.pid, 0), 2); /* memq://: LCM starts no thread */
	assert_int_equal(fifo_threads(p.pid, 40), 1);
	assert_int_equal(fifo_threads(p.pid, 39), 1);
	stop_ok(&p);
}

/* ---- systemd ------------------------------------------------------------------- */

struct notify {
	int fd;
	char path[300];
};

static void notify_open(struct notify *n, const char *name)
{
	struct sockaddr_un sa = { .sun_family = AF_UNIX };

	snprintf(n->path, sizeof(n->path), "%s/%s", tmpdir, name);
	unlink(n->path);
	n->fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
	assert_true(n->fd >= 0);
	assert_true(strlen(n->path) < sizeof(sa.sun_path));
	strcpy(sa.sun_path, n->path);
	assert_int_equal(bind(n->fd, (struct sockaddr *)&sa, sizeof(sa)), 0);
}

static void notify_close(struct notify *n)
{
	close(n->fd);
	unlink(n->path);
}

/* One datagram within timeout_ms into buf (NUL-terminated); false on timeout. */
static bool notify_recv(struct notify *n, char *buf, size_t len, int timeout_ms)
{
	struct pollfd pfd = { .fd = n->fd, .events = POLLIN };
	ssize_t r;

	if (timeout_ms < 0 || poll(&pfd, 1, timeout_ms) <= 0)
		return false;
	r = recv(n->fd, buf, len - 1, 0);
	if (r < 0)
		return false;
	buf[r] = '\0';
	return true;
}

/* Count the datagrams with `what` (and those with STATUS=) in the next ms; keep the last STATUS. */
static unsigned notify_count(struct notify *n, struct proc *p, int ms, const char *what,
			     unsigned *statuses, char *last_status, size_t len)
{
	int64_t end = now_ms() + ms;
	unsigned count = 0;
	char buf[1024];

	if (statuses)
		*statuses = 0;
	for (int64_t left; (left = end - now_ms()) > 0;) {
		/* keep the daemon's pipe drained, it must never block on stderr */
		pump(p, 0);
		if (!notify_recv(n, buf, sizeof(buf), left > 50 ? 50 : (int)left))
			continue;
		if (strstr(buf, what))
			count++;
		if (strstr(buf, "STATUS=")) {
			if (statuses)
				(*statuses)++;
			if (last_status)
				snprintf(last_status, len, "%s", strstr(buf, "STATUS="));
		}
	}
	return count;
}

static void test_notify_ready_watchdog_and_stall(void **state)
{
	static struct proc p;
	struct notify n;
	struct spawn_opts so = {
		.watchdog_usec = "200000", /* pings every 100 ms */
		.stall_ms = "1200",
	};
	char buf[1024], status[1024] = "";
	unsigned pings, statuses;
	int64_t t_ready;

	(void)state;
	notify_open(&n, "notify-wd");
	so.notify_socket = n.path;
	spawn(&p, &so, SIM3);
	/* READY=1 with a STATUS= summary comes first */
	assert_true(notify_recv(&n, buf, sizeof(buf), 5000));
	t_ready = now_ms();
	if (!strstr(buf, "READY=1"))
		fail_msg("first notification is not READY=1: %s", buf);
	assert_non_null(strstr(buf, "STATUS=3 motors: enabled 0, ready 3"));

	/* the loop runs: WATCHDOG=1 about every 100 ms, STATUS= every second */
	pings = notify_count(&n, &p, 900, "WATCHDOG=1", &statuses, status, sizeof(status));
	if (pings < 4)
		fail_msg("%u WATCHDOG=1 in 900 ms, expected about 9", pings);

	/* the loop stops at 1200 ms; give the last ping of its cycles until 1500 ms */
	notify_count(&n, &p, (int)(t_ready + 1500 - now_ms()), "WATCHDOG=1", NULL, NULL, 0);
	pings = notify_count(&n, &p, 1800, "WATCHDOG=1", &statuses, status, sizeof(status));
	if (pings)
		fail_msg("%u WATCHDOG=1 after the loop stalled; output:\n%s", pings, p.out);
	/* the main thread is alive and says why */
	assert_true(statuses >= 1);
	if (!strstr(status, "LOOP STALLED"))
		fail_msg("last status does not tell of the stall: %s", status);
	wait_for(&p, "<3>rmdd: rt loop: no cycle completed", 2000);
	expect_in(&p, "the systemd watchdog is no longer fed");

	stop_ok(&p);
	notify_close(&n);
}

static void test_notify_without_watchdog(void **state)
{
	static struct proc p;
	struct notify n;
	struct spawn_opts so = { 0 };
	char buf[1024];
	unsigned pings, statuses;
	bool stopping = false;

	(void)state;
	notify_open(&n, "notify-nowd");
	so.notify_socket = n.path;
	/* WATCHDOG_PID names another process: the watchdog is not ours */
	so.watchdog_usec = "200000";
	so.watchdog_pid = "1";
	spawn(&p, &so, SIM3);
	assert_true(notify_recv(&n, buf, sizeof(buf), 5000));
	assert_non_null(strstr(buf, "READY=1"));
	pings = notify_count(&n, &p, 1300, "WATCHDOG=1", &statuses, NULL, 0);
	assert_int_equal(pings, 0);
	assert_true(statuses >= 1);
	kill(p.pid, SIGTERM);
	while (notify_recv(&n, buf, sizeof(buf), 3000))
		if (strstr(buf, "STOPPING=1"))
			stopping = true;
	assert_true(stopping);
	assert_int_equal(finish(&p, 5000), 0);
	notify_close(&n);
}

/* ---- real-time privileges -------------------------------------------------------- */

static void test_no_rt_warns_once_and_runs(void **state)
{
	static struct proc p;
	struct spawn_opts so = { .no_rt = true };

	(void)state;
	spawn(&p, &so, SIM3);
	while (!p.eof && !strstr(p.out, "running:"))
		pump(&p, 5000);
	if (p.eof) {
		int st = finish(&p, 1000);

		if (st == EXIT_NO_CAPS) {
			fprintf(stderr, "SKIP: cannot drop CAP_SYS_NICE/CAP_IPC_LOCK here (%s)\n",
				strerror(EPERM));
			skip();
		}
		fail_msg("rmdd exited (%d) without the rt privilege:\n%s", st, p.out);
	}
	wait_for(&p, "<4>rmdd: no real-time priority: SCHED_FIFO refused", 2000);
	expect_in(&p, "Give the user rtprio 49 in /etc/security/limits.d/");
	if (!MLOCK_IS_NOOP) {
		wait_for(&p, "<4>rmdd: no memory lock: mlockall failed", 2000);
		expect_in(&p, "Give the user memlock unlimited in /etc/security/limits.d/");
		assert_int_equal(count_of(p.out, "no memory lock"), 1);
	}
	assert_false(has_fifo_thread(p.pid, 40));
	stop_ok(&p);
	assert_int_equal(count_of(p.out, "no real-time priority"), 1);
}

static void test_require_rt_refuses(void **state)
{
	static struct proc p;
	struct spawn_opts so = { .no_rt = true };
	static const char *const args[] = { "--sim",	    "3", "--lcm-url", "memq://",
					    "--require-rt", NULL };
	int st;

	(void)state;
	spawn(&p, &so, args);
	st = finish(&p, 10000);
	if (st == EXIT_NO_CAPS) {
		fprintf(stderr, "SKIP: cannot drop CAP_SYS_NICE/CAP_IPC_LOCK here\n");
		skip();
	}
	assert_int_equal(st, 1);
	/* mlockall comes first (before bring-up), so it is the one named */
	expect_in(&p, MLOCK_IS_NOOP ? "<3>rmdd: --require-rt: SCHED_FIFO priority 40" :
				      "<3>rmdd: --require-rt: mlockall refused");
	expect_in(&p, "LimitMEMLOCK=infinity");
	assert_null(strstr(p.out, "running:"));
}

/* ---- hostile input (issue 10, defects 6, 7, 8) ------------------------------------ */

/*
 * The installed rmdd has no test hook: RMDD_TEST_STALL_AFTER_MS in its
 * environment does nothing, and the name is not in the binary.  Before, it
 * stopped the rt loop of the production daemon.
 */
static void test_no_stall_hook_in_rmdd(void **state)
{
	static struct proc p;
	static char bin[64 << 20]; /* rmdd, sanitizer builds included */
	struct spawn_opts so = { .env_extra = "RMDD_TEST_STALL_AFTER_MS=100" };
	FILE *f;
	size_t n;

	(void)state;
	f = fopen(rmdd, "rb");
	assert_non_null(f);
	n = fread(bin, 1, sizeof(bin), f);
	fclose(f);
	assert_true(n > 0 && n < sizeof(bin));
	if (memmem(bin, n, "RMDD_TEST_STALL_AFTER_MS", 24))
		fail_msg("%s holds the test hook RMDD_TEST_STALL_AFTER_MS", rmdd);
	spawn_running(&p, &so, SIM3);
	for (int64_t end = now_ms() + 600; now_ms() < end;)
		pump(&p, 50);
	if (strstr(p.out, "test hook"))
		fail_msg("the installed rmdd ran the test hook:\n%s", p.out);
	stop_ok(&p);
}

/* rmdd-test's hook takes 1..86400000 ms; before, 2^63 - 1 overflowed. */
static void test_stall_hook_bounds(void **state)
{
	static const char *const bad[] = { "9223372036854775807", "9223372036854776", "-5", "0",
					   "12abc" };
	static struct proc p;

	(void)state;
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		struct spawn_opts so = { .stall_ms = bad[i] };
		char want[128];
		int st;

		spawn(&p, &so, SIM3);
		st = finish(&p, 5000);
		snprintf(want, sizeof(want),
			 "RMDD_TEST_STALL_AFTER_MS=\"%s\": expected 1..86400000", bad[i]);
		if (st != 2 || !strstr(p.out, want))
			fail_msg("RMDD_TEST_STALL_AFTER_MS=%s: exit %d, output:\n%s", bad[i], st,
				 p.out);
	}
}

/*
 * A CPU in loop.cpu_affinity that does not exist: --check-config refuses it
 * and the daemon names it.  Before, --check-config passed and the daemon
 * said "no real-time guarantees ... run as root", false on both counts.
 */
static void test_cpu_affinity_missing(void **state)
{
	static struct proc p;
	char path[512];
	/* argv[0]: --check-config, then --config */
	const char *argv[] = { "--check-config", path, "--lcm-url", "memq://", NULL };

	(void)state;
	snprintf(path, sizeof(path), "%s/cpu.yaml", tmpdir);
	write_file(path, "loop:\n  cpu_affinity: [0, 1023]\nbuses: [{name: s0, type: sim}]\n"
			 "motors: [{name: a, bus: s0, id: 1, mode: torque, "
			 "torque_constant_nm_a: 2}]\n");
	assert_int_equal(run(&p, argv), 1);
	expect_in(&p, "cpu.yaml: loop.cpu_affinity: CPU 1023 does not exist on this machine, or "
		      "rmdd may not use it (it may use CPUs 0");
	argv[0] = "--config";
	assert_int_equal(run(&p, argv), 1);
	expect_in(&p, "<3>rmdd: ");
	expect_in(&p, "loop.cpu_affinity: CPU 1023 does not exist on this machine");
	assert_null(strstr(p.out, "run as root"));
	assert_null(strstr(p.out, "running:"));
}

/*
 * Issue 21: the LCM URL is --lcm-url, else the file's lcm.url, else
 * $LCM_DEFAULT_URL (as LCM's own tools), else the default.
 */
static void test_lcm_default_url(void **state)
{
	static const char *const sim1[] = { "--sim", "1", NULL };
	struct spawn_opts so = { .env_extra = "LCM_DEFAULT_URL=memq://" };
	static struct proc p;
	static char path[512];
	static const char *const file[] = { "--config", path, NULL };

	(void)state;
	/* no file: the environment's URL */
	spawn(&p, &so, sim1);
	wait_for(&p, "; LCM memq://, channels", 5000);
	stop_ok(&p);
	/* a file that writes lcm.url: the file's (memq:// with a query LCM ignores) */
	so.env_extra = "LCM_DEFAULT_URL=udpm://239.255.76.67:7667?ttl=0";
	config_file(path, "url.yaml",
		    "lcm: {url: \"memq://?from=file\"}\nbuses: [{name: s0, type: sim}]\n"
		    "motors: [{name: a, bus: s0, id: 1, mode: torque, torque_constant_nm_a: 2}]\n");
	spawn(&p, &so, file);
	wait_for(&p, "; LCM memq://?from=file, channels", 5000);
	stop_ok(&p);
}

/* --check-config of a FIFO or a directory: refused by name at once (a FIFO blocked). */
static void test_check_config_special_files(void **state)
{
	static const char *const expect[] = { "fifo.yaml: is a FIFO, not a regular file",
					      ": is a directory, not a regular file" };
	static struct proc p;
	char fifo[512];
	const char *check[] = { "--check-config", NULL, NULL };

	(void)state;
	snprintf(fifo, sizeof(fifo), "%s/fifo.yaml", tmpdir);
	unlink(fifo);
	assert_int_equal(mkfifo(fifo, 0600), 0);
	for (int i = 0; i < 2; i++) {
		check[1] = i ? tmpdir : fifo;
		assert_int_equal(run(&p, check), 1);
		expect_in(&p, expect[i]);
	}
	unlink(fifo);
}

/*
 * Issue 13: a V2 motor (no 0xB3) is driven only with comm_loss_ms: 0 in the
 * file: --check-config refuses it otherwise, naming the motor and the key
 * to write, and takes it with the key.
 */
static void test_check_config_v2_protection(void **state)
{
	static const char head[] = "buses: [{name: s0, type: sim}]\n"
				   "motors: [{name: grip, bus: s0, id: 1, protocol: v2, "
				   "mode: torque, torque_constant_nm_a: 2";
	static struct proc p;
	char path[512], yaml[512];
	const char *argv[] = { "--check-config", path, NULL };

	(void)state;
	snprintf(path, sizeof(path), "%s/v2.yaml", tmpdir);
	snprintf(yaml, sizeof(yaml), "%s}]\n", head);
	write_file(path, yaml);
	assert_int_equal(run(&p, argv), 1);
	expect_in(&p, "v2.yaml:2: motors[0].comm_loss_ms: motor grip is V2, which has no "
		      "comm-loss protection (no 0xB3 in the V2 manual): rmdd drives it only with "
		      "the protection off explicitly; write comm_loss_ms: 0 in its entry");
	snprintf(yaml, sizeof(yaml), "%s, comm_loss_ms: 0}]\n", head);
	write_file(path, yaml);
	assert_int_equal(run(&p, argv), 0);
	assert_null(strstr(p.out, "comm_loss_ms"));
}

/*
 * Issue 33.5: MIT on V4 firmware, its scaling the firmware's.  The
 * bring-up report says the scaling chosen per motor and why: an X6 on
 * V4.4 firmware its own, a V4.2 motor found by protocol: auto the preset,
 * V3 firmware of protocol: mit the V3 preset.
 */
static void test_mit_scaling_reported(void **state)
{
	static struct proc p;

	(void)state;
	spawn_config(&p, "mit.yaml",
		     "buses: [{name: s0, type: sim}]\n"
		     "motors:\n"
		     "  - {name: x6, bus: s0, id: 1, protocol: v4, mode: mit,"
		     " sim: {version_date: 2026042402, model: X6S2V3}}\n"
		     "  - {name: knee, bus: s0, id: 2, protocol: auto, mode: mit,"
		     " sim: {firmware: v4}}\n"
		     "  - {name: hip, bus: s0, id: 3, protocol: mit, mode: mit}\n");
	stop_ok(&p);
	expect_in(&p,
		  "(x6): X6S2V3, firmware 2026042402, 48.0 V, 25 °C, MIT scaling p ±12.566 rad, "
		  "v ±45 rad/s, t ±60 N·m, kp 0..500, kd 0..50: its firmware's own (V4.4 X6, "
		  "from firmware 2026042402)");
	expect_in(&p, "(knee): X8S2V10, firmware 2025070202, 48.0 V, 25 °C, protocol auto: v4, MIT "
		      "scaling p ±12.5 rad, v ±45 rad/s, t ±24 N·m, kp 0..500, kd 0..5: the V4.2 "
		      "§5.1 preset (no mit ranges in its entry; firmware before 2026042402)");
	expect_in(&p, "(hip): X8S2V10, firmware 20220206, 48.0 V, 25 °C, MIT scaling p ±12.5 rad, "
		      "v ±45 rad/s, t ±24 N·m, kp 0..500, kd 0..5: the V3 §5.1 preset");
}

/*
 * Issue 32 point 17: a V4.4 X6 whose 0xB2 answers come 20 ms late (its
 * three tries given up) is asked once more, waiting the whole
 * probe.reply_timeout_ms: its date read, its MIT scaling the firmware's,
 * and the report says it was asked again.  (Before: brought up with date
 * 0, its MIT refused.)  A motor that never answers 0xB2 is said to have
 * been asked again.
 */
static void test_late_date_asked_again(void **state)
{
	static struct proc p;

	(void)state;
	spawn_config(
		&p, "late-date.yaml",
		"buses:\n"
		"  - {name: s0, type: sim, sim: {faults: [{kind: delay, motor: 1, "
		"probability: 1, delay_us: 20000, cmd: 0xB2, count: 3}]}}\n"
		"motors:\n"
		"  - {name: x6, bus: s0, id: 1, protocol: v4, mode: mit,"
		" sim: {version_date: 2026042402, model: X6S2V3}}\n"
		"  - {name: mute, bus: s0, id: 2, protocol: v4, mode: torque, torque_constant_nm_a: 2,"
		" sim: {ignores_cmd: 0xB2}}\n");
	stop_ok(&p);
	expect_in(&p, "(x6): X6S2V3, firmware 2026042402 (its 0xB2 answered only when asked "
		      "again, waiting up to 100 ms: probe.reply_timeout_ms), 48.0 V, 25 °C, MIT "
		      "scaling p ±12.566 rad, v ±45 rad/s, t ±60 N·m, kp 0..500, kd 0..50: its "
		      "firmware's own (V4.4 X6, from firmware 2026042402)");
	expect_in(&p, "(mute): X8S2V10, no answer to 0xB2 (asked again, waiting 100 ms: "
		      "probe.reply_timeout_ms), 48.0 V");
}

/*
 * MIT whose scaling cannot be decided is refused at bring-up (exit 1),
 * naming firmware date and model and what to write: a model with no V4.4
 * scaling, an entry that contradicts the firmware's (both values), and
 * protocol: mit (V3 firmware) on a V4 motor, which keeps mode mit.
 */
static void test_mit_scaling_refused(void **state)
{
	static struct proc p;

	(void)state;
	refused(&p, "mit-bad.yaml",
		"buses: [{name: s0, type: sim}]\n"
		"motors:\n"
		"  - {name: x4, bus: s0, id: 1, protocol: v4, mode: mit,"
		" sim: {version_date: 2026042402, model: X4-36}}\n"
		"  - {name: x6, bus: s0, id: 2, protocol: v4, mode: mit,"
		" mit: {t_min: -24, t_max: 24}, sim: {version_date: 2026042402, model: "
		"X6S2V3}}\n"
		"  - {name: old, bus: s0, id: 3, protocol: mit, mode: mit,"
		" sim: {firmware: v4}}\n");
	expect_in(&p, "(x4): X4-36, firmware 2026042402, 48.0 V, 25 °C; refused: MIT refused, its "
		      "scaling unknown: firmware 2026042402, model X4-36; from 2026042402 V4 "
		      "firmware scales MIT by model and rmdd knows X6, X8 only: give its entry all "
		      "ten mit ranges as its firmware scales them (missing: p_min, p_max, v_min, "
		      "v_max, t_min, t_max, kp_min, kp_max, kd_min, kd_max)");
	expect_in(&p,
		  "(x6): X6S2V3, firmware 2026042402, 48.0 V, 25 °C; refused: MIT refused: its "
		  "entry's mit t_min -24 contradicts its firmware's -60 (V4.4 X6, from firmware "
		  "2026042402; this one: firmware 2026042402, model X6S2V3): set t_min: -60 or "
		  "leave it out");
	expect_in(&p, "(old): X8S2V10, firmware 2025070202, 48.0 V, 25 °C; refused: its firmware "
		      "2025070202 is v4, but its protocol is mit (set protocol: v4, or auto, and "
		      "keep mode: mit)");
	assert_null(strstr(p.out, "running:"));
}

/*
 * --check-config cannot read the firmware: it says what each firmware of
 * the motor's dialect would make of its entry.
 */
static void test_check_config_mit(void **state)
{
	static struct proc p;
	char path[512];
	const char *argv[] = { "--check-config", path, NULL };

	(void)state;
	config_file(path, "mit-check.yaml",
		    "buses: [{name: s0, type: sim}]\n"
		    "motors: [{name: x6, bus: s0, id: 1, protocol: v4, mode: mit}]\n");
	assert_int_equal(run(&p, argv), 0);
	expect_in(&p, "MIT scaling, decided at bring-up from each motor's firmware date (0xB2) and "
		      "model (0xB5)");
	expect_in(&p, "x6: no mit ranges in its entry; v4 firmware before 2026042402: the preset p "
		      "±12.5 rad, v ±45 rad/s, t ±24 N·m, kp 0..500, kd 0..5; from firmware "
		      "2026042402, X6: p ±12.566 rad, v ±45 rad/s, t ±60 N·m, kp 0..500, kd 0..50, "
		      "the firmware's");
	expect_in(&p, "other models of such firmware, or no firmware date: refused at bring-up");
}

/*
 * Issue 31 point 5: --check-config warns of a geared motor in mode position
 * or mit that will be position uncertain after every power cycle (no count
 * kept, travel band not narrower than one rotor turn at the output, the
 * reading's step included), naming the motor and the fixes; and the daemon
 * on the same file (its simulated motors keep no count unless the entry
 * says so) decides the same: uncertain where it warned, certain where not.
 */
struct geared_row {
	const char *entry; /* the motor's keys after name, bus, id */
	const char *warn;  /* in --check-config's output; NULL: no warning */
	const char *trust; /* the daemon's bring-up line for knee; NULL: not run */
};

#define UNCERTAIN "(knee): position uncertain: its travel band is not narrower than one rotor turn"

static const struct geared_row geared_rows[] = {
	/* 1:9, nothing said: 40 deg per rotor turn, no band */
	{ "mode: position, gear_ratio: 9",
	  "geared.yaml:2: motors[0]: warning: knee (mode position, gear_ratio 9) will be position "
	  "uncertain after every power cycle: one rotor turn is 40 deg at the output, and its "
	  "travel band (no travel_rad, no position limits) is not narrower",
	  UNCERTAIN },
	/* 34 deg of travel: under 40 deg with V3's 1 deg step either way */
	{ "mode: position, gear_ratio: 9, travel_rad: [-0.3, 0.3]", NULL,
	  "(knee): position certain: one position in its travel band fits" },
	/* 39 deg of travel: under 40 deg, but not with the reading's step */
	{ "mode: position, gear_ratio: 9, travel_rad: [-0.34, 0.34]",
	  "knee (mode position, gear_ratio 9) will be position uncertain", UNCERTAIN },
	/* the position limits are the band without travel_rad */
	{ "mode: position, gear_ratio: 9, limits: {position_min_rad: -1, position_max_rad: 1}",
	  "and its travel band (its position limits) is not narrower", UNCERTAIN },
	{ "mode: position, gear_ratio: 9, multi_turn_saved: true", NULL,
	  "(knee): position certain: the motor keeps its multi-turn count" },
	{ "mode: mit, gear_ratio: 9", "knee (mode mit, gear_ratio 9) will be position uncertain",
	  UNCERTAIN },
	/* torque and speed never need the position: no warning */
	{ "mode: torque, gear_ratio: 9", NULL, NULL },
	/* direct drive: the brief's point is geared joints */
	{ "mode: position", NULL, NULL },
	/* limits written in degrees (two output turns and more) */
	{ "mode: torque, limits: {position_min_rad: -90, position_max_rad: 90}",
	  "geared.yaml:2: motors[0].limits.position_max_rad: warning: knee: 90 rad is 14.3 output "
	  "turns from zero: if degrees were meant, write 1.5708",
	  NULL },
	{ "mode: torque, travel_rad: [0, 180], gear_ratio: 1",
	  "motors[0].travel_rad: warning: knee: 180 rad is 28.6 output turns", NULL },
	/* 12 rad (under 4 pi) is a joint's travel in rad, and a motor keeping its count may turn */
	{ "mode: torque, limits: {position_min_rad: -12, position_max_rad: 12}", NULL, NULL },
	{ "mode: torque, multi_turn_saved: true, limits: {position_min_rad: -90, "
	  "position_max_rad: 90}",
	  NULL, NULL },
};

static void test_check_config_geared(void **state)
{
	static struct proc p;
	char path[512], yaml[1024];
	const char *argv[] = { "--check-config", path, NULL };

	(void)state;
	for (size_t k = 0; k < sizeof(geared_rows) / sizeof(geared_rows[0]); k++) {
		const struct geared_row *r = &geared_rows[k];

		snprintf(yaml, sizeof(yaml),
			 "buses: [{name: s0, type: sim}]\n"
			 "motors: [{name: knee, bus: s0, id: 1, torque_constant_nm_a: 2, %s}]\n",
			 r->entry);
		config_file(path, "geared.yaml", yaml);
		assert_int_equal(run(&p, argv), 0); /* a warning, not an error */
		if (r->warn) {
			expect_in(&p, r->warn);
			if (strstr(r->warn, "uncertain"))
				expect_in(&p,
					  "Fix: travel_rad: [min, max] narrower than 40 deg (360 / "
					  "gear_ratio, less the reading's step), or "
					  "multi_turn_saved: true if its firmware saves the count "
					  "(0x20 index 4, V3 §2.33.4), or home it at each start "
					  "(rmd.home_t, the Python client's home()");
		} else if (strstr(p.out, "warning")) {
			fail_msg("row %zu (%s): no warning expected:\n%s", k, r->entry, p.out);
		}
		if (!r->trust)
			continue;
		spawn_config(&p, "geared.yaml", yaml);
		wait_for(&p, r->trust, 5000);
		stop_ok(&p);
	}
}

/* ---- set-up ----------------------------------------------------------------------- */

static int setup(void **state)
{
	(void)state;
	/* a daemon that outlives a failed test must not keep a pipe of ours */
	signal(SIGPIPE, SIG_IGN);
	snprintf(tmpdir, sizeof(tmpdir), "/tmp/test_rmdd.XXXXXX");
	if (find_prog(rmdd, sizeof(rmdd), "RMDD", "rmdd") < 0 ||
	    find_prog(rmdd_test, sizeof(rmdd_test), "RMDD_TEST", "rmdd-test") < 0 ||
	    !mkdtemp(tmpdir))
		return -1;
	return 0;
}

/* After each test: no daemon outlives it, whatever failed. */
static int reap(void **state)
{
	(void)state;
	if (live_pid > 0) {
		kill(live_pid, SIGKILL);
		waitpid(live_pid, NULL, 0);
		live_pid = 0;
	}
	return 0;
}

static int teardown(void **state)
{
	(void)state;
	return rm_tree(tmpdir);
}

/* ---- issue 13: comm-loss protection -------------------------------------------- */

/*
 * rmdd's configuration for these tests, at tmpdir/name: three motors a, b,
 * c on sim bus s0 with the given probe.on_missing and sim fault; c_extra
 * goes into motor c's entry.
 */
static void write_cl_config(char *path, size_t len, const char *name, const char *on_missing,
			    const char *fault, const char *c_extra)
{
	char text[1024];

	snprintf(path, len, "%s/%s", tmpdir, name);
	snprintf(text, sizeof(text),
		 "probe: {on_missing: %s}\n"
		 "buses: [{name: s0, type: sim, sim: {faults: [%s]}}]\n"
		 "motors:\n"
		 "  - {name: a, bus: s0, id: 1, mode: torque, torque_constant_nm_a: 2}\n"
		 "  - {name: b, bus: s0, id: 2, mode: torque, torque_constant_nm_a: 2}\n"
		 "  - {name: c, bus: s0, id: 3, mode: torque, torque_constant_nm_a: 2%s}\n",
		 on_missing, fault, c_extra);
	write_file(path, text);
}

/*
 * The reproducer: motor 1's frames are dropped from 5 ms to 300 ms,
 * so its 0xB3 answer at bring-up is lost.  probe.on_missing refuse: exit 1,
 * naming the motor and why; start: it is armed once it answers, and the
 * exit line says every motor's protection stays set.
 */
static void test_comm_loss_reproducer(void **state)
{
	static const char drop[] = "{kind: drop, motor: 1, probability: 1, start_s: 0.005, "
				   "end_s: 0.3}";
	static struct proc p;
	char path[512];
	const char *args[] = { "--config", path, "--lcm-url", "memq://", "-v", NULL };

	(void)state;
	write_cl_config(path, sizeof(path), "cl-refuse.yaml", "refuse", drop, "");
	assert_int_equal(run(&p, args), 1);
	expect_in(&p,
		  "<4>rmdd:   s0: comm-loss protection (0xB3) 100 ms: motor 1 (a) did not "
		  "answer 0xB3: it cannot be enabled until it does; 2 3 (2 set, echo verified)");
	expect_in(&p, "0 motor(s) missing, 1 without comm-loss protection (0xB3 not set), and "
		      "probe.on_missing is refuse");
	assert_null(strstr(p.out, "running:"));

	write_cl_config(path, sizeof(path), "cl-start.yaml", "start", drop, "");
	spawn_running(&p, NULL, args);
	wait_for(&p,
		 "<6>rmdd: s0: motor 1 (a): comm-loss protection (0xB3) 100 ms set, echo "
		 "verified",
		 5000);
	stop_ok(&p);
	expect_in(&p, "every motor was sent stop (0x80); their comm-loss protection (0xB3) stays "
		      "set");
}

/*
 * The exit line names exactly the motors whose protection is set: motor 1
 * never answers 0xB3 (the sim drops those answers, command 179 = 0xB3),
 * motor 3's is off by its own key.
 */
static void test_comm_loss_exit_line(void **state)
{
	static struct proc p;
	char path[512];
	const char *args[] = { "--config", path, "--lcm-url", "memq://", "-v", NULL };

	(void)state;
	write_cl_config(path, sizeof(path), "cl-exit.yaml", "start",
			"{kind: drop, motor: 1, probability: 1, cmd: 179}", ", comm_loss_ms: 0");
	spawn_running(&p, NULL, args);
	stop_ok(&p);
	expect_in(&p, "motor 3 (c) off (its comm_loss_ms: 0);");
	expect_in(&p, "<5>rmdd: every motor was sent stop (0x80); comm-loss protection (0xB3) "
		      "stays set on b; not set on a (did not answer 0xB3), c (off by config)\n");
	assert_null(strstr(p.out, "their comm-loss protection (0xB3) stays set"));
}

/* ---- issue 12: version, usage errors, plain logs off journald, -q, the LCM error --------- */

/* --version and -V: "rmdd VERSION", the version the build gave every program. */
static void test_version(void **state)
{
	static const char *const longv[] = { "--version", NULL }, *const shortv[] = { "-V", NULL };
	static struct proc p;
	char ver[128], want[160];

	(void)state;
	snprintf(want, sizeof(want), "rmdd %s\n", built_version(ver, sizeof(ver)));
	assert_int_equal(run(&p, longv), 0);
	assert_string_equal(p.out, want);
	assert_int_equal(run(&p, shortv), 0);
	assert_string_equal(p.out, want);
}

/* A usage error: one line (a suggestion for a near miss), the usage line, "see --help". */
static void test_usage_error_is_short(void **state)
{
	static const char *const cases[][5] = {
		{ "--chek-config", "x.yaml", NULL,
		  "rmdd: unknown option \"--chek-config\" (did you mean --check-config?)\n" },
		{ "--sim", "3", "extra", NULL, "rmdd: unexpected argument \"extra\"\n" },
		{ "--config", NULL, NULL, NULL, "rmdd: --config needs a value\n" },
	};
	static struct proc p;

	(void)state;
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		const char *first = cases[i][4] ? cases[i][4] : cases[i][3];

		assert_int_equal(run(&p, cases[i]), 2);
		if (strncmp(p.out, first, strlen(first)))
			fail_msg("expected first \"%s\", got:\n%s", first, p.out);
		expect_in(&p, "\nusage: rmdd [--config FILE | --sim [N] | --check-config FILE] "
			      "[OPTIONS]\nsee `rmdd --help`\n");
		assert_int_equal(count_of(p.out, "\n"), 3);
	}
}

/* Read up to "running:", stop with SIGTERM; the output must hold no "<N>" prefix. */
static void expect_plain_run(struct proc *p, const char *what)
{
	wait_for(p, "rmdd: running: 3 motor(s)", 5000);
	kill(p->pid, SIGTERM);
	assert_int_equal(finish(p, 5000), 0);
	expect_in(p, "rmdd: statistics (exit)");
	for (int level = 0; level <= 7; level++) {
		char tag[8];

		snprintf(tag, sizeof(tag), "<%d>", level);
		if (strstr(p->out, tag))
			fail_msg("%s: a %s prefix off journald:\n%s", what, tag, p->out);
	}
}

static void no_journal(const void *ctx)
{
	(void)ctx;
	unsetenv("JOURNAL_STREAM");
}

/*
 * <N> prefixes only when journald reads stderr (JOURNAL_STREAM = its
 * device:inode; the other tests run so): plain on a pipe, on a pipe whose
 * JOURNAL_STREAM names another stream, and on a terminal.
 */
static void test_log_plain_off_journald(void **state)
{
	static struct proc p;
	struct spawn_opts so = { .plain_log = true };

	(void)state;
	spawn(&p, &so, SIM3);
	expect_plain_run(&p, "a pipe");

	so.env_extra = "JOURNAL_STREAM=1:1";
	spawn(&p, &so, SIM3);
	expect_plain_run(&p, "a pipe, JOURNAL_STREAM of another stream");

	memset(&p, 0, sizeof(p));
	p.pid = spawn_pty(rmdd, SIM3, &p.fd, no_journal, NULL);
	live_pid = p.pid;
	expect_plain_run(&p, "a terminal");

	/* and with journald: the levels */
	spawn(&p, NULL, SIM3);
	wait_for(&p, "<5>rmdd: running: 3 motor(s)", 5000);
	stop_ok(&p);
	expect_in(&p, "<6>rmdd: statistics (exit)");
}

/* -q: only warnings and errors; the exit statistics are info, so they go too. */
static void test_quiet_is_quiet(void **state)
{
	static const char *const args[] = { "--sim", "3", "--lcm-url", "memq://", "-q", NULL };
	static struct proc p;
	struct notify n;
	struct spawn_opts so = { 0 };
	char buf[1024];

	(void)state;
	notify_open(&n, "notify-quiet");
	so.notify_socket = n.path;
	spawn(&p, &so, args);
	assert_true(notify_recv(&n, buf, sizeof(buf), 5000));
	assert_non_null(strstr(buf, "READY=1"));
	stop_ok(&p);
	notify_close(&n);
	for (int level = 5; level <= 7; level++) {
		char tag[8];

		snprintf(tag, sizeof(tag), "<%d>", level);
		if (strstr(p.out, tag))
			fail_msg("-q printed a %s line:\n%s", tag, p.out);
	}
	assert_null(strstr(p.out, "statistics"));
}

/* An LCM URL that cannot be created: one clean line, the URL as given, no doubled prefix. */
static void test_lcm_error_is_clean(void **state)
{
	static const char *const args[] = { "--sim", "3", "--lcm-url", "udpm://300.1.1.1:7667",
					    NULL };
	static struct proc p;

	(void)state;
	assert_int_equal(run(&p, args), 1);
	expect_in(&p, "<3>rmdd: LCM: cannot create \"udpm://300.1.1.1:7667\": a bad URL, or "
		      "multicast has no route");
	assert_int_equal(count_of(p.out, "LCM:"), 1);
	assert_null(strstr(p.out, "recv_buf_size"));
	assert_null(strstr(p.out, "running:"));
}

/* A directory given as --config (not only --check-config) is named as one. */
static void test_config_directory(void **state)
{
	static struct proc p;
	const char *args[] = { "--config", tmpdir, "--lcm-url", "memq://", NULL };

	(void)state;
	assert_int_equal(run(&p, args), 1);
	expect_in(&p, ": is a directory, not a regular file");
	assert_null(strstr(p.out, "syntax error"));
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test_teardown(test_usage_errors, reap),
		cmocka_unit_test_teardown(test_no_default_config, reap),
		cmocka_unit_test_teardown(test_bad_config, reap),
		cmocka_unit_test_teardown(test_infeasible_plan, reap),
		cmocka_unit_test_teardown(test_bus_error_names_the_bus, reap),
		cmocka_unit_test_teardown(test_missing_motor_refused, reap),
		cmocka_unit_test_teardown(test_sigterm, reap),
		cmocka_unit_test_teardown(test_cpus_kept_awake, reap),
		cmocka_unit_test_teardown(test_sigint, reap),
		cmocka_unit_test_teardown(test_sigusr1_and_sighup_keep_running, reap),
		cmocka_unit_test_teardown(test_lost_motor_logged_with_context, reap),
		cmocka_unit_test_teardown(test_estop_logged, reap),
		cmocka_unit_test_teardown(test_short_power_cycle_logged, reap),
		cmocka_unit_test_teardown(test_found_late_other_dialect, reap),
		cmocka_unit_test_teardown(test_started_fifo_only_the_loop_stays, reap),
		cmocka_unit_test_teardown(test_notify_ready_watchdog_and_stall, reap),
		cmocka_unit_test_teardown(test_notify_without_watchdog, reap),
		cmocka_unit_test_teardown(test_no_rt_warns_once_and_runs, reap),
		cmocka_unit_test_teardown(test_require_rt_refuses, reap),
		cmocka_unit_test_teardown(test_no_stall_hook_in_rmdd, reap),
		cmocka_unit_test_teardown(test_stall_hook_bounds, reap),
		cmocka_unit_test_teardown(test_cpu_affinity_missing, reap),
		cmocka_unit_test_teardown(test_lcm_default_url, reap),
		cmocka_unit_test_teardown(test_check_config_special_files, reap),
		cmocka_unit_test_teardown(test_comm_loss_reproducer, reap),
		cmocka_unit_test_teardown(test_comm_loss_exit_line, reap),
		cmocka_unit_test_teardown(test_version, reap),
		cmocka_unit_test_teardown(test_usage_error_is_short, reap),
		cmocka_unit_test_teardown(test_log_plain_off_journald, reap),
		cmocka_unit_test_teardown(test_quiet_is_quiet, reap),
		cmocka_unit_test_teardown(test_lcm_error_is_clean, reap),
		cmocka_unit_test_teardown(test_config_directory, reap),
		cmocka_unit_test_teardown(test_check_config_v2_protection, reap),
		cmocka_unit_test_teardown(test_mit_scaling_reported, reap),
		cmocka_unit_test_teardown(test_late_date_asked_again, reap),
		cmocka_unit_test_teardown(test_mit_scaling_refused, reap),
		cmocka_unit_test_teardown(test_check_config_mit, reap),
		cmocka_unit_test_teardown(test_check_config_geared, reap),
	};

	if (getenv("RMD_TEST_FILTER")) /* e.g. RMD_TEST_FILTER=test_cpu_affinity_missing */
		cmocka_set_test_filter(getenv("RMD_TEST_FILTER"));
	return cmocka_run_group_tests_name("rmdd", tests, setup, teardown);
}

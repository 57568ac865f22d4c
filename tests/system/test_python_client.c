// SPDX-License-Identifier: MIT
/*
 * The Python client (python/rmd/client.py, installed with `pip install
 * ./python`) against a real `rmdd --sim 3` over LCM on loopback: the Python
 * half is tests/system/python_client.py, run by the venv's Python that
 * `make python-venv` makes (build/venv: the package installed as users
 * install it, not the checkout).  This suite starts rmdd, runs the script,
 * listens to RMD_COMMAND, RMD_STATE and RMD_HEALTH itself and checks:
 *   - track: the client enables motor1, the measured position reaches two
 *     targets, leaving the `with` block sends enable = 0 and motor1 ends
 *     READY; its seq starts at 0 and never goes back, no command is
 *     rejected (a NaN setpoint is a ValueError in set(), never sent), and
 *     the watchdog has nothing to trip afterwards;
 *   - trip: after the client goes quiet rmdd's watchdog latches the safe
 *     action (LC_SAFE); the next spin() raises MotorStopped naming the
 *     watchdog, later spins do not re-enable motor1 and set() refuses it;
 *     enable() brings motor1 back (enable = 0 seen before enable = 1), it
 *     tracks again and ends READY;
 *   - absent: without rmdd, connect() raises RmdError naming the URL;
 *   - pause: with state_t every 50 ms, pauses 30 ms shorter than the
 *     command timeout keep motor1 ENABLED (the send() after one goes out
 *     at once), a pause of four timeouts trips the watchdog and the next
 *     spin() says so, naming the silence.
 *
 * The Python is $RMD_PYTHON, else BUILD/venv/bin/python3 or build/venv
 * (also found beside this binary); without one that imports rmd.Client,
 * or without multicast on loopback (routed here when root, as
 * tests/harness/lcm_loopback.h does), every test skips loudly.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <limits.h>
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

#include <sys/prctl.h>
#include <sys/wait.h>

#include <cmocka.h>
#include <lcm/lcm.h>

#include "harness/lcm_loopback.h"
#include "harness/proc.h"
#include "rmd/rmd_command_t.h"
#include "rmd/rmd_health_t.h"
#include "rmd/rmd_state_t.h"

#define SIM_MOTORS "3"
#define SCRIPT_TIMEOUT_S 30
#define COMMAND_TIMEOUT_MS 100 /* rmdd --sim's safety.command_timeout_ms */

static char rmdd_bin[PATH_MAX], python[PATH_MAX], script[PATH_MAX], tmpdir[64];
static bool no_multicast, have_python;
static unsigned test_no;

struct fixture {
	char url[96];
	char rmdd_log[128], py_log[128], rmdd2_log[128];
	pid_t rmdd, py, rmdd2; /* rmdd2: a second daemon (--force) */
	lcm_t *lcm;
	lcm_subscription_t *sub;

	/* what the client sent, as rmdd heard it */
	unsigned n_cmds, seq_back;
	int64_t first_seq, last_seq;
	int last_enable0; /* motor 0's enable in the newest command: -1 none */
	/* what rmdd said */
	int lifecycle0; /* motor 0, newest state_t; -1 none */
	int watchdog;	/* the newest health_t's */
	int64_t safe_action_events, commands_rejected;
	unsigned n_health;
};

static double mono_s(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

/* A whole (small) file, NUL-terminated; "" when unreadable.  Static buffer. */
static const char *log_text(const char *path)
{
	static char text[64 * 1024];

	return file_text(path, text, sizeof(text));
}

/* ---- LCM: what the client sends and rmdd answers -------------------------------------------- */

static void heard_command(struct fixture *f, const rmd_command_t *msg)
{
	if (f->n_cmds == 0)
		f->first_seq = msg->seq;
	else if (msg->seq < f->last_seq)
		f->seq_back++;
	f->last_seq = msg->seq;
	f->n_cmds++;
	f->last_enable0 = -1;
	for (int i = 0; i < msg->count && i < RMD_COMMAND_T_MAX_MOTORS; i++)
		if (msg->motor[i].index == 0)
			f->last_enable0 = msg->motor[i].enable;
}

/* RMD_COMMAND, RMD_STATE and RMD_HEALTH: one raw subscription, decoded here. */
static void on_message(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
	struct fixture *f = user;
	union {
		rmd_command_t cmd;
		rmd_state_t state;
		rmd_health_t health;
	} m;

	if (!strcmp(channel, "RMD_COMMAND") &&
	    rmd_command_t_decode(rbuf->data, 0, (int)rbuf->data_size, &m.cmd) >= 0) {
		heard_command(f, &m.cmd);
		rmd_command_t_decode_cleanup(&m.cmd);
	} else if (!strcmp(channel, "RMD_STATE") &&
		   rmd_state_t_decode(rbuf->data, 0, (int)rbuf->data_size, &m.state) >= 0) {
		f->lifecycle0 = m.state.count > 0 ? m.state.motor[0].lifecycle : -1;
		rmd_state_t_decode_cleanup(&m.state);
	} else if (!strcmp(channel, "RMD_HEALTH") &&
		   rmd_health_t_decode(rbuf->data, 0, (int)rbuf->data_size, &m.health) >= 0) {
		f->watchdog = m.health.watchdog;
		f->safe_action_events = m.health.safe_action_events;
		f->commands_rejected = m.health.commands_rejected;
		f->n_health++;
		rmd_health_t_decode_cleanup(&m.health);
	}
}

/* Handle LCM for `s` seconds, or until *done (when given) holds. */
static void listen_for(struct fixture *f, double s, const bool *done)
{
	double end = mono_s() + s;

	while (mono_s() < end && !(done && *done))
		lcm_handle_timeout(f->lcm, 10);
}

/* ---- processes --------------------------------------------------------------------------- */

/*
 * argv[0] (a path) with stdout and stderr to `log`; it dies with this suite.
 * PYTHONPATH and LCM_DEFAULT_URL are unset (group_setup did).
 */
static pid_t start(const char *const *argv, const char *log)
{
	pid_t pid = fork();

	if (pid < 0)
		fail_msg("fork: %s", strerror(errno));
	if (pid > 0)
		return pid;
	prctl(PR_SET_PDEATHSIG, SIGKILL);
	if (!freopen(log, "w", stdout) || dup2(fileno(stdout), 2) < 0)
		_exit(126);
	execv(argv[0], (char *const *)argv);
	fprintf(stderr, "%s: %s\n", argv[0], strerror(errno));
	_exit(127);
}

/* The exit status (128 + signal when killed) of *pid within `s` seconds, listening meanwhile; -1 if it runs on. */
static int reap(struct fixture *f, pid_t *pid, double s)
{
	double end = mono_s() + s;
	int ws;

	while (*pid > 0) {
		pid_t r = waitpid(*pid, &ws, WNOHANG);

		if (r == *pid) {
			*pid = 0;
			return WIFEXITED(ws) ? WEXITSTATUS(ws) : 128 + WTERMSIG(ws);
		}
		if (r < 0 || mono_s() >= end)
			return -1;
		if (f && f->lcm)
			lcm_handle_timeout(f->lcm, 5);
		else
			usleep(5000);
	}
	return -1;
}

static void end_child(pid_t *pid, int sig)
{
	if (*pid <= 0)
		return;
	kill(*pid, sig);
	if (reap(NULL, pid, 5) < 0 && *pid > 0) {
		kill(*pid, SIGKILL);
		reap(NULL, pid, 5);
	}
}

/* ---- set-up ------------------------------------------------------------------------------- */

/* The first of `cands` (NULL-terminated) that passes access(mode), into out. */
static bool pick(char *out, const char *const *cands, int mode)
{
	for (; *cands; cands++)
		if ((*cands)[0] && access(*cands, mode) == 0)
			return snprintf(out, PATH_MAX, "%s", *cands) > 0;
	return false;
}

static int group_setup(void **state)
{
	const char *build = getenv("BUILD"), *env_py = getenv("RMD_PYTHON"),
		   *env_rmdd = getenv("RMDD");
	char exe[PATH_MAX] = "", c[6][PATH_MAX + 64], cmd[3 * PATH_MAX];
	ssize_t n;

	(void)state;
	if (!build || !*build)
		build = "build";
	snprintf(c[0], sizeof(c[0]), "%s", env_rmdd ? env_rmdd : "");
	snprintf(c[1], sizeof(c[1]), "%s/rmdd", build);
	if (!pick(rmdd_bin, (const char *const[]){ c[0], c[1], NULL }, X_OK)) {
		fprintf(stderr, "test_python_client: no %s (set RMDD or BUILD)\n", c[1]);
		return -1;
	}
	/* this binary is BUILD/tests/system/test_python_client */
	n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
	exe[n > 0 ? n : 0] = '\0';
	for (int i = 0; i < 3 && strrchr(exe, '/'); i++)
		*strrchr(exe, '/') = '\0';

	snprintf(c[0], sizeof(c[0]), "%s", env_py ? env_py : "");
	snprintf(c[1], sizeof(c[1]), "%s/venv/bin/python3", build);
	snprintf(c[2], sizeof(c[2]), "build/venv/bin/python3");
	snprintf(c[3], sizeof(c[3]), "%s/venv/bin/python3", exe);
	snprintf(c[4], sizeof(c[4]), "%s/../venv/bin/python3", exe); /* build/san */
	have_python =
		pick(python, (const char *const[]){ c[0], c[1], c[2], c[3], c[4], NULL }, X_OK);
	snprintf(c[0], sizeof(c[0]), "tests/system/python_client.py");
	snprintf(c[1], sizeof(c[1]), "%s/../tests/system/python_client.py", exe);
	snprintf(c[2], sizeof(c[2]), "%s/../../tests/system/python_client.py", exe);
	have_python = pick(script, (const char *const[]){ c[0], c[1], c[2], NULL }, R_OK) &&
		      have_python;

	/* the installed package, whatever the caller's environment says */
	unsetenv("PYTHONPATH");
	unsetenv("LCM_DEFAULT_URL");
	unsetenv("NOTIFY_SOCKET");
	if (have_python) {
		snprintf(cmd, sizeof(cmd), "'%s' -c 'import lcm, rmd; rmd.Client' >/dev/null 2>&1",
			 python);
		have_python = system(cmd) == 0;
	}
	snprintf(tmpdir, sizeof(tmpdir), "/tmp/test_python_client.XXXXXX");
	if (!mkdtemp(tmpdir))
		return -1;
	signal(SIGPIPE, SIG_IGN);
	no_multicast = !lcm_loopback_ready("test_python_client");
	if (!have_python)
		fprintf(stderr,
			"\n*** test_python_client: SKIPPING every test: no Python with the rmd "
			"package (%s).\n"
			"*** make python-venv (python3 -m venv build/venv; build/venv/bin/pip "
			"install ./python), or set RMD_PYTHON\n\n",
			python[0] ? python : "no BUILD/venv/bin/python3");
	return 0;
}

static int group_teardown(void **state)
{
	char cmd[128];

	(void)state;
	snprintf(cmd, sizeof(cmd), "rm -rf '%s'", tmpdir);
	return system(cmd) == 0 ? 0 : -1;
}

static int setup(void **state)
{
	struct fixture *f;
	int port;

	*state = NULL;
	if (no_multicast || !have_python)
		return 0;
	f = calloc(1, sizeof(*f));
	assert_non_null(f);
	/* a port per process and test, away from test_lcm_system's 45000.. */
	port = 30000 + (int)(getpid() % 700) * 20 + (int)(test_no++ % 20);
	snprintf(f->url, sizeof(f->url), "udpm://239.255.76.67:%d?ttl=0", port);
	snprintf(f->rmdd_log, sizeof(f->rmdd_log), "%s/rmdd.%u.log", tmpdir, test_no);
	snprintf(f->py_log, sizeof(f->py_log), "%s/python.%u.log", tmpdir, test_no);
	snprintf(f->rmdd2_log, sizeof(f->rmdd2_log), "%s/rmdd2.%u.log", tmpdir, test_no);
	f->lifecycle0 = f->last_enable0 = -1;
	f->lcm = lcm_create(f->url);
	assert_non_null(f->lcm);
	f->sub = lcm_subscribe(f->lcm, "RMD_(COMMAND|STATE|HEALTH)", on_message, f);
	assert_non_null(f->sub);
	*state = f;
	return 0;
}

static int teardown(void **state)
{
	struct fixture *f = *state;

	if (!f)
		return 0;
	end_child(&f->py, SIGKILL);
	end_child(&f->rmdd2, SIGTERM);
	end_child(&f->rmdd, SIGTERM);
	lcm_unsubscribe(f->lcm, f->sub);
	lcm_destroy(f->lcm);
	free(f);
	return 0;
}

/* The fixture, or skip: setup said why, loudly, in group_setup. */
static struct fixture *client_or_skip(void **state)
{
	struct fixture *f = *state;

	if (!f) {
		print_message("skipped: %s\n", no_multicast ? "no multicast on loopback" :
							      "no Python with the rmd package");
		skip();
	}
	return f;
}

/* rmdd (argv) on this test's URL, until its state_t comes (motor 0 READY). */
static void start_rmdd_argv(struct fixture *f, const char *const *argv)
{
	double end = mono_s() + 10;

	f->rmdd = start(argv, f->rmdd_log);
	while (f->lifecycle0 != RMD_STATE_T_LC_READY) {
		int st = reap(f, &f->rmdd, 0.01);

		if (st >= 0)
			fail_msg("rmdd exited (%d) at start; its output:\n%s", st,
				 log_text(f->rmdd_log));
		if (mono_s() >= end)
			fail_msg("rmdd: motor1 not READY on %s within 10 s; its output:\n%s",
				 f->url, log_text(f->rmdd_log));
	}
}

/* rmdd --sim on this test's URL, until its state_t comes (motor 0 READY). */
static void start_rmdd(struct fixture *f)
{
	const char *argv[] = { rmdd_bin, "--sim", SIM_MOTORS, "--lcm-url", f->url, NULL };

	start_rmdd_argv(f, argv);
}

/* python_client.py WHAT URL [ARG] to its end; returns its output (exit 0 checked). */
static const char *run_script_arg(struct fixture *f, const char *what, const char *arg)
{
	const char *argv[] = { python, script, what, f->url, arg, NULL };
	const char *out;
	int st;

	f->py = start(argv, f->py_log);
	st = reap(f, &f->py, SCRIPT_TIMEOUT_S);
	out = log_text(f->py_log);
	if (st != 0) {
		/* whole, before log_text() reuses its buffer (cmocka cuts fail_msg() at 1 kB) */
		printf("python_client.py %s: its output:\n%s\n", what, out);
		fflush(stdout);
		fail_msg("python_client.py %s: %s %d (its output above); rmdd's:\n%s", what,
			 st < 0 ? "still running after" : "exit", st < 0 ? SCRIPT_TIMEOUT_S : st,
			 log_text(f->rmdd_log));
	}
	print_message("python_client.py %s:\n%s", what, out);
	/* the installed package, not the checkout's python/ or build/python */
	if (!strstr(out, "site-packages/rmd/"))
		fail_msg("python_client.py did not run the installed rmd package:\n%s", out);
	return out;
}

static const char *run_script(struct fixture *f, const char *what)
{
	return run_script_arg(f, what, NULL);
}

static unsigned occurrences(const char *s, const char *what)
{
	unsigned n = 0;

	for (; (s = strstr(s, what)); s += strlen(what))
		n++;
	return n;
}

/* After the script: the commands it sent, motor1 READY, and the watchdog quiet. */
static void check_after(struct fixture *f, int64_t safe_actions)
{
	bool ready = false;
	unsigned health_then;

	assert_true(f->n_cmds > 10);
	if (f->first_seq != 0 || f->seq_back)
		fail_msg("seq: first %lld (want 0), went back %u times", (long long)f->first_seq,
			 f->seq_back);
	/* its last command: enable = 0 for motor1 */
	assert_int_equal(f->last_enable0, 0);
	ready = f->lifecycle0 == RMD_STATE_T_LC_READY;
	listen_for(f, 1, &ready);
	assert_int_equal(f->lifecycle0, RMD_STATE_T_LC_READY);
	/* well past the command timeout: nothing enabled, so no (new) safe action */
	listen_for(f, 3 * COMMAND_TIMEOUT_MS / 1000.0, NULL);
	health_then = f->n_health;
	listen_for(f, 0.5, NULL);
	assert_true(f->n_health > health_then);
	assert_int_equal(f->lifecycle0, RMD_STATE_T_LC_READY);
	assert_int_equal(f->commands_rejected, 0);
	assert_int_equal(f->safe_action_events, safe_actions);
	assert_int_not_equal(f->watchdog, RMD_HEALTH_T_WD_TRIPPED);
}

/* ---- tests -------------------------------------------------------------------------------- */

/*
 * rmdd --sim, python_client.py `what`: motor1 enabled `enables` times and
 * tracked both targets, READY at the end, `safe_actions` in health_t.
 */
static const char *enable_and_track(struct fixture *f, const char *what, unsigned enables,
				    int64_t safe_actions)
{
	const char *out;

	start_rmdd(f);
	out = run_script(f, what);
	assert_int_equal(occurrences(out, "enabled: motor1 (index 0)"), enables);
	assert_int_equal(occurrences(out, "tracked: target"), 2);
	assert_non_null(strstr(out, "left: motor1 lifecycle 1"));
	check_after(f, safe_actions);
	return out;
}

static void test_enable_track_and_disable_on_exit(void **state)
{
	const char *out = enable_and_track(client_or_skip(state), "track", 1, 0);

	/* issue 20.12: a NaN setpoint is a ValueError, never sent (check_after: 0 rejected) */
	assert_non_null(strstr(out, "nan: motor1: velocity = nan is not finite"));
}

static void test_enable_after_the_watchdog_tripped(void **state)
{
	struct fixture *f = client_or_skip(state);

	const char *out = enable_and_track(f, "trip", 2, 1);

	assert_non_null(strstr(out, "tripped: motor1 is safe"));
	/* enable() of another motor meanwhile: motor1's stop waits for the next send() */
	assert_non_null(strstr(out, "enabled: motor2 beside the stopped motor1"));
	/* issue 20.12: the next spin() says so, and nothing re-enables motor1 */
	assert_non_null(strstr(out, "stopped: motors stopped: motor1 is safe: rmdd's watchdog "
				    "tripped"));
	assert_non_null(strstr(out, "set after the trip: motor1: not enabled by this client "
				    "(safe: enable() it again)"));
	/*
	 * rmdd saw enable = 0 before the second enable = 1: the client sends it
	 * from the trip on (safe -> stopping -> ready), then enable() enables
	 */
	{
		const char *log = log_text(f->rmdd_log), *left = strstr(log, "(motor1): safe -> ");

		if (!left || !strstr(left, "(motor1): enabled"))
			fail_msg("want motor1 to leave SAFE, then be enabled, in rmdd's log:\n%s",
				 log);
	}
}

/*
 * A controller's pauses shorter than the command timeout (a garbage
 * collection, a slow plot) with state_t every 50 ms: the send() after one
 * goes out at once and motor1 stays ENABLED.  Before, it first waited up
 * to 100 ms for a fresh state_t, and that wait lengthened a 60 ms pause
 * into a trip (CI: examples/sine.py in the VM, "sent nothing for 125 ms").
 * A pause of four timeouts trips the watchdog: the next spin() raises
 * MotorStopped naming it and the whole silence, nothing re-enables motor1.
 */
static void test_pauses_shorter_than_the_timeout(void **state)
{
	struct fixture *f = client_or_skip(state);
	char cfg[PATH_MAX], timeout[16];
	const char *argv[] = { rmdd_bin, "--config", cfg, "--lcm-url", f->url, NULL };
	const char *out, *said;
	unsigned busy;
	double silence_ms = 0;
	FILE *o;

	snprintf(cfg, sizeof(cfg), "%s/pause.yaml", tmpdir);
	o = fopen(cfg, "w");
	assert_non_null(o);
	fprintf(o,
		"loop: {rate_hz: 100}\n"
		"safety: {command_timeout_ms: %d}\n"
		"lcm: {state_every_n: 5}\n"
		"incidents: {enabled: false}\n"
		"buses: [{name: s0, type: sim}]\n"
		"motors:\n"
		"  - {name: motor1, bus: s0, id: 1, mode: position, torque_constant_nm_a: 2, "
		"multi_turn_saved: true}\n"
		"  - {name: motor2, bus: s0, id: 2, mode: position, torque_constant_nm_a: 2, "
		"multi_turn_saved: true}\n",
		COMMAND_TIMEOUT_MS);
	assert_int_equal(fclose(o), 0);
	start_rmdd_argv(f, argv);
	snprintf(timeout, sizeof(timeout), "%d", COMMAND_TIMEOUT_MS);
	out = run_script_arg(f, "pause", timeout);
	assert_has(out, "pauses: ", "python_client.py pause");
	said = strstr(out, "long pause: motors stopped: motor1 is safe: rmdd's watchdog tripped "
			   "(this client sent nothing for ");
	if (!said || sscanf(strstr(said, "for ") + 4, "%lf", &silence_ms) != 1)
		fail_msg("want the long pause's MotorStopped naming the watchdog in:\n%s", out);
	/* the silence said is the pause's, not the time since the send after it */
	if (silence_ms < 4 * COMMAND_TIMEOUT_MS)
		fail_msg("MotorStopped says %.0f ms of silence after a pause of %d ms:\n%s",
			 silence_ms, 4 * COMMAND_TIMEOUT_MS, out);
	assert_non_null(strstr(out, "left: motor1 lifecycle 1"));
	/* one trip, the long pause's, and one more for each pause the machine held too long */
	busy = occurrences(out, "busy machine:");
	check_after(f, 1 + (int64_t)busy);
}

static void test_no_rmdd_is_a_clear_error(void **state)
{
	struct fixture *f = client_or_skip(state);
	const char *out = run_script(f, "absent");
	char want[160];

	snprintf(want, sizeof(want), "is rmdd running, with --lcm-url %s and prefix RMD_?", f->url);
	if (!strstr(out, "no rmd.config_t on RMD_CONFIG within 1 s: ") || !strstr(out, want))
		fail_msg("want \"%s\" in:\n%s", want, out);
}

/*
 * Issue 13: rmd.Client identifies itself (command_t.controller, random per
 * client); a second client is rejected while the first owns the motor (its
 * enable() raises NotOwner naming the owner, issue 20.12) and takes it over
 * with takeover = True; the old owner's next send() raises NotOwner.
 */
static void test_second_client_rejected_then_takes_over(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	const char *out;

	start_rmdd(f);
	out = run_script(f, "takeover");
	assert_non_null(strstr(out, "intruder: b rejected while a owns motor1"));
	assert_non_null(strstr(out, "not owner: enable: controller "));
	assert_non_null(strstr(out, "owns the motors (health_t.owner"));
	/* and the old owner's next send() after the takeover */
	assert_non_null(strstr(out, "a told: send: controller "));
	assert_non_null(strstr(out, "takeover: b drives motor1, a is rejected"));
	assert_non_null(strstr(log_text(f->rmdd_log), "takes the motors over from controller"));
}

/*
 * Issue 20.4: a second rmdd on the same URL and prefix (--force): the
 * client raises MixedStreamError naming both daemons' pids, or with
 * allow_mixed keeps the first one's config_t.
 */
static void test_two_daemons_are_a_clear_error(void **state)
{
	struct fixture *f = client_or_skip(state);
	const char *argv[] = { rmdd_bin, "--sim", "2", "--lcm-url", f->url, "--force", NULL };
	char pid1[32], pid2[32];
	const char *out;
	double end;

	start_rmdd(f);
	f->rmdd2 = start(argv, f->rmdd2_log);
	for (end = mono_s() + 10; !strstr(log_text(f->rmdd2_log), "running:");) {
		if (reap(f, &f->rmdd2, 0.05) >= 0 || mono_s() >= end)
			fail_msg("the second rmdd (--force) not running; its output:\n%s",
				 log_text(f->rmdd2_log));
	}
	snprintf(pid1, sizeof(pid1), "pid %d", (int)f->rmdd);
	snprintf(pid2, sizeof(pid2), "pid %d", (int)f->rmdd2);
	out = run_script(f, "mixed");
	if (!strstr(out, "mixed: two rmdd publish on") || !strstr(out, pid1) ||
	    !strstr(out, pid2) || !strstr(out, "allow_mixed: kept instance"))
		fail_msg("want MixedStreamError naming %s and %s in:\n%s", pid1, pid2, out);
}

/*
 * Issue 30: two rmdd as one robot (instances left and right, each the
 * other's peer, prefixes LEFT_ and RIGHT_): python_client.py robot opens
 * them as one rmd.Robot (docs/robot.md).
 */
static void test_robot_one_view(void **state)
{
	struct fixture *f = client_or_skip(state);
	static const char *const side[2][2] = { { "left", "right" }, { "right", "left" } };
	char cfg[2][PATH_MAX], log2[2][160];
	const char *out;

	for (int k = 0; k < 2; k++) {
		FILE *o;

		snprintf(cfg[k], sizeof(cfg[k]), "%s/%s.yaml", tmpdir, side[k][0]);
		o = fopen(cfg[k], "w");
		assert_non_null(o);
		fprintf(o,
			"lcm: {channel_prefix: %s_}\n"
			"incidents: {enabled: false}\n"
			"robot: {instance: %s, peers: [%s]}\n"
			"buses: [{name: s0, type: sim}]\n"
			"motors:\n"
			"  - {name: %s_hip, bus: s0, id: 1, mode: torque, torque_constant_nm_a: 2}\n"
			"  - {name: %s_knee, bus: s0, id: 2, mode: torque, torque_constant_nm_a: 2}\n",
			k ? "RIGHT" : "LEFT", side[k][0], side[k][1], side[k][0], side[k][0]);
		assert_int_equal(fclose(o), 0);
		snprintf(log2[k], sizeof(log2[k]), "%s/%s.%u.log", tmpdir, side[k][0], test_no);
	}
	{
		const char *a0[] = { rmdd_bin, "--config", cfg[0], "--lcm-url", f->url, NULL };
		const char *a1[] = { rmdd_bin, "--config", cfg[1], "--lcm-url", f->url, NULL };

		f->rmdd = start(a0, log2[0]);
		f->rmdd2 = start(a1, log2[1]);
	}
	for (double end = mono_s() + 10;
	     !strstr(log_text(log2[0]), "running:") || !strstr(log_text(log2[1]), "running:");) {
		if (reap(f, &f->rmdd, 0.02) >= 0 || reap(f, &f->rmdd2, 0.02) >= 0 ||
		    mono_s() >= end)
			fail_msg("the robot's two rmdd not running:\n%s\n%s", log_text(log2[0]),
				 log_text(log2[1]));
	}
	out = run_script(f, "robot");
	assert_has(out, "robot: every motor ENABLED through one send()", "python_client.py robot");
	assert_has(out, "robot: stop() -> ", "python_client.py robot");
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test_setup_teardown(test_enable_track_and_disable_on_exit, setup,
						teardown),
		cmocka_unit_test_setup_teardown(test_enable_after_the_watchdog_tripped, setup,
						teardown),
		cmocka_unit_test_setup_teardown(test_pauses_shorter_than_the_timeout, setup,
						teardown),
		cmocka_unit_test_setup_teardown(test_no_rmdd_is_a_clear_error, setup, teardown),
		cmocka_unit_test_setup_teardown(test_robot_one_view, setup, teardown),
		cmocka_unit_test_setup_teardown(test_two_daemons_are_a_clear_error, setup,
						teardown),
		cmocka_unit_test_setup_teardown(test_second_client_rejected_then_takes_over, setup,
						teardown),
	};

	return cmocka_run_group_tests_name("python_client", tests, group_setup, group_teardown);
}

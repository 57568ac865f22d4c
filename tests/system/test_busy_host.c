// SPDX-License-Identifier: MIT
/*
 * A developer's machine (issue 31 point 3): `rmdd --sim` as a normal user
 * (no SCHED_FIFO, no mlockall; as root the suite runs it as `nobody`)
 * beside two CPU hogs, with build/sine_controller driving every motor,
 * for RUN_S seconds, and rmdd's whole process stopped (SIGSTOP) for
 * STOP_MS in the middle.  The simulated motors are rmdd's own: the host
 * holding the loop away is not rmdd falling silent (rmd/bus_sim.h "Host
 * gaps"), so no motor may be lost -- judged on every state_t and
 * health_t the test hears, and on rmdd's log.  Before the fix the stop
 * alone tripped every motor's 100 ms comm-loss protection (0xF1: lost).
 *
 * Multicast on loopback must work (else every test skips, loudly).  Every
 * child dies with the test.  RMD_TEST_FILTER=name runs one test.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <limits.h>
#include <pwd.h>
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
#include <sys/stat.h>
#include <sys/wait.h>

#include <cmocka.h>
#include <lcm/lcm.h>

#include "harness/lcm_loopback.h"
#include "harness/proc.h"
#include "harness/suite.h"
#include "rmd/rmd_health_t.h"
#include "rmd/rmd_state_t.h"
#include "rmd/time.h"

#define SUITE "test_busy_host"
#define RUN_S 20       /* the run the issue measured */
#define STOP_MS 300    /* rmdd stopped this long, at STOP_AT_S */
#define STOP_AT_S 10   /* ... into the run */
#define START_MS 30000 /* rmdd's bring-up, on a busy machine */
#define HOGS 2
#define NS_PER_MS INT64_C(1000000)

static char rmdd[PATH_MAX], rmdctl[PATH_MAX], sine[PATH_MAX];
static char dir[] = "/tmp/rmdd-busy-XXXXXX";
static bool multicast;
static pid_t hog[HOGS];

/* What the test heard from rmdd. */
static struct heard {
	unsigned states, driven; /* state_t messages; those with a motor ENABLED */
	unsigned lost;		 /* motors that entered LOST */
	char lost_what[256];	 /* the first such, for the message */
	int8_t lc[RMD_STATE_T_MAX_MOTORS];
	unsigned health;
	double wake_max_us; /* the latest health_t's */
	int64_t overruns;
} heard;

static void on_state(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_state_t *msg,
		     void *user)
{
	bool driven = false;

	(void)rbuf;
	(void)channel;
	(void)user;
	heard.states++;
	for (int i = 0; i < msg->count && i < RMD_STATE_T_MAX_MOTORS; i++) {
		int8_t lc = msg->motor[i].lifecycle;

		if (lc == RMD_STATE_T_LC_LOST && heard.lc[i] != RMD_STATE_T_LC_LOST &&
		    !heard.lost++)
			snprintf(heard.lost_what, sizeof(heard.lost_what),
				 "motor %d LOST in cycle %lld", i, (long long)msg->cycle);
		driven |= lc == RMD_STATE_T_LC_ENABLED;
		heard.lc[i] = lc;
	}
	heard.driven += driven;
}

static void on_health(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_health_t *msg,
		      void *user)
{
	(void)rbuf;
	(void)channel;
	(void)user;
	heard.health++;
	heard.wake_max_us = msg->wake_max_us;
	heard.overruns = msg->overruns;
}

/* A CPU hog that dies with the test. */
static pid_t hog_start(void)
{
	pid_t pid = fork();

	assert_true(pid >= 0);
	if (pid == 0) {
		prctl(PR_SET_PDEATHSIG, SIGKILL);
		for (volatile unsigned long n = 0;; n++)
			;
	}
	return pid;
}

static void hogs_stop(void)
{
	for (unsigned i = 0; i < HOGS; i++) {
		if (hog[i] > 0) {
			kill(hog[i], SIGKILL);
			waitpid(hog[i], NULL, 0);
		}
		hog[i] = 0;
	}
}

static int group_setup(void **state)
{
	(void)state;
	if (lcm_tools_setup(SUITE, rmdd, rmdctl, dir, &multicast) < 0)
		return -1;
	if (find_prog(sine, sizeof(sine), "SINE_CONTROLLER", "sine_controller") < 0)
		return -1;
	/* rmdd as nobody writes its incident recordings here (systemd's StateDirectory=) */
	return chmod(dir, 0777);
}

static int group_teardown(void **state)
{
	hogs_stop();
	return lcm_tools_teardown(state);
}

static int teardown(void **state)
{
	(void)state;
	hogs_stop();
	kid_kill_all();
	return 0;
}

/* Stop rmdd's whole process for ms, timed from when every thread is stopped. */
static int64_t stop_rmdd(pid_t pid, int ms)
{
	struct timespec ts = { .tv_sec = ms / 1000, .tv_nsec = (long)(ms % 1000) * NS_PER_MS };
	int64_t t0;

	assert_int_equal(kill(pid, SIGSTOP), 0);
	if (!pid_wait_stopped(pid, START_MS))
		fail_msg("rmdd not stopped %d ms after SIGSTOP", START_MS);
	t0 = rmd_now_ns();
	nanosleep(&ts, NULL);
	assert_int_equal(kill(pid, SIGCONT), 0);
	return rmd_now_ns() - t0;
}

/*
 * rmdd --sim without real-time privileges beside two CPU hogs, a
 * controller driving, rmdd stopped for STOP_MS once: no motor lost.
 */
static void test_normal_user_beside_hogs(void **state)
{
	char url[128], state_dir[PATH_MAX], uid[32], gid[32];
	const struct passwd *pw = getpwnam("nobody");
	const char *as_user[] = { "setpriv", "--reuid", uid,
				  "--regid", gid,	"--clear-groups",
				  rmdd,	     "--sim",	"--lcm-url",
				  url,	     NULL };
	const char *sine_argv[] = { sine, "--url", url, "--duration", "60", NULL };
	struct kid *k, *ctl;
	rmd_state_t_subscription_t *ss;
	rmd_health_t_subscription_t *hs;
	int64_t t0, end, stopped_ns = 0;
	lcm_t *lcm;
	bool root = geteuid() == 0;

	(void)state;
	if (!multicast)
		skip();
	if (root && !pw)
		fail_msg("running as root and there is no user nobody to run rmdd as");
	memset(&heard, 0, sizeof(heard));
	lcm_test_url(url, sizeof(url), 60100, 100, 0);
	if (pw) {
		snprintf(uid, sizeof(uid), "%u", (unsigned)pw->pw_uid);
		snprintf(gid, sizeof(gid), "%u", (unsigned)pw->pw_gid);
	}
	snprintf(state_dir, sizeof(state_dir), "%s/state", dir);
	for (unsigned i = 0; i < HOGS; i++)
		hog[i] = hog_start();

	setenv("STATE_DIRECTORY", state_dir, 1);
	k = kid_spawn("rmdd", root ? as_user : as_user + 6, NULL, 0);
	unsetenv("STATE_DIRECTORY");
	kid_wait_output(k, "running:", START_MS, NULL);
	/* a normal user's rmdd: no real-time priority (else this test proves nothing); the
	 * rt thread's refusal is said by the main thread, around the running line */
	kid_wait_output(k, "no real-time priority: SCHED_FIFO refused", START_MS, NULL);

	lcm = lcm_create(url);
	assert_non_null(lcm);
	ss = rmd_state_t_subscribe(lcm, "RMD_STATE", on_state, NULL);
	hs = rmd_health_t_subscribe(lcm, "RMD_HEALTH", on_health, NULL);
	rmd_state_t_subscription_set_queue_capacity(ss, LCM_RX_STATES);
	ctl = kid_spawn("sine_controller", sine_argv, NULL, 0);

	t0 = rmd_now_ns();
	end = t0 + RUN_S * INT64_C(1000000000);
	while (rmd_now_ns() < end) {
		lcm_handle_timeout(lcm, 20);
		kid_read(k);
		kid_read(ctl);
		if (!stopped_ns && rmd_now_ns() - t0 >= STOP_AT_S * INT64_C(1000000000))
			stopped_ns = stop_rmdd(k->pid, STOP_MS);
		if (kid_poll_exit(k))
			fail_msg("rmdd exited (status %d):\n%s", k->status, kid_tail(k));
	}
	rmd_state_t_unsubscribe(lcm, ss);
	rmd_health_t_unsubscribe(lcm, hs);
	lcm_destroy(lcm);
	kid_free(ctl);
	kill(k->pid, SIGINT);
	kid_wait_exit(k, START_MS, NULL);
	hogs_stop();

	print_message("busy host: %u state_t (%u with a motor enabled), %u health_t; rmdd stopped "
		      "%.0f ms; its overruns %lld, longest wake-up %.1f ms late\n",
		      heard.states, heard.driven, heard.health, (double)stopped_ns / 1e6,
		      (long long)heard.overruns, heard.wake_max_us / 1e3);
	/* what makes the run a test: rmdd published, the controller drove, the stop was seen */
	if (!heard.states || !heard.health)
		fail_msg("no state_t or health_t from rmdd on %s:\n%s", url, kid_tail(k));
	if (!heard.driven)
		fail_msg("the controller never had a motor ENABLED:\n%s", kid_tail(ctl));
	if (heard.wake_max_us < 0.9 * STOP_MS * 1e3)
		fail_msg("rmdd's health_t says its longest wake-up was %.1f ms late, though it was "
			 "stopped for %.0f ms: the stop went unseen",
			 heard.wake_max_us / 1e3, (double)stopped_ns / 1e6);
	if (heard.lost)
		fail_msg("%u simulated motor(s) lost (the first: %s) beside %d CPU hogs:\n%s",
			 heard.lost, heard.lost_what, HOGS, kid_tail(k));
	assert_lacks(k->out, "treated as lost", "rmdd's log");
	assert_lacks(k->out, "): lost (", "rmdd's log");
}

SUITE_MAIN(SUITE, group_setup, group_teardown,
	   {
		   cmocka_unit_test_teardown(test_normal_user_beside_hogs, teardown),
	   })

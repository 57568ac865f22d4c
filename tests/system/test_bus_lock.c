// SPDX-License-Identifier: MIT
/*
 * One owner per bus (src/tools/common/buslock.h), with real processes: the
 * built rmdd runs on an RS485 bus whose line is a pseudo-terminal the test
 * holds (no motor answers: probe.on_missing start keeps it running), with
 * its lock files in a directory of this test ($RMD_LOCK_DIR).
 *   - while it runs, every rmdctl command that would send on that line
 *     (scan, monitor, status, set-timeout, move, and through a symlink to
 *     the line) refuses with exit 2 and a message naming rmdd's pid and
 *     --force; with --force it talks (nobody answers: exit 1);
 *   - a second rmdd on the same line refuses to start;
 *   - once rmdd has exited (SIGTERM, and after SIGKILL: the kernel drops
 *     the lock), rmdctl talks on the line again without --force.
 */
#define _GNU_SOURCE
#include <fcntl.h>
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
#include <unistd.h>

#include <cmocka.h>

#include "harness/proc.h"
#include "rmd/time.h"

#define LOCK_MS 15000 /* rmdd up with its bus open (sanitizers, a busy machine) */

static char rmdd_bin[PATH_MAX], rmdctl_bin[PATH_MAX];
static char dir[] = "/tmp/test_bus_lock.XXXXXX";
static char cfg[PATH_MAX], link_path[PATH_MAX], lock_path[PATH_MAX], pts[128];
static int master = -1, slave = -1;

static int group_setup(void **state)
{
	char key[128];
	FILE *f;

	(void)state;
	if (find_prog(rmdd_bin, sizeof(rmdd_bin), "RMDD", "rmdd") < 0 ||
	    find_prog(rmdctl_bin, sizeof(rmdctl_bin), "RMDCTL", "rmdctl") < 0 || !mkdtemp(dir))
		return -1;
	master = posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
	if (master < 0 || grantpt(master) < 0 || unlockpt(master) < 0 ||
	    ptsname_r(master, pts, sizeof(pts)) != 0)
		return -1;
	/* held open, never read: the master does not hang up between programs */
	slave = open(pts, O_RDWR | O_NOCTTY | O_CLOEXEC);
	if (slave < 0)
		return -1;
	snprintf(cfg, sizeof(cfg), "%s/rmdd.yaml", dir);
	f = fopen(cfg, "w");
	if (!f)
		return -1;
	fprintf(f,
		"loop: {rate_hz: 250}\n"
		"probe: {on_missing: start}\n"
		"buses:\n"
		"  - {name: rs0, type: rs485, device: %s, baud: 1000000, turnaround_us: 800}\n"
		"motors:\n"
		"  - {name: pan, bus: rs0, id: 1, mode: position, torque_constant_nm_a: 2.0}\n",
		pts);
	fclose(f);
	snprintf(link_path, sizeof(link_path), "%s/ttyRMD", dir);
	if (symlink(pts, link_path) < 0)
		return -1;
	/* the key: the resolved device path, '/' as '_' */
	snprintf(key, sizeof(key), "%s", pts);
	for (char *p = key; *p; p++)
		if (*p == '/')
			*p = '_';
	snprintf(lock_path, sizeof(lock_path), "%s/rmdd-bus-%s.lock", dir, key);
	setenv("RMD_LOCK_DIR", dir, 1);
	unsetenv("NOTIFY_SOCKET");
	unsetenv("RMDCTL_BUS");
	return 0;
}

static int group_teardown(void **state)
{
	(void)state;
	kid_kill_all();
	close_fd(&slave);
	close_fd(&master);
	return rm_tree(dir);
}

static int teardown(void **state)
{
	(void)state;
	kid_kill_all();
	return 0;
}

static struct kid *start_rmdd(const char *name)
{
	const char *argv[] = { rmdd_bin, "--config", cfg, "--lcm-url", "memq://", NULL };

	return kid_spawn(name, argv, NULL, 0);
}

/* The lock file holds pid: rmdd has its bus open and locked. */
static void wait_locked(struct kid *k)
{
	int64_t end = rmd_now_ns() + (int64_t)LOCK_MS * 1000000;
	char want[32], got[32];

	snprintf(want, sizeof(want), "%ld\n", (long)k->pid);
	for (;;) {
		if (!strcmp(file_text(lock_path, got, sizeof(got)), want))
			return;
		if (kid_poll_exit(k) || rmd_now_ns() > end)
			fail_msg("rmdd did not lock %s within %d ms; its output:\n%s", lock_path,
				 LOCK_MS, kid_tail(k));
		kid_read(k);
		usleep(10000);
	}
}

/* Every command that would send on the line refuses while rmdd runs; --force talks. */
static void test_refused_while_rmdd_runs(void **state)
{
	struct kid *rmdd = start_rmdd("rmdd");
	char owner[64];
	struct run_case c[] = {
		{ .args = { "scan", "--bus", pts }, .status = 2 },
		{ .args = { "monitor", "--once", "--bus", pts }, .status = 2 },
		{ .args = { "status", "1", "--bus", pts }, .status = 2 },
		{ .args = { "set-timeout", "1", "100", "--yes", "--bus", pts }, .status = 2 },
		{ .args = { "move", "1", "10", "--yes", "--bus", pts }, .status = 2 },
		{ .args = { "scan", "--bus", link_path }, .status = 2 },
	};
	const struct run_case forced[] = {
		{ .args = { "scan", "1-2", "--force", "--bus", pts },
		  .status = 1,
		  .err_has = { "no motor answered" },
		  .err_lacks = "in use" },
		{ .args = { "status", "1", "--bus", pts, "--force" },
		  .status = 1,
		  .err_has = { "motor 1 did not answer" },
		  .err_lacks = "in use" },
	};

	(void)state;
	wait_locked(rmdd);
	snprintf(owner, sizeof(owner), "is in use by a running rmdd (pid %ld, lock ",
		 (long)rmdd->pid);
	for (size_t i = 0; i < sizeof(c) / sizeof(c[0]); i++) {
		c[i].out_has[0] = "";
		c[i].err_has[0] = owner;
		c[i].err_has[1] = "add --force";
		c[i].err_has[2] = "rmdctl top";
	}
	run_cases(rmdctl_bin, c, sizeof(c) / sizeof(c[0]), NULL);
	run_cases(rmdctl_bin, forced, sizeof(forced) / sizeof(forced[0]), NULL);
	/* rmdd was not disturbed out of its run */
	assert_false(kid_poll_exit(rmdd));
}

/* A second rmdd on the same line does not start. */
static void test_second_rmdd_refused(void **state)
{
	struct kid *first = start_rmdd("rmdd 1"), *second;
	char want[PATH_MAX + 96];

	(void)state;
	wait_locked(first);
	second = start_rmdd("rmdd 2");
	assert_int_equal(kid_wait_exit(second, LOCK_MS, NULL), 1);
	snprintf(want, sizeof(want), "is in use by another rmdd (pid %ld, lock %s)",
		 (long)first->pid, lock_path);
	assert_has(second->out, want, "second rmdd");
	assert_false(kid_poll_exit(first));
}

/* After rmdd: SIGTERM (clean exit) and SIGKILL (the kernel drops the lock) free the line. */
static void test_free_after_rmdd(void **state)
{
	static const int sigs[] = { SIGTERM, SIGKILL };
	const struct run_case c[] = {
		{ .args = { "scan", "1", "--bus", pts },
		  .status = 1,
		  .err_has = { "no motor answered" },
		  .err_lacks = "in use" },
	};

	(void)state;
	for (size_t i = 0; i < sizeof(sigs) / sizeof(sigs[0]); i++) {
		struct kid *rmdd = start_rmdd("rmdd");

		wait_locked(rmdd);
		kill(rmdd->pid, sigs[i]);
		kid_wait_exit(rmdd, LOCK_MS, NULL);
		kid_free(rmdd);
		run_cases(rmdctl_bin, c, 1, NULL);
	}
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test_teardown(test_refused_while_rmdd_runs, teardown),
		cmocka_unit_test_teardown(test_second_rmdd_refused, teardown),
		cmocka_unit_test_teardown(test_free_after_rmdd, teardown),
	};

	return cmocka_run_group_tests_name("bus_lock", tests, group_setup, group_teardown);
}

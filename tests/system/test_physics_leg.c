// SPDX-License-Identifier: MIT
/*
 * The leg of examples/physics/ through the whole chain on rmdd's sim bus
 * (docs/physics.md "The whole loop"): a real rmdd ($RMDD, else
 * $BUILD/rmdd) on examples/physics/leg.yaml as shipped, the example
 * controller build/leg_stand ($LEG_STAND) over LCM on loopback (a URL of
 * its own), and this suite reading state_t (harness/leg.h):
 *   - the standing leg holds its height: the hip's height from the joint
 *     angles and the model's kinematics (examples/physics/leg.h) within
 *     LEG_STAND_TOL_M of the pose's over 2000 states (2 s of the loop),
 *     with the knee's current carrying the weight;
 *   - when the controller dies (SIGKILL) the watchdog's safe action (stop,
 *     leg.yaml) shows in state_t (both motors SAFE, no current in their
 *     replies), and the leg falls: the hip drops LEG_FALL_M, the knee folds.
 * Why the height from the angles: it is what a controller of the real leg
 * knows too, and the sim puts nothing on the wire (or in state_t) that a
 * real leg would not; the foot stays on the floor while it stands and
 * while it falls, so the kinematics hold.
 *
 *   - rmd-view (python/rmd/view.py) poses the leg's model headless into PNG
 *     frames and the picture changes with the joint angle
 *     (tests/system/view_check.py, run by the venv's Python: $RMD_PYTHON,
 *     else BUILD/venv/bin/python3, `make python-venv`; without it, or
 *     without mujoco in it, the test skips, loudly).
 *
 * Multicast on loopback must work (else the test skips, loudly); the
 * physics module is build/lib beside rmdd (else the suite skips, naming it).
 */
#define _GNU_SOURCE
#include <limits.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <sys/stat.h>

#include <cmocka.h>

#include "harness/lcm_loopback.h"
#include "harness/leg.h"
#include "harness/proc.h"
#include "harness/suite.h"

static char rmdd_bin[PATH_MAX], rmdctl_bin[PATH_MAX], leg_bin[PATH_MAX], config[PATH_MAX + 64],
	dir[PATH_MAX] = "/tmp/test_physics_leg.XXXXXX";
static bool multicast, have_module;

static int group_setup(void **state)
{
	const char *src = getenv("RMD_SRCDIR");

	(void)state;
	if (lcm_tools_setup("test_physics_leg", rmdd_bin, rmdctl_bin, dir, &multicast) < 0 ||
	    find_prog(leg_bin, sizeof(leg_bin), "LEG_STAND", "leg_stand") < 0)
		return -1;
	have_module = physics_module_found(rmdd_bin, "test_physics_leg");
	snprintf(config, sizeof(config), "%s/examples/physics/leg.yaml", src && src[0] ? src : ".");
	return access(config, R_OK);
}

static void test_stands_and_falls(void **state)
{
	char url[128];
	const char *argv[] = { rmdd_bin, "--config", config, "--lcm-url", url, NULL };
	struct kid *rmdd;

	(void)state;
	if (!multicast || !have_module)
		skip();
	lcm_test_url(url, sizeof(url), 44100, 20, 0);
	rmdd = kid_spawn("rmdd", argv, NULL, 0);
	leg_stand_and_fall(url, leg_bin, rmdd, 2000, 60000);
	kid_free(rmdd);
}

/* rmd-view headless: tests/system/view_check.py. */
static void test_view_png(void **state)
{
	const char *py_env = getenv("RMD_PYTHON"), *build = getenv("BUILD");
	const char *src = getenv("RMD_SRCDIR");
	char py[PATH_MAX], script[PATH_MAX + 64], work[PATH_MAX + 16];
	const char *probe[] = { "-c", "import mujoco, PIL, lcm, rmd.view", NULL };
	struct run r = { 0 };

	(void)state;
	snprintf(py, sizeof(py), "%s/venv/bin/python3", build && build[0] ? build : "build");
	if (py_env && py_env[0])
		snprintf(py, sizeof(py), "%s", py_env);
	else if (access(py, X_OK)) /* SANITIZE=1: BUILD is build/san, the venv build/venv's */
		snprintf(py, sizeof(py), "build/venv/bin/python3");
	if (access(py, X_OK)) {
		print_message("SKIP: %s: no Python venv (make python-venv)\n", py);
		skip();
	}
	run_prog(&r, py, probe, NULL);
	if (r.status) {
		print_message("SKIP: %s has no mujoco, Pillow or rmd.view (make python-venv: "
			      "'./python[view]'): %s\n",
			      py, r.err);
		run_free(&r);
		skip();
	}
	run_free(&r);
	if (!src || !src[0])
		src = ".";
	snprintf(script, sizeof(script), "%s/tests/system/view_check.py", src);
	snprintf(work, sizeof(work), "%s/view", dir);
	assert_int_equal(mkdir(work, 0755), 0);
	{
		const char *args[] = { script, src, work, NULL };

		run_prog(&r, py, args,
			 &(struct run_opts){ .unset_env = "DISPLAY", .limit_ms = 300000 });
	}
	print_message("%s%s", r.out, r.err);
	assert_int_equal(r.status, 0);
	assert_has(r.out, "view_check: ok", "view_check.py");
	run_free(&r);
}

SUITE_MAIN("physics_leg", group_setup, lcm_tools_teardown,
	   {
		   cmocka_unit_test(test_stands_and_falls),
		   cmocka_unit_test(test_view_png),
	   })

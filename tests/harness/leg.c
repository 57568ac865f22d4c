// SPDX-License-Identifier: MIT
/* The leg of examples/physics/ judged through state_t (harness/leg.h). */
#define _GNU_SOURCE
#include <limits.h>
#include <math.h>
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
#include <lcm/lcm.h>

#include "../../examples/physics/leg.h"
#include "harness/leg.h"
#include "rmd/rmd_state_t.h"
#include "rmd/time.h"

bool physics_module_found(const char *rmdd, const char *suite)
{
	char path[PATH_MAX + 32];
	const char *slash = strrchr(rmdd, '/');

	snprintf(path, sizeof(path), "%.*s/lib/rmd-physics.so", slash ? (int)(slash - rmdd) : 1,
		 slash ? rmdd : ".");
	if (access(path, R_OK) == 0 || getenv("RMD_PHYSICS_MODULE"))
		return true;
	fprintf(stderr, "%s: no physics module (%s): built without MuJoCo; skipping\n", suite,
		path);
	return false;
}

enum { HIP, KNEE, N_JOINTS };

/* What state_t said last, and extremes over the current window. */
static struct {
	lcm_t *lcm;
	struct kid *rmdd, *ctl;
	unsigned long n;
	int lc[N_JOINTS];
	double pos[N_JOINTS], current[N_JOINTS];
	double h_min, h_max, knee_min, cur_max[N_JOINTS];
	rmd_state_t_subscription_t *sub;
} L;

static void window_reset(void)
{
	L.h_min = INFINITY;
	L.h_max = -INFINITY;
	L.knee_min = INFINITY;
	L.cur_max[HIP] = L.cur_max[KNEE] = 0.0;
}

static void on_state(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_state_t *s,
		     void *user)
{
	double h;

	(void)rbuf;
	(void)channel;
	(void)user;
	/* leg.yaml and leg-vcan.yaml: hip is motor 0, knee motor 1 */
	if (s->count < N_JOINTS)
		return;
	for (int j = 0; j < N_JOINTS; j++) {
		L.lc[j] = s->motor[j].lifecycle;
		L.pos[j] = s->motor[j].position;
		L.current[j] = s->motor[j].current;
		if (fabs(L.current[j]) > L.cur_max[j])
			L.cur_max[j] = fabs(L.current[j]);
	}
	h = leg_height_m(L.pos[HIP], L.pos[KNEE]);
	L.h_min = fmin(L.h_min, h);
	L.h_max = fmax(L.h_max, h);
	L.knee_min = fmin(L.knee_min, L.pos[KNEE]);
	L.n++;
}

bool (*leg_busy)(char *why, size_t size);

/* A failed judgement: fail, or skip when leg_busy says the machine was too busy to judge. */
static void __attribute__((format(printf, 1, 2))) leg_fail(const char *fmt, ...)
{
	char msg[4096], why[512];
	va_list ap;

	va_start(ap, fmt);
	vsnprintf(msg, sizeof(msg), fmt, ap);
	va_end(ap);
	if (leg_busy && leg_busy(why, sizeof(why))) {
		print_message("(what failed: %s)\n", msg);
		kid_free(L.ctl);
		rmd_state_t_unsubscribe(L.lcm, L.sub);
		lcm_destroy(L.lcm);
		memset(&L, 0, sizeof(L));
		print_message("busy machine: %s: not judged\n", why);
		skip();
	}
	fail_msg("%s", msg);
}

/* LCM for up to ms, and the children's output; an rmdd that exits fails the test. */
static void service(int ms)
{
	lcm_handle_timeout(L.lcm, ms);
	while (lcm_handle_timeout(L.lcm, 0) > 0)
		;
	kid_read(L.rmdd);
	if (L.ctl)
		kid_read(L.ctl);
	if (kid_poll_exit(L.rmdd))
		fail_msg("rmdd exited (%d); its output:\n%s", L.rmdd->status, kid_tail(L.rmdd));
}

/* n more states, at most ms. */
static void states(unsigned long n, int ms, const char *what)
{
	unsigned long want = L.n + n;
	int64_t end = rmd_now_ns() + (int64_t)ms * RMD_NS_PER_MS;

	while (L.n < want) {
		if (rmd_now_ns() > end)
			leg_fail("%s: %lu of %lu state_t within %d ms", what, n - (want - L.n), n,
				 ms);
		service(10);
	}
}

static const char *describe(char *buf, size_t len)
{
	snprintf(buf, len,
		 "height %.3f..%.3f m, hip %+.3f knee %+.3f rad (knee down to %+.3f), "
		 "lifecycles %d %d, |current| up to %.2f %.2f A",
		 L.h_min, L.h_max, L.pos[HIP], L.pos[KNEE], L.knee_min, L.lc[HIP], L.lc[KNEE],
		 L.cur_max[HIP], L.cur_max[KNEE]);
	return buf;
}

void leg_stand_and_fall(const char *url, const char *leg_stand, struct kid *rmdd,
			unsigned stand_states, int wait_ms)
{
	const char *argv[] = { leg_stand, "--url", url, NULL };
	char what[512];
	double knee_stood, h_stood;
	int64_t end;

	memset(&L, 0, sizeof(L));
	L.rmdd = rmdd;
	L.lcm = lcm_create(url);
	assert_non_null(L.lcm);
	L.sub = rmd_state_t_subscribe(L.lcm, "RMD_STATE", on_state, NULL);
	assert_non_null(L.sub);
	states(10, wait_ms, "rmdd's first states");

	/* stands: the height over stand_states states, the motors enabled, the knee loaded */
	L.ctl = kid_spawn("leg_stand", argv, NULL, 0);
	end = rmd_now_ns() + (int64_t)wait_ms * RMD_NS_PER_MS;
	while (!strstr(L.ctl->out, "leg_stand: standing\n")) {
		if (kid_poll_exit(L.ctl) || rmd_now_ns() > end)
			leg_fail("leg_stand: no \"standing\" within %d ms (%s); its output:\n%s",
				 wait_ms, L.ctl->reaped ? "it exited" : "it runs on",
				 kid_tail(L.ctl));
		service(10);
	}
	window_reset();
	states(stand_states, wait_ms, "standing");
	print_message("standing over %u states: %s\n", stand_states, describe(what, sizeof(what)));
	if (L.h_min < LEG_STAND_M - LEG_STAND_TOL_M || L.h_max > LEG_STAND_M + LEG_STAND_TOL_M)
		leg_fail("the leg did not hold %.3f +- %.3f m: %s; leg_stand:\n%s", LEG_STAND_M,
			 LEG_STAND_TOL_M, what, kid_tail(L.ctl));
	if (L.lc[HIP] != RMD_STATE_T_LC_ENABLED || L.lc[KNEE] != RMD_STATE_T_LC_ENABLED)
		leg_fail("standing, but the motors are not ENABLED: %s", what);
	/* about 3 N·m on the knee at 2.6 N·m/A: the model's weight is on the motor */
	if (L.cur_max[KNEE] < 0.3)
		leg_fail("the knee carries no weight: %s", what);
	knee_stood = L.pos[KNEE];
	h_stood = leg_height_m(L.pos[HIP], L.pos[KNEE]);

	/* the controller dies: the watchdog's safe action (stop), then gravity */
	kill(L.ctl->pid, SIGKILL);
	end = rmd_now_ns() + (int64_t)wait_ms * RMD_NS_PER_MS;
	while (L.lc[HIP] != RMD_STATE_T_LC_SAFE || L.lc[KNEE] != RMD_STATE_T_LC_SAFE) {
		if (rmd_now_ns() > end)
			leg_fail("leg_stand killed, but the motors did not go SAFE within %d ms: "
				 "%s; rmdd:\n%s",
				 wait_ms, describe(what, sizeof(what)), kid_tail(rmdd));
		service(10);
	}
	window_reset();
	/*
	 * A second of rmdd's cycles (leg.yaml: 1 kHz) with the output off; the
	 * currents from the replies after the first 50 (the cycles that sent
	 * the safe action may still carry a reply from before it).
	 */
	states(50, wait_ms, "falling");
	L.cur_max[HIP] = L.cur_max[KNEE] = 0.0;
	states(950, wait_ms, "falling");
	print_message("after the safe action, 1000 states: %s\n", describe(what, sizeof(what)));
	/* the motors' replies: output off (0x80), no current; SAFE still */
	if (L.cur_max[HIP] > 0.05 || L.cur_max[KNEE] > 0.05)
		leg_fail("the safe action (stop) left current in the motors: %s", what);
	if (L.lc[HIP] != RMD_STATE_T_LC_SAFE || L.lc[KNEE] != RMD_STATE_T_LC_SAFE)
		leg_fail("the motors left SAFE with no controller: %s", what);
	if (L.h_min > h_stood - LEG_FALL_M || L.knee_min > knee_stood - 0.3)
		leg_fail("the leg did not fall (from %.3f m, knee %+.3f rad): %s", h_stood,
			 knee_stood, what);
	kid_free(L.ctl);
	L.ctl = NULL;
	rmd_state_t_unsubscribe(L.lcm, L.sub);
	lcm_destroy(L.lcm);
}

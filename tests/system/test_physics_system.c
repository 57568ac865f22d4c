// SPDX-License-Identifier: MIT
/*
 * The physics behind rmdd's sim bus, through the whole chain: a real rmdd
 * process ($RMDD, else $BUILD/rmdd, else build/rmdd) runs a configuration
 * whose sim.physics puts its one motor on the hinge of
 * tests/data/physics/pendulum.xml (copied beside the configuration, so the
 * relative model path is resolved against the file's folder), and the test
 * judges what rmdd publishes: state_t over LCM on loopback, a URL of its
 * own.
 *   - released at 60 deg with the output off, the period of the swing in
 *     state_t (positions from 0x92 at 0.01 deg, stamped with their
 *     receive times: the sim bus's time) matches the large-angle formula
 *     within 2 %;
 *   - a configuration whose joint the model lacks: rmdd exits at start
 *     with FILE:LINE: key and the model's joints, before any bus is opened.
 *
 * The physics runs in the sim bus's time (CLOCK_MONOTONIC, stepped lazily
 * to each frame's time), so a busy machine delays the replies but not the
 * swing they sample.  Multicast on loopback must work (else every test
 * skips, loudly); the physics module is build/lib beside rmdd (else the
 * suite skips, naming it).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <setjmp.h>
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

#include "harness/lcm_loopback.h"
#include "harness/leg.h"
#include "harness/pendulum.h"
#include "harness/proc.h"
#include "harness/suite.h"
#include "rmd/rmd_state_t.h"
#include "rmd/time.h"

#define G 9.81
#define MASS 1.0
#define LEN 0.5
#define I_TOTAL (MASS * LEN * LEN + 1e-4 + 0.001) /* bob, its own, the motor's armature */
#define SAMPLES 8192

static char rmdd_bin[PATH_MAX], rmdctl_bin[PATH_MAX], dir[PATH_MAX] = "/tmp/test_physics.XXXXXX";
static bool multicast, have_module;
static unsigned test_no;

/* The pendulum's configuration: line numbers matter to the error test. */
static const char config_fmt[] =
	"loop: {rate_hz: 1000}\n"
	"safety: {comm_loss_ms: 0}\n"
	"buses:\n"
	"  - {name: s0, type: sim}\n"
	"motors:\n"
	"  - name: arm\n"
	"    bus: s0\n"
	"    id: 1\n"
	"    mode: torque\n"
	"    torque_constant_nm_a: 1.0\n"
	"    status_poll_hz: 10\n"
	"    feedback: {position: multi_turn, rate_hz: 250}\n"
	"    sim: {kt_nm_a: 1.0, has_brake: false, start_angle_deg: 60, coulomb_nm: 0,\n"
	"          viscous_nm_s_rad: 0, inertia_kgm2: 0.001}\n"
	"sim:\n"
	"  physics:\n"
	"    model: pendulum.xml\n"
	"    joints: {arm: %s}\n";

struct trace {
	double t_s[SAMPLES], pos[SAMPLES];
	unsigned n;
	int64_t last_rx_ns;
};

static void on_state(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_state_t *s,
		     void *user)
{
	struct trace *tr = user;
	const rmd_motor_state_t *m;

	(void)rbuf;
	(void)channel;
	if (s->count < 1 || tr->n >= SAMPLES)
		return;
	m = &s->motor[0];
	/* each 0x92 answer once, at its own receive time */
	if (!m->position_rx_time_ns || m->position_rx_time_ns == tr->last_rx_ns)
		return;
	tr->last_rx_ns = m->position_rx_time_ns;
	tr->t_s[tr->n] = (double)m->position_rx_time_ns * 1e-9;
	tr->pos[tr->n++] = m->position;
}

static int group_setup(void **state)
{
	char path[PATH_MAX + 32], model[PATH_MAX], text[4096];
	const char *src = getenv("RMD_SRCDIR");
	FILE *in, *out;
	size_t n;

	(void)state;
	if (lcm_tools_setup("test_physics_system", rmdd_bin, rmdctl_bin, dir, &multicast) < 0)
		return -1;
	have_module = physics_module_found(rmdd_bin, "test_physics_system");
	snprintf(model, sizeof(model), "%s/tests/data/physics/pendulum.xml",
		 src && src[0] ? src : ".");
	in = fopen(model, "r");
	if (!in)
		return -1;
	n = fread(text, 1, sizeof(text), in);
	fclose(in);
	snprintf(path, sizeof(path), "%s/pendulum.xml", dir);
	out = fopen(path, "w");
	if (!out || fwrite(text, 1, n, out) != n || fclose(out))
		return -1;
	return 0;
}

/* The configuration with the hinge's name `joint`, as dir/NAME. */
static void write_config(char *path, size_t len, const char *name, const char *joint)
{
	FILE *f;

	snprintf(path, len, "%s/%s", dir, name);
	f = fopen(path, "w");
	assert_non_null(f);
	fprintf(f, config_fmt, joint);
	assert_int_equal(fclose(f), 0);
}

/* (a) through rmdd: the period in state_t. */
static void test_period_in_state(void **state)
{
	static struct trace tr;
	char cfg[PATH_MAX + 32], url[128];
	const char *argv[] = { rmdd_bin, "--config", cfg, "--lcm-url", url, NULL };
	double want = pendulum_period_s(I_TOTAL, MASS, LEN, G, M_PI / 3.0);
	double cross[16], got, first = NAN;
	unsigned k = 0;
	rmd_state_t_subscription_t *sub;
	struct kid *rmdd;
	lcm_t *lcm;
	int64_t end;

	(void)state;
	if (!multicast || !have_module)
		skip();
	memset(&tr, 0, sizeof(tr));
	write_config(cfg, sizeof(cfg), "pendulum.yaml", "swing");
	lcm_test_url(url, sizeof(url), 54000, 100, test_no++);
	lcm = lcm_create(url);
	assert_non_null(lcm);
	sub = rmd_state_t_subscribe(lcm, "RMD_STATE", on_state, &tr);
	rmdd = kid_spawn("rmdd", argv, NULL, 0);
	/* five periods of samples (the sim time, not the wall's, is what is judged) */
	end = rmd_now_ns() + 30 * RMD_NS_PER_S;
	while (rmd_now_ns() < end && (tr.n < 2 || tr.t_s[tr.n - 1] - tr.t_s[0] < 5 * want)) {
		lcm_handle_timeout(lcm, 100);
		kid_read(rmdd);
		if (kid_poll_exit(rmdd))
			fail_msg("rmdd exited (%d); its output:\n%s", rmdd->status, kid_tail(rmdd));
	}
	kid_free(rmdd);
	rmd_state_t_unsubscribe(lcm, sub); /* lcm-gen's subscriptions are the caller's to free */
	lcm_destroy(lcm);
	assert_true(tr.n > 100);
	/* upward zero crossings, interpolated between samples */
	for (unsigned i = 1; i < tr.n && k < 16; i++)
		if (tr.pos[i - 1] < 0.0 && tr.pos[i] >= 0.0)
			cross[k++] = tr.t_s[i - 1] + (tr.t_s[i] - tr.t_s[i - 1]) * -tr.pos[i - 1] /
							     (tr.pos[i] - tr.pos[i - 1]);
	for (unsigned i = 0; i < tr.n; i++)
		if (isnan(first))
			first = tr.pos[i];
	assert_true(k >= 3);
	got = (cross[k - 1] - cross[0]) / (k - 1);
	print_message("state_t: %u positions, %u crossings; period %.4f s, formula %.4f s "
		      "(%+.2f %%); first position %.2f deg\n",
		      tr.n, k, got, want, 100.0 * (got / want - 1.0), first * 180.0 / M_PI);
	assert_true(fabs(got / want - 1.0) < 0.02);
}

/* (d) through rmdd: a joint the model lacks stops it at start, naming file, line and key. */
static void test_bad_joint_refused(void **state)
{
	char cfg[PATH_MAX + 32], url[128], want[2 * PATH_MAX + 160];
	const char *argv[] = { rmdd_bin, "--config", cfg, "--lcm-url", url, NULL };
	struct kid *rmdd;
	int st;

	(void)state;
	if (!have_module)
		skip();
	write_config(cfg, sizeof(cfg), "bad-joint.yaml", "knee");
	lcm_test_url(url, sizeof(url), 54000, 100, test_no++);
	rmdd = kid_spawn("rmdd", argv, NULL, 0);
	st = kid_wait_exit(rmdd, 20000, NULL);
	assert_int_not_equal(st, 0);
	snprintf(want, sizeof(want),
		 "%s:18: sim.physics.joints: the model %s/pendulum.xml has "
		 "no joint \"knee\" (its joints: swing)",
		 cfg, dir);
	assert_has(rmdd->out, want, "rmdd's error");
	/* nothing was opened, so nothing moved */
	assert_lacks(rmdd->out, "bus s0: open", "rmdd's output");
	assert_lacks(rmdd->out, "bring-up", "rmdd's output");
	kid_free(rmdd);
}

SUITE_MAIN("physics_system", group_setup, lcm_tools_teardown,
	   {
		   cmocka_unit_test(test_period_in_state),
		   cmocka_unit_test(test_bad_joint_refused),
	   })

// SPDX-License-Identifier: MIT
/*
 * Issue 33 point 5: MIT is a mode of V3 and V4 firmware, and its scaling
 * is the firmware's (docs/protocol-v4.md "MIT scaling").  Each test runs
 * the loop (bring-up included, with an injected clock) over one simulated
 * bus, from an rmdd.yaml text, and judges the wire: the MIT frames the sim
 * bus carried, decoded here with the ranges the sources give (written out
 * below, not taken from rmdd's table), against what the controller asked,
 * and what the simulated motor did with them.
 *
 *   V4.2 (and V3) firmware: p ±12.5 rad, v ±45 rad/s, t ±24 N·m, kp 0..500,
 *                           kd 0..5 (V3 §5.1, V4.2 §5.1)
 *   from firmware 2026042402 (V4.4): p ±12.566 rad, t ±(the model's
 *                           maximum: X6 60 N·m, X8 129 N·m), kd 0..50
 *
 * Every motor here has a load of 5 N·m on its shaft: a torque of 5 N·m
 * holds it still, so the simulated motor's torque (kt x iq) is what its
 * firmware made of the frames.  Before issue 33 every one of these fails:
 * mode mit needed protocol mit, which a V4 date refuses.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "rmd/bringup.h"
#include "rmd/bus_sim.h"
#include "rmd/config.h"
#include "rmd/config_yaml.h"
#include "rmd/loop.h"
#include "rmd/mit.h"
#include "rmd/plan.h"
#include "rmd/sim.h"
#include "rmd/sim_wire.h"
#include "rmd/spsc.h"
#include "rmd/state.h"

#include "harness/clock.h"
#include "harness/loop_io.h"
#include "harness/rig.h"
#include "harness/suite.h"

#define MS INT64_C(1000000)

/* The ranges the sources give (see the top of this file). */
static const struct rmd_mit_ranges V42 = { -12.5, 12.5, -45, 45, -24, 24, 0, 500, 0, 5 };
static const struct rmd_mit_ranges V44_X6 = { -12.566, 12.566, -45, 45, -60, 60, 0, 500, 0, 50 };
static const struct rmd_mit_ranges V44_X8 = { -12.566, 12.566, -45, 45, -129, 129, 0, 500, 0, 50 };

/* What the controller asks: p 1 rad (kp 0: no stiffness), v 0, kd 2, t 5 N·m. */
#define ASK_P 1.0
#define ASK_KD 2.0
#define ASK_T 5.0

static struct rig R; /* R.report: the bring-up's, bu_ret what it returned */
static int bu_ret;

/* The yaml's motor 1 on bus s0, loaded and opened, the loop built; bring-up when asked. */
static void rig_up(const char *yaml, bool bringup)
{
	char path[] = "/tmp/rmd-test-mit-mode-XXXXXX", err[4096];
	int fd = mkstemp(path);

	rig_reset(&R);
	bu_ret = 0;
	assert_true(fd >= 0);
	assert_int_equal(write(fd, yaml, strlen(yaml)), (ssize_t)strlen(yaml));
	close(fd);
	if (rmd_config_load(path, &R.io.cfg, &R.io.sim, err, sizeof(err)) != 0) {
		unlink(path);
		fail_msg("the configuration is refused:\n%s", err);
	}
	unlink(path);
	R.rt = true;		 /* cycles as the rt thread runs them */
	R.events_in_ring = true; /* the tests pop them */
	rig_start(&R, rig_wire_tap);
	if (bringup)
		bu_ret = rmd_loop_bringup(R.l, &R.report);
}

static struct rmd_sim_motor *sim(void)
{
	return rmd_sim_wire_motor(rmd_bus_sim_get(&R.io.buses[0]), 1);
}

static struct rmd_motor_state mstate(void)
{
	struct rmd_snapshot s;

	rmd_loop_get_snapshot(R.l, &s);
	return s.m[0];
}

/* The controller's MIT setpoint for motor 1 (ASK_*), enable = 1. */
static void ask_mit(void)
{
	struct rmd_setpoint *sp = &R.cmd.m[0];

	R.cmd.present = 1;
	*sp = (struct rmd_setpoint){ .enable = true,
				     .mode = RMD_MODE_MIT,
				     .pos_rad = ASK_P,
				     .kd = ASK_KD,
				     .torque_nm = ASK_T };
}

/* Host frames on 0x400 + ID (MIT requests) from rig_host[from]. */
static unsigned mit_requests(unsigned from)
{
	unsigned n = 0;

	for (unsigned k = from; k < rig_host_n; k++)
		n += rig_host[k].can_id >= 0x400 && rig_host[k].can_id <= 0x41F;
	return n;
}

/*
 * Every MIT request on the wire from rig_host[from], decoded with r, carries
 * what the controller asked (within r's step); and there are some.
 */
static void frames_carry(const struct rmd_mit_ranges *r, unsigned from, const char *what)
{
	double t_step = (r->t_max - r->t_min) / 4095, kd_step = (r->kd_max - r->kd_min) / 4095;
	double p_step = (r->p_max - r->p_min) / 65535;
	unsigned n = 0;

	for (unsigned k = from; k < rig_host_n; k++) {
		struct rmd_mit_cmd c;
		uint8_t id;

		if (rig_host[k].can_id != 0x401)
			continue;
		assert_int_equal(rmd_mit_decode_cmd(r, &rig_host[k], &id, &c), 0);
		if (fabs(c.t_ff_nm - ASK_T) > t_step || fabs(c.kd - ASK_KD) > kd_step ||
		    fabs(c.p_des_rad - ASK_P) > p_step || c.kp != 0.0)
			fail_msg("%s: frame %u decodes to p %g kd %g t %g (asked p %g kd %g t %g)",
				 what, k, c.p_des_rad, c.kd, c.t_ff_nm, ASK_P, ASK_KD, ASK_T);
		n++;
	}
	if (n < 50)
		fail_msg("%s: %u MIT frames on the wire", what, n);
}

/* Bring-up found it, ENABLED in MIT after the command; the wire and the motor judged with r. */
static void runs_with(const struct rmd_mit_ranges *r, const char *what)
{
	unsigned from;
	struct rmd_motor_state st;
	const struct rmd_sim_motor *m;
	unsigned replies = 0;

	if (bu_ret != 0)
		fail_msg("%s: bring-up returned %d (motor state %d)", what, bu_ret,
			 R.report.motor[0].state);
	ask_mit();
	rig_run(&R, 100, true);
	assert_int_equal(mstate().lifecycle, RMD_LC_ENABLED);
	from = rig_host_n;
	rig_run(&R, 300, true);
	frames_carry(r, from, what);
	m = sim();
	/* the firmware's own reading of them, and what it did: 5 N·m holds the load */
	assert_int_equal(m->ctrl, RMD_SIM_MIT);
	if (fabs(m->mit.t_ff_nm - ASK_T) > 0.1 || fabs(m->p.kt_nm_a * m->iq_a - ASK_T) > 0.1)
		fail_msg("%s: the simulated motor took t_ff %g and makes %g N·m (asked %g)", what,
			 m->mit.t_ff_nm, m->p.kt_nm_a * m->iq_a, ASK_T);
	/* its MIT replies (0x501) were taken: rmdd's torque is the motor's */
	for (unsigned k = 0; k < rig_motor_n; k++)
		replies += rig_motor[k].can_id == 0x501;
	assert_true(replies >= 50);
	st = mstate();
	if (fabs(st.torque_nm - m->p.kt_nm_a * m->iq_a) > 0.2)
		fail_msg("%s: rmdd reports %g N·m, the motor makes %g", what, st.torque_nm,
			 m->p.kt_nm_a * m->iq_a);
}

/* Bring-up refused it, and no MIT frame reached the wire, however long it is asked. */
static void refused(const char *what)
{
	ask_mit();
	rig_run(&R, 500, true);
	if (bu_ret == 0 && R.report.motor[0].state != RMD_BRINGUP_MISMATCH)
		fail_msg("%s: bring-up accepted it", what);
	assert_int_not_equal(mstate().lifecycle, RMD_LC_ENABLED);
	assert_int_equal(mit_requests(0), 0);
	assert_int_not_equal(sim()->ctrl, RMD_SIM_MIT);
}

#define BUS                      \
	"loop: {rate_hz: 500}\n" \
	"buses:\n"               \
	"  - {name: s0, type: sim}\n"
#define MOTOR "motors:\n  - {name: m1, bus: s0, id: 1, multi_turn_saved: true, "

/*
 * A motor's entry, from an rmdd.yaml text, that bring-up runs in MIT on
 * ranges r (runs_with()), or, r NULL, refuses (refused()): a test each.
 */
struct entry_case {
	const char *test;
	const char *yaml;
	const struct rmd_mit_ranges *r;
	const char *what;
};

static const struct entry_case runs_rows[] = {
	/* A V4.2 motor (firmware 2025070202) in mode mit: today's scaling, on 0x401 / 0x501. */
	{ "test_v42_motor_in_mit",
	  BUS MOTOR "protocol: v4, mode: mit,\n"
		    "     sim: {version_date: 2025070202, model: X6S2V3, load_nm: 5}}\n",
	  &V42, "V4.2 X6" },
	/* An X6 on V4.4 firmware, no mit ranges in its entry: the X6's V4.4 scaling. */
	{ "test_v44_x6_its_scaling",
	  BUS MOTOR "protocol: v4, mode: mit,\n"
		    "     sim: {version_date: 2026042402, model: X6S2V3, load_nm: 5}}\n",
	  &V44_X6, "V4.4 X6" },
	/* An X8 on later V4.4 firmware (an eight-digit date is build 00 of that day). */
	{ "test_v44_x8_its_scaling",
	  BUS MOTOR "protocol: v4, mode: mit,\n"
		    "     sim: {version_date: 20260601, model: X8ProV2, load_nm: 5}}\n",
	  &V44_X8, "V4.4 X8" },
	/* protocol: auto finds the firmware; MIT is how it is driven. */
	{ "test_auto_finds_v44",
	  BUS MOTOR "protocol: auto, mode: mit,\n"
		    "     sim: {firmware: v4, version_date: 2026042402, model: X6S2V3, "
		    "load_nm: 5}}\n",
	  &V44_X6, "auto, V4.4 X6" },
	/* Today's protocol: mit on V3 firmware keeps working, on today's scaling. */
	{ "test_protocol_mit_on_v3",
	  BUS MOTOR "protocol: mit, mode: mit,\n"
		    "     sim: {version_date: 20220206, load_nm: 5}}\n",
	  &V42, "protocol mit, V3" },
	/* An entry whose ranges agree with V4.4's (4 pi for 12.566) runs on them. */
	{ "test_v44_entry_agrees",
	  BUS MOTOR "protocol: v4, mode: mit,\n"
		    "     mit: {p_min: -12.56637, p_max: 12.56637, t_min: -60, t_max: 60},\n"
		    "     sim: {version_date: 2026042402, model: X6S2V3, load_nm: 5}}\n",
	  &V44_X6, "V4.4 X6, agreeing entry" },
};

static const struct entry_case refused_rows[] = {
	/* Firmware that does not answer 0xB2: its date unknown, MIT refused. */
	{ "test_no_date_refused",
	  BUS MOTOR "protocol: v4, mode: mit,\n"
		    "     sim: {version_date: 2026042402, model: X6S2V3, load_nm: 5, "
		    "ignores_cmd: 0xB2}}\n",
	  NULL, "V4.4 X6, no 0xB2" },
	/* The entry's legacy ranges contradict the X6's V4.4 scaling: refused. */
	{ "test_v44_entry_contradicts",
	  BUS MOTOR "protocol: v4, mode: mit,\n"
		    "     mit: {t_min: -24, t_max: 24},\n"
		    "     sim: {version_date: 2026042402, model: X6S2V3, load_nm: 5}}\n",
	  NULL, "V4.4 X6, t ±24 in its entry" },
	/* protocol: mit (V3 firmware) on a motor whose date says V4: refused, as V3's. */
	{ "test_protocol_mit_on_v4_refused",
	  BUS MOTOR "protocol: mit, mode: mit,\n"
		    "     sim: {firmware: v4, version_date: 2026042402, model: X6S2V3, "
		    "load_nm: 5}}\n",
	  NULL, "protocol mit, V4.4 firmware" },
};

static void test_entry_row(void **state)
{
	const struct entry_case *c = *state;

	rig_up(c->yaml, true);
	if (c->r)
		runs_with(c->r, c->what);
	else
		refused(c->what);
	rig_stop(&R);
}

/*
 * kd on V4.4, where the sources disagree (0..50 its changelog, 0..5 a
 * measurement): the entry's kd_max is taken, the rest is the X6's.
 */
static void test_v44_entry_kd_taken(void **state)
{
	static const struct rmd_mit_ranges x6_kd5 = { -12.566, 12.566, -45, 45, -60,
						      60,      0,      500, 0,	5 };

	(void)state;
	rig_up(BUS MOTOR "protocol: v4, mode: mit, mit: {kd_max: 5},\n"
			 "     sim: {version_date: 2026042402, model: X6S2V3, load_nm: 5}}\n",
	       true);
	ask_mit();
	rig_run(&R, 400, true);
	assert_int_equal(mstate().lifecycle, RMD_LC_ENABLED);
	frames_carry(&x6_kd5, 0, "V4.4 X6, kd_max 5 in its entry");
	rig_stop(&R);
}

/* protocol: auto finding V2 firmware, which has no MIT mode: refused. */
static void test_auto_finds_v2_refused(void **state)
{
	(void)state;
	rig_up(BUS MOTOR "protocol: auto, mode: mit, comm_loss_ms: 0,\n"
			 "     sim: {firmware: v2, load_nm: 5}}\n",
	       true);
	assert_int_equal(R.report.motor[0].mismatch, RMD_BRINGUP_MISMATCH_NO_MIT);
	refused("auto, V2 firmware");
	rig_stop(&R);
}

/* A model rmdd has no V4.4 scaling of: refused, nothing on 0x400 + ID. */
static void test_v44_unknown_model_refused(void **state)
{
	(void)state;
	rig_up(BUS MOTOR "protocol: v4, mode: mit,\n"
			 "     sim: {version_date: 2026042402, model: X4-36, load_nm: 5}}\n",
	       true);
	refused("V4.4 X4-36");
	assert_int_equal(bu_ret, -EPROTO);
	rig_stop(&R);
}

/*
 * The loop alone (no bring-up: nothing read the firmware): a V4 motor in
 * mode mit becomes READY, but MIT is never enabled for it, counted and
 * reported once.
 */
static void test_loop_refuses_undecided(void **state)
{
	struct rmd_loop_counters c;
	struct rmd_event e;
	unsigned seen = 0;

	(void)state;
	rig_up(BUS MOTOR "protocol: v4, mode: mit,\n"
			 "     sim: {version_date: 2026042402, model: X6S2V3, load_nm: 5}}\n",
	       false);
	R.cmd.present = 1;
	rig_run(&R, 200, true);
	assert_int_equal(mstate().lifecycle, RMD_LC_READY);
	ask_mit();
	rig_run(&R, 300, true);
	assert_int_equal(mstate().lifecycle, RMD_LC_READY);
	assert_int_equal(mit_requests(0), 0);
	rmd_loop_get_counters(R.l, &c);
	assert_true(c.ignored[RMD_IGN_MIT_SCALING] >= 290);
	while (rmd_ring_pop(&R.io.events, &e))
		seen += e.kind == RMD_EV_MIT_REFUSED;
	assert_int_equal(seen, 1);
	rig_stop(&R);
}

/* Motor 1 in mode mit on V4 firmware, missing for the first 0.5 s: found by the re-probe. */
#define LATE_MOTOR                                                                         \
	"loop: {rate_hz: 500}\n"                                                           \
	"probe: {on_missing: start}\n"                                                     \
	"buses:\n"                                                                         \
	"  - name: s0\n"                                                                   \
	"    type: sim\n"                                                                  \
	"    sim: {faults: [{kind: disappear, motor: 1, start_s: 0, end_s: 0.5}]}\n" MOTOR \
	"protocol: v4, mode: mit,\n"

/*
 * Missing at bring-up, found later by the loop's re-probe: it asks the
 * model (0xB5) and the date (0xB2), decides the V4.4 scaling, and only then
 * brings the motor back; it runs on the X6's V4.4 ranges.
 */
static void test_late_motor_decided(void **state)
{
	(void)state;
	rig_up(LATE_MOTOR "     sim: {version_date: 2026042402, model: X6S2V3, load_nm: 5}}\n",
	       true);
	assert_int_equal(R.report.motor[0].state, RMD_BRINGUP_MISSING);
	bu_ret = 0;
	R.cmd.present = 1;
	{
		unsigned from = rig_host_n, b5 = 0;

		for (unsigned k = 0; k < 3000 && mstate().lifecycle != RMD_LC_READY; k++)
			rig_run(&R, 1, true);
		assert_int_equal(mstate().lifecycle, RMD_LC_READY);
		/* the loop's re-probe asked the model, not bring-up alone */
		for (unsigned k = from; k < rig_host_n; k++)
			b5 += rig_host[k].can_id == 0x141 && rig_host[k].data[0] == 0xB5;
		assert_true(b5 >= 1);
	}
	assert_int_equal(mit_requests(0), 0);
	runs_with(&V44_X6, "late V4.4 X6");
	rig_stop(&R);
}

/* Missing at bring-up, found later with a model rmdd knows no V4.4 scaling of: left out. */
static void test_late_motor_unknown_model(void **state)
{
	struct rmd_event e;
	unsigned seen = 0;

	(void)state;
	rig_up(LATE_MOTOR "     sim: {version_date: 2026042402, model: X4-36, load_nm: 5}}\n",
	       true);
	assert_int_equal(R.report.motor[0].state, RMD_BRINGUP_MISSING);
	ask_mit();
	rig_run(&R, 2000, true);
	assert_int_equal(mstate().lifecycle, RMD_LC_LOST);
	assert_int_equal(mit_requests(0), 0);
	assert_int_not_equal(sim()->ctrl, RMD_SIM_MIT);
	while (rmd_ring_pop(&R.io.events, &e))
		seen += e.kind == RMD_EV_MIT_SCALING && e.a == 2026042402;
	assert_int_equal(seen, 1);
	rig_stop(&R);
}

int main(void)
{
	struct CMUnitTest tests[SUITE_N(runs_rows) + SUITE_N(refused_rows) + 6];
	size_t n = 0;

	for (size_t k = 0; k < SUITE_N(runs_rows); k++)
		tests[n++] = SUITE_ROW(runs_rows[k].test, test_entry_row, &runs_rows[k]);
	tests[n++] = (struct CMUnitTest)cmocka_unit_test(test_v44_entry_kd_taken);
	tests[n++] = (struct CMUnitTest)cmocka_unit_test(test_auto_finds_v2_refused);
	tests[n++] = (struct CMUnitTest)cmocka_unit_test(test_v44_unknown_model_refused);
	for (size_t k = 0; k < SUITE_N(refused_rows); k++)
		tests[n++] = SUITE_ROW(refused_rows[k].test, test_entry_row, &refused_rows[k]);
	tests[n++] = (struct CMUnitTest)cmocka_unit_test(test_loop_refuses_undecided);
	tests[n++] = (struct CMUnitTest)cmocka_unit_test(test_late_motor_decided);
	tests[n++] = (struct CMUnitTest)cmocka_unit_test(test_late_motor_unknown_model);
	return suite_run("mit_mode", tests, n, NULL, NULL);
}

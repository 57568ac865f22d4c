// SPDX-License-Identifier: MIT
/*
 * Multi-turn position after a power cycle (rmd/multiturn.h): the period
 * per gear ratio; the decision over a table of bands, readings and
 * tolerances; and through a motor record, at several angles, gear ratios,
 * both directions and zero offsets, that the shift makes the motor report
 * the true position exactly and take a position command in the same frame.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "rmd/config.h"
#include "rmd/mit.h"
#include "rmd/motor.h"
#include "rmd/multiturn.h"
#include "harness/suite.h"

#define DEG (M_PI / 180.0)

static void test_period(void **state)
{
	(void)state;
	assert_float_equal(rmd_multiturn_period_rad(1.0), 2.0 * M_PI, 1e-12);
	assert_float_equal(rmd_multiturn_period_rad(9.0), 40.0 * DEG, 1e-12);
	assert_float_equal(rmd_multiturn_period_rad(36.0), 10.0 * DEG, 1e-12);
	assert_float_equal(rmd_multiturn_period_rad(0.0), 0.0, 0.0);
}

struct settle_case {
	const char *name;
	struct rmd_multiturn mt;
	double pos_rad;
	enum rmd_pos_trust want;
	double want_shift_rad;
};

static void test_settle_table(void **state)
{
	const double p9 = 40.0 * DEG;
	const struct settle_case cases[] = {
		{ "saved wins over no band",
		  { .saved = true, .period_rad = 2 * M_PI, .lo_rad = -INFINITY, .hi_rad = INFINITY },
		  7.0,
		  RMD_POS_SAVED,
		  0 },
		{ "no band",
		  { .period_rad = 2 * M_PI, .lo_rad = -INFINITY, .hi_rad = INFINITY },
		  1.0,
		  RMD_POS_AMBIGUOUS,
		  0 },
		{ "band one period wide",
		  { .period_rad = 2 * M_PI, .lo_rad = -M_PI, .hi_rad = M_PI },
		  1.0,
		  RMD_POS_AMBIGUOUS,
		  0 },
		{ "band plus tolerance one period",
		  { .period_rad = 2 * M_PI, .lo_rad = -3.1, .hi_rad = 3.1, .tol_rad = 0.05 },
		  1.0,
		  RMD_POS_AMBIGUOUS,
		  0 },
		{ "direct drive, in band already",
		  { .period_rad = 2 * M_PI, .lo_rad = -0.5, .hi_rad = 2.5 },
		  1.0,
		  RMD_POS_IN_BAND,
		  0 },
		{ "direct drive, one turn up",
		  { .period_rad = 2 * M_PI, .lo_rad = 4.5, .hi_rad = 7.5 },
		  1.0,
		  RMD_POS_IN_BAND,
		  2 * M_PI },
		{ "direct drive, two turns down",
		  { .period_rad = 2 * M_PI, .lo_rad = -13.0, .hi_rad = -10.0 },
		  0.5,
		  RMD_POS_IN_BAND,
		  -4 * M_PI },
		{ "direct drive, gap in the band's complement",
		  { .period_rad = 2 * M_PI, .lo_rad = 0.0, .hi_rad = 1.0 },
		  3.0,
		  RMD_POS_OUTSIDE,
		  0 },
		{ "1:9, three periods up",
		  { .period_rad = p9, .lo_rad = 100 * DEG, .hi_rad = 130 * DEG },
		  -10 * DEG,
		  RMD_POS_IN_BAND,
		  3 * p9 },
		{ "1:9, band 30 deg, reading at its low edge",
		  { .period_rad = p9, .lo_rad = 0, .hi_rad = 30 * DEG },
		  -40 * DEG,
		  RMD_POS_IN_BAND,
		  p9 },
		{ "1:9, just below the edge, within tol",
		  { .period_rad = p9, .lo_rad = 0, .hi_rad = 30 * DEG, .tol_rad = 1 * DEG },
		  -40.5 * DEG,
		  RMD_POS_IN_BAND,
		  p9 },
		{ "1:9, band 45 deg wide",
		  { .period_rad = p9, .lo_rad = 0, .hi_rad = 45 * DEG },
		  10 * DEG,
		  RMD_POS_AMBIGUOUS,
		  0 },
		{ "1:9, in the 10 deg gap",
		  { .period_rad = p9, .lo_rad = 0, .hi_rad = 30 * DEG },
		  35 * DEG,
		  RMD_POS_OUTSIDE,
		  0 },
		{ "NaN",
		  { .period_rad = p9, .lo_rad = 0, .hi_rad = 30 * DEG },
		  NAN,
		  RMD_POS_AMBIGUOUS,
		  0 },
		{ "no gear ratio",
		  { .period_rad = 0, .lo_rad = 0, .hi_rad = 0.1 },
		  0.05,
		  RMD_POS_AMBIGUOUS,
		  0 },
	};

	(void)state;
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		const struct settle_case *c = &cases[i];
		double shift = -1.0;
		enum rmd_pos_trust got = rmd_multiturn_settle(&c->mt, c->pos_rad, &shift);

		if (got != c->want)
			fail_msg("%s: trust %d, want %d", c->name, got, c->want);
		if (fabs(shift - c->want_shift_rad) > 1e-12)
			fail_msg("%s: shift %.15g, want %.15g", c->name, shift, c->want_shift_rad);
	}
}

/* A V3 motor's config entry: the loader's defaults, then these. */
static struct rmd_config_motor v3_motor(int dir, double gear, double zero_rad)
{
	struct rmd_config_motor c;

	rmd_config_motor_defaults(&c);
	snprintf(c.name, sizeof(c.name), "knee");
	c.id = 1;
	c.proto = RMD_PROTO_V3;
	c.mode = RMD_MODE_POSITION;
	c.direction = dir;
	c.gear_ratio = gear;
	c.zero_offset_rad = zero_rad;
	c.torque_constant_nm_a = 2.0;
	return c;
}

/*
 * The joint is at `truth` (reported frame); its band is [truth - below,
 * truth + above]; after the power cycle the motor's native angle is off by
 * `turns` periods.  The shift must give truth back exactly, and a
 * position command for truth must go to the motor's new native angle.
 */
static void check_cycle(int dir, double gear, double zero, double truth, double below, double above,
			int turns)
{
	struct rmd_config_motor c = v3_motor(dir, gear, zero);
	struct rmd_motor m;
	struct rmd_multiturn mt;
	double native_true, native_now, rep, shift;
	enum rmd_pos_trust t;

	assert_int_equal(rmd_motor_init(&m, &c), 0);
	mt = (struct rmd_multiturn){ .period_rad = rmd_multiturn_period_rad(gear),
				     .lo_rad = truth - below,
				     .hi_rad = truth + above,
				     .tol_rad = 0.01 * DEG };
	native_true = rmd_motor_to_native_pos(&m, truth);
	native_now = native_true - turns * mt.period_rad;
	rep = rmd_motor_from_native_pos(&m, native_now);
	t = rmd_multiturn_settle(&mt, rep, &shift);
	if (t != RMD_POS_IN_BAND)
		fail_msg("dir %d gear %g zero %g truth %g turns %d: trust %d", dir, gear, zero,
			 truth, turns, t);
	rmd_motor_shift_pos(&m, shift);
	if (fabs(rmd_motor_from_native_pos(&m, native_now) - truth) > 1e-9)
		fail_msg("dir %d gear %g zero %g truth %g turns %d: reports %.12g", dir, gear, zero,
			 truth, turns, rmd_motor_from_native_pos(&m, native_now));
	if (fabs(rmd_motor_to_native_pos(&m, truth) - native_now) > 1e-9)
		fail_msg(
			"dir %d gear %g zero %g truth %g turns %d: command to %.12g, motor at %.12g",
			dir, gear, zero, truth, turns, rmd_motor_to_native_pos(&m, truth),
			native_now);
}

/* A home's position against the band (issue 33 point 6): the band widened by the step. */
static void test_in_band(void **state)
{
	static const struct {
		double lo, hi, tol, pos;
		bool in;
	} cases[] = {
		{ -0.3, 2.4, 0.01, 1.0, true },
		{ -0.3, 2.4, 0.01, 2.405, true }, /* within the step */
		{ -0.3, 2.4, 0.01, 2.42, false },
		{ -0.3, 2.4, 0.01, -0.311, false },
		{ -0.3, 2.4, 0.01, 90.0, false },	  /* degrees sent for radians */
		{ -INFINITY, INFINITY, 0.01, 1e5, true }, /* no band, no limits */
		{ -INFINITY, 1.0, 0.01, -1e5, true },	  /* open below */
		{ -0.3, 2.4, 0.01, NAN, false },
		{ -INFINITY, INFINITY, 0.01, INFINITY, false },
	};

	(void)state;
	for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
		struct rmd_multiturn mt = { .period_rad = 1.0,
					    .lo_rad = cases[k].lo,
					    .hi_rad = cases[k].hi,
					    .tol_rad = cases[k].tol };

		if (rmd_multiturn_in_band(&mt, cases[k].pos) != cases[k].in)
			fail_msg("case %zu: %g in [%g, %g] +- %g: %s, want %s", k, cases[k].pos,
				 cases[k].lo, cases[k].hi, cases[k].tol, cases[k].in ? "out" : "in",
				 cases[k].in ? "in" : "out");
	}
}

static void test_motor_cycles(void **state)
{
	static const double gears[] = { 1.0, 6.0, 9.0, 36.0 };
	static const double zeros[] = { 0.0, 0.7, -2.5 };
	static const double truths_deg[] = { -170.0, -33.3, 0.0, 12.5, 95.0, 400.0, -721.0 };
	static const int turns[] = { -3, -1, 0, 1, 2, 7 };

	(void)state;
	for (int dir = -1; dir <= 1; dir += 2)
		for (size_t g = 0; g < 4; g++)
			for (size_t z = 0; z < 3; z++)
				for (size_t a = 0; a < 7; a++)
					for (size_t k = 0; k < 6; k++) {
						double p = rmd_multiturn_period_rad(gears[g]);

						/* the joint anywhere in a band 0.8 periods wide */
						check_cycle(dir, gears[g], zeros[z],
							    truths_deg[a] * DEG, 0.1 * p, 0.7 * p,
							    turns[k]);
						check_cycle(dir, gears[g], zeros[z],
							    truths_deg[a] * DEG, 0.79 * p, 0.0,
							    turns[k]);
					}
}

SUITE_MAIN("multiturn", NULL, NULL,
	   {
		   cmocka_unit_test(test_period),
		   cmocka_unit_test(test_settle_table),
		   cmocka_unit_test(test_in_band),
		   cmocka_unit_test(test_motor_cycles),
	   })

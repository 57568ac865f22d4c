// SPDX-License-Identifier: MIT
/*
 * The position-after-a-power-cycle procedure (rmd/proc_settle.h), as
 * tables: a motor that keeps its count is decided at once; otherwise two
 * readings that come to the same decide (a first one, or one that
 * disagrees with it, waits for a later reading); the refusal is reported
 * once an episode; homing is refused while enabled, before a position,
 * while the settle runs and outside the travel band, else shifts the
 * frame by what the controller says.  The loop's use of it is judged on
 * the wire by test_loop's position cases.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include <cmocka.h>

#include "rmd/proc_settle.h"
#include "harness/suite.h"

#define DEG (M_PI / 180.0)

/* 1:9 behind a gearbox (a 40 deg period), travel [-10, 20] deg: one position of each class. */
static const struct rmd_multiturn band = { .period_rad = 40.0 * DEG,
					   .lo_rad = -10.0 * DEG,
					   .hi_rad = 20.0 * DEG,
					   .tol_rad = 1.0 * DEG };

static void test_begin(void **state)
{
	struct rmd_multiturn saved = band;
	struct rmd_settle s;

	(void)state;
	saved.saved = true;
	assert_int_equal(rmd_settle_begin(&s, &saved, 100), RMD_POS_SAVED);
	assert_false(rmd_settle_due(&s, 200));
	assert_int_equal(rmd_settle_begin(&s, &band, 100), RMD_POS_UNKNOWN);
	assert_false(rmd_settle_due(&s, 99));
	assert_true(rmd_settle_due(&s, 100));
	rmd_settle_forget(&s);
	assert_false(rmd_settle_due(&s, 200));
}

/* Readings after a begin at t = 0: what each decides. */
static void test_readings(void **state)
{
	static const struct {
		const char *name;
		unsigned n;
		double deg[3];
		enum rmd_pos_trust want[3];
		double shift_deg; /* of the deciding one */
	} cases[] = {
		{ "two agree, in band", 2, { 5, 6 }, { RMD_POS_UNKNOWN, RMD_POS_IN_BAND }, 0 },
		{ "two agree, a period off",
		  2,
		  { 45, 46 },
		  { RMD_POS_UNKNOWN, RMD_POS_IN_BAND },
		  -40 },
		{ "one garbled reading",
		  3,
		  { 5, 125, 126 },
		  { RMD_POS_UNKNOWN, RMD_POS_UNKNOWN, RMD_POS_IN_BAND },
		  -120 },
		{ "outside the band", 2, { 25, 25 }, { RMD_POS_UNKNOWN, RMD_POS_OUTSIDE }, 0 },
	};

	(void)state;
	for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
		struct rmd_settle s;
		double shift = 0.0;

		rmd_settle_begin(&s, &band, 0);
		for (unsigned n = 0; n < cases[k].n; n++) {
			int64_t t = 10 * (int64_t)(n + 1);
			enum rmd_pos_trust got;

			if (!rmd_settle_due(&s, t))
				fail_msg("%s: reading %u at %lld not due", cases[k].name, n,
					 (long long)t);
			got = rmd_settle_reading(&s, &band, cases[k].deg[n] * DEG, t, &shift);
			if (got != cases[k].want[n])
				fail_msg("%s: reading %u: %d, want %d", cases[k].name, n, got,
					 cases[k].want[n]);
			/* a reading at the same time again is not a later one */
			if (got == RMD_POS_UNKNOWN && rmd_settle_due(&s, t))
				fail_msg("%s: reading %u due again at its own time", cases[k].name,
					 n);
		}
		assert_float_equal(shift, cases[k].shift_deg * DEG, 1e-9);
		rmd_settle_decided(&s, cases[k].want[cases[k].n - 1]);
		assert_false(rmd_settle_due(&s, 1000));
	}
}

/* A refusal is reported once an episode; a trusted decision ends the episode. */
static void test_warn_once(void **state)
{
	struct rmd_settle s;

	(void)state;
	rmd_settle_begin(&s, &band, 0);
	assert_true(rmd_settle_warn_once(&s));
	assert_false(rmd_settle_warn_once(&s));
	rmd_settle_decided(&s, RMD_POS_AMBIGUOUS); /* still not trusted */
	assert_false(rmd_settle_warn_once(&s));
	rmd_settle_decided(&s, RMD_POS_HOMED);
	assert_true(rmd_settle_warn_once(&s));
	rmd_settle_forget(&s);
	assert_true(rmd_settle_warn_once(&s));
}

static void test_home(void **state)
{
	static const struct {
		const char *name;
		bool enabled, reachable, have_pos, settling, as_reported;
		double reported_deg, pos_deg;
		int want;
		double shift_deg;
	} cases[] = {
		{ "homed", false, true, true, false, false, 45, 5, 0, -40 },
		{ "as reported", false, true, true, false, true, 5, 0, 0, 0 },
		{ "enabled", true, true, true, false, false, 45, 5, RMD_HOME_ENABLED, 0 },
		{ "no position yet", false, true, false, false, false, 45, 5, RMD_HOME_NO_POS, 0 },
		{ "lost", false, false, true, false, false, 45, 5, RMD_HOME_NO_POS, 0 },
		{ "settling", false, true, true, true, false, 45, 5, RMD_HOME_NO_POS, 0 },
		{ "degrees for radians", false, true, true, false, false, 5, 5 / DEG,
		  RMD_HOME_OUTSIDE, 0 },
		{ "as reported, outside", false, true, true, false, true, 45, 0, RMD_HOME_OUTSIDE,
		  0 },
		{ "within the step", false, true, true, false, false, 5, 20.5, 0, 15.5 },
	};

	(void)state;
	for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
		const struct rmd_settle_home_facts f = {
			.enabled = cases[k].enabled,
			.reachable = cases[k].reachable,
			.have_pos = cases[k].have_pos,
			.reported = cases[k].reported_deg * DEG,
		};
		struct rmd_settle s;
		double shift, at;
		int r;

		rmd_settle_forget(&s);
		if (cases[k].settling)
			rmd_settle_begin(&s, &band, 0);
		r = rmd_settle_home(&s, &band, &f, cases[k].as_reported, cases[k].pos_deg * DEG,
				    &shift, &at);
		if (r != cases[k].want)
			fail_msg("%s: %d, want %d", cases[k].name, r, cases[k].want);
		assert_float_equal(shift, cases[k].shift_deg * DEG, 1e-9);
		if (r == RMD_HOME_OUTSIDE)
			assert_float_equal(at,
					   (cases[k].as_reported ? cases[k].reported_deg :
								   cases[k].pos_deg) *
						   DEG,
					   1e-9);
	}
}

SUITE_MAIN("proc_settle", NULL, NULL,
	   {
		   cmocka_unit_test(test_begin),
		   cmocka_unit_test(test_readings),
		   cmocka_unit_test(test_warn_once),
		   cmocka_unit_test(test_home),
	   })

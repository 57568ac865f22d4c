// SPDX-License-Identifier: MIT
/*
 * Whether a motor's position commands have an effect (rmd/proc_effect.h),
 * step by step: readings of a motor and what the record says of each.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "harness/suite.h"
#include "rmd/proc_effect.h"

#define MS INT64_C(1000000)
#define DEG (M_PI / 180.0)

/* A reading: driven, target, speed limit (rad/s), position, time; told or not. */
struct reading {
	bool driven;
	double target_deg, vmax, pos_deg;
	int64_t t;
	bool want;
};

struct effect_case {
	const char *name;
	struct reading r[8];
	unsigned n;
};

static const struct effect_case cases[] = {
	{ "held far from its target for the hold: told once",
	  { { true, 30, 2, 0, 100 * MS, false },
	    { true, 30, 2, 0.2, 400 * MS, false },
	    { true, 30, 2, 0.3, 600 * MS, true },
	    { true, 30, 2, 0.3, 900 * MS, false },
	    { true, 30, 2, 0.3, 2000 * MS, false } },
	  5 },
	{ "moving towards it: never told",
	  { { true, 30, 2, 0, 100 * MS, false },
	    { true, 30, 2, 5, 400 * MS, false },
	    { true, 30, 2, 10, 700 * MS, false },
	    { true, 30, 2, 15, 1000 * MS, false },
	    { true, 30, 2, 20, 1300 * MS, false } },
	  5 },
	{ "near its target: never told",
	  { { true, 4, 2, 0, 100 * MS, false }, { true, 4, 2, 0, 2000 * MS, false } },
	  2 },
	{ "asked slower than the hold can tell: never told",
	  { { true, 30, 0.02, 0, 100 * MS, false }, { true, 30, 0.02, 0, 2000 * MS, false } },
	  2 },
	{ "not driven to a position: forgets, told again in a new episode",
	  { { true, 30, 2, 0, 100 * MS, false },
	    { true, 30, 2, 0, 700 * MS, true },
	    { false, 30, 2, 0, 800 * MS, false },
	    { true, 30, 2, 0, 900 * MS, false },
	    { true, 30, 2, 0, 1500 * MS, true } },
	  5 },
	{ "it moved, then stuck: the hold from where it stuck",
	  { { true, 60, 2, 0, 100 * MS, false },
	    { true, 60, 2, 10, 500 * MS, false },
	    { true, 60, 2, 10, 900 * MS, false },
	    { true, 60, 2, 10, 1000 * MS, true } },
	  4 },
	{ "no speed limit (0) is judged",
	  { { true, -30, 0, 0, 100 * MS, false }, { true, -30, 0, 0, 600 * MS, true } },
	  2 },
};

static void test_steps(void **state)
{
	(void)state;
	for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
		const struct effect_case *c = &cases[k];
		struct rmd_effect e = { 0 };

		for (unsigned i = 0; i < c->n; i++) {
			const struct reading *r = &c->r[i];
			bool told = rmd_effect_watch(&e, r->driven, r->target_deg * DEG, r->vmax,
						     r->pos_deg * DEG, r->t);

			if (told != r->want)
				fail_msg("%s, reading %u: told %d", c->name, i, told);
		}
	}
}

SUITE_MAIN("proc_effect", NULL, NULL,
	   {
		   cmocka_unit_test(test_steps),
	   })

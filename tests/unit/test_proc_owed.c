// SPDX-License-Identifier: MIT
/*
 * The owed frames procedure (rmd/proc_owed.h), as tables: which frame a
 * control slot carries, in turn; which answers pay the debt (an echo of a
 * request booked after the debt began), which leave it unpaid, which say
 * nothing; resends; and the bound after which the motor is taken as
 * lost.  The loop's use of it is judged on the wire by test_lifecycle.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include <cmocka.h>

#include "rmd/proc_owed.h"
#include "harness/suite.h"

/* Control slots of a motor that owes `bits`, none answered: the frames they carry. */
static void test_next_in_turn(void **state)
{
	static const struct {
		unsigned bits;
		uint8_t want[4];
	} cases[] = {
		{ RMD_OWE_OFF | RMD_OWE_BRAKE, { 0x80, 0x78, 0x80, 0x78 } },
		{ RMD_OWE_OFF, { 0x80, 0x80, 0x80, 0x80 } },
		{ RMD_OWE_BRAKE, { 0x78, 0x78, 0x78, 0x78 } },
		{ 0, { 0, 0, 0, 0 } },
	};

	(void)state;
	for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
		struct rmd_owed o;

		rmd_owed_begin(&o, cases[k].bits, 10);
		for (unsigned n = 0; n < 4; n++) {
			uint8_t cmd = rmd_owed_next(&o);

			if (cmd != cases[k].want[n])
				fail_msg("bits %u, slot %u: 0x%02X, want 0x%02X", cases[k].bits, n,
					 cmd, cases[k].want[n]);
			if (cmd)
				rmd_owed_sent(&o, cmd);
		}
	}
}

/* One answer to a debt of 0x80 and 0x78 begun at sequence 10. */
static void test_answers(void **state)
{
	static const struct {
		const char *name;
		uint8_t cmd;
		uint64_t req_seq;
		bool repeats;
		enum rmd_owed_outcome want;
		uint8_t bits_after;
	} cases[] = {
		{ "0x80 echoed", 0x80, 10, true, RMD_OWED_PAID, RMD_OWE_BRAKE },
		{ "0x78 echoed", 0x78, 12, true, RMD_OWED_PAID, RMD_OWE_OFF },
		{ "an older 0x80 proves nothing", 0x80, 9, true, RMD_OWED_NONE,
		  RMD_OWE_OFF | RMD_OWE_BRAKE },
		{ "answered, not its echo", 0x80, 11, false, RMD_OWED_UNPAID,
		  RMD_OWE_OFF | RMD_OWE_BRAKE },
		{ "another command", 0x9C, 11, true, RMD_OWED_NONE, RMD_OWE_OFF | RMD_OWE_BRAKE },
	};

	(void)state;
	for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
		struct rmd_owed o;
		enum rmd_owed_outcome r;

		rmd_owed_begin(&o, RMD_OWE_OFF | RMD_OWE_BRAKE, 10);
		r = rmd_owed_answer(&o, cases[k].cmd, cases[k].req_seq, cases[k].repeats);
		if (r != cases[k].want || o.bits != cases[k].bits_after)
			fail_msg("%s: outcome %d, owed %u; want %d, %u", cases[k].name, r, o.bits,
				 cases[k].want, cases[k].bits_after);
	}
}

/* Both echoed: clear; an echo again after that changes nothing; nothing owed: none. */
static void test_paid_in_full(void **state)
{
	struct rmd_owed o;

	(void)state;
	rmd_owed_begin(&o, RMD_OWE_OFF | RMD_OWE_BRAKE, 0);
	assert_int_equal(rmd_owed_answer(&o, 0x78, 1, true), RMD_OWED_PAID);
	assert_int_equal(rmd_owed_answer(&o, 0x78, 2, true), RMD_OWED_AGAIN);
	assert_int_equal(rmd_owed_answer(&o, 0x80, 3, true), RMD_OWED_CLEAR);
	assert_int_equal(o.bits, 0);
	assert_int_equal(rmd_owed_next(&o), 0);
	assert_int_equal(rmd_owed_answer(&o, 0x80, 4, true), RMD_OWED_NONE);
	/* dropped (another state's entry): nothing owed */
	rmd_owed_begin(&o, RMD_OWE_OFF, 5);
	rmd_owed_drop(&o);
	assert_int_equal(rmd_owed_next(&o), 0);
	assert_false(rmd_owed_exhausted(&o));
}

/* Resends are told apart from first sends; RMD_OWED_SENDS_MAX unpaid: exhausted. */
static void test_resends_and_bound(void **state)
{
	struct rmd_owed o;
	unsigned resends = 0;

	(void)state;
	rmd_owed_begin(&o, RMD_OWE_OFF | RMD_OWE_BRAKE, 0);
	for (unsigned n = 0; n < RMD_OWED_SENDS_MAX; n++) {
		assert_false(rmd_owed_exhausted(&o));
		resends += rmd_owed_sent(&o, rmd_owed_next(&o));
	}
	assert_int_equal(resends, RMD_OWED_SENDS_MAX - 2); /* each frame's first is no resend */
	assert_true(rmd_owed_exhausted(&o));
	/* a new debt starts afresh */
	rmd_owed_begin(&o, RMD_OWE_BRAKE, 40);
	assert_false(rmd_owed_exhausted(&o));
	assert_false(rmd_owed_sent(&o, 0x78));
	assert_true(rmd_owed_sent(&o, 0x78));
}

SUITE_MAIN("proc_owed", NULL, NULL,
	   {
		   cmocka_unit_test(test_next_in_turn),
		   cmocka_unit_test(test_answers),
		   cmocka_unit_test(test_paid_in_full),
		   cmocka_unit_test(test_resends_and_bound),
	   })

// SPDX-License-Identifier: MIT
/*
 * The comm-loss arming procedure (rmd/proc_arm.h), as tables: what a
 * motor's protection is when forgotten (off, unsupported, pending); what
 * an answer to a write says (the request repeated, zeros, another time);
 * a round's steps (three writes, each awaited, a failed round, an answer
 * that ends it); an enable that waits, one refused (unsupported, a round
 * that failed lately), reported once an episode; bring-up's outcome
 * taken over; the request's bytes (V3 §2.30's worked example).  The
 * loop's use of it is judged on the wire by test_loop's comm-loss cases.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "rmd/codec.h"
#include "rmd/proc_arm.h"
#include "harness/suite.h"

#define MS INT64_C(1000000)

static void test_forget(void **state)
{
	static const struct {
		uint32_t ms;
		bool has_b3;
		uint8_t want;
	} cases[] = {
		{ 0, true, RMD_CL_OFF },
		{ 0, false, RMD_CL_OFF },
		{ 100, false, RMD_CL_UNSUPPORTED },
		{ 100, true, RMD_CL_PENDING },
	};

	(void)state;
	for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
		struct rmd_arm a = { .round = true, .want = true, .warned = true };

		rmd_arm_forget(&a, cases[k].ms, cases[k].has_b3);
		if (a.cl != cases[k].want || a.round || a.want || a.warned)
			fail_msg("%u ms, b3 %d: cl %u round %d want %d warned %d", cases[k].ms,
				 cases[k].has_b3, a.cl, a.round, a.want, a.warned);
		assert_int_equal(rmd_arm_pending(&a), cases[k].want == RMD_CL_PENDING);
	}
}

/* The frame a motor writes 1000 ms with (V3 §2.30: B3 00 00 00 E8 03 00 00). */
static struct rmd_frame written(void)
{
	struct rmd_msg msg;
	struct rmd_frame f;

	rmd_arm_request(1000, &msg);
	assert_int_equal(rmd_encode(RMD_PROTO_V3, RMD_DIR_REQUEST, 1, &msg, &f), 0);
	return f;
}

static void test_request_and_outcome(void **state)
{
	static const uint8_t want[8] = { 0xB3, 0, 0, 0, 0xE8, 0x03, 0, 0 };
	const struct rmd_frame req = written();
	static const struct {
		const char *name;
		uint8_t data[8];
		uint8_t len;
		enum rmd_comm_loss want;
	} cases[] = {
		{ "repeated", { 0xB3, 0, 0, 0, 0xE8, 0x03, 0, 0 }, 8, RMD_CL_ARMED },
		{ "zeros (V3 §2.30 example 2)", { 0xB3 }, 8, RMD_CL_ARMED_ZEROS },
		{ "another time", { 0xB3, 0, 0, 0, 0x64, 0, 0, 0 }, 8, RMD_CL_DIFFERS },
		{ "short", { 0xB3, 0, 0, 0, 0xE8, 0x03, 0 }, 7, RMD_CL_DIFFERS },
		{ "another command", { 0x9A }, 8, RMD_CL_DIFFERS },
	};

	(void)state;
	assert_int_equal(req.can_id, 0x141);
	assert_memory_equal(req.data, want, 8);
	for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
		struct rmd_frame rep = { .can_id = 0x241, .len = cases[k].len };

		memcpy(rep.data, cases[k].data, 8);
		if (rmd_arm_b3_outcome(req.data, &rep) != cases[k].want)
			fail_msg("%s: %d, want %d", cases[k].name,
				 rmd_arm_b3_outcome(req.data, &rep), cases[k].want);
	}
}

/* A round nobody answers: three writes, each awaited, then it fails (no answer). */
static void test_round_unanswered(void **state)
{
	struct rmd_arm a = { 0 };
	int64_t t = 1000 * MS;

	(void)state;
	rmd_arm_forget(&a, 100, true);
	rmd_arm_start_round(&a);
	/* away (LOST): the round waits */
	assert_int_equal(rmd_arm_step(&a, false, t), RMD_ARM_IDLE);
	for (unsigned n = 0; n < RMD_ARM_TRIES; n++) {
		assert_int_equal(rmd_arm_step(&a, true, t), RMD_ARM_WRITE);
		rmd_arm_written(&a, t + 5 * MS);
		assert_int_equal(rmd_arm_step(&a, true, t + 4 * MS), RMD_ARM_IDLE);
		t += 5 * MS;
	}
	assert_int_equal(rmd_arm_step(&a, true, t), RMD_ARM_FAILED);
	assert_int_equal(a.cl, RMD_CL_NO_ANSWER);
	assert_false(a.round);
	assert_int_equal(a.round_end_ns, t);
	assert_int_equal(rmd_arm_step(&a, true, t + MS), RMD_ARM_IDLE);
}

/* Answers during and after a round. */
static void test_answers(void **state)
{
	const struct rmd_frame req = written();
	struct rmd_frame same = req, other = req;
	struct rmd_arm a = { 0 };

	(void)state;
	same.can_id = 0x241;
	other.can_id = 0x241;
	other.data[4] = 0x64;
	other.data[5] = 0;
	rmd_arm_forget(&a, 1000, true);
	rmd_arm_start_round(&a);
	/* another time: the round goes on, and a failed round says it differs */
	assert_int_equal(rmd_arm_answer(&a, req.data, &other, 10), RMD_ARM_OTHER_TIME);
	assert_true(a.round);
	assert_int_equal(a.cl, RMD_CL_PENDING);
	for (unsigned n = 0; n < RMD_ARM_TRIES; n++) {
		assert_int_equal(rmd_arm_step(&a, true, 20), RMD_ARM_WRITE);
		rmd_arm_written(&a, 20);
	}
	assert_int_equal(rmd_arm_step(&a, true, 20), RMD_ARM_FAILED);
	assert_int_equal(a.cl, RMD_CL_DIFFERS);
	/* the echo, late: armed now, reported; again: as it was */
	a.warned = true;
	assert_int_equal(rmd_arm_answer(&a, req.data, &same, 30), RMD_ARM_NOW_ARMED);
	assert_int_equal(a.cl, RMD_CL_ARMED);
	assert_false(a.warned); /* a new episode of refusals */
	assert_int_equal(a.round_end_ns, 30);
	assert_int_equal(rmd_arm_answer(&a, req.data, &same, 40), RMD_ARM_STILL_ARMED);
	/* another time outside a round: it differs */
	assert_int_equal(rmd_arm_answer(&a, req.data, &other, 50), RMD_ARM_OTHER_TIME);
	assert_int_equal(a.cl, RMD_CL_DIFFERS);
	/* off by config: nothing to judge */
	rmd_arm_forget(&a, 0, true);
	assert_int_equal(rmd_arm_answer(&a, req.data, &same, 60), RMD_ARM_NOTHING);
	assert_int_equal(a.cl, RMD_CL_OFF);
}

/* Enables for a motor that is not armed. */
static void test_enables(void **state)
{
	const struct rmd_setpoint sp = { .enable = true, .mode = RMD_MODE_SPEED, .vel_rad_s = 1.0 };
	struct rmd_arm a = { 0 };
	int64_t t = 5000 * MS;

	(void)state;
	/* no 0xB3 (V2) and not off: refused, nothing to write; reported once */
	rmd_arm_forget(&a, 100, false);
	assert_int_equal(rmd_arm_enable_wanted(&a, &sp, t), RMD_ARM_REFUSE);
	assert_true(rmd_arm_refused(&a));
	assert_false(rmd_arm_refused(&a));
	assert_int_equal(a.rejects, 2);
	/* pending: a round starts and the enable waits, its setpoint kept */
	rmd_arm_forget(&a, 100, true);
	assert_int_equal(rmd_arm_enable_wanted(&a, &sp, t), RMD_ARM_WAIT);
	assert_true(a.round && a.want);
	assert_memory_equal(&a.sp, &sp, sizeof(sp));
	/* a round that failed just now: refused for RMD_ARM_ROUND_NS, then a new round */
	a.round = false;
	a.want = false;
	a.round_end_ns = t;
	assert_int_equal(rmd_arm_enable_wanted(&a, &sp, t + RMD_ARM_ROUND_NS - 1), RMD_ARM_REFUSE);
	assert_int_equal(rmd_arm_enable_wanted(&a, &sp, t + RMD_ARM_ROUND_NS), RMD_ARM_WAIT);
	assert_true(a.round);
	assert_int_equal(a.tries, 0);
}

/* Bring-up's writes taken over; off and unsupported stay what they are. */
static void test_took_over(void **state)
{
	struct rmd_arm a = { 0 };

	(void)state;
	rmd_arm_took_over(&a, 100, true, RMD_CL_ARMED_ZEROS, 7);
	assert_int_equal(a.cl, RMD_CL_ARMED_ZEROS);
	assert_int_equal(a.round_end_ns, 7);
	rmd_arm_took_over(&a, 100, true, RMD_CL_NO_ANSWER, 8);
	assert_int_equal(a.cl, RMD_CL_NO_ANSWER);
	rmd_arm_took_over(&a, 0, true, RMD_CL_ARMED, 9);
	assert_int_equal(a.cl, RMD_CL_OFF);
	rmd_arm_took_over(&a, 100, false, RMD_CL_PENDING, 9);
	assert_int_equal(a.cl, RMD_CL_UNSUPPORTED);
}

SUITE_MAIN("proc_arm", NULL, NULL,
	   {
		   cmocka_unit_test(test_forget),
		   cmocka_unit_test(test_request_and_outcome),
		   cmocka_unit_test(test_round_unanswered),
		   cmocka_unit_test(test_answers),
		   cmocka_unit_test(test_enables),
		   cmocka_unit_test(test_took_over),
	   })

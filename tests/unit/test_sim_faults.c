// SPDX-License-Identifier: MIT
/*
 * The simulator's fault engine (rmd/sim_faults.h), by itself: names and
 * their aliases, which entries make sense, windows opening and closing,
 * what each per-frame kind does to a frame, floods, and the next event.
 * The in-process wire's use of it is test_sim_wire; rmd-sim's, on a real
 * wire, test_rmd_sim.  Every window case runs on two time axes, the wire's
 * (0) and rmd-sim's (a CLOCK_MONOTONIC start subtracted), with one result.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "rmd/sim_faults.h"
#include "harness/suite.h"

#define S_NS INT64_C(1000000000)

static const struct rmd_sim_fault windows[] = {
	{ .kind = RMD_SIM_FAULT_DISAPPEAR,
	  .motor_id = 2,
	  .start_ns = 1 * S_NS,
	  .end_ns = 2 * S_NS,
	  .param = 1 },
	{ .kind = RMD_SIM_FAULT_ERROR_FLAG, .motor_id = 0, .start_ns = 3 * S_NS, .param = 0x1000 },
	{ .kind = RMD_SIM_FAULT_BUS_OFF, .start_ns = 5 * S_NS, .end_ns = 6 * S_NS },
	{ .kind = RMD_SIM_FAULT_FLOOD,
	  .start_ns = 7 * S_NS,
	  .end_ns = 8 * S_NS,
	  .param = S_NS / 4,
	  .can_id = 0x7FF },
	{ .kind = RMD_SIM_FAULT_DROP, .motor_id = 1, .probability = 1.0 },
};

static void test_names(void **state)
{
	(void)state;
	for (int k = 0; k < RMD_SIM_FAULT_COUNT; k++) {
		assert_string_equal(rmd_sim_fault_kind_name(k), rmd_sim_fault_kind_names[k]);
		assert_int_equal(rmd_sim_fault_kind_from_name(rmd_sim_fault_kind_name(k)), k);
	}
	assert_null(rmd_sim_fault_kind_names[RMD_SIM_FAULT_COUNT]);
	assert_null(rmd_sim_fault_kind_name(RMD_SIM_FAULT_COUNT));
	/* rmd-sim's old spellings stay aliases */
	assert_int_equal(rmd_sim_fault_kind_from_name("error"), RMD_SIM_FAULT_ERROR_FLAG);
	assert_int_equal(rmd_sim_fault_kind_from_name("bad-dlc"), RMD_SIM_FAULT_BAD_DLC);
	assert_int_equal(rmd_sim_fault_kind_from_name("Bus-Off"), RMD_SIM_FAULT_BUS_OFF);
	assert_int_equal(rmd_sim_fault_kind_from_name("explode"), -EINVAL);
	assert_int_equal(rmd_sim_fault_kind_from_name(NULL), -EINVAL);
	assert_int_equal(rmd_sim_fault_kind_from_name("a_name_far_too_long_for_a_kind"), -EINVAL);
}

static void test_check(void **state)
{
	static const struct {
		struct rmd_sim_fault f;
		int want;
	} cases[] = {
		{ { .kind = RMD_SIM_FAULT_DROP, .probability = 0.5 }, 0 },
		{ { .kind = RMD_SIM_FAULT_DROP, .probability = 1.5 }, -EINVAL },
		{ { .kind = RMD_SIM_FAULT_DROP, .motor_id = 33 }, -EINVAL },
		{ { .kind = RMD_SIM_FAULT_DELAY, .param = -1 }, -EINVAL },
		{ { .kind = RMD_SIM_FAULT_BAD_DLC, .param = 8 }, -EINVAL },
		{ { .kind = RMD_SIM_FAULT_WRONG_ID, .param = 0 }, -EINVAL },
		{ { .kind = RMD_SIM_FAULT_DISAPPEAR, .param = 2 }, -EINVAL },
		{ { .kind = RMD_SIM_FAULT_ERROR_FLAG, .param = 0x10000 }, -EINVAL },
		{ { .kind = RMD_SIM_FAULT_BUS_OFF, .motor_id = 1 }, -EINVAL },
		{ { .kind = RMD_SIM_FAULT_BUS_POWER }, 0 },
		{ { .kind = RMD_SIM_FAULT_BUS_POWER, .motor_id = 2 }, -EINVAL },
		{ { .kind = RMD_SIM_FAULT_BUS_POWER, .param = 1 }, -EINVAL },
		{ { .kind = RMD_SIM_FAULT_FLOOD, .param = 0 }, -EINVAL },
		{ { .kind = RMD_SIM_FAULT_FLOOD, .param = 1, .can_id = 0x800 }, -EINVAL },
		{ { .kind = RMD_SIM_FAULT_FLOOD, .param = 1, .start_ns = 5, .end_ns = 5 },
		  -EINVAL },
		{ { .kind = RMD_SIM_FAULT_COUNT }, -EINVAL },
	};
	struct rmd_sim_faults fs;

	(void)state;
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++)
		if (rmd_sim_fault_check(&cases[i].f) != cases[i].want)
			fail_msg("case %zu: expected %d", i, cases[i].want);
	rmd_sim_faults_init(&fs);
	assert_int_equal(rmd_sim_faults_set(&fs, windows, 5), 0);
	assert_int_equal(rmd_sim_faults_set(&fs, &cases[1].f, 1), -EINVAL);
	assert_int_equal(fs.n, 5); /* unchanged */
	assert_int_equal(rmd_sim_faults_set(&fs, windows, RMD_SIM_MAX_FAULTS + 1), -E2BIG);
}

/* The windows on an axis whose 0 is at `origin` of the caller's clock. */
static void run_windows(int64_t origin)
{
	struct rmd_sim_faults fs;
	uint64_t counts[RMD_SIM_FAULT_COUNT] = { 0 };
	struct rmd_frame f;
	uint64_t rng = 1;
	uint32_t ch;

#define AT(sec) ((int64_t)((sec)*S_NS) + origin - origin)
	assert_int_equal(rmd_sim_faults_set(&fs, windows, 5), 0);
	assert_int_equal(rmd_sim_faults_update(&fs, AT(0.5), counts), 0);
	assert_int_equal(rmd_sim_faults_next_ns(&fs, AT(0.5)), AT(1));
	ch = rmd_sim_faults_update(&fs, AT(1), counts);
	assert_int_equal(ch, 1u << 0);
	assert_true(fs.open[0]);
	assert_true(rmd_sim_faults_absent(&fs, 2));
	assert_true(rmd_sim_faults_unpowered(&fs, 2));
	assert_false(rmd_sim_faults_absent(&fs, 1));
	assert_int_equal(counts[RMD_SIM_FAULT_DISAPPEAR], 1);
	assert_int_equal(rmd_sim_faults_next_ns(&fs, AT(1)), AT(2));
	assert_int_equal(rmd_sim_faults_update(&fs, AT(2), counts), 1u << 0);
	assert_false(rmd_sim_faults_absent(&fs, 2));
	assert_int_equal(rmd_sim_faults_update(&fs, AT(3), counts), 1u << 1);
	assert_int_equal(rmd_sim_faults_error_bits(&fs, 7), 0x1000);
	assert_false(rmd_sim_faults_bus_off(&fs));
	rmd_sim_faults_update(&fs, AT(5.5), counts);
	assert_true(rmd_sim_faults_bus_off(&fs));
	rmd_sim_faults_update(&fs, AT(7), counts);
	assert_false(rmd_sim_faults_bus_off(&fs));
	/* the flood: a frame every 250 ms from its start, counted per frame */
	assert_int_equal(counts[RMD_SIM_FAULT_FLOOD], 0);
	assert_true(rmd_sim_faults_flood_due(&fs, 3, AT(7)));
	assert_false(rmd_sim_faults_flood_due(&fs, 2, AT(7)));
	assert_int_equal(rmd_sim_faults_flood_take(&fs, 3, &rng, &f, counts), AT(7));
	assert_int_equal(f.can_id, 0x7FF);
	assert_int_equal(f.len, 8);
	assert_false(rmd_sim_faults_flood_due(&fs, 3, AT(7)));
	assert_int_equal(rmd_sim_faults_next_ns(&fs, AT(7)), AT(7.25));
	assert_int_equal(counts[RMD_SIM_FAULT_FLOOD], 1);
	rmd_sim_faults_update(&fs, AT(8), counts);
	assert_false(rmd_sim_faults_flood_due(&fs, 3, AT(9)));
	assert_int_equal(rmd_sim_faults_next_ns(&fs, AT(8)), INT64_MAX);
	assert_int_equal(counts[RMD_SIM_FAULT_DISAPPEAR], 1);
	assert_int_equal(counts[RMD_SIM_FAULT_ERROR_FLAG], 1);
	assert_int_equal(counts[RMD_SIM_FAULT_BUS_OFF], 1);
#undef AT
}

/* A bus power cut: every motor absent and unpowered while it lasts, counted once. */
static void test_bus_power(void **state)
{
	const struct rmd_sim_fault f[] = {
		{ .kind = RMD_SIM_FAULT_DISAPPEAR, .motor_id = 3, .start_ns = 0, .param = 0 },
		{ .kind = RMD_SIM_FAULT_BUS_POWER, .start_ns = 1 * S_NS, .end_ns = 3 * S_NS },
	};
	uint64_t counts[RMD_SIM_FAULT_COUNT] = { 0 };
	struct rmd_sim_faults fs;

	(void)state;
	assert_true(rmd_sim_fault_is_window(RMD_SIM_FAULT_BUS_POWER));
	assert_int_equal(rmd_sim_fault_kind_from_name("bus-power"), RMD_SIM_FAULT_BUS_POWER);
	rmd_sim_faults_init(&fs);
	assert_int_equal(rmd_sim_faults_set(&fs, f, 2), 0);
	rmd_sim_faults_update(&fs, S_NS / 2, counts);
	assert_false(rmd_sim_faults_bus_unpowered(&fs));
	assert_true(rmd_sim_faults_absent(&fs, 3));
	assert_false(rmd_sim_faults_unpowered(&fs, 3));
	assert_false(rmd_sim_faults_absent(&fs, 1));
	assert_int_equal(rmd_sim_faults_update(&fs, S_NS, counts), 1u << 1);
	assert_true(rmd_sim_faults_bus_unpowered(&fs));
	for (uint8_t id = 1; id <= RMD_MAX_MOTORS; id++) {
		assert_true(rmd_sim_faults_absent(&fs, id));
		assert_true(rmd_sim_faults_unpowered(&fs, id));
	}
	assert_int_equal(rmd_sim_faults_next_ns(&fs, S_NS), 3 * S_NS);
	assert_int_equal(rmd_sim_faults_update(&fs, 3 * S_NS, counts), 1u << 1);
	assert_false(rmd_sim_faults_bus_unpowered(&fs));
	assert_false(rmd_sim_faults_unpowered(&fs, 1));
	assert_true(rmd_sim_faults_absent(&fs, 3)); /* its own cable cut stays */
	assert_int_equal(counts[RMD_SIM_FAULT_BUS_POWER], 1);
}

static void test_windows(void **state)
{
	(void)state;
	run_windows(0);			       /* the in-process wire's axis */
	run_windows(INT64_C(123456789012345)); /* rmd-sim's: CLOCK_MONOTONIC minus its start */
}

static void test_per_frame(void **state)
{
	static const struct {
		struct rmd_sim_fault f;
		uint32_t can_id_in, can_id_out;
		uint8_t len_out;
		int64_t delay_ns;
		bool kept;
	} cases[] = {
		{ { .kind = RMD_SIM_FAULT_DROP, .probability = 1 }, 0x241, 0x241, 8, 0, false },
		{ { .kind = RMD_SIM_FAULT_DROP, .probability = 0 }, 0x241, 0x241, 8, 0, true },
		{ { .kind = RMD_SIM_FAULT_DROP, .motor_id = 2, .probability = 1 },
		  0x241,
		  0x241,
		  8,
		  0,
		  true }, /* another motor's */
		{ { .kind = RMD_SIM_FAULT_DROP, .probability = 1, .start_ns = 10 },
		  0x241,
		  0x241,
		  8,
		  0,
		  true }, /* window not open yet */
		{ { .kind = RMD_SIM_FAULT_DELAY, .probability = 1, .param = 150000 },
		  0x241,
		  0x241,
		  8,
		  150000,
		  true },
		{ { .kind = RMD_SIM_FAULT_BAD_DLC, .probability = 1, .param = 3 },
		  0x241,
		  0x241,
		  3,
		  0,
		  true },
		{ { .kind = RMD_SIM_FAULT_WRONG_ID, .probability = 1, .param = 5 },
		  0x241,
		  0x245,
		  8,
		  0,
		  true },
		{ { .kind = RMD_SIM_FAULT_WRONG_ID, .probability = 1, .param = 5 },
		  0x141,
		  0x145,
		  8,
		  0,
		  true }, /* V2 */
		{ { .kind = RMD_SIM_FAULT_WRONG_ID, .probability = 1, .param = 5 },
		  0x501,
		  0x505,
		  8,
		  0,
		  true }, /* MIT */
		{ { .kind = RMD_SIM_FAULT_WRONG_ID, .probability = 1, .param = 5 },
		  0x300,
		  0x300,
		  8,
		  0,
		  true }, /* carries no ID: not hit */
		{ { .kind = RMD_SIM_FAULT_GARBAGE, .probability = 1 }, 0x241, 0x241, 8, 0, true },
	};

	(void)state;
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		struct rmd_sim_faults fs;
		uint64_t counts[RMD_SIM_FAULT_COUNT] = { 0 };
		struct rmd_frame f = { .can_id = cases[i].can_id_in, .len = 8 };
		uint64_t rng = 42;
		int64_t ready = 1000;
		bool kept, hit;

		assert_int_equal(rmd_sim_faults_set(&fs, &cases[i].f, 1), 0);
		kept = rmd_sim_faults_frame(&fs, &rng, 1, 0, &f, &ready, counts);
		hit = counts[cases[i].f.kind] == 1;
		if (kept != cases[i].kept || f.can_id != cases[i].can_id_out ||
		    f.len != cases[i].len_out || ready != 1000 + cases[i].delay_ns)
			fail_msg("case %zu (%s): kept %d id 0x%03X len %u ready %lld", i,
				 rmd_sim_fault_kind_name(cases[i].f.kind), kept, f.can_id, f.len,
				 (long long)ready);
		if (cases[i].f.kind == RMD_SIM_FAULT_GARBAGE) {
			uint8_t zero[8] = { 0 };

			assert_true(memcmp(f.data, zero, 8) != 0);
		}
		/* counted when it acted */
		assert_int_equal(hit, cases[i].can_id_in != cases[i].can_id_out ||
					      cases[i].len_out != 8 || cases[i].delay_ns ||
					      !cases[i].kept ||
					      cases[i].f.kind == RMD_SIM_FAULT_GARBAGE);
	}
}

/* A per-frame fault limited to the answers of one command, and to the first count of them. */
static void test_cmd_and_count(void **state)
{
	static const struct rmd_sim_fault drop_b3 = {
		.kind = RMD_SIM_FAULT_DROP, .motor_id = 1, .probability = 1, .cmd = 0xB3, .count = 2
	};
	struct rmd_sim_faults fs;
	uint64_t rng = 1, counts[RMD_SIM_FAULT_COUNT] = { 0 };
	struct rmd_frame b3 = { .can_id = 0x241, .len = 8, .data = { 0xB3, 0, 0, 0, 0x64 } };
	struct rmd_frame st = { .can_id = 0x241, .len = 8, .data = { 0x9C } };
	int64_t ready = 0;

	(void)state;
	assert_int_equal(rmd_sim_faults_set(&fs, &drop_b3, 1), 0);
	/* another command's answer passes; the first two 0xB3 answers are lost, not the third */
	assert_true(rmd_sim_faults_frame(&fs, &rng, 1, 0, &st, &ready, counts));
	assert_false(rmd_sim_faults_frame(&fs, &rng, 1, 0, &b3, &ready, counts));
	assert_true(rmd_sim_faults_frame(&fs, &rng, 1, 0, &st, &ready, counts));
	assert_false(rmd_sim_faults_frame(&fs, &rng, 1, 0, &b3, &ready, counts));
	assert_true(rmd_sim_faults_frame(&fs, &rng, 1, 0, &b3, &ready, counts));
	assert_int_equal(counts[RMD_SIM_FAULT_DROP], 2);
	/* setting the table again starts the count again */
	assert_int_equal(rmd_sim_faults_set(&fs, &drop_b3, 1), 0);
	assert_false(rmd_sim_faults_frame(&fs, &rng, 1, 0, &b3, &ready, counts));
}

SUITE_MAIN("sim_faults", NULL, NULL,
	   {
		   cmocka_unit_test(test_names),
		   cmocka_unit_test(test_check),
		   cmocka_unit_test(test_bus_power),
		   cmocka_unit_test(test_windows),
		   cmocka_unit_test(test_per_frame),
		   cmocka_unit_test(test_cmd_and_count),
	   })

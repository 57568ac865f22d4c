// SPDX-License-Identifier: MIT
/*
 * Bus planner: budgets with the exact numbers of DESIGN.md (135-bit frames,
 * 3 V3/MIT motors or 4 batched V2 motors per 1 Mbit/s bus at 1 kHz), V2
 * 0x280 batching, rate divisors, status polls, RS485, and
 * `rmdd --check-config` run as a process on the examples.
 *
 * The rmdd binary: $RMDD, else $BUILD/rmdd, else build/rmdd.  Data under
 * the repository root (the current directory; $RMD_SRCDIR overrides).
 */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>

#include "rmd/can_timing.h"
#include "rmd/config.h"
#include "rmd/config_yaml.h"
#include "rmd/plan.h"

static struct rmd_config cfg; /* large: off the stack */
static struct rmd_plan plan;
static char err[8192];
static char rmdd[4096];
static char srcdir[1024] = ".";

static void cfg_reset(unsigned rate_hz)
{
	rmd_config_defaults(&cfg);
	cfg.loop.rate_hz = rate_hz;
	snprintf(cfg.source, sizeof(cfg.source), "test");
}

static unsigned add_bus(const char *name, enum rmd_bus_kind kind)
{
	struct rmd_config_bus *b = &cfg.buses[cfg.n_buses];

	memset(b, 0, sizeof(*b));
	snprintf(b->name, sizeof(b->name), "%s", name);
	snprintf(b->interface, sizeof(b->interface), "%s", name);
	snprintf(b->device, sizeof(b->device), "/dev/ttyUSB0");
	b->kind = kind;
	b->bitrate = 1000000;
	b->baud = 1000000;
	b->turnaround_ns = RMD_CONFIG_DEFAULT_RS485_TURNAROUND_NS;
	return cfg.n_buses++;
}

static unsigned add_motor(unsigned bus, unsigned id, enum rmd_proto proto, enum rmd_mode mode,
			  unsigned divisor, double poll_hz)
{
	struct rmd_config_motor *m = &cfg.motors[cfg.n_motors];

	memset(m, 0, sizeof(*m));
	snprintf(m->name, sizeof(m->name), "m%u", cfg.n_motors + 1);
	m->bus = bus;
	m->id = (uint8_t)id;
	m->proto = proto;
	m->mode = mode;
	m->direction = 1;
	m->gear_ratio = 1;
	m->torque_constant_nm_a = 2;
	m->mit = rmd_mit_default_ranges;
	m->rate_divisor = divisor;
	m->status_poll_hz = poll_hz;
	return cfg.n_motors++;
}

static int build(void)
{
	return rmd_plan_build(&cfg, &plan, err, sizeof(err));
}

static void expect_ok(void)
{
	int r = build();

	if (r)
		fail_msg("plan refused (%d):\n%s", r, err);
	assert_true(plan.feasible);
}

static void expect_in(const char *haystack, const char *needle)
{
	if (!strstr(haystack, needle))
		fail_msg("expected \"%s\" in:\n%s", needle, haystack);
}

/* 135 bits at 1 Mbit/s */
#define FRAME_NS 135000

/*
 * Walk `cycles` cycles of bus b through rmd_plan_cycle() and check it
 * against the plan: every cycle within the worst case and the cycle, at
 * most one status poll, each motor commanded exactly at its divisor unless
 * a poll takes its place.  Counts per motor go to ctrl[] and polls[].
 */
static void walk(unsigned b, uint64_t cycles, unsigned ctrl[RMD_MAX_MOTORS],
		 unsigned polls[RMD_MAX_MOTORS])
{
	const struct rmd_plan_bus *pb = &plan.bus[b];
	struct rmd_plan_slot s[RMD_PLAN_MAX_SLOTS];

	memset(ctrl, 0, RMD_MAX_MOTORS * sizeof(ctrl[0]));
	memset(polls, 0, RMD_MAX_MOTORS * sizeof(polls[0]));
	for (uint64_t n = 0; n < cycles; n++) {
		unsigned cnt = rmd_plan_cycle(&plan, b, n, s), frames = 0, status = 0;
		int polled = -1;

		assert_true(cnt <= RMD_PLAN_MAX_SLOTS);
		for (unsigned i = 0; i < cnt; i++) {
			frames += 1u + s[i].replies;
			switch (s[i].kind) {
			case RMD_SLOT_CONTROL:
				ctrl[s[i].motor]++;
				break;
			case RMD_SLOT_V2_TORQUES:
				assert_int_equal(s[i].can_id, 0x280);
				assert_int_equal(i, 0);
				for (unsigned l = 0; l < pb->n_motors; l++)
					if (pb->batched & (1u << l))
						ctrl[pb->motors[l]]++;
				break;
			case RMD_SLOT_STATUS:
				status++;
				polls[s[i].motor]++;
				polled = s[i].motor;
				assert_int_equal(s[i].can_id, 0x140 + cfg.motors[s[i].motor].id);
				break;
			}
		}
		assert_true(status <= 1);
		assert_true(frames <= pb->max_frames);
		assert_true(rmd_plan_cost_ns(pb, frames, cnt) <= pb->worst_ns);
		assert_true(pb->worst_ns <= plan.period_ns);
		/* every motor due in this cycle is commanded, unless polled in its place */
		for (unsigned l = 0; l < pb->n_motors; l++) {
			unsigned mi = pb->motors[l];
			const struct rmd_plan_motor *pm = &plan.motor[mi];
			bool due = n % pm->divisor == pm->phase, seen = false;

			for (unsigned i = 0; i < cnt; i++)
				if ((s[i].kind == RMD_SLOT_CONTROL && s[i].motor == mi) ||
				    (s[i].kind == RMD_SLOT_V2_TORQUES && pm->batched))
					seen = true;
			if (due && !seen && polled != (int)mi)
				fail_msg("cycle %llu: motor %s due but not commanded",
					 (unsigned long long)n, cfg.motors[mi].name);
			if (!due && seen)
				fail_msg("cycle %llu: motor %s commanded out of turn",
					 (unsigned long long)n, cfg.motors[mi].name);
		}
	}
}

/* ------------------------------------------------------------------ */

static void test_five_v3_refused(void **state)
{
	(void)state;
	cfg_reset(1000);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	for (unsigned i = 1; i <= 5; i++)
		add_motor(0, i, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 10);
	assert_int_equal(build(), -ENOSPC);
	assert_string_equal(err, "can0: 5 motors at 1000 Hz need 1350 µs per cycle worst case, "
				 "the cycle is 1000 µs: use ≤ 3 motors, or a rate ≤ 740 Hz");
	assert_false(plan.feasible);
	assert_false(plan.bus[0].feasible);
	assert_int_equal(plan.bus[0].control_ns, 10 * FRAME_NS);
	/* at the suggested rate it fits */
	cfg.loop.rate_hz = 740;
	expect_ok();
	cfg.loop.rate_hz = 741;
	assert_int_equal(build(), -ENOSPC);
}

static void test_three_v3_accepted(void **state)
{
	unsigned ctrl[RMD_MAX_MOTORS], polls[RMD_MAX_MOTORS];
	struct rmd_plan_slot s[RMD_PLAN_MAX_SLOTS];
	const struct rmd_plan_bus *pb = &plan.bus[0];

	(void)state;
	cfg_reset(1000);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	for (unsigned i = 1; i <= 3; i++)
		add_motor(0, i, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 10);
	expect_ok();
	assert_string_equal(err, "");
	assert_int_equal(rmd_can_frame_bits_worst(8), 135);
	assert_int_equal(pb->control_ns, 6 * FRAME_NS);
	assert_int_equal(pb->worst_ns, 6 * FRAME_NS); /* polls take a setpoint's place */
	assert_int_equal(pb->max_frames, 6);
	assert_int_equal(pb->max_requests, 3);
	assert_int_equal(rmd_plan_cycle(&plan, 0, 1, s), 3);
	for (unsigned i = 0; i < 3; i++) {
		assert_int_equal(s[i].kind, RMD_SLOT_CONTROL);
		assert_int_equal(s[i].motor, i);
		assert_int_equal(s[i].can_id, 0x141 + i);
		assert_int_equal(s[i].replies, 1);
	}
	walk(0, pb->hyperperiod * 3, ctrl, polls);
	for (unsigned i = 0; i < 3; i++) {
		assert_true(plan.motor[i].poll_hz >= 10.0);
		assert_int_equal(plan.motor[i].replacing, plan.motor[i].polls);
		/* the polls of three hyperperiods, and a setpoint fewer each */
		assert_int_equal(polls[i], 3 * plan.motor[i].polls);
		assert_int_equal(ctrl[i] + polls[i], pb->hyperperiod * 3);
	}
	assert_int_equal(rmd_plan_cycle(&plan, 1, 0, s), 0); /* no such bus */
}

static void test_three_mit_accepted(void **state)
{
	struct rmd_plan_slot s[RMD_PLAN_MAX_SLOTS];
	unsigned ctrl[RMD_MAX_MOTORS], polls[RMD_MAX_MOTORS];

	(void)state;
	cfg_reset(1000);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	for (unsigned i = 1; i <= 3; i++)
		add_motor(0, i, RMD_PROTO_MIT, RMD_MODE_MIT, 1, 10);
	expect_ok();
	assert_int_equal(plan.bus[0].worst_ns, 6 * FRAME_NS);
	assert_int_equal(rmd_plan_cycle(&plan, 0, 1, s), 3);
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(s[i].can_id, 0x401 + i);
	walk(0, plan.bus[0].hyperperiod, ctrl, polls);
	/* the polls speak V3 0x9A on 0x140 + ID (checked in walk) */
	assert_int_equal(polls[0] + polls[1] + polls[2], plan.bus[0].n_polls);
	/* a fourth motor does not fit */
	add_motor(0, 4, RMD_PROTO_MIT, RMD_MODE_MIT, 1, 10);
	assert_int_equal(build(), -ENOSPC);
	expect_in(err, "can0: 4 motors at 1000 Hz need 1080 µs per cycle worst case, the cycle "
		       "is 1000 µs: use ≤ 3 motors, or a rate ≤ 925 Hz");
}

static void test_four_v2_batched(void **state)
{
	struct rmd_plan_slot s[RMD_PLAN_MAX_SLOTS];
	unsigned ctrl[RMD_MAX_MOTORS], polls[RMD_MAX_MOTORS];
	const struct rmd_plan_bus *pb = &plan.bus[0];
	unsigned n;

	(void)state;
	cfg_reset(1000);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	for (unsigned i = 1; i <= 4; i++)
		add_motor(0, i, RMD_PROTO_V2, RMD_MODE_TORQUE, 1, 10);
	expect_ok();
	assert_int_equal(pb->batch, RMD_BATCH_ON);
	assert_int_equal(pb->batched, 0xF);
	assert_int_equal(pb->control_ns, 5 * FRAME_NS); /* one 0x280 frame + 4 replies */
	assert_int_equal(pb->worst_ns, 7 * FRAME_NS);	/* a poll fits beside it */
	n = rmd_plan_cycle(&plan, 0, 1, s);
	assert_int_equal(n, 1);
	assert_int_equal(s[0].kind, RMD_SLOT_V2_TORQUES);
	assert_int_equal(s[0].can_id, 0x280);
	assert_int_equal(s[0].replies, 4);
	walk(0, pb->hyperperiod, ctrl, polls);
	for (unsigned i = 0; i < 4; i++) {
		assert_int_equal(ctrl[i], pb->hyperperiod);
		assert_int_equal(plan.motor[i].replacing, 0);
		assert_true(plan.motor[i].poll_hz >= 10.0);
	}
}

/*
 * V2 §4.1: the motors take the torque of their own ID's slot, so motors 2,
 * 3 and 4 share one 0x280 frame whether or not motor 1 exists; motor 5 is
 * commanded on its own.  6 frames: it fits.
 */
static void test_v2_ids_2_to_5(void **state)
{
	struct rmd_plan_slot s[RMD_PLAN_MAX_SLOTS];
	const struct rmd_plan_bus *pb = &plan.bus[0];

	(void)state;
	cfg_reset(1000);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	for (unsigned i = 2; i <= 5; i++)
		add_motor(0, i, RMD_PROTO_V2, RMD_MODE_TORQUE, 1, 0);
	expect_ok();
	assert_int_equal(pb->batched, 0x7);
	assert_int_equal(pb->control_ns, 6 * FRAME_NS);
	assert_int_equal(rmd_plan_cycle(&plan, 0, 0, s), 2);
	assert_int_equal(s[0].kind, RMD_SLOT_V2_TORQUES);
	assert_int_equal(s[0].replies, 3);
	assert_int_equal(s[1].kind, RMD_SLOT_CONTROL);
	assert_int_equal(s[1].can_id, 0x145);
}

/* IDs 5..8 cannot share a 0x280 frame: 8 frames, refused. */
static void test_v2_unbatched_refused(void **state)
{
	(void)state;
	cfg_reset(1000);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	for (unsigned i = 5; i <= 8; i++)
		add_motor(0, i, RMD_PROTO_V2, RMD_MODE_TORQUE, 1, 10);
	assert_int_equal(build(), -ENOSPC);
	assert_int_equal(plan.bus[0].batch, RMD_BATCH_NONE);
	assert_string_equal(err, "can0: 4 motors at 1000 Hz need 1080 µs per cycle worst case, "
				 "the cycle is 1000 µs: use ≤ 3 motors, or a rate ≤ 925 Hz");
}

/* No 0x280 frame when a motor would misread it. */
static void test_v2_batch_conditions(void **state)
{
	(void)state;
	/* a V3 motor on the bus takes 0x280 as a broadcast command */
	cfg_reset(1000);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	add_motor(0, 1, RMD_PROTO_V2, RMD_MODE_TORQUE, 1, 0);
	add_motor(0, 2, RMD_PROTO_V2, RMD_MODE_TORQUE, 1, 0);
	add_motor(0, 5, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 0);
	expect_ok();
	assert_int_equal(plan.bus[0].batch, RMD_BATCH_V3_ON_BUS);
	assert_int_equal(plan.bus[0].batched, 0);
	assert_int_equal(plan.bus[0].control_ns, 6 * FRAME_NS);
	/* a V2 motor with ID 1..4 in speed mode would take the torque */
	cfg_reset(1000);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	add_motor(0, 1, RMD_PROTO_V2, RMD_MODE_TORQUE, 1, 0);
	add_motor(0, 2, RMD_PROTO_V2, RMD_MODE_SPEED, 1, 0);
	add_motor(0, 3, RMD_PROTO_V2, RMD_MODE_TORQUE, 1, 0);
	expect_ok();
	assert_int_equal(plan.bus[0].batch, RMD_BATCH_MODES);
	assert_int_equal(plan.bus[0].batched, 0);
	/* different divisors */
	cfg.motors[1].mode = RMD_MODE_TORQUE;
	cfg.motors[1].rate_divisor = 2;
	expect_ok();
	assert_int_equal(plan.bus[0].batch, RMD_BATCH_DIVISORS);
	/* one candidate: nothing to batch */
	cfg_reset(1000);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	add_motor(0, 1, RMD_PROTO_V2, RMD_MODE_TORQUE, 1, 0);
	add_motor(0, 6, RMD_PROTO_V2, RMD_MODE_TORQUE, 1, 0);
	expect_ok();
	assert_int_equal(plan.bus[0].batch, RMD_BATCH_NONE);
}

/* Motors with divisor 2 take turns: 6 V3 motors fit where 5 at divisor 1 do not. */
static void test_divisors_spread(void **state)
{
	unsigned ctrl[RMD_MAX_MOTORS], polls[RMD_MAX_MOTORS];
	const struct rmd_plan_bus *pb = &plan.bus[0];

	(void)state;
	cfg_reset(1000);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	for (unsigned i = 1; i <= 6; i++)
		add_motor(0, i, RMD_PROTO_V3, RMD_MODE_TORQUE, 2, 0);
	expect_ok();
	assert_int_equal(pb->hc, 2);
	assert_int_equal(pb->control_ns, 6 * FRAME_NS);
	assert_int_equal(pb->frames[0], 6);
	assert_int_equal(pb->frames[1], 6);
	walk(0, 100, ctrl, polls);
	for (unsigned i = 0; i < 6; i++)
		assert_int_equal(ctrl[i], 50);

	/* mixed: 1 motor every cycle, 2 every 2nd, 4 every 4th: 1+1+1 per cycle */
	cfg_reset(1000);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	add_motor(0, 1, RMD_PROTO_V3, RMD_MODE_TORQUE, 4, 0);
	add_motor(0, 2, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 0);
	add_motor(0, 3, RMD_PROTO_V3, RMD_MODE_TORQUE, 2, 0);
	add_motor(0, 4, RMD_PROTO_V3, RMD_MODE_TORQUE, 4, 0);
	add_motor(0, 5, RMD_PROTO_V3, RMD_MODE_TORQUE, 2, 0);
	add_motor(0, 6, RMD_PROTO_V3, RMD_MODE_TORQUE, 4, 0);
	add_motor(0, 7, RMD_PROTO_V3, RMD_MODE_TORQUE, 4, 0);
	expect_ok();
	assert_int_equal(pb->hc, 4);
	for (unsigned c = 0; c < 4; c++)
		assert_int_equal(pb->frames[c], 6);
	assert_true(fabs(pb->avg_frames - 6.0) < 1e-9);
	walk(0, 400, ctrl, polls);
	for (unsigned i = 0; i < 7; i++)
		assert_int_equal(ctrl[i], 400 / cfg.motors[i].rate_divisor);

	/* divisors whose pattern is too long */
	cfg_reset(1000);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	add_motor(0, 1, RMD_PROTO_V3, RMD_MODE_TORQUE, 7, 0);
	add_motor(0, 2, RMD_PROTO_V3, RMD_MODE_TORQUE, 11, 0);
	assert_int_equal(build(), -EINVAL);
	expect_in(err, "can0: rate divisors 7, 11 repeat every 77 cycles, more than 64");
}

/* At most one poll per cycle, evenly spread, at no less than the asked rate. */
static void test_polls_spread(void **state)
{
	unsigned ctrl[RMD_MAX_MOTORS], polls[RMD_MAX_MOTORS];
	struct rmd_plan_slot s[RMD_PLAN_MAX_SLOTS];
	const struct rmd_plan_bus *pb = &plan.bus[0];
	uint64_t last[RMD_MAX_MOTORS], gap[RMD_MAX_MOTORS];

	(void)state;
	cfg_reset(1000);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	add_motor(0, 1, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 10);
	add_motor(0, 2, RMD_PROTO_MIT, RMD_MODE_MIT, 1, 20);
	add_motor(0, 3, RMD_PROTO_V3, RMD_MODE_SPEED, 2, 5);
	expect_ok();
	/* 2 motors every cycle + 1 every other: room for an extra poll */
	assert_int_equal(pb->control_ns, 6 * FRAME_NS);
	assert_int_equal(pb->worst_ns, 6 * FRAME_NS);
	for (unsigned k = 0; k < pb->n_polls; k++)
		assert_false(pb->polls[k].replaces);
	assert_int_equal(pb->poll_every % pb->hc, 0);
	for (unsigned i = 0; i < 3; i++)
		assert_true(plan.motor[i].poll_hz >= cfg.motors[i].status_poll_hz);
	/* 10 : 20 : 5 -> 2 : 4 : 1 entries */
	assert_int_equal(pb->n_polls, 7);
	assert_int_equal(plan.motor[0].polls, 2);
	assert_int_equal(plan.motor[1].polls, 4);
	assert_int_equal(plan.motor[2].polls, 1);
	walk(0, pb->hyperperiod * 2, ctrl, polls);
	assert_int_equal(polls[0], 4);
	assert_int_equal(polls[1], 8);
	assert_int_equal(polls[2], 2);
	/* the same motor's polls come at even intervals */
	memset(last, 0, sizeof(last));
	memset(gap, 0, sizeof(gap));
	for (uint64_t n = 0; n < pb->hyperperiod * 3; n++) {
		unsigned cnt = rmd_plan_cycle(&plan, 0, n, s);

		for (unsigned i = 0; i < cnt; i++) {
			unsigned m = s[i].motor;

			if (s[i].kind != RMD_SLOT_STATUS)
				continue;
			if (last[m] && n - last[m] > gap[m])
				gap[m] = n - last[m];
			last[m] = n;
		}
	}
	/* no motor waits longer than 1/status_poll_hz for its next poll */
	assert_true(gap[0] > 0 && gap[0] <= 100);
	assert_true(gap[1] > 0 && gap[1] <= 50);
	assert_true(gap[2] > 0 && gap[2] <= 200);

	/* the sum of the polls cannot exceed one per cycle */
	cfg_reset(100);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	add_motor(0, 1, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 60);
	add_motor(0, 2, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 60);
	assert_int_equal(build(), -ENOSPC);
	expect_in(err, "can0: status polls at 120 Hz in all do not fit in one poll every 1 cycle "
		       "(100 a second at 100 Hz): lower status_poll_hz");
}

/* A poll of a motor in the 0x280 frame cannot take its place: it needs room. */
static void test_poll_no_room(void **state)
{
	(void)state;
	cfg_reset(1000);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	for (unsigned i = 1; i <= 5; i++)
		add_motor(0, i, RMD_PROTO_V2, RMD_MODE_TORQUE, 1, 10);
	/* 0x280 + 4 replies + motor 5's 2 frames = 7 frames: full */
	assert_int_equal(build(), -ENOSPC);
	assert_int_equal(plan.bus[0].control_ns, 7 * FRAME_NS);
	expect_in(err, "can0: no room for the status polls of motor m1, which is in the 0x280 "
		       "frame: the least busy cycle with a poll needs 1215 µs of 1000 µs; set "
		       "its status_poll_hz to 0");
	/* without polls for the batched motors, motor 5's take its setpoint's place */
	for (unsigned i = 0; i < 4; i++)
		cfg.motors[i].status_poll_hz = 0;
	expect_ok();
	assert_int_equal(plan.motor[4].replacing, plan.motor[4].polls);
}

static void test_rs485_budget(void **state)
{
	const struct rmd_plan_bus *pb = &plan.bus[0];

	(void)state;
	cfg_reset(1000);
	add_bus("rs0", RMD_BUS_KIND_RS485);
	add_motor(0, 1, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 10);
	/* 13 bytes of 10 bits each way at 1 Mbaud, and 800 us turnaround */
	assert_int_equal(build(), -ENOSPC);
	assert_string_equal(err, "rs0: 1 motor at 1000 Hz needs 1060 µs per cycle worst case, "
				 "the cycle is 1000 µs: use a rate ≤ 943 Hz");
	cfg.loop.rate_hz = 250;
	add_motor(0, 2, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 10);
	expect_ok();
	assert_int_equal(pb->control_ns, 2 * 1060000);
	assert_int_equal(pb->worst_ns, 3 * 1060000); /* an extra poll fits */
	/* 115200 baud, no turnaround: 4 frames of 130 bits = 4513.9 us */
	cfg.loop.rate_hz = 200;
	cfg.buses[0].baud = 115200;
	cfg.buses[0].turnaround_ns = 0;
	cfg.motors[1].status_poll_hz = 0;
	cfg.motors[0].status_poll_hz = 0;
	expect_ok();
	assert_int_equal(pb->control_ns, rmd_can_wire_ns(4 * 130, 115200));
}

static void test_bitrate_500k(void **state)
{
	(void)state;
	cfg_reset(1000);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	cfg.buses[0].bitrate = 500000;
	add_motor(0, 1, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 0);
	expect_ok();
	assert_int_equal(plan.bus[0].control_ns, 2 * 2 * FRAME_NS);
	add_motor(0, 2, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 0);
	assert_int_equal(build(), -ENOSPC);
	assert_string_equal(err, "can0: 2 motors at 1000 Hz need 1080 µs per cycle worst case, "
				 "the cycle is 1000 µs: use ≤ 1 motor, or a rate ≤ 925 Hz");
}

/* DESIGN.md: 32 motors on one bus top out near 116 Hz. */
static void test_32_on_one_bus(void **state)
{
	struct rmd_plan_slot s[RMD_PLAN_MAX_SLOTS];
	unsigned ctrl[RMD_MAX_MOTORS], polls[RMD_MAX_MOTORS];

	(void)state;
	cfg_reset(1000);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	for (unsigned i = 1; i <= 32; i++)
		add_motor(0, i, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 1);
	assert_int_equal(build(), -ENOSPC);
	assert_string_equal(err, "can0: 32 motors at 1000 Hz need 8640 µs per cycle worst case, "
				 "the cycle is 1000 µs: use ≤ 3 motors, or a rate ≤ 115 Hz");
	cfg.loop.rate_hz = 115;
	expect_ok();
	/* no room for an extra poll: it takes a setpoint's place */
	assert_true(plan.bus[0].polls[0].replaces);
	assert_int_equal(rmd_plan_cycle(&plan, 0, plan.bus[0].polls[0].cycle, s), 32);
	assert_int_equal(s[31].kind, RMD_SLOT_STATUS);
	walk(0, plan.bus[0].hyperperiod, ctrl, polls);
}

/* 12 motors on 4 buses at 1 kHz: the example file and rmdd --sim's config. */
static void test_sim12_feasible(void **state)
{
	char path[2048];

	(void)state;
	snprintf(path, sizeof(path), "%s/examples/sim-12.yaml", srcdir);
	assert_int_equal(rmd_config_load(path, &cfg, NULL, err, sizeof(err)), 0);
	expect_ok();
	assert_int_equal(plan.n_buses, 4);
	for (unsigned b = 0; b < 4; b++) {
		unsigned ctrl[RMD_MAX_MOTORS], polls[RMD_MAX_MOTORS];

		assert_true(plan.bus[b].feasible);
		assert_int_equal(plan.bus[b].worst_ns, 6 * FRAME_NS);
		walk(b, plan.bus[b].hyperperiod, ctrl, polls);
	}
	for (unsigned n = 1; n <= RMD_MAX_MOTORS; n++) {
		assert_int_equal(rmd_config_sim_default(&cfg, NULL, n), 0);
		expect_ok();
	}
}

static void test_print(void **state)
{
	char *buf = NULL;
	size_t len = 0;
	FILE *f;

	(void)state;
	cfg_reset(1000);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
	for (unsigned i = 1; i <= 4; i++)
		add_motor(0, i, RMD_PROTO_V2, RMD_MODE_TORQUE, 1, 10);
	expect_ok();
	f = open_memstream(&buf, &len);
	assert_non_null(f);
	rmd_plan_print(&plan, &cfg, f);
	fclose(f);
	expect_in(buf, "bus can0 (socketcan can0, 1000000 bit/s): 4 motors");
	expect_in(buf, "0x280 frame: torques of m1 m2 m3 m4");
	expect_in(buf, "frames per cycle: busiest 7 (2 requests)");
	expect_in(buf, "worst case: 945 µs per cycle of 1000 µs, load 94.5%");
	expect_in(buf, "verdict: ok");
	expect_in(buf, "verdict: every bus fits");
	free(buf);
}

/* ------------------------------------------------------------------ */
/* rmdd --check-config as a process */

struct run {
	int status;
	char out[65536];
	char err[16384];
};

static void slurp(int fd, char *buf, size_t len)
{
	ssize_t n;
	size_t k = 0;

	lseek(fd, 0, SEEK_SET);
	while (k + 1 < len && (n = read(fd, buf + k, len - 1 - k)) > 0)
		k += (size_t)n;
	buf[k] = '\0';
	close(fd);
}

static void run_rmdd(struct run *r, const char *a1, const char *a2)
{
	char ob[] = "/tmp/rmdd-out-XXXXXX", eb[] = "/tmp/rmdd-err-XXXXXX";
	int out = mkstemp(ob), errfd = mkstemp(eb), ws;
	pid_t pid;

	assert_true(out >= 0 && errfd >= 0);
	unlink(ob);
	unlink(eb);
	pid = fork();
	assert_true(pid >= 0);
	if (pid == 0) {
		dup2(out, 1);
		dup2(errfd, 2);
		alarm(30); /* survives exec: a run that hangs fails instead of hanging the suite */
		execl(rmdd, rmdd, a1, a2, (char *)NULL);
		_exit(127);
	}
	assert_int_equal(waitpid(pid, &ws, 0), pid);
	r->status = WIFEXITED(ws) ? WEXITSTATUS(ws) : 128 + WTERMSIG(ws);
	slurp(out, r->out, sizeof(r->out));
	slurp(errfd, r->err, sizeof(r->err));
}

static void test_rmdd_check_examples(void **state)
{
	static const char *const ok[] = { "examples/rmdd.yaml", "examples/sim-12.yaml",
					  "examples/v2-batch.yaml", "examples/rs485.yaml",
					  "examples/sim-faults.yaml" };
	static struct run r;
	char path[2048];

	(void)state;
	for (size_t i = 0; i < sizeof(ok) / sizeof(ok[0]); i++) {
		snprintf(path, sizeof(path), "%s/%s", srcdir, ok[i]);
		run_rmdd(&r, "--check-config", path);
		if (r.status != 0)
			fail_msg("%s: exit %d\n%s%s", ok[i], r.status, r.out, r.err);
		expect_in(r.out, "verdict: every bus fits");
		assert_string_equal(r.err, "");
	}
	snprintf(path, sizeof(path), "%s/examples/sim-12.yaml", srcdir);
	run_rmdd(&r, "-C", path);
	assert_int_equal(r.status, 0);
	expect_in(r.out, "12 motors on 4 buses, loop 1000 Hz (cycle 1000 µs)");
	expect_in(r.out, "bus rr (sim, 1000000 bit/s): 3 motors");
	expect_in(r.out, "worst case: 810 µs per cycle of 1000 µs, load 81.0%");
}

static void test_rmdd_check_refuses(void **state)
{
	static struct run r;
	char path[2048];

	(void)state;
	snprintf(path, sizeof(path), "%s/tests/data/config/five-per-bus.yaml", srcdir);
	run_rmdd(&r, "--check-config", path);
	assert_int_equal(r.status, 1);
	expect_in(r.err, "can0: 5 motors at 1000 Hz need 1350 µs per cycle worst case, the cycle "
			 "is 1000 µs: use ≤ 3 motors, or a rate ≤ 740 Hz");
	expect_in(r.out, "verdict: DOES NOT FIT");

	snprintf(path, sizeof(path), "%s/tests/data/config/id-range.yaml", srcdir);
	run_rmdd(&r, "--check-config", path);
	assert_int_equal(r.status, 1);
	expect_in(r.err, "id-range.yaml:7: motors[3].id: 40 is out of range (1..32)");
	assert_string_equal(r.out, "");

	run_rmdd(&r, "--check-config", "/nonexistent.yaml");
	assert_int_equal(r.status, 1);
	expect_in(r.err, "/nonexistent.yaml: cannot open: No such file or directory");
}

static void test_rmdd_options(void **state)
{
	static struct run r;

	(void)state;
	run_rmdd(&r, "--help", NULL);
	assert_int_equal(r.status, 0);
	expect_in(r.out, "--check-config FILE");
	run_rmdd(&r, "--version", NULL);
	assert_int_equal(r.status, 0);
	expect_in(r.out, "rmdd ");
	run_rmdd(&r, "--bogus", NULL);
	assert_int_equal(r.status, 2);
	run_rmdd(&r, "--check-config", NULL); /* FILE missing */
	assert_int_equal(r.status, 2);
	run_rmdd(&r, "--sim=99", NULL); /* more motors than a daemon drives */
	assert_int_equal(r.status, 2);
	expect_in(r.err, "rmdd: --sim 99: the motor count is 1..32");
}

static int find_rmdd(void **state)
{
	const char *env = getenv("RMDD"), *build = getenv("BUILD"), *dir = getenv("RMD_SRCDIR");

	(void)state;
	if (dir && *dir)
		snprintf(srcdir, sizeof(srcdir), "%s", dir);
	if (env && *env)
		snprintf(rmdd, sizeof(rmdd), "%s", env);
	else
		snprintf(rmdd, sizeof(rmdd), "%s/rmdd", build && *build ? build : "build");
	if (access(rmdd, X_OK) != 0) {
		print_error("rmdd binary \"%s\" not found (set RMDD or BUILD)\n", rmdd);
		return -1;
	}
	return 0;
}

/*
 * A status poll rate near 0 (1e-300 Hz; the loader refuses it, other callers
 * may not): the spacing was a float-to-unsigned conversion out of range,
 * undefined, and on x86-64 it gave 0 and the self-contradicting "status
 * polls at 1e-300 Hz in all do not fit" (issue 10, defect 3).
 */
static void test_poll_rate_near_zero(void **state)
{
	static const double rates[] = { 1e-300, 1e-12, 2e-7, 1e-3 };
	const struct rmd_plan_bus *pb = &plan.bus[0];

	(void)state;
	for (size_t i = 0; i < sizeof(rates) / sizeof(rates[0]); i++) {
		cfg_reset(1000);
		add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
		/* alone on its bus: nothing else bounds the spacing */
		add_motor(0, 1, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, rates[i]);
		if (build() != 0)
			fail_msg("status_poll_hz %g: %s", rates[i], err);
		assert_true(pb->poll_every > 0);
		assert_int_equal(pb->poll_every % pb->hc, 0);
		/* at least the rate asked for, never less */
		assert_true(plan.motor[0].poll_hz >= rates[i]);
	}
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_five_v3_refused),
		cmocka_unit_test(test_three_v3_accepted),
		cmocka_unit_test(test_three_mit_accepted),
		cmocka_unit_test(test_four_v2_batched),
		cmocka_unit_test(test_v2_ids_2_to_5),
		cmocka_unit_test(test_v2_unbatched_refused),
		cmocka_unit_test(test_v2_batch_conditions),
		cmocka_unit_test(test_divisors_spread),
		cmocka_unit_test(test_polls_spread),
		cmocka_unit_test(test_poll_no_room),
		cmocka_unit_test(test_rs485_budget),
		cmocka_unit_test(test_bitrate_500k),
		cmocka_unit_test(test_32_on_one_bus),
		cmocka_unit_test(test_sim12_feasible),
		cmocka_unit_test(test_print),
		cmocka_unit_test(test_poll_rate_near_zero),
	};
	const struct CMUnitTest proc_tests[] = {
		cmocka_unit_test(test_rmdd_check_examples),
		cmocka_unit_test(test_rmdd_check_refuses),
		cmocka_unit_test(test_rmdd_options),
	};
	const char *dir = getenv("RMD_SRCDIR");
	int fails;

	if (dir && *dir)
		snprintf(srcdir, sizeof(srcdir), "%s", dir);
	fails = cmocka_run_group_tests_name("plan", tests, NULL, NULL);
	fails += cmocka_run_group_tests_name("rmdd --check-config", proc_tests, find_rmdd, NULL);
	return fails;
}

// SPDX-License-Identifier: MIT
/*
 * Bus planner: budgets with the exact numbers of docs/design.md (135-bit frames,
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

#include "harness/proc.h"
#include "harness/suite.h"

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

/* An empty plan at rate_hz on one CAN bus, can0 at 1 Mbit/s. */
static void can0(unsigned rate_hz)
{
	cfg_reset(rate_hz);
	add_bus("can0", RMD_BUS_KIND_SOCKETCAN);
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

/* The plan is refused with rc, and err holds msg. */
static void expect_refused(int rc, const char *msg)
{
	int r = build();

	if (r != rc || !strstr(err, msg))
		fail_msg("plan: %d \"%s\", want %d \"%s\"", r, err, rc, msg);
}

static void expect_in(const char *haystack, const char *needle)
{
	if (!strstr(haystack, needle))
		fail_msg("expected \"%s\" in:\n%s", needle, haystack);
}

/* 135 bits at 1 Mbit/s */
#define FRAME_NS 135000

/*
 * The plans most tests start from: one bus of like motors with IDs
 * first..last, and what the planner must say of it.
 */
struct variant {
	const char *bus;
	enum rmd_bus_kind kind;
	unsigned bitrate; /* 0: 1 Mbit/s */
	unsigned rate_hz;
	unsigned first, last;
	enum rmd_proto proto;
	enum rmd_mode mode;
	unsigned divisor;
	double poll_hz;
	int rc;		 /* rmd_plan_build() */
	const char *err; /* its whole message ("" when it fits) */
	long control_ns; /* plan.bus[0].control_ns, 0: not checked */
	long worst_ns;	 /* plan.bus[0].worst_ns, 0: not checked */
};

enum {
	FIVE_V3,
	THREE_V3,
	THREE_MIT,
	FOUR_V2,
	V2_IDS_2_TO_5,
	V2_UNBATCHED,
	SIX_V3_DIV2,
	FIVE_V2_POLLED,
	RS485_ONE,
	ONE_V3_500K,
	V3_32,
};

#define CAN0 "can0", RMD_BUS_KIND_SOCKETCAN, 0, 1000
#define NO_ROOM_3 "the cycle is 1000 µs: use ≤ 3 motors, or a rate ≤ "

static const struct variant variants[] = {
	[FIVE_V3] = { CAN0, 1, 5, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 10, -ENOSPC,
		      "can0: 5 motors at 1000 Hz need 1350 µs per cycle worst case, " NO_ROOM_3
		      "740 Hz",
		      10 * FRAME_NS, 0 },
	[THREE_V3] = { CAN0, 1, 3, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 10, 0, "", 6 * FRAME_NS,
		       6 * FRAME_NS /* polls take a setpoint's place */ },
	[THREE_MIT] = { CAN0, 1, 3, RMD_PROTO_MIT, RMD_MODE_MIT, 1, 10, 0, "", 6 * FRAME_NS,
			6 * FRAME_NS },
	/* one 0x280 frame + 4 replies; a poll fits beside it */
	[FOUR_V2] = { CAN0, 1, 4, RMD_PROTO_V2, RMD_MODE_TORQUE, 1, 10, 0, "", 5 * FRAME_NS,
		      7 * FRAME_NS },
	[V2_IDS_2_TO_5] = { CAN0, 2, 5, RMD_PROTO_V2, RMD_MODE_TORQUE, 1, 0, 0, "", 6 * FRAME_NS,
			    0 },
	[V2_UNBATCHED] = { CAN0, 5, 8, RMD_PROTO_V2, RMD_MODE_TORQUE, 1, 10, -ENOSPC,
			   "can0: 4 motors at 1000 Hz need 1080 µs per cycle worst case, " NO_ROOM_3
			   "925 Hz",
			   0, 0 },
	[SIX_V3_DIV2] = { CAN0, 1, 6, RMD_PROTO_V3, RMD_MODE_TORQUE, 2, 0, 0, "", 6 * FRAME_NS, 0 },
	/* 0x280 + 4 replies + motor 5's 2 frames = 7 frames: full */
	[FIVE_V2_POLLED] = { CAN0, 1, 5, RMD_PROTO_V2, RMD_MODE_TORQUE, 1, 10, -ENOSPC,
			     "can0: no room for the status polls of motor m1, which is in the "
			     "0x280 frame: the least busy cycle with a poll needs 1215 µs of "
			     "1000 µs; set its status_poll_hz to 0",
			     7 * FRAME_NS, 0 },
	/* 13 bytes of 10 bits each way at 1 Mbaud, and 800 us turnaround */
	[RS485_ONE] = { "rs0", RMD_BUS_KIND_RS485, 0, 1000, 1, 1, RMD_PROTO_V3, RMD_MODE_TORQUE, 1,
			10, -ENOSPC,
			"rs0: 1 motor at 1000 Hz needs 1060 µs per cycle worst case, the cycle is "
			"1000 µs: use a rate ≤ 943 Hz",
			0, 0 },
	[ONE_V3_500K] = { "can0", RMD_BUS_KIND_SOCKETCAN, 500000, 1000, 1, 1, RMD_PROTO_V3,
			  RMD_MODE_TORQUE, 1, 0, 0, "", 2 * 2 * FRAME_NS, 0 },
	/* docs/design.md: 32 motors on one bus top out near 116 Hz */
	[V3_32] = { CAN0, 1, 32, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 1, -ENOSPC,
		    "can0: 32 motors at 1000 Hz need 8640 µs per cycle worst case, " NO_ROOM_3
		    "115 Hz",
		    0, 0 },
};

/* Build variants[k] and check what the planner says of it. */
static void variant(unsigned k)
{
	const struct variant *v = &variants[k];
	int r;

	cfg_reset(v->rate_hz);
	add_bus(v->bus, v->kind);
	if (v->bitrate)
		cfg.buses[0].bitrate = v->bitrate;
	for (unsigned id = v->first; id <= v->last; id++)
		add_motor(0, id, v->proto, v->mode, v->divisor, v->poll_hz);
	r = build();
	if (r != v->rc || strcmp(err, v->err) != 0)
		fail_msg("variant %u: %d \"%s\", want %d \"%s\"", k, r, err, v->rc, v->err);
	assert_int_equal(plan.feasible, r == 0);
	assert_int_equal(plan.bus[0].feasible, r == 0);
	if (v->control_ns)
		assert_int_equal(plan.bus[0].control_ns, v->control_ns);
	if (v->worst_ns)
		assert_int_equal(plan.bus[0].worst_ns, v->worst_ns);
}

/*
 * Walk `cycles` cycles of bus b through rmd_plan_cycle() and check it
 * against the plan: every cycle within the worst case and the cycle, at
 * most poll_burst status polls of different motors, each motor commanded exactly at its divisor unless
 * a poll takes its place.  Counts per motor go to ctrl[] and polls[].
 */
static unsigned fine_reads[RMD_MAX_MOTORS]; /* walk(): 0x92 reads per motor */

static void walk(unsigned b, uint64_t cycles, unsigned ctrl[RMD_MAX_MOTORS],
		 unsigned polls[RMD_MAX_MOTORS])
{
	const struct rmd_plan_bus *pb = &plan.bus[b];
	struct rmd_plan_slot s[RMD_PLAN_MAX_SLOTS];

	memset(ctrl, 0, RMD_MAX_MOTORS * sizeof(ctrl[0]));
	memset(polls, 0, RMD_MAX_MOTORS * sizeof(polls[0]));
	memset(fine_reads, 0, sizeof(fine_reads));
	for (uint64_t n = 0; n < cycles; n++) {
		unsigned cnt = rmd_plan_cycle(&plan, b, n, s), frames = 0, status = 0;
		uint64_t polled = 0; /* bit mi: motor mi polled in this cycle */

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
				/* one poll per motor per cycle */
				assert_false(polled & (1ull << s[i].motor));
				polled |= 1ull << s[i].motor;
				assert_int_equal(s[i].can_id, 0x140 + cfg.motors[s[i].motor].id);
				break;
			case RMD_SLOT_FINE: {
				const struct rmd_plan_motor *pm = &plan.motor[s[i].motor];

				/* a 0x92 read exactly at its divisor and phase */
				assert_true(pm->fine_divisor > 0);
				assert_int_equal(n % pm->fine_divisor, pm->fine_phase);
				assert_int_equal(s[i].can_id, 0x140 + cfg.motors[s[i].motor].id);
				fine_reads[s[i].motor]++;
				break;
			}
			}
		}
		assert_true(status <= (pb->poll_every ? pb->poll_burst : 0));
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
			if (due && !seen && !(polled & (1ull << mi)))
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
	variant(FIVE_V3);
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
	variant(THREE_V3);
	assert_int_equal(rmd_can_frame_bits_worst(8), 135);
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
	variant(THREE_MIT);
	assert_int_equal(rmd_plan_cycle(&plan, 0, 1, s), 3);
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(s[i].can_id, 0x401 + i);
	walk(0, plan.bus[0].hyperperiod, ctrl, polls);
	/* the polls speak V3 0x9A on 0x140 + ID (checked in walk) */
	assert_int_equal(polls[0] + polls[1] + polls[2], plan.bus[0].n_polls);
	/* a fourth motor does not fit */
	add_motor(0, 4, RMD_PROTO_MIT, RMD_MODE_MIT, 1, 10);
	expect_refused(-ENOSPC,
		       "can0: 4 motors at 1000 Hz need 1080 µs per cycle worst case, the cycle "
		       "is 1000 µs: use ≤ 3 motors, or a rate ≤ 925 Hz");
}

static void test_four_v2_batched(void **state)
{
	struct rmd_plan_slot s[RMD_PLAN_MAX_SLOTS];
	unsigned ctrl[RMD_MAX_MOTORS], polls[RMD_MAX_MOTORS];
	const struct rmd_plan_bus *pb = &plan.bus[0];
	unsigned n;

	(void)state;
	variant(FOUR_V2);
	assert_int_equal(pb->batch, RMD_BATCH_ON);
	assert_int_equal(pb->batched, 0xF);
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
	variant(V2_IDS_2_TO_5);
	assert_int_equal(pb->batched, 0x7);
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
	variant(V2_UNBATCHED);
	assert_int_equal(plan.bus[0].batch, RMD_BATCH_NONE);
}

/*
 * Issue 33 point 1: while a batched motor is not driven, a cycle of the
 * 0x280 frame gives the batched motors their own frames instead, as many
 * as fit (never fewer than the frame's own 1 + n frames hold), and the
 * budget counts them: the busiest cycle is the frame's or theirs.
 */
static void test_v2_batch_own(void **state)
{
	static const struct {
		unsigned n, rate_hz;
		double poll_hz;
		unsigned own, worst_frames;
	} cases[] = {
		{ 4, 1000, 0, 3, 6 },  /* 5 frames, 2 more fit: 3 of 4 a cycle */
		{ 4, 1000, 10, 2, 7 }, /* a poll beside the frame: 2 (4 frames), no more */
		{ 4, 500, 10, 4, 10 }, /* all of them, and the poll */
		{ 3, 1000, 0, 3, 6 },  { 2, 1000, 0, 2, 4 },
	};

	(void)state;
	for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
		can0(cases[k].rate_hz);
		for (unsigned i = 1; i <= cases[k].n; i++)
			add_motor(0, i, RMD_PROTO_V2, RMD_MODE_TORQUE, 1, cases[k].poll_hz);
		expect_ok();
		assert_int_equal(plan.bus[0].batch, RMD_BATCH_ON);
		if (plan.bus[0].batch_own != cases[k].own ||
		    plan.bus[0].worst_ns != (int64_t)cases[k].worst_frames * FRAME_NS)
			fail_msg(
				"%u V2 motors at %u Hz, polls %g Hz: %u of them a cycle, worst %lld "
				"ns; want %u, %lld",
				cases[k].n, cases[k].rate_hz, cases[k].poll_hz,
				plan.bus[0].batch_own, (long long)plan.bus[0].worst_ns,
				cases[k].own, (long long)cases[k].worst_frames * FRAME_NS);
	}
}

/* No 0x280 frame when a motor would misread it. */
static const struct batch_case {
	const char *why;
	unsigned n;
	struct {
		unsigned id;
		enum rmd_proto proto;
		enum rmd_mode mode;
		unsigned divisor;
	} m[3];
	enum rmd_plan_batch batch;
	long control_ns; /* 0: not checked */
} batch_cases[] = {
#define V2(id, mode, div)                              \
	{                                              \
		id, RMD_PROTO_V2, RMD_MODE_##mode, div \
	}
	{ "a V3 motor on the bus takes 0x280 as a broadcast command",
	  3,
	  { V2(1, TORQUE, 1), V2(2, TORQUE, 1), { 5, RMD_PROTO_V3, RMD_MODE_TORQUE, 1 } },
	  RMD_BATCH_V3_ON_BUS,
	  6 * FRAME_NS },
	{ "a V2 motor with ID 1..4 in speed mode would take the torque",
	  3,
	  { V2(1, TORQUE, 1), V2(2, SPEED, 1), V2(3, TORQUE, 1) },
	  RMD_BATCH_MODES,
	  0 },
	{ "different divisors",
	  3,
	  { V2(1, TORQUE, 1), V2(2, TORQUE, 2), V2(3, TORQUE, 1) },
	  RMD_BATCH_DIVISORS,
	  0 },
	{ "one candidate: nothing to batch",
	  2,
	  { V2(1, TORQUE, 1), V2(6, TORQUE, 1) },
	  RMD_BATCH_NONE,
	  0 },
#undef V2
};

static void test_v2_batch_conditions(void **state)
{
	(void)state;
	for (size_t k = 0; k < sizeof(batch_cases) / sizeof(batch_cases[0]); k++) {
		const struct batch_case *c = &batch_cases[k];

		can0(1000);
		for (unsigned i = 0; i < c->n; i++)
			add_motor(0, c->m[i].id, c->m[i].proto, c->m[i].mode, c->m[i].divisor, 0);
		expect_ok();
		if (plan.bus[0].batch != c->batch || plan.bus[0].batched != 0)
			fail_msg("%s: batch %d (mask %#x), want %d", c->why, plan.bus[0].batch,
				 plan.bus[0].batched, c->batch);
		if (c->control_ns)
			assert_int_equal(plan.bus[0].control_ns, c->control_ns);
	}
}

/* Motors with divisor 2 take turns: 6 V3 motors fit where 5 at divisor 1 do not. */
static void test_divisors_spread(void **state)
{
	unsigned ctrl[RMD_MAX_MOTORS], polls[RMD_MAX_MOTORS];
	const struct rmd_plan_bus *pb = &plan.bus[0];

	(void)state;
	variant(SIX_V3_DIV2);
	assert_int_equal(pb->hc, 2);
	assert_int_equal(pb->frames[0], 6);
	assert_int_equal(pb->frames[1], 6);
	walk(0, 100, ctrl, polls);
	for (unsigned i = 0; i < 6; i++)
		assert_int_equal(ctrl[i], 50);

	/* mixed: 1 motor every cycle, 2 every 2nd, 4 every 4th: 1+1+1 per cycle */
	can0(1000);
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
	can0(1000);
	add_motor(0, 1, RMD_PROTO_V3, RMD_MODE_TORQUE, 7, 0);
	add_motor(0, 2, RMD_PROTO_V3, RMD_MODE_TORQUE, 11, 0);
	expect_refused(-EINVAL, "can0: rate divisors 7, 11 repeat every 77 cycles, more than 64");
}

/* At most one poll per cycle, evenly spread, at no less than the asked rate. */
static void test_polls_spread(void **state)
{
	unsigned ctrl[RMD_MAX_MOTORS], polls[RMD_MAX_MOTORS];
	struct rmd_plan_slot s[RMD_PLAN_MAX_SLOTS];
	const struct rmd_plan_bus *pb = &plan.bus[0];
	uint64_t last[RMD_MAX_MOTORS], gap[RMD_MAX_MOTORS];

	(void)state;
	can0(1000);
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

	/* one motor's polls cannot exceed one per cycle */
	can0(100);
	add_motor(0, 1, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 120);
	expect_refused(-ENOSPC,
		       "can0: status polls at 120 Hz in all do not fit in one poll every 1 cycle "
		       "(100 a second at 100 Hz): lower status_poll_hz");
	/* two motors' polls: two a cycle at most, one each */
	add_motor(0, 2, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 120);
	expect_refused(-ENOSPC,
		       "can0: status polls at 240 Hz in all do not fit in 2 polls of different "
		       "motors every 1 cycle (200 a second at 100 Hz): lower status_poll_hz");
	/* 120 Hz in all over two motors fit, two polls a cycle */
	cfg.motors[0].status_poll_hz = 60;
	cfg.motors[1].status_poll_hz = 60;
	expect_ok();
	assert_int_equal(pb->poll_burst, 2);
	/* 2 setpoints and 2 polls, with their replies */
	assert_int_equal(pb->worst_ns, 8 * FRAME_NS);
	assert_true(plan.motor[0].poll_hz >= 60 && plan.motor[1].poll_hz >= 60);
	walk(0, pb->hyperperiod * 2, ctrl, polls);
}

/* A poll of a motor in the 0x280 frame cannot take its place: it needs room. */
static void test_poll_no_room(void **state)
{
	(void)state;
	variant(FIVE_V2_POLLED);
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
	variant(RS485_ONE);
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
	variant(ONE_V3_500K);
	add_motor(0, 2, RMD_PROTO_V3, RMD_MODE_TORQUE, 1, 0);
	expect_refused(-ENOSPC, "can0: 2 motors at 1000 Hz need 1080 µs per cycle worst case, "
				"the cycle is 1000 µs: use ≤ 1 motor, or a rate ≤ 925 Hz");
}

/* docs/design.md: 32 motors on one bus top out near 116 Hz. */
static void test_32_on_one_bus(void **state)
{
	struct rmd_plan_slot s[RMD_PLAN_MAX_SLOTS];
	unsigned ctrl[RMD_MAX_MOTORS], polls[RMD_MAX_MOTORS];

	(void)state;
	variant(V3_32);
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
	variant(FOUR_V2);
	f = open_memstream(&buf, &len);
	assert_non_null(f);
	rmd_plan_print(&plan, &cfg, f);
	fclose(f);
	expect_in(buf, "bus can0 (socketcan can0, 1000000 bit/s): 4 motors");
	expect_in(buf, "0x280 frame: torques of m1 m2 m3 m4");
	expect_in(buf, "while one of them is not enabled in torque mode: no 0x280; their own "
		       "frames, 2 of the 4 a cycle of the frame, in turn");
	/* the poll's cycle, and the cycle that gives two motors their own frames and a poll */
	expect_in(buf, "frames per cycle: busiest 7 (3 requests)");
	expect_in(buf, "worst case: 945 µs per cycle of 1000 µs, load 94.5%");
	expect_in(buf, "verdict: ok");
	expect_in(buf, "verdict: every bus fits");
	free(buf);
}

/* ------------------------------------------------------------------ */
/* rmdd --check-config as a process */

/* rmdd with one or two arguments (a2 may be NULL); r's last output is freed first. */
static void run_rmdd(struct run *r, const char *a1, const char *a2)
{
	run_free(r);
	run_prog(r, rmdd, (const char *const[]){ a1, a2, NULL }, NULL);
}

/* rmdd --check-config on a file (under srcdir unless absolute), and what it must say. */
struct check_case {
	const char *file;
	int status;
	const char *out_has; /* as in struct run_case */
	const char *err_has;
};

static void check_config(const struct check_case *c)
{
	char path[2048];
	struct run_case rc = { .args = { "--check-config", path },
			       .status = c->status,
			       .out_has = { c->out_has },
			       .err_has = { c->err_has } };

	snprintf(path, sizeof(path), "%s%s%s", c->file[0] == '/' ? "" : srcdir,
		 c->file[0] == '/' ? "" : "/", c->file);
	run_cases(rmdd, &rc, 1, NULL);
}

static const char *const examples[] = { "examples/rmdd.yaml", "examples/sim-12.yaml",
					"examples/v2-batch.yaml", "examples/rs485.yaml",
					"examples/sim-faults.yaml" };

static void test_rmdd_check_examples(void **state)
{
	static struct run r;
	char path[2048];

	(void)state;
	for (size_t i = 0; i < sizeof(examples) / sizeof(examples[0]); i++)
		check_config(&(struct check_case){
			examples[i], 0, "verdict: every bus fits",
			/* its two homed joints: the warning says what homing is for */
			i ? "" :
			    "rmdd.yaml:470: motors[1]: warning: shoulder_pitch (mode position, "
			    "gear_ratio 36) will be position uncertain after every power cycle" });
	snprintf(path, sizeof(path), "%s/examples/sim-12.yaml", srcdir);
	run_rmdd(&r, "-C", path);
	assert_int_equal(r.status, 0);
	expect_in(r.out, "12 motors on 4 buses, loop 1000 Hz (cycle 1000 µs)");
	expect_in(r.out, "bus rr (sim, 1000000 bit/s): 3 motors");
	expect_in(r.out, "worst case: 810 µs per cycle of 1000 µs, load 81.0%");
}

static const struct check_case refused[] = {
	{ "tests/data/config/five-per-bus.yaml", 1, "verdict: DOES NOT FIT",
	  "can0: 5 motors at 1000 Hz need 1350 µs per cycle worst case, the cycle is 1000 µs: "
	  "use ≤ 3 motors, or a rate ≤ 740 Hz" },
	{ "tests/data/config/id-range.yaml", 1, "",
	  "id-range.yaml:7: motors[3].id: 40 is out of range (1..32)" },
	{ "/nonexistent.yaml", 1, NULL,
	  "/nonexistent.yaml: cannot open: No such file or directory" },
};

static void test_rmdd_check_refuses(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(refused) / sizeof(refused[0]); i++)
		check_config(&refused[i]);
}

static const struct run_case option_cases[] = {
	{ .args = { "--help" }, .out_has = { "--check-config FILE" } },
	{ .args = { "--version" }, .out_has = { "rmdd " } },
	{ .args = { "--bogus" }, .status = 2 },
	{ .args = { "--check-config" }, .status = 2 }, /* FILE missing */
	/* more motors than a daemon drives */
	{ .args = { "--sim=99" },
	  .status = 2,
	  .err_has = { "rmdd: --sim 99: the motor count is 1..32" } },
};

static void test_rmdd_options(void **state)
{
	(void)state;
	run_cases(rmdd, option_cases, sizeof(option_cases) / sizeof(option_cases[0]), NULL);
}

static int find_rmdd(void **state)
{
	const char *dir = getenv("RMD_SRCDIR");

	(void)state;
	if (dir && *dir)
		snprintf(srcdir, sizeof(srcdir), "%s", dir);
	return find_prog(rmdd, sizeof(rmdd), "RMDD", "rmdd");
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

/* ------------------------------------------------------------------ */
/* issue 13: fine position reads (0x92) in the plan */

static void fine(unsigned i, double rate_hz)
{
	cfg.motors[i].feedback.position = RMD_FEEDBACK_MULTI_TURN;
	cfg.motors[i].feedback.rate_hz = rate_hz;
}

/* The plan's text for --check-config, in a malloc'ed string. */
static char *printed(void)
{
	char *buf = NULL;
	size_t len = 0;
	FILE *f = open_memstream(&buf, &len);

	assert_non_null(f);
	rmd_plan_print(&plan, &cfg, f);
	fclose(f);
	return buf;
}

/*
 * Two V3 motors at 1 kHz with 0x92 reads at 250 Hz and a third commanded
 * every other cycle: each read every 4th cycle, in the cycles without the
 * third motor's setpoint (the reads fill the least busy ones), every
 * setpoint still sent, and the busiest cycle within the budget the walk
 * checks cycle by cycle.
 */
static void test_fine_reads_planned(void **state)
{
	unsigned ctrl[RMD_MAX_MOTORS], polls[RMD_MAX_MOTORS];
	const struct rmd_plan_bus *pb = &plan.bus[0];
	char *out;

	(void)state;
	can0(1000);
	add_motor(0, 1, RMD_PROTO_V3, RMD_MODE_POSITION, 1, 10);
	add_motor(0, 2, RMD_PROTO_V3, RMD_MODE_POSITION, 1, 10);
	add_motor(0, 3, RMD_PROTO_V3, RMD_MODE_POSITION, 2, 0); /* no fine feedback */
	fine(0, 250);
	fine(1, 250);
	expect_ok();
	assert_int_equal(pb->n_fine, 2);
	assert_int_equal(pb->hc, 4);
	for (unsigned i = 0; i < 2; i++) {
		assert_int_equal(plan.motor[i].fine_divisor, 4);
		assert_float_equal(plan.motor[i].pos_hz, 250.0, 1e-9);
	}
	assert_int_equal(plan.motor[2].fine_divisor, 0);
	assert_float_equal(plan.motor[2].pos_hz, 500.0, 1e-9);
	assert_int_not_equal(plan.motor[0].fine_phase, plan.motor[1].fine_phase);
	for (unsigned i = 0; i < 2; i++)
		assert_int_not_equal(plan.motor[i].fine_phase % 2, plan.motor[2].phase);
	/* 4 or 6 frames of setpoints, a read where there are 4: never more than 6 */
	assert_int_equal(pb->control_ns, 6 * FRAME_NS);
	assert_true(pb->worst_ns <= plan.period_ns);
	walk(0, pb->hyperperiod * 2, ctrl, polls);
	for (unsigned i = 0; i < 3; i++) /* every setpoint */
		assert_int_equal(ctrl[i] + polls[i],
				 pb->hyperperiod * 2 / cfg.motors[i].rate_divisor);
	assert_int_equal(fine_reads[0], pb->hyperperiod * 2 / 4);
	assert_int_equal(fine_reads[1], pb->hyperperiod * 2 / 4);
	assert_int_equal(fine_reads[2], 0);
	out = printed();
	expect_in(out, "position: 0x92 every 4 cycles (250 Hz), step 0.01° (175 µrad)");
	expect_in(out, "with its 0x92 reads this bus fits a loop rate up to ");
	free(out);
	/* a rate that is not a whole divisor: the next faster one (at least what was asked) */
	can0(1000);
	add_motor(0, 1, RMD_PROTO_V3, RMD_MODE_POSITION, 1, 10);
	fine(0, 300);
	expect_ok();
	assert_int_equal(plan.motor[0].fine_divisor, 3);
	assert_true(plan.motor[0].pos_hz >= 300.0);
	/* default: the command rate; with rate_divisor 2, every other cycle */
	can0(1000);
	add_motor(0, 1, RMD_PROTO_V3, RMD_MODE_POSITION, 2, 0);
	fine(0, 0);
	expect_ok();
	assert_int_equal(plan.motor[0].fine_divisor, 2);
	assert_float_equal(plan.motor[0].pos_hz, 500.0, 1e-9);
}

/*
 * The budget holds with the reads: three motors with reads every cycle do
 * not fit 1 kHz, and the refusal says the reads are in the count and what
 * to lower; the rate it names, and the rate the print says the bus fits,
 * do fit; without fine feedback the print says nothing of 0x92.
 */
static void test_fine_budget(void **state)
{
	char *out;
	unsigned fits;
	const char *at;

	(void)state;
	can0(1000);
	for (unsigned id = 1; id <= 3; id++)
		add_motor(0, id, RMD_PROTO_V3, RMD_MODE_POSITION, 1, 10);
	expect_ok();
	out = printed();
	assert_null(strstr(out, "0x92"));
	free(out);
	for (unsigned i = 0; i < 3; i++)
		fine(i, 0);
	expect_refused(-ENOSPC, "can0: 3 motors at 1000 Hz need 1620 µs per cycle worst case "
				"(0x92 position reads included), the cycle is 1000 µs: use ≤ 1 "
				"motor, or a rate ≤ 617 Hz, or a lower feedback.rate_hz");
	out = printed();
	at = strstr(out, "with its 0x92 reads this bus fits a loop rate up to ");
	assert_non_null(at);
	fits = (unsigned)atoi(at + strlen("with its 0x92 reads this bus fits a loop rate up to "));
	free(out);
	assert_int_equal(fits, 617);
	cfg.loop.rate_hz = fits;
	expect_ok();
	assert_true(plan.bus[0].worst_ns <= plan.period_ns);
	cfg.loop.rate_hz = fits + 1;
	assert_int_equal(build(), -ENOSPC);
	/* two of them at 1 kHz with reads at 250 Hz fit */
	can0(1000);
	for (unsigned id = 1; id <= 2; id++)
		add_motor(0, id, RMD_PROTO_V3, RMD_MODE_POSITION, 1, 10);
	fine(0, 250);
	fine(1, 250);
	expect_ok();
	assert_int_equal(plan.bus[0].control_ns, 6 * FRAME_NS);
}

/*
 * Issue 13: 3 motors at 25 Hz with the default status_poll_hz (10 Hz, 30
 * polls a second in all) on a 2 %-load bus.  One poll a cycle gives 25 a
 * second: two a cycle fit, each motor polled at >= 10 Hz, and the busiest
 * cycle counts both.
 */
static const char r25_yaml[] =
	"loop: {rate_hz: 25}\n"
	"safety: {comm_loss_ms: 400}\n"
	"buses: [{name: sim0, type: sim}]\n"
	"motors:\n"
	"  - {name: a, bus: sim0, id: 1, mode: position, torque_constant_nm_a: 2.0}\n"
	"  - {name: b, bus: sim0, id: 2, mode: position, torque_constant_nm_a: 2.0}\n"
	"  - {name: c, bus: sim0, id: 3, mode: position, torque_constant_nm_a: 2.0}\n";

static void test_polls_burst(void **state)
{
	unsigned ctrl[RMD_MAX_MOTORS], polls[RMD_MAX_MOTORS];
	const struct rmd_plan_bus *pb = &plan.bus[0];
	struct rmd_plan_slot s[RMD_PLAN_MAX_SLOTS];
	uint64_t last[RMD_MAX_MOTORS] = { 0 };
	char path[] = "/tmp/test_plan_r25_XXXXXX";
	char *out;

	(void)state;
	temp_file(path, r25_yaml);
	assert_int_equal(rmd_config_load(path, &cfg, NULL, err, sizeof(err)), 0);
	unlink(path);
	for (unsigned i = 0; i < 3; i++)
		assert_float_equal(cfg.motors[i].status_poll_hz, RMD_CONFIG_DEFAULT_STATUS_POLL_HZ,
				   0);
	expect_ok();
	assert_int_equal(pb->poll_burst, 2);
	assert_int_equal(pb->poll_every, 1);
	assert_int_equal(pb->n_polls % pb->poll_burst, 0);
	/* 3 setpoints and 2 polls, with their replies */
	assert_int_equal(pb->control_ns, 6 * FRAME_NS);
	assert_int_equal(pb->worst_ns, 10 * FRAME_NS);
	assert_int_equal(pb->max_frames, 10);
	assert_int_equal(pb->max_requests, 5);
	for (unsigned i = 0; i < 3; i++) {
		assert_true(plan.motor[i].poll_hz >= 10.0);
		assert_int_equal(plan.motor[i].replacing, 0);
	}
	/* one simulated second: >= 10 polls each, never more than 1/10 s apart */
	walk(0, 25, ctrl, polls);
	for (unsigned i = 0; i < 3; i++) {
		assert_true(polls[i] >= 10);
		assert_int_equal(ctrl[i], 25);
	}
	for (uint64_t n = 0; n < 3 * pb->hyperperiod + 25; n++) {
		unsigned cnt = rmd_plan_cycle(&plan, 0, n, s);

		for (unsigned i = 0; i < cnt; i++) {
			if (s[i].kind != RMD_SLOT_STATUS)
				continue;
			if (last[s[i].motor])
				assert_true((n - last[s[i].motor]) * 10 <= 25);
			last[s[i].motor] = n;
		}
	}
	out = printed();
	expect_in(out, "10 Hz asked, 16.7 Hz planned, extra frames");
	expect_in(out, "worst case: 1350 µs per cycle of 40000 µs, load 3.4%");
	expect_in(out, "schedule: control pattern 1 cycle, 2 status polls every 1 cycles, "
		       "repeats every 3 cycles");
	expect_in(out, "verdict: every bus fits");
	free(out);
}

/* The same through rmdd --check-config: accepted, the polls per poll cycle printed. */
static void test_rmdd_check_polls_burst(void **state)
{
	char path[] = "/tmp/test_plan_r25_XXXXXX";

	(void)state;
	temp_file(path, r25_yaml);
	check_config(&(struct check_case){ path, 0, "2 status polls every 1 cycles", "" });
	check_config(&(struct check_case){ path, 0, "verdict: every bus fits", "" });
	unlink(path);
}

/* rmdd --check-config on the example with fine feedback: the reads and the rate printed. */
static void test_rmdd_check_fine_example(void **state)
{
	(void)state;
	check_config(&(struct check_case){ "examples/sim-fine.yaml", 0,
					   "position: 0x92 every cycle (500 Hz), step 0.01°", "" });
	check_config(&(struct check_case){ "examples/sim-fine.yaml", 0,
					   "with its 0x92 reads this bus fits a loop rate up to",
					   "" });
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
		cmocka_unit_test(test_v2_batch_own),
		cmocka_unit_test(test_divisors_spread),
		cmocka_unit_test(test_polls_spread),
		cmocka_unit_test(test_poll_no_room),
		cmocka_unit_test(test_rs485_budget),
		cmocka_unit_test(test_bitrate_500k),
		cmocka_unit_test(test_32_on_one_bus),
		cmocka_unit_test(test_sim12_feasible),
		cmocka_unit_test(test_print),
		cmocka_unit_test(test_poll_rate_near_zero),
		cmocka_unit_test(test_fine_reads_planned),
		cmocka_unit_test(test_fine_budget),
		cmocka_unit_test(test_polls_burst),
	};
	const struct CMUnitTest proc_tests[] = {
		cmocka_unit_test(test_rmdd_check_examples),
		cmocka_unit_test(test_rmdd_check_refuses),
		cmocka_unit_test(test_rmdd_options),
		cmocka_unit_test(test_rmdd_check_fine_example),
		cmocka_unit_test(test_rmdd_check_polls_burst),
	};
	const char *dir = getenv("RMD_SRCDIR");
	int fails;

	if (dir && *dir)
		snprintf(srcdir, sizeof(srcdir), "%s", dir);
	fails = SUITE_RUN("plan", tests, NULL, NULL);
	fails += SUITE_RUN("rmdd --check-config", proc_tests, find_rmdd, NULL);
	return fails;
}

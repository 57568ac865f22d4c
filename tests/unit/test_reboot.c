// SPDX-License-Identifier: MIT
/*
 * Did a motor reboot? (rmd/reboot.h): the judgements over tables -- a
 * runtime against the time the motor was known running (its clock's
 * slack, its count's wrap), the motor's multi-turn angle against rmdd's
 * count (motion its speeds explain, gear ratios, bad readings), the
 * brake against rmdd's release -- and the check as a procedure, step by
 * step: when an episode opens, what it sends, how answers end it.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include <cmocka.h>

#include "rmd/reboot.h"
#include "harness/suite.h"

#define MS INT64_C(1000000)
#define S INT64_C(1000000000)
#define DEG (M_PI / 180.0)

static const char *const verdict_name[] = { "nothing", "running", "booted", "count astray" };
static const char *const outcome_name[] = { "wait", "fine", "rebooted", "uncheckable",
					    "undecided" };

struct runtime_case {
	const char *name;
	int64_t since_ns;
	bool boot_known;
	int64_t boot_ns;
	uint32_t runtime_ms;
	int64_t sent_ns;
	enum rmd_reboot_verdict want;
};

static void test_runtime_table(void **state)
{
	const int64_t t = 10000 * S; /* the loop's clock, well after any motor started */
	const struct runtime_case cases[] = {
		{ "up for an hour, known running a second ago", t - S, false, 0, 3600000, t,
		  RMD_REBOOT_SAYS_RUNNING },
		{ "the field report: booted 3 ms ago, its last answer 5.2 ms ago", t - 5200000,
		  true, t - 3600 * S, 3, t, RMD_REBOOT_SAYS_BOOTED },
		{ "a 1 ms glitch, booted at once: 1 ms LSB", t - 2 * MS - 100000, true,
		  t - 3600 * S, 0, t, RMD_REBOOT_SAYS_BOOTED },
		{ "younger than its LSB and the slack: cannot tell", t - 1 * MS, true, t - 3600 * S,
		  0, t, RMD_REBOOT_SAYS_RUNNING },
		{ "found 1 s after its boot, read an hour on: exactly the time", t - 3600 * S,
		  false, 0, 3601000, t, RMD_REBOOT_SAYS_RUNNING },
		{ "... its clock 2 % slow", t - 3600 * S, false, 0, 3528980, t,
		  RMD_REBOOT_SAYS_RUNNING },
		{ "... 4 % slow: beyond RMD_REBOOT_CLOCK_SLACK, taken for a boot", t - 3600 * S,
		  false, 0, 3456960, t, RMD_REBOOT_SAYS_BOOTED },
		{ "found just now: the first read places its boot", t - 3 * MS, false, 0, 50000, t,
		  RMD_REBOOT_SAYS_RUNNING },
		{ "booted between found and the first read", t - 30 * MS, false, 0, 10, t,
		  RMD_REBOOT_SAYS_BOOTED },
		{ "up 48.5 days: a short count may be its wrap", t - 10 * S, true,
		  t - (int64_t)(48.5 * 86400) * S, 200, t, RMD_REBOOT_SAYS_NOTHING },
		{ "wrapped 1 s ago (49.7 days + 1 s since its boot placed)", t - 10 * S, true,
		  t - RMD_REBOOT_RUNTIME_WRAP_NS - S, 1000, t, RMD_REBOOT_SAYS_NOTHING },
		{ "up 40 days: a short count is a boot", t - 10 * S, true, t - 40 * 86400 * S, 200,
		  t, RMD_REBOOT_SAYS_BOOTED },
		{ "up 40 days, its count right", t - 10 * S, true, t - 40 * 86400 * S,
		  (uint32_t)(40 * 86400 * 1000u), t, RMD_REBOOT_SAYS_RUNNING },
		{ "asked before it was known running", t + S, true, t - 3600 * S, 5, t,
		  RMD_REBOOT_SAYS_RUNNING },
	};

	(void)state;
	for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
		const struct runtime_case *c = &cases[k];
		struct rmd_reboot r;
		enum rmd_reboot_verdict v;

		rmd_reboot_init(&r);
		r.since_ns = c->since_ns;
		r.boot_known = c->boot_known;
		r.boot_ns = c->boot_ns;
		v = rmd_reboot_runtime_says(&r, c->runtime_ms, c->sent_ns);
		if (v != c->want)
			fail_msg("%s: %s, not %s", c->name, verdict_name[v], verdict_name[c->want]);
	}
}

struct turns_case {
	const char *name;
	double gear;
	double tol_rad;
	struct rmd_reboot_reading before, now;
	enum rmd_reboot_verdict want;
};

static void test_turns_table(void **state)
{
	const int64_t t = 100 * S;
	const struct turns_case cases[] = {
		{ "direct drive, 400 deg counted, 40 deg read, at rest",
		  1.0,
		  1e-4,
		  { 400 * DEG, t, 0.0, 0.0 },
		  { 40 * DEG, t + MS, 0.0, 0.0 },
		  RMD_REBOOT_SAYS_BOOTED },
		{ "1:6, one rotor turn (60 deg) off, at rest",
		  6.0,
		  1e-4,
		  { 400 * DEG, t, 0.0, 0.0 },
		  { 340 * DEG, t + MS, 0.0, 0.0 },
		  RMD_REBOOT_SAYS_BOOTED },
		{ "1:36, 10 deg off at rest",
		  36.0,
		  1e-5,
		  { 100 * DEG, t, 0.0, 0.0 },
		  { 90 * DEG, t + MS, 0.0, 0.0 },
		  RMD_REBOOT_SAYS_BOOTED },
		{ "1:36, 4 deg off: less than half a rotor turn",
		  36.0,
		  1e-5,
		  { 100 * DEG, t, 0.0, 0.0 },
		  { 96 * DEG, t + MS, 0.0, 0.0 },
		  RMD_REBOOT_SAYS_RUNNING },
		{ "1:6 at 20 rad/s, 1 ms apart",
		  6.0,
		  1e-4,
		  { 1.0, t, 20.0, 0.0 },
		  { 1.02, t + MS, 20.0, 0.0 },
		  RMD_REBOOT_SAYS_RUNNING },
		{ "1:6 braking from 20 rad/s to 0 over 40 ms: 0.4 rad",
		  6.0,
		  1e-4,
		  { 1.0, t, 20.0, 0.0 },
		  { 1.4, t + 40 * MS, 0.0, 0.0 },
		  RMD_REBOOT_SAYS_RUNNING },
		{ "1:6, a turn of the rotor that 2 x its speed explains",
		  6.0,
		  1e-4,
		  { 0.0, t, 6.0, 0.0 },
		  { 60 * DEG, t + 100 * MS, 6.0, 0.0 },
		  RMD_REBOOT_SAYS_RUNNING },
		{ "1:6, a turn its speed explains only once over",
		  6.0,
		  1e-4,
		  { 0.0, t, 11.0, 0.0 },
		  { 60 * DEG, t + 100 * MS, 0.0, 0.0 },
		  RMD_REBOOT_SAYS_RUNNING },
		{ "1:6, a turn no speed explains",
		  6.0,
		  1e-4,
		  { 0.0, t, 2.0, 0.0 },
		  { -60 * DEG, t + 100 * MS, 2.0, 0.0 },
		  RMD_REBOOT_SAYS_BOOTED },
		/*
		 * a count at the wrong scale (rmdd's gear_ratio 1, the motor's 6: the
		 * CI run of 2026-12-02, at 250 deg/s one reply apart): no boot moves
		 * the angle by 4.43 rotor turns
		 */
		{ "1:6, 265.73 deg apart at 250 deg/s, 3 ms apart",
		  6.0,
		  1e-4,
		  { 319.73 * DEG, t, 250 * DEG, 0.0 },
		  { 54.00 * DEG, t + 3 * MS, 250 * DEG, 0.0 },
		  RMD_REBOOT_SAYS_COUNT_ASTRAY },
		{ "direct drive, 300 deg apart at rest",
		  1.0,
		  1e-4,
		  { 340 * DEG, t, 0.0, 0.0 },
		  { 40 * DEG, t + MS, 0.0, 0.0 },
		  RMD_REBOOT_SAYS_COUNT_ASTRAY },
		{ "1:6, two rotor turns and 1 deg at 250 deg/s, 3 ms apart: booted",
		  6.0,
		  1e-4,
		  { 121.0 * DEG, t, 250 * DEG, 0.0 },
		  { 0.0, t + 3 * MS, 250 * DEG, 0.0 },
		  RMD_REBOOT_SAYS_BOOTED },
		{ "1:6, two rotor turns and 0.4 deg at rest: the anchor's error allowed",
		  6.0,
		  1e-4,
		  { 120.4 * DEG, t, 0.0, 0.5 * DEG },
		  { 0.0, t + MS, 0.0, 0.0 },
		  RMD_REBOOT_SAYS_BOOTED },
		{ "1:6, two rotor turns and 0.4 deg at rest, no anchor error: astray",
		  6.0,
		  1e-4,
		  { 120.4 * DEG, t, 0.0, 0.0 },
		  { 0.0, t + MS, 0.0, 0.0 },
		  RMD_REBOOT_SAYS_COUNT_ASTRAY },
		{ "a reading not finite",
		  6.0,
		  1e-4,
		  { NAN, t, 0.0, 0.0 },
		  { 1.0, t + MS, 0.0, 0.0 },
		  RMD_REBOOT_SAYS_NOTHING },
		{ "a speed not finite",
		  6.0,
		  1e-4,
		  { 0.0, t, INFINITY, 0.0 },
		  { 3.0, t + MS, 0.0, 0.0 },
		  RMD_REBOOT_SAYS_NOTHING },
		{ "now before before",
		  6.0,
		  1e-4,
		  { 0.0, t, 0.0, 0.0 },
		  { 3.0, t - MS, 0.0, 0.0 },
		  RMD_REBOOT_SAYS_NOTHING },
		{ "no gear ratio",
		  0.0,
		  1e-4,
		  { 0.0, t, 0.0, 0.0 },
		  { 3.0, t + MS, 0.0, 0.0 },
		  RMD_REBOOT_SAYS_NOTHING },
	};

	(void)state;
	for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
		const struct turns_case *c = &cases[k];
		struct rmd_multiturn mt = { .period_rad = c->gear > 0 ? 2 * M_PI / c->gear : 0,
					    .lo_rad = -INFINITY,
					    .hi_rad = INFINITY,
					    .tol_rad = c->tol_rad };
		enum rmd_reboot_verdict v = rmd_reboot_turns_says(&mt, &c->before, &c->now);

		if (v != c->want)
			fail_msg("%s: %s, not %s", c->name, verdict_name[v], verdict_name[c->want]);
	}
}

/* ---- the check, step by step ---- */

enum op {
	FOUND,	  /* rmd_reboot_found(a: first_check) at t */
	FORGET,	  /* rmd_reboot_forget() */
	MISSED,	  /* rmd_reboot_missed(seq a, check b, heard_seq c) at t */
	SLOW,	  /* rmd_reboot_slow() at t */
	NEXT,	  /* rmd_reboot_next(0xB1): want_cmd */
	RUNTIME,  /* rmd_reboot_runtime(seq a, runtime_ms b, sent t, received t + 1 ms) */
	ANSWER,	  /* rmd_reboot_answer(seq a, verdict b) */
	RELEASED, /* rmd_reboot_released(seq a) */
	BRAKE,	  /* rmd_reboot_brake_says(held b, seq a, released c): want_v */
	COUNT,	  /* rmd_reboot_count(verdict b): want_v, and news c */
	LOCKED,	  /* rmd_reboot_brake(seq a, the brake_says() of held, released b, checkable c) */
};

struct step {
	enum op op;
	int64_t t;
	uint64_t a, b, c;
	enum rmd_reboot_outcome want;	/* MISSED, RUNTIME, ANSWER */
	int want_pending;		/* -1: not checked */
	unsigned want_cmd;		/* NEXT */
	enum rmd_reboot_verdict want_v; /* BRAKE, COUNT */
};

struct seq_case {
	const char *name;
	struct step steps[16];
	unsigned n;
};

#define HOLD (20 * MS) /* MISSED's slow_hold_ns */

/* A step: op at t with a, b, c; its outcome, and whether a check is pending after it. */
#define ST(o, t_, a_, b_, c_, w, p)                                                       \
	{                                                                                 \
		.op = o, .t = t_, .a = a_, .b = b_, .c = c_, .want = w, .want_pending = p \
	}
/* rmd_reboot_count(v) says want, news or not; then pending p. */
#define CT(v, want, news, p)                                                      \
	{                                                                         \
		.op = COUNT, .b = v, .c = news, .want_v = want, .want_pending = p \
	}
/* rmd_reboot_next() sends cmd. */
#define NX(cmd)                                                 \
	{                                                       \
		.op = NEXT, .want_pending = -1, .want_cmd = cmd \
	}
/* rmd_reboot_brake_says(held, seq, released) says v. */
#define BR(seq, held, rel, v)                                                               \
	{                                                                                   \
		.op = BRAKE, .a = seq, .b = held, .c = rel, .want_pending = -1, .want_v = v \
	}
/* An answer to seq says released rel (held); rmd_reboot_brake(checkable chk): w, pending p. */
#define BK(seq, rel, chk, w, p)                                                          \
	{                                                                                \
		.op = LOCKED, .a = seq, .b = rel, .c = chk, .want = w, .want_pending = p \
	}
/* rmd_reboot_released(seq). */
#define RL(seq)                                              \
	{                                                    \
		.op = RELEASED, .a = seq, .want_pending = -1 \
	}

static const struct seq_case seqs[] = {
	{ "not found: no check", { ST(MISSED, 1 * S, 5, 0, 0, RMD_REBOOT_WAIT, 0), NX(0) }, 2 },
	{ "found: checked at once, the runtime places its boot",
	  { ST(FOUND, 1 * S, 1, 0, 0, 0, 1), NX(0xB1), NX(0x9C),
	    ST(RUNTIME, 1 * S + 2 * MS, 3, 60000, 0, RMD_REBOOT_FINE, 0), NX(0) },
	  5 },
	{ "a glitch: missed, the first read after it says booted",
	  { ST(FOUND, 1 * S, 1, 0, 0, 0, 1),
	    ST(RUNTIME, 1 * S + 2 * MS, 3, 60000, 0, RMD_REBOOT_FINE, 0),
	    ST(MISSED, 5 * S, 100, 0, 100, RMD_REBOOT_WAIT, 1), NX(0xB1),
	    ST(RUNTIME, 5 * S + 8 * MS, 105, 2, 0, RMD_REBOOT_REBOOTED, 0),
	    ST(MISSED, 5 * S + 9 * MS, 101, 0, 100, RMD_REBOOT_WAIT, 0) },
	  6 },
	{ "a lost frame: the read says running; misses of requests before it open nothing",
	  { ST(FOUND, 1 * S, 0, 0, 0, 0, 0), ST(MISSED, 5 * S, 100, 0, 100, RMD_REBOOT_WAIT, 1),
	    ST(RUNTIME, 5 * S + 2 * MS, 103, 64000, 0, RMD_REBOOT_FINE, 0),
	    ST(MISSED, 5 * S + 3 * MS, 102, 0, 100, RMD_REBOOT_WAIT, 0),
	    ST(MISSED, 5 * S + 4 * MS, 104, 0, 104, RMD_REBOOT_WAIT, 1) },
	  5 },
	{ "a miss after a later answer: no silence",
	  { ST(FOUND, 1 * S, 0, 0, 0, 0, 0), ST(MISSED, 5 * S, 100, 0, 102, RMD_REBOOT_WAIT, 0) },
	  2 },
	{ "slow, not silent: no check within the hold",
	  { ST(FOUND, 1 * S, 0, 0, 0, 0, 0), ST(SLOW, 5 * S, 0, 0, 0, 0, -1),
	    ST(MISSED, 5 * S + 10 * MS, 100, 0, 100, RMD_REBOOT_WAIT, 0),
	    ST(MISSED, 5 * S + 30 * MS, 101, 0, 101, RMD_REBOOT_WAIT, 1) },
	  4 },
	{ "found, firmware without 0xB1: three skipped, answering between: no checks",
	  { ST(FOUND, 1 * S, 1, 0, 0, 0, 1),
	    ST(MISSED, 1 * S + 3 * MS, 10, 1, 12, RMD_REBOOT_WAIT, 1),
	    ST(MISSED, 1 * S + 5 * MS, 12, 1, 14, RMD_REBOOT_WAIT, 1),
	    ST(MISSED, 1 * S + 7 * MS, 14, 1, 16, RMD_REBOOT_UNCHECKABLE, 0),
	    ST(MISSED, 2 * S, 20, 0, 20, RMD_REBOOT_WAIT, 0), ST(FOUND, 3 * S, 1, 0, 0, 0, 0) },
	  6 },
	{ "found, silent: its unanswered reads count for nothing",
	  { ST(FOUND, 1 * S, 1, 0, 0, 0, 1),
	    ST(MISSED, 1 * S + 3 * MS, 10, 1, 10, RMD_REBOOT_WAIT, 1),
	    ST(MISSED, 1 * S + 5 * MS, 12, 1, 10, RMD_REBOOT_WAIT, 1),
	    ST(MISSED, 1 * S + 7 * MS, 14, 1, 10, RMD_REBOOT_WAIT, 1),
	    ST(MISSED, 1 * S + 9 * MS, 16, 1, 10, RMD_REBOOT_WAIT, 1) },
	  5 },
	{ "later, a skipped read only keeps the check going (late answers look the same)",
	  { ST(FOUND, 1 * S, 0, 0, 0, 0, 0), ST(MISSED, 2 * S, 10, 0, 10, RMD_REBOOT_WAIT, 1),
	    ST(MISSED, 2 * S + 3 * MS, 11, 1, 13, RMD_REBOOT_WAIT, 1),
	    ST(MISSED, 2 * S + 5 * MS, 13, 1, 15, RMD_REBOOT_WAIT, 1),
	    ST(MISSED, 2 * S + 7 * MS, 15, 1, 17, RMD_REBOOT_WAIT, 1),
	    ST(RUNTIME, 2 * S + 9 * MS, 11, 900000, 0, RMD_REBOOT_FINE, 0) },
	  6 },
	{ "V2: answers that cannot tell end the check undecided",
	  { ST(FOUND, 1 * S, 0, 0, 0, 0, 0), ST(MISSED, 2 * S, 10, 0, 10, RMD_REBOOT_WAIT, 1),
	    ST(ANSWER, 0, 11, RMD_REBOOT_SAYS_NOTHING, 0, RMD_REBOOT_WAIT, 1),
	    ST(ANSWER, 0, 12, RMD_REBOOT_SAYS_NOTHING, 0, RMD_REBOOT_WAIT, 1),
	    ST(ANSWER, 0, 13, RMD_REBOOT_SAYS_NOTHING, 0, RMD_REBOOT_UNDECIDED, 0) },
	  5 },
	{ "V2: a count gone astray tells nothing, and is no reboot",
	  { ST(FOUND, 1 * S, 0, 0, 0, 0, 0), ST(MISSED, 2 * S, 10, 0, 10, RMD_REBOOT_WAIT, 1),
	    ST(ANSWER, 0, 11, RMD_REBOOT_SAYS_COUNT_ASTRAY, 0, RMD_REBOOT_WAIT, 1),
	    ST(ANSWER, 0, 12, RMD_REBOOT_SAYS_COUNT_ASTRAY, 0, RMD_REBOOT_WAIT, 1),
	    ST(ANSWER, 0, 13, RMD_REBOOT_SAYS_COUNT_ASTRAY, 0, RMD_REBOOT_UNDECIDED, 0) },
	  5 },
	{ "V2: a count gone astray judges no boot and opens no check until found again",
	  { ST(FOUND, 1 * S, 0, 0, 0, 0, 0), ST(MISSED, 2 * S, 10, 0, 10, RMD_REBOOT_WAIT, 1),
	    CT(RMD_REBOOT_SAYS_RUNNING, RMD_REBOOT_SAYS_RUNNING, 0, 1),
	    CT(RMD_REBOOT_SAYS_COUNT_ASTRAY, RMD_REBOOT_SAYS_NOTHING, 1, 0), NX(0),
	    ST(MISSED, 3 * S, 20, 0, 20, RMD_REBOOT_WAIT, 0), NX(0),
	    CT(RMD_REBOOT_SAYS_BOOTED, RMD_REBOOT_SAYS_NOTHING, 0, 0),
	    CT(RMD_REBOOT_SAYS_COUNT_ASTRAY, RMD_REBOOT_SAYS_NOTHING, 0, 0),
	    ST(FOUND, 4 * S, 0, 0, 0, 0, 0),
	    CT(RMD_REBOOT_SAYS_BOOTED, RMD_REBOOT_SAYS_BOOTED, 0, 0),
	    ST(MISSED, 5 * S, 30, 0, 30, RMD_REBOOT_WAIT, 1) },
	  12 },
	{ "V2: a count that parted is a reboot, pending or not",
	  { ST(FOUND, 1 * S, 0, 0, 0, 0, 0),
	    ST(ANSWER, 0, 11, RMD_REBOOT_SAYS_RUNNING, 0, RMD_REBOOT_WAIT, 0),
	    ST(ANSWER, 0, 12, RMD_REBOOT_SAYS_BOOTED, 0, RMD_REBOOT_REBOOTED, 0) },
	  3 },
	{ "lost: nothing pending, nothing found",
	  { ST(FOUND, 1 * S, 1, 0, 0, 0, 1), ST(FORGET, 0, 0, 0, 0, 0, 0),
	    ST(MISSED, 2 * S, 10, 0, 10, RMD_REBOOT_WAIT, 0) },
	  3 },
	{ "the brake: a lock after a reported release is a boot's",
	  { RL(10), BR(9, 1, 0, RMD_REBOOT_SAYS_NOTHING), BR(11, 1, 0, RMD_REBOOT_SAYS_NOTHING),
	    BR(12, 1, 1, RMD_REBOOT_SAYS_RUNNING), BR(13, 1, 0, RMD_REBOOT_SAYS_BOOTED) },
	  5 },
	{ "the brake: not held released (SAFE, READY) tells nothing, and forgets",
	  { RL(10), BR(12, 1, 1, RMD_REBOOT_SAYS_RUNNING), BR(13, 0, 0, RMD_REBOOT_SAYS_NOTHING),
	    BR(14, 1, 0, RMD_REBOOT_SAYS_NOTHING) },
	  4 },
	{ "the brake: a new release forgets the old one's report",
	  { RL(10), BR(12, 1, 1, RMD_REBOOT_SAYS_RUNNING), RL(20),
	    BR(19, 1, 0, RMD_REBOOT_SAYS_NOTHING) },
	  4 },
	{ "the brake: a lock opens a check, whose runtime says it booted",
	  { ST(FOUND, 1 * S, 0, 0, 0, 0, 0), RL(10), BK(12, 1, 1, RMD_REBOOT_WAIT, 0),
	    BK(13, 0, 1, RMD_REBOOT_WAIT, 1), NX(0xB1),
	    ST(RUNTIME, 5 * S, 14, 2, 0, RMD_REBOOT_REBOOTED, 0) },
	  6 },
	{ "the brake: a lock another node's frame said; the runtime says running, and the next "
	  "lock opens none until it is reported released again",
	  { ST(FOUND, 1 * S, 0, 0, 0, 0, 0), RL(10), BK(12, 1, 1, RMD_REBOOT_WAIT, 0),
	    BK(13, 0, 1, RMD_REBOOT_WAIT, 1), NX(0xB1),
	    ST(RUNTIME, 5 * S, 14, 64000, 0, RMD_REBOOT_FINE, 0), BK(15, 0, 1, RMD_REBOOT_WAIT, 0),
	    BK(16, 1, 1, RMD_REBOOT_WAIT, 0), BK(17, 0, 1, RMD_REBOOT_WAIT, 1) },
	  9 },
	{ "the brake: firmware that answers no check read is judged by its brake alone",
	  { ST(FOUND, 1 * S, 0, 0, 0, 0, 0), RL(10), BK(12, 1, 0, RMD_REBOOT_WAIT, 0),
	    BK(13, 0, 0, RMD_REBOOT_REBOOTED, 0) },
	  4 },
	{ "the brake: firmware that never reports it released never fires",
	  { RL(10), BR(12, 1, 0, RMD_REBOOT_SAYS_NOTHING), BR(13, 1, 0, RMD_REBOOT_SAYS_NOTHING) },
	  3 },
};

static void test_check_steps(void **state)
{
	(void)state;
	for (size_t k = 0; k < sizeof(seqs) / sizeof(seqs[0]); k++) {
		const struct seq_case *c = &seqs[k];
		struct rmd_reboot r;

		rmd_reboot_init(&r);
		for (unsigned i = 0; i < c->n; i++) {
			const struct step *s = &c->steps[i];
			enum rmd_reboot_outcome out = RMD_REBOOT_WAIT;
			enum rmd_reboot_verdict v;
			bool news;
			unsigned cmd;

			switch (s->op) {
			case FOUND:
				rmd_reboot_found(&r, s->t, s->a);
				break;
			case FORGET:
				rmd_reboot_forget(&r);
				break;
			case MISSED:
				out = rmd_reboot_missed(&r, s->a, s->b, s->c, s->t, HOLD);
				break;
			case SLOW:
				rmd_reboot_slow(&r, s->t);
				break;
			case NEXT:
				cmd = rmd_reboot_next(&r, 0xB1);
				if (cmd != s->want_cmd)
					fail_msg("%s, step %u: sends 0x%02X, not 0x%02X", c->name,
						 i, cmd, s->want_cmd);
				break;
			case RUNTIME:
				out = rmd_reboot_runtime(&r, s->a, (uint32_t)s->b, s->t,
							 s->t + 1 * MS, NULL);
				break;
			case ANSWER:
				out = rmd_reboot_answer(&r, s->a, (enum rmd_reboot_verdict)s->b);
				break;
			case RELEASED:
				rmd_reboot_released(&r, s->a);
				break;
			case COUNT:
				v = rmd_reboot_count(&r, (enum rmd_reboot_verdict)s->b, &news);
				if (v != s->want_v || news != (bool)s->c)
					fail_msg("%s, step %u: says %s (news %d), not %s", c->name,
						 i, verdict_name[v], news, verdict_name[s->want_v]);
				break;
			case LOCKED:
				v = rmd_reboot_brake_says(&r, true, s->a, s->b);
				out = rmd_reboot_brake(&r, s->a, v, s->c);
				break;
			case BRAKE:
				v = rmd_reboot_brake_says(&r, s->b, s->a, s->c);
				if (v != s->want_v)
					fail_msg("%s, step %u: the brake says %s, not %s", c->name,
						 i, verdict_name[v], verdict_name[s->want_v]);
				break;
			}
			if (out != s->want)
				fail_msg("%s, step %u: %s, not %s", c->name, i, outcome_name[out],
					 outcome_name[s->want]);
			if (s->want_pending >= 0 && r.pending != (bool)s->want_pending)
				fail_msg("%s, step %u: pending %d", c->name, i, r.pending);
		}
	}
}

SUITE_MAIN("reboot", NULL, NULL,
	   {
		   cmocka_unit_test(test_runtime_table),
		   cmocka_unit_test(test_turns_table),
		   cmocka_unit_test(test_check_steps),
	   })

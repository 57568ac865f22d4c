// SPDX-License-Identifier: MIT
/*
 * MIT motion mode tests (V3 §5): the manual's worked example both ways,
 * hand-computed vectors for bit placement, clamping and exact half-LSB
 * rounding, per-motor ranges, NaN/Inf refusal, exhaustive code round trips
 * and seeded random value round trips (RMD_TEST_SEED=n repeats a run).
 */
#include <errno.h>
#include <float.h>
#include <math.h>
#include <setjmp.h>
#include <stdbool.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <cmocka.h>

#include "rmd/mit.h"

#include "harness/hex.h"
#include "harness/rng.h"
#include "harness/suite.h"

static uint64_t seed;

/* Default ranges but torque ±18 N·m, as some firmware has (docs/design.md); set by main(). */
static struct rmd_mit_ranges ranges_t18;

/* Every value equals its code (every minimum 0): shows where each bit lands. */
static const struct rmd_mit_ranges ranges_identity = {
	.p_max = 65535.0,
	.v_max = 4095.0,
	.t_max = 4095.0,
	.kp_max = 4095.0,
	.kd_max = 4095.0,
};

/* Field by field: the structs have padding. */
static bool frames_equal(const struct rmd_frame *a, const struct rmd_frame *b)
{
	return a->can_id == b->can_id && a->len == b->len &&
	       memcmp(a->data, b->data, sizeof(a->data)) == 0;
}

static double lsb(double min, double max, unsigned bits)
{
	return (max - min) / (double)((1ul << bits) - 1);
}

static double clamp(double x, double min, double max)
{
	return x < min ? min : x > max ? max : x;
}

/* splitmix64: the same sequence from the same seed on every libc. */
static uint64_t rng_state;

static uint64_t rng_next(void)
{
	return splitmix64(&rng_state);
}

/* Uniform in [lo, hi]. */
static double rng_uniform(double lo, double hi)
{
	return lo + (hi - lo) * (double)(rng_next() >> 11) / (double)(1ull << 53);
}

/* ---- Requests ---------------------------------------------------------- */

struct cmd_vec {
	const char *name;
	const struct rmd_mit_ranges *r; /* NULL: rmd_mit_default_ranges */
	uint8_t id;
	struct rmd_mit_cmd cmd;
	const char *hex;
};

static const struct cmd_vec cmd_vecs[] = {
	/* V3 §5.4 example 1: p 0xE666, v 0x82E, kp 0x052, kd 0x333, t 0xB55. */
	{ "V3 §5.4 example 1", NULL, 1, { 10.0, 1.02, 10.0, 1.0, 10.0 }, "401#E66682E052333B55" },
	{ "all minimum", NULL, 1, { -12.5, -45.0, 0.0, 0.0, -24.0 }, "401#0000000000000000" },
	{ "all maximum, id 32", NULL, 32, { 12.5, 45.0, 500.0, 5.0, 24.0 }, "420#FFFFFFFFFFFFFFFF" },
	/* 12.5 * 65535 / 25 = 32767.5 and 45 * 4095 / 90 = 2047.5 round up. */
	{ "zero is a half code", NULL, 2, { 0.0, 0.0, 0.0, 0.0, 0.0 }, "402#8000800000000800" },
	{ "bit placement",
	  &ranges_identity,
	  3,
	  { 0x1234, 0x567, 0x89A, 0xBCD, 0xEF0 },
	  "403#123456789ABCDEF0" },
	/* 28 * 4095 / 36 = 3185 = 0xC71: same command, other torque range. */
	{ "torque ±18 firmware",
	  &ranges_t18,
	  1,
	  { 10.0, 1.02, 10.0, 1.0, 10.0 },
	  "401#E66682E052333C71" },
};

static void check_cmd_near(const char *name, const struct rmd_mit_ranges *r,
			   const struct rmd_mit_cmd *got, const struct rmd_mit_cmd *want,
			   double tol_lsb)
{
	const struct {
		const char *field;
		double got, want, lsb;
	} f[] = {
		{ "p_des", got->p_des_rad, want->p_des_rad, lsb(r->p_min, r->p_max, 16) },
		{ "v_des", got->v_des_rad_s, want->v_des_rad_s, lsb(r->v_min, r->v_max, 12) },
		{ "kp", got->kp, want->kp, lsb(r->kp_min, r->kp_max, 12) },
		{ "kd", got->kd, want->kd, lsb(r->kd_min, r->kd_max, 12) },
		{ "t_ff", got->t_ff_nm, want->t_ff_nm, lsb(r->t_min, r->t_max, 12) },
	};

	for (size_t i = 0; i < sizeof(f) / sizeof(f[0]); i++)
		if (!(fabs(f[i].got - f[i].want) <= tol_lsb * f[i].lsb))
			fail_msg("%s: %s decoded %.9g, want %.9g within %g LSB (%.3g)", name,
				 f[i].field, f[i].got, f[i].want, tol_lsb, f[i].lsb);
}

static void test_cmd_vectors(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(cmd_vecs) / sizeof(cmd_vecs[0]); i++) {
		const struct cmd_vec *v = &cmd_vecs[i];
		const struct rmd_mit_ranges *r = v->r ? v->r : &rmd_mit_default_ranges;
		struct rmd_frame f, want = frame_from(v->hex), again;
		struct rmd_mit_cmd dec;
		uint8_t id = 0;
		char got_hex[32], again_hex[32];
		int ret;

		/* encode(struct) == hex */
		ret = rmd_mit_encode_cmd(r, v->id, &v->cmd, &f);
		if (ret != 0)
			fail_msg("%s: encode returned %d", v->name, ret);
		if (strcmp(frame_hex(&f, got_hex), v->hex) != 0)
			fail_msg("%s: encode gave %s, want %s", v->name, got_hex, v->hex);

		/* decode(hex) == struct within 1 LSB per field */
		ret = rmd_mit_decode_cmd(r, &want, &id, &dec);
		if (ret != 0 || id != v->id)
			fail_msg("%s: decode returned %d, id %u", v->name, ret, id);
		check_cmd_near(v->name, r, &dec, &v->cmd, 1.0);

		/* encode(decode(hex)) == hex exactly */
		assert_int_equal(rmd_mit_encode_cmd(r, id, &dec, &again), 0);
		if (strcmp(frame_hex(&again, again_hex), v->hex) != 0)
			fail_msg("%s: re-encode of decoded values gave %s, want %s", v->name,
				 again_hex, v->hex);
	}
}

/* V3 §5.4 prints p = 9.99 (it divides by 65536); the frame is 10.0 rad. */
static void test_cmd_manual_example_values(void **state)
{
	struct rmd_frame f = frame_from("401#E66682E052333B55");
	struct rmd_mit_cmd c;
	uint8_t id;

	(void)state;
	assert_int_equal(rmd_mit_decode_cmd(&rmd_mit_default_ranges, &f, &id, &c), 0);
	assert_int_equal(id, 1);
	/* 58982 * 25 / 65535 - 12.5, 2094 * 90 / 4095 - 45, ... */
	assert_float_equal(c.p_des_rad, 10.000190738, 1e-8);
	assert_float_equal(c.v_des_rad_s, 1.021978022, 1e-8);
	assert_float_equal(c.kp, 10.012210012, 1e-8);
	assert_float_equal(c.kd, 1.0, 1e-12);
	assert_float_equal(c.t_ff_nm, 10.004395604, 1e-8);
	/* The manual's 9.99 (9.9998 with its 65536) is within one LSB too. */
	assert_true(fabs(c.p_des_rad - 9.9998474) < lsb(-12.5, 12.5, 16));
}

struct clamp_vec {
	const char *name;
	struct rmd_mit_cmd cmd;
	const char *hex;
};

static const struct clamp_vec clamp_vecs[] = {
	{ "above every range", { 100.0, 1000.0, 1e6, 50.0, 1e3 }, "401#FFFFFFFFFFFFFFFF" },
	{ "below every range", { -100.0, -1000.0, -1.0, -0.5, -1e3 }, "401#0000000000000000" },
	{ "mixed ends", { 1e9, -1e9, 1e9, -1.0, 1e9 }, "401#FFFF000FFF000FFF" },
	{ "negative gains clamp to 0", { 10.0, 1.02, -5.0, -1.0, 10.0 }, "401#E66682E000000B55" },
	{ "largest finite doubles",
	  { DBL_MAX, -DBL_MAX, DBL_MAX, -DBL_MAX, DBL_MAX },
	  "401#FFFF000FFF000FFF" },
	{ "just outside the ends",
	  { 12.5000001, -45.0000001, 500.0000001, -1e-300, 24.0000001 },
	  "401#FFFF000FFF000FFF" },
};

static void test_cmd_clamp(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(clamp_vecs) / sizeof(clamp_vecs[0]); i++) {
		const struct clamp_vec *v = &clamp_vecs[i];
		struct rmd_frame f;
		char hex[32];
		int ret = rmd_mit_encode_cmd(&rmd_mit_default_ranges, 1, &v->cmd, &f);

		if (ret != 0)
			fail_msg("%s: encode returned %d", v->name, ret);
		if (strcmp(frame_hex(&f, hex), v->hex) != 0)
			fail_msg("%s: encode gave %s, want %s", v->name, hex, v->hex);
	}
}

/* ---- Quantisation primitives ------------------------------------------- */

struct quant_vec {
	const char *name;
	double x, min, max;
	unsigned bits;
	uint32_t want;
};

static void test_to_uint_rounding(void **state)
{
	const struct quant_vec vecs[] = {
		/* Exact halves go away from zero (round(), not banker's rounding). */
		{ "12-bit 0.5", 0.5, 0.0, 4095.0, 12, 1 },
		{ "12-bit 1.5", 1.5, 0.0, 4095.0, 12, 2 },
		{ "12-bit 2.5 (not to even)", 2.5, 0.0, 4095.0, 12, 3 },
		{ "12-bit 4094.5", 4094.5, 0.0, 4095.0, 12, 4095 },
		{ "12-bit just below 0.5", nextafter(0.5, 0.0), 0.0, 4095.0, 12, 0 },
		{ "12-bit just above 0.5", nextafter(0.5, 1.0), 0.0, 4095.0, 12, 1 },
		{ "16-bit 0.5", 0.5, 0.0, 65535.0, 16, 1 },
		{ "16-bit 65534.5", 65534.5, 0.0, 65535.0, 16, 65535 },
		{ "16-bit 2.5 (not to even)", 2.5, 0.0, 65535.0, 16, 3 },
		/* Half codes in the default ranges. */
		{ "p 10.0 = 58981.5", 10.0, -12.5, 12.5, 16, 58982 },
		{ "p 0.0 = 32767.5", 0.0, -12.5, 12.5, 16, 32768 },
		{ "v 0.0 = 2047.5", 0.0, -45.0, 45.0, 12, 2048 },
		{ "t 0.0 = 2047.5", 0.0, -24.0, 24.0, 12, 2048 },
		{ "t 10.0 = 2900.625", 10.0, -24.0, 24.0, 12, 2901 },
		{ "v 1.02 = 2093.91", 1.02, -45.0, 45.0, 12, 2094 },
		{ "kp 10.0 = 81.9", 10.0, 0.0, 500.0, 12, 82 },
		/* Ends and clamping. */
		{ "p min", -12.5, -12.5, 12.5, 16, 0 },
		{ "p max", 12.5, -12.5, 12.5, 16, 65535 },
		{ "below min", -13.0, -12.5, 12.5, 16, 0 },
		{ "above max", 13.0, -12.5, 12.5, 16, 65535 },
		{ "NaN -> min", NAN, -12.5, 12.5, 16, 0 },
		{ "-Inf -> min", -INFINITY, -12.5, 12.5, 16, 0 },
		{ "+Inf -> max", INFINITY, -12.5, 12.5, 16, 65535 },
		{ "1 bit half", 0.5, 0.0, 1.0, 1, 1 },
		{ "32 bits max", 1.0, 0.0, 1.0, 32, UINT32_MAX },
		/* Misuse gives 0, never a wild code. */
		{ "bits 0", 1.0, 0.0, 2.0, 0, 0 },
		{ "bits 33", 1.0, 0.0, 2.0, 33, 0 },
		{ "empty range", 1.0, 1.0, 1.0, 12, 0 },
		{ "reversed range", 1.0, 2.0, 0.0, 12, 0 },
		{ "NaN range", 1.0, NAN, 2.0, 12, 0 },
		{ "infinite span", 1.0, -DBL_MAX, DBL_MAX, 12, 0 },
	};

	(void)state;
	for (size_t i = 0; i < sizeof(vecs) / sizeof(vecs[0]); i++) {
		const struct quant_vec *v = &vecs[i];
		uint32_t got = rmd_mit_to_uint(v->x, v->min, v->max, v->bits);

		if (got != v->want)
			fail_msg("%s: to_uint gave %u, want %u", v->name, got, v->want);
	}
}

static void test_from_uint(void **state)
{
	(void)state;
	assert_true(rmd_mit_from_uint(0, -12.5, 12.5, 16) == -12.5);
	assert_true(rmd_mit_from_uint(65535, -12.5, 12.5, 16) == 12.5);
	assert_true(rmd_mit_from_uint(65536, -12.5, 12.5, 16) == 12.5);
	assert_true(rmd_mit_from_uint(4095, -0.3, 0.7, 12) == 0.7);
	assert_true(rmd_mit_from_uint(819, 0.0, 5.0, 12) == 1.0);
	assert_true(rmd_mit_from_uint(UINT32_MAX, 0.0, 1.0, 32) == 1.0);
	assert_true(isnan(rmd_mit_from_uint(1, 0.0, 1.0, 0)));
	assert_true(isnan(rmd_mit_from_uint(1, 0.0, 1.0, 33)));
	assert_true(isnan(rmd_mit_from_uint(1, 1.0, 1.0, 12)));
	assert_true(isnan(rmd_mit_from_uint(1, 0.0, INFINITY, 12)));
}

/* Every code of every field decodes and re-encodes to itself. */
static void test_codes_round_trip_exhaustive(void **state)
{
	const struct {
		const char *name;
		double min, max;
		unsigned bits;
	} fields[] = {
		{ "p ±12.5", -12.5, 12.5, 16 },	      { "v ±45", -45.0, 45.0, 12 },
		{ "t ±24", -24.0, 24.0, 12 },	      { "t ±18", -18.0, 18.0, 12 },
		{ "kp 0..500", 0.0, 500.0, 12 },      { "kd 0..5", 0.0, 5.0, 12 },
		{ "p ±4π", -4 * M_PI, 4 * M_PI, 16 }, { "odd 16-bit", -0.3, 1e4 / 3, 16 },
	};

	(void)state;
	for (size_t i = 0; i < sizeof(fields) / sizeof(fields[0]); i++) {
		uint32_t top = (uint32_t)((1ul << fields[i].bits) - 1);

		for (uint32_t u = 0; u <= top; u++) {
			double x =
				rmd_mit_from_uint(u, fields[i].min, fields[i].max, fields[i].bits);
			uint32_t back =
				rmd_mit_to_uint(x, fields[i].min, fields[i].max, fields[i].bits);

			if (back != u)
				fail_msg("%s: code %u -> %.17g -> %u", fields[i].name, u, x, back);
		}
	}
}

static void random_ranges(struct rmd_mit_ranges *r)
{
	r->p_min = rng_uniform(-100.0, 0.0);
	r->p_max = r->p_min + rng_uniform(0.01, 200.0);
	r->v_min = rng_uniform(-100.0, 0.0);
	r->v_max = r->v_min + rng_uniform(0.01, 200.0);
	r->t_min = rng_uniform(-100.0, 0.0);
	r->t_max = r->t_min + rng_uniform(0.01, 200.0);
	r->kp_min = rng_uniform(0.0, 10.0);
	r->kp_max = r->kp_min + rng_uniform(0.01, 1000.0);
	r->kd_min = rng_uniform(0.0, 1.0);
	r->kd_max = r->kd_min + rng_uniform(0.01, 10.0);
}

/* Uniform over the range and 10% beyond each end, so clamping is covered. */
static double random_in(double min, double max)
{
	double margin = (max - min) / 10.0;

	return rng_uniform(min - margin, max + margin);
}

/*
 * decode(encode(x)) is within half an LSB of clamp(x) (round to nearest),
 * and encode(decode(encode(x))) == encode(x), over default, ±18 N·m and
 * random ranges.
 */
static void test_cmd_random_round_trip(void **state)
{
	(void)state;
	rng_state = seed;
	for (int i = 0; i < 30000; i++) {
		struct rmd_mit_ranges rr;
		const struct rmd_mit_ranges *r;
		struct rmd_mit_cmd c, clamped, dec;
		struct rmd_frame f, f2;
		uint8_t id = (uint8_t)(1 + rng_next() % RMD_MAX_MOTORS), id2;
		char name[96], h1[32], h2[32];

		switch (i % 3) {
		case 0:
			r = &rmd_mit_default_ranges;
			break;
		case 1:
			r = &ranges_t18;
			break;
		default:
			random_ranges(&rr);
			r = &rr;
			break;
		}
		c.p_des_rad = random_in(r->p_min, r->p_max);
		c.v_des_rad_s = random_in(r->v_min, r->v_max);
		c.kp = random_in(r->kp_min, r->kp_max);
		c.kd = random_in(r->kd_min, r->kd_max);
		c.t_ff_nm = random_in(r->t_min, r->t_max);
		clamped.p_des_rad = clamp(c.p_des_rad, r->p_min, r->p_max);
		clamped.v_des_rad_s = clamp(c.v_des_rad_s, r->v_min, r->v_max);
		clamped.kp = clamp(c.kp, r->kp_min, r->kp_max);
		clamped.kd = clamp(c.kd, r->kd_min, r->kd_max);
		clamped.t_ff_nm = clamp(c.t_ff_nm, r->t_min, r->t_max);
		snprintf(name, sizeof(name), "random cmd #%d (RMD_TEST_SEED=%llu)", i,
			 (unsigned long long)seed);

		if (rmd_mit_encode_cmd(r, id, &c, &f) != 0)
			fail_msg("%s: encode failed", name);
		if (rmd_mit_decode_cmd(r, &f, &id2, &dec) != 0 || id2 != id)
			fail_msg("%s: decode failed", name);
		check_cmd_near(name, r, &dec, &clamped, 0.5 * (1.0 + 1e-9));
		if (rmd_mit_encode_cmd(r, id, &dec, &f2) != 0)
			fail_msg("%s: re-encode failed", name);
		if (!frames_equal(&f, &f2))
			fail_msg("%s: %s re-encoded as %s", name, frame_hex(&f, h1),
				 frame_hex(&f2, h2));
	}
}

/* ---- Refusals ---------------------------------------------------------- */

static void test_cmd_non_finite_rejected(void **state)
{
	const double bad[] = { NAN, -NAN, INFINITY, -INFINITY };
	const char *const fields[] = { "p_des", "v_des", "kp", "kd", "t_ff" };

	(void)state;
	for (size_t fi = 0; fi < 5; fi++) {
		for (size_t bi = 0; bi < sizeof(bad) / sizeof(bad[0]); bi++) {
			struct rmd_mit_cmd c = { 1.0, 1.0, 10.0, 1.0, 1.0 };
			double *slot[] = { &c.p_des_rad, &c.v_des_rad_s, &c.kp, &c.kd, &c.t_ff_nm };
			struct rmd_frame f, sentinel;
			int ret;

			memset(&f, 0xA5, sizeof(f));
			sentinel = f;
			*slot[fi] = bad[bi];
			ret = rmd_mit_encode_cmd(&rmd_mit_default_ranges, 1, &c, &f);
			if (ret != -EINVAL)
				fail_msg("%s = %g: encode returned %d, want -EINVAL", fields[fi],
					 bad[bi], ret);
			if (!frames_equal(&f, &sentinel))
				fail_msg("%s = %g: frame written on error", fields[fi], bad[bi]);
		}
	}
}

static void test_cmd_bad_id_and_ranges(void **state)
{
	const struct rmd_mit_cmd c = { 1.0, 1.0, 10.0, 1.0, 1.0 };
	const uint8_t bad_ids[] = { 0, 33, 0x7F, 0xFF };
	struct rmd_mit_ranges r = rmd_mit_default_ranges;
	struct rmd_mit_cmd dec;
	struct rmd_mit_reply rep;
	struct rmd_frame f;
	uint8_t id;

	(void)state;
	for (size_t i = 0; i < sizeof(bad_ids); i++)
		if (rmd_mit_encode_cmd(&rmd_mit_default_ranges, bad_ids[i], &c, &f) != -EINVAL)
			fail_msg("encode to id %u accepted", bad_ids[i]);

	/* Invalid ranges refuse both ways (and a valid frame with them). */
	r.t_min = r.t_max;
	assert_int_equal(rmd_mit_encode_cmd(&r, 1, &c, &f), -EINVAL);
	f = frame_from("401#E66682E052333B55");
	assert_int_equal(rmd_mit_decode_cmd(&r, &f, &id, &dec), -EINVAL);
	f = frame_from("501#01E66682EB550000");
	assert_int_equal(rmd_mit_decode_reply(&r, &f, &rep), -EINVAL);
}

static void test_ranges_valid(void **state)
{
	const struct {
		const char *name;
		size_t off; /* offset of the double to spoil */
		double value;
	} bad[] = {
		{ "p_min == p_max", offsetof(struct rmd_mit_ranges, p_min), 12.5 },
		{ "v_min > v_max", offsetof(struct rmd_mit_ranges, v_min), 50.0 },
		{ "t_min NaN", offsetof(struct rmd_mit_ranges, t_min), NAN },
		{ "t_max NaN", offsetof(struct rmd_mit_ranges, t_max), NAN },
		{ "kp_max +Inf", offsetof(struct rmd_mit_ranges, kp_max), INFINITY },
		{ "p_min -Inf", offsetof(struct rmd_mit_ranges, p_min), -INFINITY },
		{ "kp_min negative", offsetof(struct rmd_mit_ranges, kp_min), -1.0 },
		{ "kd_min negative", offsetof(struct rmd_mit_ranges, kd_min), -0.1 },
	};
	struct rmd_mit_ranges wide = rmd_mit_default_ranges;

	(void)state;
	assert_true(rmd_mit_ranges_valid(&rmd_mit_default_ranges));
	assert_true(rmd_mit_ranges_valid(&ranges_t18));
	assert_true(rmd_mit_ranges_valid(&ranges_identity));
	assert_false(rmd_mit_ranges_valid(NULL));
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		struct rmd_mit_ranges r = rmd_mit_default_ranges;

		memcpy((char *)&r + bad[i].off, &bad[i].value, sizeof(double));
		if (rmd_mit_ranges_valid(&r))
			fail_msg("%s: accepted", bad[i].name);
	}
	/* Both ends finite, their difference not. */
	wide.p_min = -DBL_MAX;
	wide.p_max = DBL_MAX;
	assert_false(rmd_mit_ranges_valid(&wide));
	/*
	 * F1 (fuzz_mit): a finite span whose product with the top code is not
	 * (1e305 * 65535 overflows) decoded every code but 0 and the top to
	 * infinity.  Bounds beyond RMD_MIT_RANGE_LIMIT are refused; at it, every
	 * code decodes to a finite value inside the range.
	 */
	wide = rmd_mit_default_ranges;
	wide.p_min = -1e305;
	wide.p_max = 1e305;
	assert_false(rmd_mit_ranges_valid(&wide));
	wide.p_min = -RMD_MIT_RANGE_LIMIT;
	wide.p_max = RMD_MIT_RANGE_LIMIT;
	assert_true(rmd_mit_ranges_valid(&wide));
	for (uint32_t u = 0; u <= 0xFFFF; u += 0x1111) {
		double x = rmd_mit_from_uint(u, wide.p_min, wide.p_max, 16);

		assert_true(isfinite(x) && x >= wide.p_min && x <= wide.p_max);
	}
	wide.p_max = nextafter(RMD_MIT_RANGE_LIMIT, INFINITY);
	assert_false(rmd_mit_ranges_valid(&wide));
}

struct bad_frame_vec {
	const char *name;
	const char *hex;
	int want;
};

static void test_cmd_bad_frames(void **state)
{
	/* V3 §5.4 example 1 (401#E66682E052333B55) with another CAN ID or DLC. */
	const struct {
		const char *name;
		uint32_t can_id;
		uint8_t len;
		int want;
	} vecs[] = {
		{ "DLC 7", 0x401, 7, -EBADMSG },
		{ "DLC 0", 0x401, 0, -EBADMSG },
		{ "id 0x400", 0x400, 8, -EINVAL },
		{ "id 0x421", 0x421, 8, -EINVAL },
		{ "V3 single-motor id 0x141", 0x141, 8, -EINVAL },
		{ "MIT reply id 0x501", 0x501, 8, -EINVAL },
	};

	(void)state;
	for (size_t i = 0; i < sizeof(vecs) / sizeof(vecs[0]); i++) {
		struct rmd_frame f = frame_from("401#E66682E052333B55");
		struct rmd_mit_cmd c = { 7.0, 7.0, 7.0, 7.0, 7.0 };
		uint8_t id = 99;
		int ret;

		f.can_id = vecs[i].can_id;
		f.len = vecs[i].len;
		ret = rmd_mit_decode_cmd(&rmd_mit_default_ranges, &f, &id, &c);

		if (ret != vecs[i].want)
			fail_msg("%s: decode returned %d, want %d", vecs[i].name, ret,
				 vecs[i].want);
		if (id != 99 || c.p_des_rad != 7.0)
			fail_msg("%s: outputs written on error", vecs[i].name);
	}
	{
		/* A DLC above 8 cannot come from SocketCAN, but is not 8 either. */
		struct rmd_frame f = frame_from("401#E66682E052333B55");
		struct rmd_mit_cmd c;
		uint8_t id;

		f.len = 9;
		assert_int_equal(rmd_mit_decode_cmd(&rmd_mit_default_ranges, &f, &id, &c),
				 -EBADMSG);
	}
}

/* ---- Replies ----------------------------------------------------------- */

struct reply_vec {
	const char *name;
	const struct rmd_mit_ranges *r;
	struct rmd_mit_reply rep;
	const char *hex;
};

static const struct reply_vec reply_vecs[] = {
	/*
	 * V3 §5.4 example 1 reply, from its field values and the §5.3 layout;
	 * the printed table has D2 = 0x65 (contradicting p = 0xE666) and no D3.
	 */
	{ "V3 §5.4 example 1 reply",
	  &rmd_mit_default_ranges,
	  { 1, 10.0, 1.02, 10.0 },
	  "501#01E66682EB550000" },
	{ "bit placement", &ranges_identity, { 5, 0x1234, 0x567, 0x89A }, "505#05123456789A0000" },
	{ "ends, id 32",
	  &rmd_mit_default_ranges,
	  { 32, -12.5, 45.0, -24.0 },
	  "520#200000FFF0000000" },
	{ "torque ±18 firmware", &ranges_t18, { 1, 10.0, 1.02, 10.0 }, "501#01E66682EC710000" },
	{ "clamped", &rmd_mit_default_ranges, { 3, 100.0, -100.0, 100.0 }, "503#03FFFF000FFF0000" },
};

static void check_reply_near(const char *name, const struct rmd_mit_ranges *r,
			     const struct rmd_mit_reply *got, const struct rmd_mit_reply *want,
			     double tol_lsb)
{
	if (got->motor_id != want->motor_id)
		fail_msg("%s: motor_id %u, want %u", name, got->motor_id, want->motor_id);
	if (!(fabs(got->pos_rad - want->pos_rad) <= tol_lsb * lsb(r->p_min, r->p_max, 16)))
		fail_msg("%s: pos %.9g, want %.9g", name, got->pos_rad, want->pos_rad);
	if (!(fabs(got->vel_rad_s - want->vel_rad_s) <= tol_lsb * lsb(r->v_min, r->v_max, 12)))
		fail_msg("%s: vel %.9g, want %.9g", name, got->vel_rad_s, want->vel_rad_s);
	if (!(fabs(got->torque_nm - want->torque_nm) <= tol_lsb * lsb(r->t_min, r->t_max, 12)))
		fail_msg("%s: torque %.9g, want %.9g", name, got->torque_nm, want->torque_nm);
}

static void test_reply_vectors(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(reply_vecs) / sizeof(reply_vecs[0]); i++) {
		const struct reply_vec *v = &reply_vecs[i];
		struct rmd_frame f, want = frame_from(v->hex), again;
		struct rmd_mit_reply dec, clamped = v->rep;
		char hex[32];
		int ret;

		ret = rmd_mit_encode_reply(v->r, &v->rep, &f);
		if (ret != 0)
			fail_msg("%s: encode returned %d", v->name, ret);
		if (strcmp(frame_hex(&f, hex), v->hex) != 0)
			fail_msg("%s: encode gave %s, want %s", v->name, hex, v->hex);

		ret = rmd_mit_decode_reply(v->r, &want, &dec);
		if (ret != 0)
			fail_msg("%s: decode returned %d", v->name, ret);
		clamped.pos_rad = clamp(clamped.pos_rad, v->r->p_min, v->r->p_max);
		clamped.vel_rad_s = clamp(clamped.vel_rad_s, v->r->v_min, v->r->v_max);
		clamped.torque_nm = clamp(clamped.torque_nm, v->r->t_min, v->r->t_max);
		check_reply_near(v->name, v->r, &dec, &clamped, 1.0);

		assert_int_equal(rmd_mit_encode_reply(v->r, &dec, &again), 0);
		if (strcmp(frame_hex(&again, hex), v->hex) != 0)
			fail_msg("%s: re-encode of decoded values gave %s", v->name, hex);
	}
}

static void test_reply_manual_example_values(void **state)
{
	struct rmd_frame f = frame_from("501#01E66682EB550000");
	struct rmd_frame g = frame_from("501#01E66682EB55ABCD");
	struct rmd_mit_reply rep, rep2;

	(void)state;
	assert_int_equal(rmd_mit_decode_reply(&rmd_mit_default_ranges, &f, &rep), 0);
	assert_int_equal(rep.motor_id, 1);
	assert_float_equal(rep.pos_rad, 10.000190738, 1e-8);
	assert_float_equal(rep.vel_rad_s, 1.021978022, 1e-8);
	assert_float_equal(rep.torque_nm, 10.004395604, 1e-8);
	/* D6 and D7 are unused: whatever they hold does not matter. */
	assert_int_equal(rmd_mit_decode_reply(&rmd_mit_default_ranges, &g, &rep2), 0);
	assert_int_equal(rep2.motor_id, rep.motor_id);
	assert_true(rep2.pos_rad == rep.pos_rad && rep2.vel_rad_s == rep.vel_rad_s &&
		    rep2.torque_nm == rep.torque_nm);
}

static void test_reply_bad(void **state)
{
	const struct bad_frame_vec vecs[] = {
		{ "DLC 6", "501#01E66682EB55", -EBADMSG },
		{ "DLC 0", "501#", -EBADMSG },
		{ "D0 is not the CAN ID's motor", "502#01E66682EB550000", -EBADMSG },
		{ "D0 zero", "501#00E66682EB550000", -EBADMSG },
		{ "id 0x500", "500#00E66682EB550000", -EINVAL },
		{ "id 0x521", "521#21E66682EB550000", -EINVAL },
		{ "MIT request id 0x401", "401#01E66682EB550000", -EINVAL },
		{ "V3 reply id 0x241", "241#01E66682EB550000", -EINVAL },
	};
	const double bad[] = { NAN, INFINITY, -INFINITY };

	(void)state;
	for (size_t i = 0; i < sizeof(vecs) / sizeof(vecs[0]); i++) {
		struct rmd_frame f = frame_from(vecs[i].hex);
		struct rmd_mit_reply rep = { 99, 7.0, 7.0, 7.0 };
		int ret = rmd_mit_decode_reply(&rmd_mit_default_ranges, &f, &rep);

		if (ret != vecs[i].want)
			fail_msg("%s: decode returned %d, want %d", vecs[i].name, ret,
				 vecs[i].want);
		if (rep.motor_id != 99 || rep.pos_rad != 7.0)
			fail_msg("%s: outputs written on error", vecs[i].name);
	}

	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		struct rmd_mit_reply reps[] = {
			{ 1, bad[i], 0.0, 0.0 },
			{ 1, 0.0, bad[i], 0.0 },
			{ 1, 0.0, 0.0, bad[i] },
		};

		for (size_t j = 0; j < 3; j++) {
			struct rmd_frame f;

			if (rmd_mit_encode_reply(&rmd_mit_default_ranges, &reps[j], &f) != -EINVAL)
				fail_msg("reply field %zu = %g: encode accepted", j, bad[i]);
		}
	}
	{
		struct rmd_mit_reply r0 = { 0, 0.0, 0.0, 0.0 }, r33 = { 33, 0.0, 0.0, 0.0 };
		struct rmd_frame f;

		assert_int_equal(rmd_mit_encode_reply(&rmd_mit_default_ranges, &r0, &f), -EINVAL);
		assert_int_equal(rmd_mit_encode_reply(&rmd_mit_default_ranges, &r33, &f), -EINVAL);
	}
}

static void test_reply_random_round_trip(void **state)
{
	(void)state;
	rng_state = seed ^ 0x5EEDu;
	for (int i = 0; i < 30000; i++) {
		struct rmd_mit_ranges rr;
		const struct rmd_mit_ranges *r = &rmd_mit_default_ranges;
		struct rmd_mit_reply rep, clamped, dec;
		struct rmd_frame f, f2;
		char name[96];

		if (i % 2) {
			random_ranges(&rr);
			r = &rr;
		}
		rep.motor_id = (uint8_t)(1 + rng_next() % RMD_MAX_MOTORS);
		rep.pos_rad = random_in(r->p_min, r->p_max);
		rep.vel_rad_s = random_in(r->v_min, r->v_max);
		rep.torque_nm = random_in(r->t_min, r->t_max);
		clamped = rep;
		clamped.pos_rad = clamp(rep.pos_rad, r->p_min, r->p_max);
		clamped.vel_rad_s = clamp(rep.vel_rad_s, r->v_min, r->v_max);
		clamped.torque_nm = clamp(rep.torque_nm, r->t_min, r->t_max);
		snprintf(name, sizeof(name), "random reply #%d (RMD_TEST_SEED=%llu)", i,
			 (unsigned long long)seed);

		if (rmd_mit_encode_reply(r, &rep, &f) != 0 ||
		    rmd_mit_decode_reply(r, &f, &dec) != 0)
			fail_msg("%s: encode/decode failed", name);
		check_reply_near(name, r, &dec, &clamped, 0.5 * (1.0 + 1e-9));
		if (rmd_mit_encode_reply(r, &dec, &f2) != 0 || !frames_equal(&f, &f2))
			fail_msg("%s: re-encode differs", name);
	}
}

/* "P,V,T,KP,KD" maxima, as rmdctl --mit-ranges and rmd-sim take them. */
static void test_ranges_parse(void **state)
{
	static const char *const bad[] = { "",
					   "12.5,45,24,500",
					   "12.5,45,24,500,5,1",
					   "12.5,,24,500,5",
					   "12.5,45,24,500,0",
					   "-1,45,24,500,5",
					   "x,45,24,500,5",
					   "12.5,45,24,500,5 ",
					   "nan,45,24,500,5",
					   "inf,45,24,500,5",
					   "1e999,45,24,500,5",
					   "1e305,45,24,500,5" /* F1 */ };
	struct rmd_mit_ranges r = { 0 }, before;

	(void)state;
	assert_int_equal(rmd_mit_ranges_parse("12.5,45,24,500,5", &r), 0);
	assert_memory_equal(&r, &rmd_mit_default_ranges, sizeof(r));
	assert_int_equal(rmd_mit_ranges_parse("12.5,45,18,500,5", &r), 0);
	assert_true(r.t_min == -18.0 && r.t_max == 18.0 && r.kp_min == 0.0);
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		before = r;
		if (rmd_mit_ranges_parse(bad[i], &r) != -EINVAL)
			fail_msg("\"%s\" was accepted", bad[i]);
		assert_memory_equal(&r, &before, sizeof(r));
	}
}

int main(void)
{
	const char *env = getenv("RMD_TEST_SEED");
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_cmd_vectors),
		cmocka_unit_test(test_cmd_manual_example_values),
		cmocka_unit_test(test_cmd_clamp),
		cmocka_unit_test(test_to_uint_rounding),
		cmocka_unit_test(test_from_uint),
		cmocka_unit_test(test_codes_round_trip_exhaustive),
		cmocka_unit_test(test_cmd_random_round_trip),
		cmocka_unit_test(test_cmd_non_finite_rejected),
		cmocka_unit_test(test_cmd_bad_id_and_ranges),
		cmocka_unit_test(test_ranges_valid),
		cmocka_unit_test(test_cmd_bad_frames),
		cmocka_unit_test(test_reply_vectors),
		cmocka_unit_test(test_reply_manual_example_values),
		cmocka_unit_test(test_reply_bad),
		cmocka_unit_test(test_reply_random_round_trip),
		cmocka_unit_test(test_ranges_parse),
	};

	ranges_t18 = rmd_mit_default_ranges;
	ranges_t18.t_min = -18.0;
	ranges_t18.t_max = 18.0;
	seed = env && *env ? strtoull(env, NULL, 0) : (uint64_t)time(NULL);
	return SUITE_RUN("mit", tests, NULL, NULL);
}

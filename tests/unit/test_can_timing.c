// SPDX-License-Identifier: MIT
/*
 * can_timing tests: frames worked out by hand, then thousands of seeded
 * random frames cross-checked against a second, deliberately naive model
 * in this file (build the bit string as an array, CRC by polynomial long
 * division, stuff into a second array, count), and the bounds of docs/design.md.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "rmd/can_timing.h"

#include "harness/rng.h"
#include "harness/suite.h"

#define SEED_DEFAULT 0x5eed0001u
#define RANDOM_FRAMES 20000

/* ---- the reference model: bit strings as arrays of 0/1 ----------------- */

#define MAX_BITS 256

struct bits {
	unsigned n;
	unsigned char b[MAX_BITS];
};

static void push(struct bits *s, uint32_t v, unsigned n)
{
	for (unsigned i = n; i-- > 0;)
		s->b[s->n++] = (unsigned char)((v >> i) & 1u);
}

/*
 * CRC-15 as the remainder of M(x) * x^15 divided by the generator
 * x^15+x^14+x^10+x^8+x^7+x^4+x^3+1, by schoolbook long division on a copy
 * of the message with 15 zero bits appended.
 */
static uint16_t ref_crc(const struct bits *msg)
{
	static const unsigned char gen[16] = { 1, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1 };
	unsigned char work[MAX_BITS + 16];
	unsigned n = msg->n + 15;
	uint16_t crc = 0;

	memcpy(work, msg->b, msg->n);
	memset(work + msg->n, 0, 15);
	for (unsigned i = 0; i + 15 < n; i++) {
		if (!work[i])
			continue;
		for (unsigned j = 0; j < 16; j++)
			work[i + j] ^= gen[j];
	}
	for (unsigned i = n - 15; i < n; i++)
		crc = (uint16_t)(crc << 1 | work[i]);
	return crc;
}

/* The whole frame on the wire, stuffed, IFS included: its length in bits. */
static unsigned ref_frame_bits(const struct rmd_frame *f, unsigned *stuff_out)
{
	struct bits raw = { 0 }, wire = { 0 };
	unsigned n = f->len > 8 ? 8 : f->len;
	unsigned run = 0, stuff = 0;

	push(&raw, 0, 1);		   /* SOF */
	push(&raw, f->can_id & 0x7FF, 11); /* identifier */
	push(&raw, 0, 1);		   /* RTR */
	push(&raw, 0, 1);		   /* IDE */
	push(&raw, 0, 1);		   /* r0 */
	push(&raw, f->len & 0xF, 4);	   /* DLC */
	for (unsigned i = 0; i < n; i++)   /* data */
		push(&raw, f->data[i], 8);
	push(&raw, ref_crc(&raw), 15); /* CRC sequence */

	for (unsigned i = 0; i < raw.n; i++) {
		unsigned char bit = raw.b[i];

		if (wire.n > 0 && wire.b[wire.n - 1] == bit)
			run++;
		else
			run = 1;
		wire.b[wire.n++] = bit;
		if (run == 5) {
			wire.b[wire.n++] = (unsigned char)!bit;
			run = 1;
			stuff++;
		}
	}
	/* Check the result the other way round: no six equal bits remain. */
	for (unsigned i = 5; i < wire.n; i++) {
		unsigned same = 1;

		for (unsigned j = 1; j <= 5; j++)
			same &= wire.b[i - j] == wire.b[i];
		assert_false(same);
	}
	push(&wire, 1, 1);    /* CRC delimiter */
	push(&wire, 1, 1);    /* ACK slot (recessive as sent) */
	push(&wire, 1, 1);    /* ACK delimiter */
	push(&wire, 0x7F, 7); /* EOF */
	push(&wire, 0x7, 3);  /* intermission */
	if (stuff_out)
		*stuff_out = stuff;
	return wire.n;
}

/* ---- deterministic PRNG, seed printed on failure ------------------------ */

static uint64_t rng_state;

static uint64_t rng_next(void)
{
	return splitmix64(&rng_state);
}

static uint32_t test_seed(void)
{
	const char *s = getenv("RMD_TEST_SEED");

	return s ? (uint32_t)strtoul(s, NULL, 0) : SEED_DEFAULT;
}

static struct rmd_frame random_frame(unsigned len)
{
	struct rmd_frame f = { 0 };

	f.can_id = (uint32_t)(rng_next() & 0x7FF);
	f.len = (uint8_t)len;
	for (unsigned i = 0; i < 8; i++)
		f.data[i] = (uint8_t)rng_next();
	return f;
}

/* ---- tests -------------------------------------------------------------- */

/*
 * Frames worked out by hand.  The CRC values are the ones both the register
 * implementation and this file's long division compute (asserted below);
 * the stuffing given the CRC is counted by hand in each comment.
 */
struct hand_vector {
	const char *name;
	struct rmd_frame f;
	uint16_t crc;
	unsigned stuff;
	unsigned bits;
};

static const struct hand_vector hand_vectors[] = {
	/*
	 * SOF, 11 id bits, RTR, IDE, r0 and the DLC are 19 zeros; an all-zero
	 * message has CRC 0, so 34 zeros are stuffed: a one after zeros 5,
	 * 10, ..., 30 = 6 stuff bits.  47 + 6 = 53.
	 */
	{ "id 000 dlc 0", { .can_id = 0x000, .len = 0 }, 0x0000, 6, 53 },
	/*
	 * 15 zeros (SOF .. r0): stuff after 5, 10, 15 (3, the last a one);
	 * DLC 1000: its one continues the stuffed one (run 2), then 3 + 64
	 * zeros: stuff after 5, 10, ..., 65 (13), leaving a run of 2 zeros.
	 * CRC 0x145B = 001010001011011 brings that run to 4 only: 16 stuff
	 * bits, 111 + 16 = 127.
	 */
	{ "id 000 dlc 8 zeros", { .can_id = 0x000, .len = 8 }, 0x145B, 16, 127 },
	/*
	 * 15 zeros (3 stuff bits), DLC 1000 (run of 3 zeros at its end), 64
	 * ones: stuff after ones 5, 10, ..., 60 (12), leaving a run of 4
	 * ones; CRC 0x7291 = 111001010010001 starts with a one: the 5th,
	 * stuff (1); no other run of 5 in the CRC.  16 stuff bits, 127.
	 */
	{ "id 000 dlc 8 0xFF",
	  { .can_id = 0x000, .len = 8, .data = { 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF } },
	  0x7291,
	  16,
	  127 },
	/*
	 * SOF 0 then id 10101010101 alternate; RTR IDE r0 = 000 (run 3), DLC
	 * 1000 (run 3), data 01010101... (the first zero makes a run of 4),
	 * alternating up to the last data bit, a one.  CRC 0x1B04 =
	 * 001101100000100: 0 0 1 1 0 1 1 then five zeros: one stuff bit.
	 * 111 + 1 = 112.
	 */
	{ "id 555 dlc 8 0x55",
	  { .can_id = 0x555, .len = 8, .data = { 0x55, 0x55, 0x55, 0x55, 0x55, 0x55, 0x55, 0x55 } },
	  0x1B04,
	  1,
	  112 },
};

static void test_hand_vectors(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(hand_vectors) / sizeof(hand_vectors[0]); i++) {
		const struct hand_vector *v = &hand_vectors[i];
		unsigned ref_stuff;
		unsigned ref_bits = ref_frame_bits(&v->f, &ref_stuff);

		if (rmd_can_crc15(&v->f) != v->crc)
			fail_msg("%s: crc %#x, expected %#x", v->name, rmd_can_crc15(&v->f),
				 v->crc);
		if (rmd_can_stuff_bits(&v->f) != v->stuff)
			fail_msg("%s: %u stuff bits, expected %u", v->name,
				 rmd_can_stuff_bits(&v->f), v->stuff);
		if (rmd_can_frame_bits(&v->f) != v->bits)
			fail_msg("%s: %u bits, expected %u", v->name, rmd_can_frame_bits(&v->f),
				 v->bits);
		if (ref_stuff != v->stuff || ref_bits != v->bits)
			fail_msg("%s: reference model says %u stuff, %u bits", v->name, ref_stuff,
				 ref_bits);
	}
}

/* The register CRC against the long division, and the whole length. */
static void test_random_frames_match_reference(void **state)
{
	(void)state;
	for (unsigned i = 0; i < RANDOM_FRAMES; i++) {
		struct rmd_frame f = random_frame((unsigned)(rng_next() % 9));
		struct bits raw = { 0 };
		unsigned ref_stuff, ref_bits = ref_frame_bits(&f, &ref_stuff);

		push(&raw, 0, 1);
		push(&raw, f.can_id, 11);
		push(&raw, 0, 3);
		push(&raw, f.len, 4);
		for (unsigned j = 0; j < f.len; j++)
			push(&raw, f.data[j], 8);
		if (rmd_can_crc15(&f) != ref_crc(&raw) || rmd_can_frame_bits(&f) != ref_bits ||
		    rmd_can_stuff_bits(&f) != ref_stuff)
			fail_msg("seed %#x frame %u (id %03x len %u): crc %#x/%#x bits %u/%u",
				 test_seed(), i, f.can_id, f.len, rmd_can_crc15(&f), ref_crc(&raw),
				 rmd_can_frame_bits(&f), ref_bits);
	}
}

/* All-zero and all-0xFF data under every identifier, against the model. */
static void test_uniform_data_every_id(void **state)
{
	(void)state;
	for (uint32_t id = 0; id <= 0x7FF; id++) {
		for (unsigned fill = 0; fill < 2; fill++) {
			struct rmd_frame f = { .can_id = id, .len = 8 };
			unsigned bits;

			memset(f.data, fill ? 0xFF : 0x00, sizeof(f.data));
			bits = rmd_can_frame_bits(&f);
			if (bits != ref_frame_bits(&f, NULL) || bits < 111 || bits > 135)
				fail_msg("id %03x data %s: %u bits, reference %u", id,
					 fill ? "FF" : "00", bits, ref_frame_bits(&f, NULL));
		}
	}
}

/* docs/design.md: 111 bits unstuffed, 135 worst case, for 8 data bytes. */
static void test_bounds_design_figures(void **state)
{
	static const unsigned worst[9] = { 55, 65, 75, 85, 95, 105, 115, 125, 135 };

	(void)state;
	assert_int_equal(rmd_can_frame_bits_min(8), 111);
	assert_int_equal(rmd_can_frame_bits_worst(8), 135);
	for (unsigned n = 0; n <= 8; n++) {
		/* 47 + 8n + floor((33 + 8n) / 4) = 55 + 10n: 2 stuff bits per byte. */
		assert_int_equal(rmd_can_frame_bits_min(n), 47 + 8 * n);
		if (rmd_can_frame_bits_worst(n) != worst[n])
			fail_msg("dlc %u: worst %u, expected %u", n, rmd_can_frame_bits_worst(n),
				 worst[n]);
	}
	/* DLC codes 9..15 carry 8 bytes in classical CAN. */
	assert_int_equal(rmd_can_frame_bits_worst(15), 135);
	assert_int_equal(rmd_can_frame_bits_min(12), 111);
}

/* Random frames of every DLC stay inside [min, worst]. */
static void test_random_frames_within_bounds(void **state)
{
	unsigned lo = ~0u, hi = 0;

	(void)state;
	for (unsigned i = 0; i < RANDOM_FRAMES; i++) {
		unsigned n = (unsigned)(rng_next() % 9);
		struct rmd_frame f = random_frame(n);
		unsigned bits = rmd_can_frame_bits(&f);

		if (bits < rmd_can_frame_bits_min(n) || bits > rmd_can_frame_bits_worst(n))
			fail_msg("seed %#x frame %u: %u bits outside [%u, %u]", test_seed(), i,
				 bits, rmd_can_frame_bits_min(n), rmd_can_frame_bits_worst(n));
		if (n == 8) {
			lo = bits < lo ? bits : lo;
			hi = bits > hi ? bits : hi;
		}
	}
	print_message("random 8-byte frames: %u..%u bits\n", lo, hi);
}

/*
 * How close real frames come to the worst-case bound.  For every
 * identifier, the first 7 data bytes are chosen bit by bit to extend the
 * current run (so a stuff bit follows every 4 bits), and all 256 values of
 * the last byte are tried to vary the CRC.  The bound must hold for every
 * frame; the longest one found is checked against the reference model.
 */
static void test_search_longest_frame(void **state)
{
	struct rmd_frame best_f = { 0 };
	unsigned best = 0;

	(void)state;
	for (uint32_t id = 0; id <= 0x7FF; id++) {
		struct rmd_frame f = { .can_id = id, .len = 8 };
		struct bits hdr = { 0 };
		unsigned char last = 0;
		unsigned run = 0;

		push(&hdr, 0, 1);
		push(&hdr, id, 11);
		push(&hdr, 0, 3);
		push(&hdr, 8, 4);
		for (unsigned i = 0; i < hdr.n + 56; i++) {
			unsigned char bit = i < hdr.n ? hdr.b[i] : last;

			if (i >= hdr.n && bit)
				f.data[(i - hdr.n) / 8] |= (uint8_t)(0x80u >> ((i - hdr.n) % 8));
			run = run && bit == last ? run + 1 : 1;
			last = bit;
			if (run == 5) {
				last = !bit;
				run = 1;
			}
		}
		for (unsigned v = 0; v < 256; v++) {
			unsigned bits;

			f.data[7] = (uint8_t)v;
			bits = rmd_can_frame_bits(&f);
			assert_true(bits <= rmd_can_frame_bits_worst(8));
			if (bits > best) {
				best = bits;
				best_f = f;
			}
		}
	}
	assert_int_equal(best, ref_frame_bits(&best_f, NULL));
	print_message("longest 8-byte frame found: %03x#%02x%02x%02x%02x%02x%02x%02x%02x, %u bits "
		      "(bound %u)\n",
		      best_f.can_id, best_f.data[0], best_f.data[1], best_f.data[2], best_f.data[3],
		      best_f.data[4], best_f.data[5], best_f.data[6], best_f.data[7], best,
		      rmd_can_frame_bits_worst(8));
	assert_true(best >= 132);
}

static void test_wire_ns(void **state)
{
	(void)state;
	assert_int_equal(rmd_can_wire_ns(111, 1000000), 111000);
	assert_int_equal(rmd_can_wire_ns(135, 1000000), 135000);
	assert_int_equal(rmd_can_wire_ns(135, 500000), 270000);
	assert_int_equal(rmd_can_wire_ns(1, 800000), 1250);
	assert_int_equal(rmd_can_wire_ns(1, 3000000), 334); /* 333.3 rounded up */
	assert_int_equal(rmd_can_wire_ns(135, 0), 0);
	/* 7 worst-case 8-byte frames fit in 1 ms at 1 Mbit/s, 8 do not. */
	assert_true(7 * rmd_can_wire_ns(rmd_can_frame_bits_worst(8), 1000000) <= 1000000);
	assert_true(8 * rmd_can_wire_ns(rmd_can_frame_bits_worst(8), 1000000) > 1000000);
}

/* Identifier bits above 11 are ignored; a DLC of 9..15 sends 8 bytes. */
static void test_odd_inputs(void **state)
{
	struct rmd_frame a = random_frame(8), b = a, c = a;

	(void)state;
	b.can_id |= 0x1000;
	assert_int_equal(rmd_can_frame_bits(&a), rmd_can_frame_bits(&b));
	c.len = 9;
	assert_int_equal(rmd_can_data_bytes(&c), 8);
	assert_int_equal(rmd_can_frame_bits(&c), ref_frame_bits(&c, NULL));
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_hand_vectors),
		cmocka_unit_test(test_random_frames_match_reference),
		cmocka_unit_test(test_uniform_data_every_id),
		cmocka_unit_test(test_bounds_design_figures),
		cmocka_unit_test(test_random_frames_within_bounds),
		cmocka_unit_test(test_search_longest_frame),
		cmocka_unit_test(test_wire_ns),
		cmocka_unit_test(test_odd_inputs),
	};

	rng_state = test_seed();
	return SUITE_RUN("can_timing", tests, NULL, NULL);
}

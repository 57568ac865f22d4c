// SPDX-License-Identifier: MIT
/*
 * The requests of a motor's settings, built from its dialect's record
 * (rmd/dialect.h, src/proto/dialect_req.c): PID reads and writes and the
 * CAN ID.  Tables of {dialect, what, the frames on the wire}, the frames
 * from the manuals' worked examples where they print one; then the other
 * way: frames parsed back into the gains they name and carry, and the
 * answer a motor builds.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "rmd/codec.h"
#include "rmd/dialect.h"
#include "harness/hex.h"
#include "harness/suite.h"

#define ALL_SLOTS UINT32_MAX
#define MAX_FRAMES RMD_PID_SLOTS_MAX

/* The frames of reqs[0..n) to motor 1, as "141#..." text. */
static void frames_of(enum rmd_proto proto, const struct rmd_msg *reqs, int n,
		      char out[][HEX_FRAME_LEN])
{
	for (int i = 0; i < n; i++) {
		struct rmd_frame f;

		assert_int_equal(rmd_encode(proto, RMD_DIR_REQUEST, 1, &reqs[i], &f), 0);
		frame_hex(&f, out[i]);
	}
}

struct pid_vector {
	const char *name;
	enum rmd_proto proto;
	enum rmd_pid_op op;
	uint32_t slots;
	int64_t raw[RMD_PID_SLOTS_MAX];
	const char *frames[MAX_FRAMES + 1]; /* NULL-terminated */
};

static const struct pid_vector pid_vectors[] = {
	/* V3 §2.1.4: one 0x30 reads all six, whichever are asked for */
	{ "V3 read", RMD_PROTO_V3, RMD_PID_READ, ALL_SLOTS, { 0 }, { "141#3000000000000000" } },
	{ "V3 read one", RMD_PROTO_V3, RMD_PID_READ, 1u << 3, { 0 }, { "141#3000000000000000" } },
	/* V3 §2.2.4: the example's gains, current KP first */
	{ "V3 RAM",
	  RMD_PROTO_V3,
	  RMD_PID_WRITE_RAM,
	  ALL_SLOTS,
	  { 0x55, 0x19, 0x55, 0x19, 0x55, 0x19 },
	  { "141#3100551955195519" } },
	/* V3 §2.3: ROM; a frame of six writes all six, those not asked from raw */
	{ "V3 ROM one",
	  RMD_PROTO_V3,
	  RMD_PID_WRITE_ROM,
	  1u << 2,
	  { 1, 2, 3, 4, 5, 6 },
	  { "141#3200010203040506" } },
	/* the mit key: V3 firmware, V3's frames */
	{ "MIT read", RMD_PROTO_MIT, RMD_PID_READ, ALL_SLOTS, { 0 }, { "141#3000000000000000" } },
	/* V2 §3.1 .. §3.6: a read a gain, in slot order (current KP 0x34 first) */
	{ "V2 read",
	  RMD_PROTO_V2,
	  RMD_PID_READ,
	  ALL_SLOTS,
	  { 0 },
	  { "141#3400000000000000", "141#3500000000000000", "141#3200000000000000",
	    "141#3300000000000000", "141#3000000000000000", "141#3100000000000000" } },
	/* V2 §3.9 (speed KP to RAM, 0x38), §3.16 (speed KI to ROM, 0x3F): Q24 */
	{ "V2 RAM speed KP",
	  RMD_PROTO_V2,
	  RMD_PID_WRITE_RAM,
	  1u << 2,
	  { 0, 0, 1 << 21 },
	  { "141#3800000000002000" } },
	{ "V2 ROM speed KI",
	  RMD_PROTO_V2,
	  RMD_PID_WRITE_ROM,
	  1u << 3,
	  { 0, 0, 0, 1 << 24 },
	  { "141#3F00000000000001" } },
	/* V4.2 §2.1.5: 0x30 by index, 1 2 4 5 7 8 9 */
	{ "V4 read",
	  RMD_PROTO_V4,
	  RMD_PID_READ,
	  ALL_SLOTS,
	  { 0 },
	  { "141#3001000000000000", "141#3002000000000000", "141#3004000000000000",
	    "141#3005000000000000", "141#3007000000000000", "141#3008000000000000",
	    "141#3009000000000000" } },
	/* V4.2 §2.2.5: current KP 1.5 (0x3FC00000) to RAM; §2.3.5 to ROM */
	{ "V4 RAM current KP",
	  RMD_PROTO_V4,
	  RMD_PID_WRITE_RAM,
	  1u << 0,
	  { 0x3FC00000 },
	  { "141#310100000000C03F" } },
	{ "V4 ROM current KP",
	  RMD_PROTO_V4,
	  RMD_PID_WRITE_ROM,
	  1u << 0,
	  { 0x3FC00000 },
	  { "141#320100000000C03F" } },
	/* V4.2 §2.1.4 index 9: the position KD, 1.0 */
	{ "V4 RAM position KD",
	  RMD_PROTO_V4,
	  RMD_PID_WRITE_RAM,
	  1u << 6,
	  { [6] = 0x3F800000 },
	  { "141#310900000000803F" } },
};

static void test_pid_requests(void **state)
{
	(void)state;
	for (size_t v = 0; v < sizeof(pid_vectors) / sizeof(pid_vectors[0]); v++) {
		const struct pid_vector *pv = &pid_vectors[v];
		struct rmd_pid_set set = { .slots = pv->slots };
		struct rmd_msg reqs[RMD_PID_SLOTS_MAX];
		char got[MAX_FRAMES][HEX_FRAME_LEN];
		int n, want = 0;

		memcpy(set.raw, pv->raw, sizeof(set.raw));
		n = rmd_pid_requests(rmd_dialect(pv->proto), pv->op, &set, reqs);
		while (want < MAX_FRAMES && pv->frames[want])
			want++;
		if (n != want)
			fail_msg("%s: %d requests, want %d", pv->name, n, want);
		frames_of(pv->proto, reqs, n, got);
		for (int i = 0; i < n; i++)
			if (strcmp(got[i], pv->frames[i]))
				fail_msg("%s: frame %d is %s, want %s", pv->name, i, got[i],
					 pv->frames[i]);
	}
}

/* Each dialect's read names every gain once; a write carries back what it was given. */
static void test_pid_parse_round_trip(void **state)
{
	size_t nd;
	const struct rmd_dialect *dl = rmd_dialect_list(&nd);

	(void)state;
	for (size_t i = 0; i < nd; i++) {
		const struct rmd_dialect *d = &dl[i];
		uint32_t all = (UINT32_C(1) << d->n_pid_slots) - 1, seen = 0;
		struct rmd_pid_set set = { .slots = all }, back;
		struct rmd_msg reqs[RMD_PID_SLOTS_MAX];
		enum rmd_pid_op op;
		uint32_t named;
		int n;

		n = rmd_pid_requests(d, RMD_PID_READ, &set, reqs);
		assert_true(n >= 1);
		for (int k = 0; k < n; k++) {
			assert_true(rmd_pid_parse(d, &reqs[k], &op, &named, &back));
			assert_int_equal(op, RMD_PID_READ);
			assert_int_equal(back.slots, 0); /* a read carries no gain */
			assert_int_equal(seen & named, 0);
			seen |= named;
		}
		assert_int_equal(seen, all);
		for (unsigned k = 0; k < d->n_pid_slots; k++)
			set.raw[k] = 0x10 + k;
		n = rmd_pid_requests(d, RMD_PID_WRITE_ROM, &set, reqs);
		seen = 0;
		for (int k = 0; k < n; k++) {
			assert_true(rmd_pid_parse(d, &reqs[k], &op, &named, &back));
			assert_int_equal(op, RMD_PID_WRITE_ROM);
			assert_int_equal(back.slots, named);
			for (unsigned s = 0; s < d->n_pid_slots; s++)
				if (back.slots & (UINT32_C(1) << s))
					assert_int_equal(back.raw[s], 0x10 + s);
			seen |= back.slots;
		}
		assert_int_equal(seen, all);
		/* a command that is no PID command of the dialect */
		assert_false(
			rmd_pid_parse(d, &(struct rmd_msg){ .cmd = 0x9A }, &op, &named, &back));
	}
}

/* The answers of the manuals' examples, parsed: which gain, and its value. */
static void test_pid_parse_replies(void **state)
{
	struct rmd_pid_set got;
	enum rmd_pid_op op;
	struct rmd_msg m;
	uint32_t named;
	struct rmd_frame f;

	(void)state;
	/* V3 §2.1.4: all six */
	f = frame_from("241#3000551955195519");
	assert_int_equal(rmd_decode(RMD_PROTO_V3, RMD_DIR_REPLY, &f, &m, NULL), 0);
	assert_true(rmd_pid_parse(rmd_dialect(RMD_PROTO_V3), &m, &op, &named, &got));
	assert_int_equal(op, RMD_PID_READ);
	assert_int_equal(got.slots, 0x3F);
	assert_int_equal(got.raw[0], 0x55);
	assert_int_equal(got.raw[5], 0x19);
	/* V4.2 §2.1.5: index 1, 1.0 */
	f = frame_from("241#300100000000803F");
	assert_int_equal(rmd_decode(RMD_PROTO_V4, RMD_DIR_REPLY, &f, &m, NULL), 0);
	assert_true(rmd_pid_parse(rmd_dialect(RMD_PROTO_V4), &m, &op, &named, &got));
	assert_int_equal(named, 1u << 0);
	assert_int_equal(got.slots, 1u << 0);
	assert_int_equal(got.raw[0], 0x3F800000);
	assert_string_equal(rmd_field_key(rmd_pid_field(rmd_dialect(RMD_PROTO_V4), 0)), "gain");
	assert_true(rmd_pid_spec(rmd_dialect(RMD_PROTO_V4), 0)->is_float);
	/* an index §2.1.4 does not list (3): a PID command naming no gain */
	f = frame_from("241#300300000000803F");
	assert_int_equal(rmd_decode(RMD_PROTO_V4, RMD_DIR_REPLY, &f, &m, NULL), 0);
	assert_true(rmd_pid_parse(rmd_dialect(RMD_PROTO_V4), &m, &op, &named, &got));
	assert_int_equal(named, 0);
	assert_int_equal(got.slots, 0);
	/* V2 §3.5: the current KP's read (0x34) answers it alone, Q24 */
	f = frame_from("141#3400000000004000");
	assert_int_equal(rmd_decode(RMD_PROTO_V2, RMD_DIR_REPLY, &f, &m, NULL), 0);
	assert_true(rmd_pid_parse(rmd_dialect(RMD_PROTO_V2), &m, &op, &named, &got));
	assert_int_equal(named, 1u << 0);
	assert_int_equal(got.raw[0], 1 << 22);
	assert_true(rmd_pid_spec(rmd_dialect(RMD_PROTO_V2), 0)->scale < 1e-6);
}

/* What a motor answers a read with: the gains the request names, in its layout. */
static void test_pid_answer(void **state)
{
	struct rmd_pid_set set = { .slots = 0x7F, .raw = { 11, 12, 13, 14, 15, 16, 0x3F800000 } };
	char got[1][HEX_FRAME_LEN];
	struct rmd_frame f;
	struct rmd_msg req = { .cmd = 0x30 }, rep;

	(void)state;
	rmd_pid_answer(rmd_dialect(RMD_PROTO_V3), &req, &set, &rep);
	assert_int_equal(rmd_encode(RMD_PROTO_V3, RMD_DIR_REPLY, 1, &rep, &f), 0);
	assert_string_equal(frame_hex(&f, got[0]), "241#30000B0C0D0E0F10");
	rmd_msg_set(&req, RMD_FLD_INDEX, 9);
	rmd_pid_answer(rmd_dialect(RMD_PROTO_V4), &req, &set, &rep);
	assert_int_equal(rmd_encode(RMD_PROTO_V4, RMD_DIR_REPLY, 1, &rep, &f), 0);
	assert_string_equal(frame_hex(&f, got[0]), "241#300900000000803F");
	req = (struct rmd_msg){ .cmd = 0x35 }; /* V2 §3.6: current KI */
	rmd_pid_answer(rmd_dialect(RMD_PROTO_V2), &req, &set, &rep);
	assert_int_equal(rmd_encode(RMD_PROTO_V2, RMD_DIR_REPLY, 1, &rep, &f), 0);
	assert_string_equal(frame_hex(&f, got[0]), "141#350000000C000000");
}

struct id_vector {
	enum rmd_proto proto;
	const char *frame; /* the write, from motor 1 to ID 5 */
	bool every_motor, echo_from_new, then_reset;
	int64_t read_answer; /* 0x79's read of motor 5 */
};

static const struct id_vector id_vectors[] = {
	/* V3 §4.4 example 1 (to ID 2 there): 0x79 on 0x300, ID at data[7] */
	{ RMD_PROTO_V3, "300#7900000000000005", true, false, false, 0x245 },
	{ RMD_PROTO_MIT, "300#7900000000000005", true, false, false, 0x245 },
	/* V2 §3.52: 0x79 on the motor's own identifier, ID at data[4..7] */
	{ RMD_PROTO_V2, "141#7900000005000000", false, false, false, 5 },
	/* V4.2 §2.34.4 index 5, then 0x76 (§2.25); no 0x79 on that firmware */
	{ RMD_PROTO_V4, "141#2005000005000000", false, true, true, -1 },
};

static void test_set_id(void **state)
{
	(void)state;
	for (size_t v = 0; v < sizeof(id_vectors) / sizeof(id_vectors[0]); v++) {
		const struct id_vector *iv = &id_vectors[v];
		const struct rmd_dialect *d = rmd_dialect(iv->proto);
		struct rmd_set_id_req how;
		char got[1][HEX_FRAME_LEN];
		struct rmd_frame f;
		struct rmd_msg back;
		int64_t id = 0;

		assert_int_equal(rmd_set_id_request(d, 5, &how), 0);
		frames_of(iv->proto, &how.write, 1, got);
		if (strcmp(got[0], iv->frame))
			fail_msg("%s: %s, want %s", d->name, got[0], iv->frame);
		assert_int_equal(how.every_motor, iv->every_motor);
		assert_int_equal(how.echo_from_new, iv->echo_from_new);
		assert_int_equal(how.then_reset, iv->then_reset);
		if (how.then_reset)
			assert_int_equal(how.reset.cmd, 0x76);
		assert_int_equal(rmd_set_id_read_answer(d, 5), iv->read_answer);
		/* the motor's side: the write, decoded, is the ID write and gives 5 */
		f = frame_from(iv->frame);
		assert_int_equal(rmd_decode(iv->proto, RMD_DIR_UNKNOWN, &f, &back, NULL), 0);
		assert_true(rmd_set_id_parse(d, &back, &id));
		assert_int_equal(id, 5);
		/* neither a read of the ID nor another command is */
		back.v[RMD_FLD_READ_FLAG] = 1;
		back.v[RMD_FLD_INDEX] = 2;
		assert_false(rmd_set_id_parse(d, &back, &id));
		assert_int_equal(rmd_set_id_request(d, 0, &how), -EINVAL);
		assert_int_equal(rmd_set_id_request(d, RMD_MAX_MOTORS + 1, &how), -EINVAL);
	}
}

SUITE_MAIN("dialect_req", NULL, NULL,
	   {
		   cmocka_unit_test(test_pid_requests),
		   cmocka_unit_test(test_pid_parse_round_trip),
		   cmocka_unit_test(test_pid_parse_replies),
		   cmocka_unit_test(test_pid_answer),
		   cmocka_unit_test(test_set_id),
	   })

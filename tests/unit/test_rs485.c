// SPDX-License-Identifier: MIT
/*
 * RS485 framing tests (V3 §1.2.2, §6, §7): Modbus CRC-16 check vectors, every
 * RS485 frame the V3 manual prints, round trips (RMD_TEST_SEED=n repeats a
 * run), partial buffers, and each malformed-frame error.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <cmocka.h>

#include "rmd/rs485.h"

#include "harness/hex.h"
#include "harness/rng.h"
#include "harness/suite.h"

static uint64_t seed;

/* splitmix64: the same sequence from the same seed on every libc. */
static uint64_t rng_state;

static uint64_t rng_next(void)
{
	return splitmix64(&rng_state);
}

/* ---- CRC --------------------------------------------------------------- */

struct crc_vec {
	const char *name;
	const char *hex;
	uint16_t crc;
};

/*
 * Worked by hand with an independent MSB-first CRC (poly 0x8005 over
 * bit-reversed bytes, result reversed), not with the code under test.
 */
static const struct crc_vec crc_vecs[] = {
	{ "empty", "", 0xFFFF },
	/* The CRC catalogue's check value for CRC-16/MODBUS. */
	{ "\"123456789\"", "313233343536373839", 0x4B37 },
	/* Modbus RTU "read 10 holding registers from 0": on the wire ... C5 CD. */
	{ "modbus 01 03 00 00 00 0A", "01030000000A", 0xCDC5 },
	/* Modbus RTU "read 2 holding registers from 0": on the wire ... C4 0B. */
	{ "modbus 01 03 00 00 00 02", "010300000002", 0x0BC4 },
	{ "one zero byte", "00", 0x40BF },
	{ "one 0xFF byte", "FF", 0x00FF },
};

static void test_crc_vectors(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(crc_vecs) / sizeof(crc_vecs[0]); i++) {
		uint8_t buf[32];
		size_t n = bytes_from(crc_vecs[i].hex, buf, sizeof(buf));
		uint16_t got = rmd_crc16_modbus(buf, n);

		if (got != crc_vecs[i].crc)
			fail_msg("%s: crc 0x%04X, want 0x%04X", crc_vecs[i].name, got,
				 crc_vecs[i].crc);
	}
}

/* A message followed by its CRC, low byte first, has a CRC of zero. */
static void test_crc_residue(void **state)
{
	uint8_t buf[8] = { 0x01, 0x03, 0x00, 0x00, 0x00, 0x0A };
	uint16_t crc = rmd_crc16_modbus(buf, 6);

	(void)state;
	buf[6] = (uint8_t)crc;
	buf[7] = (uint8_t)(crc >> 8);
	assert_int_equal(buf[6], 0xC5);
	assert_int_equal(buf[7], 0xCD);
	assert_int_equal(rmd_crc16_modbus(buf, 8), 0);
}

/* ---- The manual's frames ----------------------------------------------- */

struct frame_vec {
	const char *name;
	uint8_t id;
	const char *data;  /* D0..D7 as the manual prints them */
	const char *frame; /* the 13 bytes on the wire */
};

/*
 * Every distinct RS485 frame printed in the V3 manual (each named by section,
 * example and line of rmd-can-rs485-protocol-v3.6-zh.txt; a frame printed
 * twice, such as a reply that repeats its request, appears once).  The manual
 * prints "CRC16L CRC16H" placeholders in every one of them, so the last two
 * bytes were worked out with the same independent CRC as the table above,
 * over the 11 bytes from the header through D7.
 */
static const struct frame_vec frame_vecs[] = {
	{ "V3 §2.1 ex1 request l.312", 0x01, "3000000000000000", "3E01083000000000000000F81D" },
	{ "V3 §2.1 ex1 reply l.326", 0x01, "3000551955195519", "3E01083000551955195519D74B" },
	{ "V3 §2.2 ex1 request l.381", 0x01, "3100551955195519", "3E010831005519551955191687" },
	{ "V3 §2.3 ex1 request l.446", 0x01, "3200551955195519", "3E010832005519551955195692" },
	{ "V3 §2.4 ex1 request l.518", 0x01, "4200000000000000", "3E010842000000000000007EE0" },
	{ "V3 §2.4 ex1 reply l.532", 0x01, "4200000010270000", "3E01084200000010270000CA2B" },
	{ "V3 §2.5 ex1 request l.583", 0x01, "4300000010270000", "3E010843000000102700000BE7" },
	{ "V3 §2.5 ex2 request l.615", 0x01, "4301000010270000", "3E010843010000102700001B27" },
	{ "V3 §2.5 ex3 request l.645", 0x01, "4302000010270000", "3E010843020000102700002827" },
	{ "V3 §2.5 ex4 request l.675", 0x01, "4303000010270000", "3E0108430300001027000038E7" },
	{ "V3 §2.6 ex1 request l.740", 0x01, "6000000000000000", "3E01086000000000000000FD21" },
	{ "V3 §2.6 ex1 reply l.754", 0x01, "6000000010270000", "3E0108600000001027000049EA" },
	{ "V3 §2.7 ex1 request l.806", 0x01, "6100000000000000", "3E010861000000000000003CED" },
	{ "V3 §2.7 ex1 reply l.820", 0x01, "6100000010270000", "3E010861000000102700008826" },
	{ "V3 §2.8 ex1 request l.871", 0x01, "6200000000000000", "3E010862000000000000007CF8" },
	{ "V3 §2.8 ex1 reply l.885", 0x01, "6200000010270000", "3E01086200000010270000C833" },
	{ "V3 §2.9 ex1 request l.929", 0x01, "6300000010270000", "3E0108630000001027000009FF" },
	{ "V3 §2.10 ex1 request l.996", 0x01, "6400000000000000", "3E01086400000000000000FCD2" },
	{ "V3 §2.10 ex1 reply l.1010", 0x01, "6400000010270000", "3E010864000000102700004819" },
	{ "V3 §2.11 ex1 request l.1063", 0x01, "9200000000000000", "3E0108920000000000000073BC" },
	{ "V3 §2.11 ex1 reply l.1077", 0x01, "92000000A08C0000", "3E010892000000A08C00009057" },
	{ "V3 §2.12 ex1 request l.1147", 0x01, "9A00000000000000", "3E01089A00000000000000721A" },
	{ "V3 §2.12 ex1 reply l.1161", 0x01, "9A320001E5010400", "3E01089A320001E50104003815" },
	{ "V3 §2.13 ex1 request l.1218", 0x01, "9C00000000000000", "3E01089C00000000000000F230" },
	{ "V3 §2.13 ex1 reply l.1232", 0x01, "9C326400F4012D00", "3E01089C326400F4012D009777" },
	{ "V3 §2.14 ex1 request l.1294", 0x01, "9D00000000000000", "3E01089D0000000000000033FC" },
	{ "V3 §2.14 ex1 reply l.1308", 0x01, "9D32C20B10FAC0F9", "3E01089D32C20B10FAC0F921AF" },
	{ "V3 §2.17 ex1 request l.1415", 0x01, "A100000064000000", "3E0108A1000000640000002F8D" },
	{ "V3 §2.17 ex1 reply l.1429", 0x01, "A1326400F4012D00", "3E0108A1326400F4012D0055FA" },
	{ "V3 §2.17 ex2 request l.1445", 0x01, "A10000009CFF0000", "3E0108A10000009CFF00002EDD" },
	{ "V3 §2.17 ex2 reply l.1459", 0x01, "A1329CFF0CFED3FF", "3E0108A1329CFF0CFED3FF5526" },
	{ "V3 §2.18 ex1 request l.1522", 0x01, "A200000010270000", "3E0108A200000010270000C463" },
	{ "V3 §2.18 ex1 reply l.1538", 0x01, "A2326400F4012D00", "3E0108A2326400F4012D0015EF" },
	{ "V3 §2.18 ex2 request l.1554", 0x01, "A2000000F0D8FFFF", "3E0108A2000000F0D8FFFFC223" },
	{ "V3 §2.18 ex2 reply l.1568", 0x01, "A2329CFF0CFED3FF", "3E0108A2329CFF0CFED3FF1533" },
	{ "V3 §2.19 ex1 request l.1634", 0x01, "A300000064000000", "3E0108A300000064000000AE54" },
	{ "V3 §2.19 ex1 reply l.1652", 0x01, "A3326400F4012D00", "3E0108A3326400F4012D00D423" },
	{ "V3 §2.20 ex1 request l.1708", 0x01, "A400F401A08C0000", "3E0108A400F401A08C00003BDD" },
	{ "V3 §2.20 ex1 reply l.1722", 0x01, "A4326400F4012D00", "3E0108A4326400F4012D0095C5" },
	{ "V3 §2.20 ex2 request l.1740", 0x01, "A400F4016073FFFF", "3E0108A400F4016073FFFF365D" },
	{ "V3 §2.20 ex2 reply l.1755", 0x01, "A4329CFF0CFED3FF", "3E0108A4329CFF0CFED3FF9519" },
	{ "V3 §2.21 ex1 request l.1822", 0x01, "A500881364000000", "3E0108A500881364000000B535" },
	{ "V3 §2.21 ex1 reply l.1836", 0x01, "A5326400F4012D00", "3E0108A5326400F4012D005409" },
	{ "V3 §2.22 ex1 request l.1896", 0x01, "A800F401A08C0000", "3E0108A800F401A08C00003B88" },
	{ "V3 §2.22 ex1 reply l.1913", 0x01, "A8326400F4012D00", "3E0108A8326400F4012D009590" },
	{ "V3 §2.22 ex2 request l.1929", 0x01, "A800F4016073FFFF", "3E0108A800F4016073FFFF3608" },
	{ "V3 §2.22 ex2 reply l.1943", 0x01, "A8329CFF0CFED3FF", "3E0108A8329CFF0CFED3FF954C" },
	{ "V3 §2.23 ex1 request l.2001", 0x01, "7000000000000000", "3E01087000000000000000FC2D" },
	{ "V3 §2.23 ex1 reply l.2017", 0x01, "7000000000000003", "3E01087000000000000003BC2C" },
	{ "V3 §2.24 ex1 request l.2068", 0x01, "7100000000000000", "3E010871000000000000003DE1" },
	{ "V3 §2.24 ex1 reply l.2082", 0x01, "710000000000D007", "3E0108710000000000D00721E3" },
	{ "V3 §2.25 ex1 request l.2127", 0x01, "7600000000000000", "3E010876000000000000007C07" },
	{ "V3 §2.28 ex1 request l.2226", 0x01, "B100000000000000", "3E0108B10000000000000031B1" },
	{ "V3 §2.28 ex1 reply l.2240", 0x01, "B100000000000010", "3E0108B100000000000010307D" },
	{ "V3 §2.29 ex1 request l.2290", 0x01, "B200000000000000", "3E0108B20000000000000071A4" },
	{ "V3 §2.29 ex1 reply l.2304", 0x01, "B20000002E893401", "3E0108B20000002E8934017E66" },
	{ "V3 §2.30 ex1 request l.2344", 0x01, "B300000000000000", "3E0108B300000000000000B068" },
	{ "V3 §2.30 ex2 request l.2374", 0x01, "B3000000E8030000", "3E0108B3000000E803000075C8" },
	{ "V3 §2.31 ex1 request l.2438", 0x01, "B400000000000000", "3E0108B400000000000000F18E" },
	{ "V3 §2.31 ex2 request l.2454", 0x01, "B400000000000001", "3E0108B400000000000001304E" },
	{ "V3 §2.31 ex3 request l.2470", 0x01, "B400000000000002", "3E0108B400000000000002704F" },
	{ "V3 §2.32 ex1 request l.2523", 0x01, "B500000000000000", "3E0108B5000000000000003042" },
	{ "V3 §2.32 ex1 reply l.2537", 0x01, "B558385332563130", "3E0108B558385332563130921F" },
	{ "V3 §2.33 ex1 request l.2585", 0x01, "2001000000000000", "3E01082001000000000000E9D1" },
	{ "V3 §2.33 ex2 request l.2615", 0x01, "2002000001000000", "3E01082002000001000000DB2D" },
	{ "V3 §6.2 ex1 request l.2908", 0xCD, "8000000000000000", "3ECD088000000000000000366A" },
	{ "V3 §6.2 ex1 reply l.2917", 0x01, "8000000000000000", "3E01088000000000000000F369" },
	{ "V3 §6.2 ex1 reply l.2922", 0x02, "8000000000000000", "3E020880000000000000000366" },
	{ "V3 §6.2 ex1 reply l.2927", 0x03, "8000000000000000", "3E0308800000000000000052A3" },
	{ "V3 §6.2 ex1 reply l.2932", 0x04, "8000000000000000", "3E04088000000000000000E379" },
	{ "V3 §6.2 ex2 request l.2941", 0xCD, "6000000000000000", "3ECD0860000000000000003822" },
	{ "V3 §6.2 ex2 reply l.2955", 0x02, "60000000204E0000", "3E020860000000204E000066F9" },
	{ "V3 §6.2 ex2 reply l.2960", 0x03, "6000000030750000", "3E030860000000307500004231" },
	{ "V3 §6.2 ex2 reply l.2965", 0x04, "60000000409C0000", "3E040860000000409C000038DF" },
	{ "V3 §7.4 ex1 request l.3020", 0xCD, "7900000000000002", "3ECD0879000000000000027885" },
	{ "V3 §7.4 ex2 request l.3036", 0xCD, "7900010000000000", "3ECD087900010000000000F895" },
	{ "V3 §7.4 ex2 reply l.3043", 0xCD, "7900010000000002", "3ECD0879000100000000027954" },
};

static void test_manual_frames(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(frame_vecs) / sizeof(frame_vecs[0]); i++) {
		const struct frame_vec *v = &frame_vecs[i];
		uint8_t data[RMD_FRAME_LEN], want[RMD_RS485_FRAME_LEN], out[RMD_RS485_FRAME_LEN];
		uint8_t got_data[RMD_FRAME_LEN], id = 0;
		char hex[2 * RMD_RS485_FRAME_LEN + 1];
		int ret;

		assert_int_equal(bytes_from(v->data, data, sizeof(data)), RMD_FRAME_LEN);
		assert_int_equal(bytes_from(v->frame, want, sizeof(want)), RMD_RS485_FRAME_LEN);

		/* build(struct) == hex */
		ret = rmd_rs485_build(v->id, data, out, sizeof(out));
		if (ret != (int)RMD_RS485_FRAME_LEN)
			fail_msg("%s: build returned %d", v->name, ret);
		if (memcmp(out, want, sizeof(want)) != 0)
			fail_msg("%s: build gave %s, want %s", v->name,
				 hex_of(out, sizeof(out), hex), v->frame);

		/* parse(hex) == struct */
		ret = rmd_rs485_parse(want, sizeof(want), &id, got_data);
		if (ret != (int)RMD_RS485_FRAME_LEN)
			fail_msg("%s: parse returned %d", v->name, ret);
		if (id != v->id || memcmp(got_data, data, sizeof(data)) != 0)
			fail_msg("%s: parse gave id 0x%02X data %s", v->name, id,
				 hex_of(got_data, sizeof(got_data), hex));
	}
}

/* ---- Round trips and stream handling ----------------------------------- */

static uint8_t random_id(void)
{
	uint64_t r = rng_next() % (RMD_MAX_MOTORS + 1);

	return r == RMD_MAX_MOTORS ? (uint8_t)RMD_RS485_BROADCAST : (uint8_t)(r + 1);
}

static void test_random_round_trip(void **state)
{
	(void)state;
	rng_state = seed;
	for (int i = 0; i < 20000; i++) {
		uint8_t data[RMD_FRAME_LEN], got[RMD_FRAME_LEN], frame[RMD_RS485_FRAME_LEN];
		uint8_t id = random_id(), got_id = 0;
		uint64_t r = rng_next();
		int ret;

		memcpy(data, &r, sizeof(data));
		ret = rmd_rs485_build(id, data, frame, sizeof(frame));
		if (ret != (int)RMD_RS485_FRAME_LEN)
			fail_msg("random #%d (RMD_TEST_SEED=%llu): build returned %d", i,
				 (unsigned long long)seed, ret);
		ret = rmd_rs485_parse(frame, sizeof(frame), &got_id, got);
		if (ret != (int)RMD_RS485_FRAME_LEN || got_id != id ||
		    memcmp(got, data, sizeof(data)) != 0)
			fail_msg("random #%d (RMD_TEST_SEED=%llu): parse returned %d, id 0x%02X", i,
				 (unsigned long long)seed, ret, got_id);
	}
}

/* V3 §6.2 example 1: 0x80 to every motor. */
static const char broadcast_off[] = "3ECD088000000000000000366A";

static void test_broadcast(void **state)
{
	const uint8_t off[RMD_FRAME_LEN] = { 0x80 };
	uint8_t frame[RMD_RS485_FRAME_LEN], want[RMD_RS485_FRAME_LEN], data[RMD_FRAME_LEN];
	uint8_t id = 0;

	(void)state;
	bytes_from(broadcast_off, want, sizeof(want));
	assert_int_equal(rmd_rs485_build(RMD_RS485_BROADCAST, off, frame, sizeof(frame)),
			 RMD_RS485_FRAME_LEN);
	assert_memory_equal(frame, want, sizeof(want));
	assert_int_equal(rmd_rs485_parse(want, sizeof(want), &id, data), RMD_RS485_FRAME_LEN);
	assert_int_equal(id, RMD_RS485_BROADCAST);
	assert_memory_equal(data, off, sizeof(off));
}

/* Every proper prefix of a good frame asks for more bytes. */
static void test_partial(void **state)
{
	uint8_t frame[RMD_RS485_FRAME_LEN], data[RMD_FRAME_LEN] = { 0x11 };
	uint8_t id = 0x77;

	(void)state;
	bytes_from("3E01089A320001E50104003815", frame, sizeof(frame));
	for (size_t n = 0; n < RMD_RS485_FRAME_LEN; n++) {
		int ret = rmd_rs485_parse(frame, n, &id, data);

		if (ret != -EAGAIN)
			fail_msg("prefix of %zu bytes: parse returned %d, want -EAGAIN", n, ret);
	}
	assert_int_equal(id, 0x77);
	assert_int_equal(data[0], 0x11);
	assert_int_equal(rmd_rs485_parse(NULL, 0, &id, data), -EAGAIN);
}

/* Two frames back to back: the first is consumed, the rest left alone. */
static void test_stream(void **state)
{
	uint8_t buf[2 * RMD_RS485_FRAME_LEN + 3], data[RMD_FRAME_LEN];
	uint8_t id = 0;

	(void)state;
	bytes_from("3E0108600000001027000049EA"
		   "3E020860000000204E000066F9"
		   "3E0308",
		   buf, sizeof(buf));
	assert_int_equal(rmd_rs485_parse(buf, sizeof(buf), &id, data), RMD_RS485_FRAME_LEN);
	assert_int_equal(id, 1);
	assert_int_equal(data[4], 0x10);
	assert_int_equal(rmd_rs485_parse(buf + 13, sizeof(buf) - 13, &id, data),
			 RMD_RS485_FRAME_LEN);
	assert_int_equal(id, 2);
	assert_int_equal(data[5], 0x4E);
	assert_int_equal(rmd_rs485_parse(buf + 26, sizeof(buf) - 26, &id, data), -EAGAIN);
}

/* ---- Malformed frames -------------------------------------------------- */

struct bad_vec {
	const char *name;
	const char *hex;
	int want;
};

static const struct bad_vec bad_vecs[] = {
	{ "header 0x00", "0001089A00000000000000721A", -EPROTO },
	{ "header 0x3F", "3F01089A00000000000000721A", -EPROTO },
	{ "header alone, wrong", "55", -EPROTO },
	{ "id 0", "3E00089A00000000000000721A", -EPROTO },
	{ "id 33", "3E21089A00000000000000721A", -EPROTO },
	{ "id 0xCC", "3ECC089A00000000000000721A", -EPROTO },
	{ "id 0xFF, partial", "3EFF", -EPROTO },
	{ "length 7", "3E01079A00000000000000721A", -EMSGSIZE },
	{ "length 9", "3E01099A00000000000000721A", -EMSGSIZE },
	{ "length 0, partial", "3E0100", -EMSGSIZE },
	{ "CRC off by one", "3E01089A00000000000000721B", -EBADMSG },
	{ "CRC high byte first", "3E01089A000000000000001A72", -EBADMSG },
	{ "CRC zero", "3E01089A000000000000000000", -EBADMSG },
	{ "data changed", "3E01089A00000000000001721A", -EBADMSG },
	{ "id changed within range", "3E02089A00000000000000721A", -EBADMSG },
	{ "broadcast with unicast CRC", "3ECD089A00000000000000721A", -EBADMSG },
};

static void test_bad_frames(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(bad_vecs) / sizeof(bad_vecs[0]); i++) {
		uint8_t buf[RMD_RS485_FRAME_LEN], data[RMD_FRAME_LEN] = { 0x11 };
		uint8_t id = 0x77;
		size_t n = bytes_from(bad_vecs[i].hex, buf, sizeof(buf));
		int ret = rmd_rs485_parse(buf, n, &id, data);

		if (ret != bad_vecs[i].want)
			fail_msg("%s: parse returned %d, want %d", bad_vecs[i].name, ret,
				 bad_vecs[i].want);
		if (id != 0x77 || data[0] != 0x11)
			fail_msg("%s: outputs written on error", bad_vecs[i].name);
	}
}

/* A CRC-16 catches every single-bit error in the 13 bytes. */
static void test_every_bit_flip(void **state)
{
	uint8_t good[RMD_RS485_FRAME_LEN], data[RMD_FRAME_LEN];
	uint8_t id;

	(void)state;
	bytes_from("3E01089C326400F4012D009777", good, sizeof(good));
	assert_int_equal(rmd_rs485_parse(good, sizeof(good), &id, data), RMD_RS485_FRAME_LEN);
	for (unsigned byte = 0; byte < RMD_RS485_FRAME_LEN; byte++) {
		for (unsigned bit = 0; bit < 8; bit++) {
			uint8_t buf[RMD_RS485_FRAME_LEN];
			int ret;

			memcpy(buf, good, sizeof(buf));
			buf[byte] ^= (uint8_t)(1u << bit);
			ret = rmd_rs485_parse(buf, sizeof(buf), &id, data);
			/* Byte 1 may flip to another valid id: then only the CRC can tell. */
			if (ret >= 0)
				fail_msg("byte %u bit %u flipped: parse accepted it", byte, bit);
			if (byte >= 3 && ret != -EBADMSG)
				fail_msg("byte %u bit %u flipped: parse returned %d, want -EBADMSG",
					 byte, bit, ret);
		}
	}
}

static void test_build_refusals(void **state)
{
	const uint8_t bad_ids[] = { 0, 33, 0x3E, 0xCC, 0xCE, 0xFF };
	const uint8_t data[RMD_FRAME_LEN] = { 0x9A };
	uint8_t out[RMD_RS485_FRAME_LEN + 1];

	(void)state;
	for (size_t i = 0; i < sizeof(bad_ids); i++) {
		memset(out, 0xA5, sizeof(out));
		if (rmd_rs485_build(bad_ids[i], data, out, sizeof(out)) != -EINVAL)
			fail_msg("build for id 0x%02X accepted", bad_ids[i]);
		if (out[0] != 0xA5)
			fail_msg("build for id 0x%02X wrote on error", bad_ids[i]);
	}
	memset(out, 0xA5, sizeof(out));
	assert_int_equal(rmd_rs485_build(1, data, out, RMD_RS485_FRAME_LEN - 1), -ENOBUFS);
	assert_int_equal(out[0], 0xA5);
	assert_int_equal(rmd_rs485_build(1, data, out, 0), -ENOBUFS);
	/* A larger buffer is fine; the byte after the frame is not touched. */
	assert_int_equal(rmd_rs485_build(32, data, out, sizeof(out)), RMD_RS485_FRAME_LEN);
	assert_int_equal(out[RMD_RS485_FRAME_LEN], 0xA5);
}

int main(void)
{
	const char *env = getenv("RMD_TEST_SEED");
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_crc_vectors),    cmocka_unit_test(test_crc_residue),
		cmocka_unit_test(test_manual_frames),  cmocka_unit_test(test_random_round_trip),
		cmocka_unit_test(test_broadcast),      cmocka_unit_test(test_partial),
		cmocka_unit_test(test_stream),	       cmocka_unit_test(test_bad_frames),
		cmocka_unit_test(test_every_bit_flip), cmocka_unit_test(test_build_refusals),
	};

	seed = env && *env ? strtoull(env, NULL, 0) : (uint64_t)time(NULL);
	return SUITE_RUN("rs485", tests, NULL, NULL);
}

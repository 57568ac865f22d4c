// SPDX-License-Identifier: MIT
/*
 * The rules issue 9 keeps in one place each: the frame describer (its three
 * styles), the native-unit field conversion, the protocol-name parser and
 * the RS485 baud table.
 */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <termios.h>

#include <cmocka.h>

#include "rmd/codec.h"
#include "rmd/describe.h"
#include "rmd/mit.h"
#include "rmd/rs485.h"
#include "harness/suite.h"

/* V3 §2.12: a 0x9A reply, 25 °C, brake locked, 48.0 V, error flags as given. */
static struct rmd_frame status_reply(uint16_t errors)
{
	struct rmd_frame f = {
		.can_id = 0x241,
		.len = 8,
		.data = { 0x9A, 0x19, 0x00, 0x00, 0xE0, 0x01, (uint8_t)errors,
			  (uint8_t)(errors >> 8) },
	};

	return f;
}

static void test_frame_keys(void **state)
{
	struct rmd_frame f = status_reply(0);
	char buf[256];

	(void)state;
	assert_int_equal(
		rmd_describe_frame(buf, sizeof(buf), RMD_PROTO_V3, RMD_DIR_REPLY, NULL, &f), 0);
	assert_string_equal(buf, "read_status_1 temperature_c=25 brake_released=0 voltage_v=48 "
				 "error_code=0x0000");
	f = status_reply(0x0004);
	rmd_describe_frame(buf, sizeof(buf), RMD_PROTO_V3, RMD_DIR_REPLY, NULL, &f);
	assert_non_null(strstr(buf, " error_code=0x0004 (low_voltage)"));
}

static void test_frame_undecoded(void **state)
{
	struct rmd_frame f = status_reply(0);
	char buf[64];

	(void)state;
	f.data[0] = 0x12;
	assert_int_equal(rmd_describe_frame(buf, sizeof(buf), RMD_PROTO_V3, RMD_DIR_REPLY, NULL,
					    &f),
			 -ENOENT);
	assert_string_equal(buf, "(command 0x12: not decoded)");
	f.len = 5;
	assert_int_equal(rmd_describe_frame(buf, sizeof(buf), RMD_PROTO_V3, RMD_DIR_REPLY, NULL,
					    &f),
			 -EBADMSG);
	assert_string_equal(buf, "(DLC 5: not a protocol frame)");
}

/*
 * V4 frames of the unverified items (docs/protocol-v4.md, "What is verified
 * and what is one report"): named and decoded by the V4 table, the V3 table
 * knows none of them.
 */
static void test_frame_v4_reports(void **state)
{
	/* Nitish05/myactuator's 0x9A: MOS 40 degC; flags 0x0804 (V4 names 0x0800) */
	struct rmd_frame st = { .can_id = 0x241,
				.len = 8,
				.data = { 0x9A, 0x32, 0x28, 0x01, 0xE5, 0x01, 0x04, 0x08 } };
	/* almond-bot/axol's 0xC0: parameter 0x55 (undervoltage) read back as -2 V */
	struct rmd_frame pa = { .can_id = 0x241,
				.len = 8,
				.data = { 0xC0, 0x00, 0x55, 0x01, 0x00, 0x00, 0x00, 0xC0 } };
	/* Nitish05/myactuator's 0xA9: 90 deg at up to 500 dps, torque byte 128 */
	struct rmd_frame fp = { .can_id = 0x141,
				.len = 8,
				.data = { 0xA9, 0x80, 0xF4, 0x01, 0x28, 0x23, 0x00, 0x00 } };
	char buf[256];

	(void)state;
	assert_int_equal(
		rmd_describe_frame(buf, sizeof(buf), RMD_PROTO_V4, RMD_DIR_REPLY, NULL, &st), 0);
	assert_string_equal(buf, "read_status_1 temperature_c=50 mos_temperature_c=40 "
				 "brake_released=1 voltage_v=48.5 error_code=0x0804 "
				 "(low_voltage+component_over_temperature)");
	assert_int_equal(
		rmd_describe_frame(buf, sizeof(buf), RMD_PROTO_V4, RMD_DIR_REPLY, NULL, &pa), 0);
	assert_string_equal(buf, "param_access index=85 read_flag=1 param_value=-2");
	assert_int_equal(
		rmd_describe_frame(buf, sizeof(buf), RMD_PROTO_V4, RMD_DIR_REQUEST, NULL, &fp), 0);
	assert_string_equal(buf, "position_force max_torque_pct=128 max_speed_dps=500 "
				 "angle_deg=90");
	assert_int_equal(rmd_describe_frame(buf, sizeof(buf), RMD_PROTO_V3, RMD_DIR_REPLY, NULL,
					    &pa),
			 -ENOENT);
}

static void test_frame_mit(void **state)
{
	const struct rmd_mit_cmd cmd = { .p_des_rad = 1.0, .kp = 10.0 };
	struct rmd_frame f;
	char buf[256];

	(void)state;
	assert_int_equal(rmd_mit_encode_cmd(&rmd_mit_default_ranges, 1, &cmd, &f), 0);
	assert_int_equal(rmd_describe_frame(buf, sizeof(buf), RMD_PROTO_MIT, RMD_DIR_REQUEST,
					    &rmd_mit_default_ranges, &f),
			 0);
	assert_true(!strncmp(buf, "mit_command position_rad=", 25));
	assert_non_null(strstr(buf, " kp="));
}

/* rmdctl decode's text and JSON: the same fields, in wire order. */
static void test_styles(void **state)
{
	struct rmd_frame f = status_reply(0);
	const struct rmd_cmd_spec *spec;
	struct rmd_msg msg;
	struct rmd_text t;
	char buf[256];

	(void)state;
	assert_int_equal(rmd_decode(RMD_PROTO_V3, RMD_DIR_REPLY, &f, &msg, NULL), 0);
	spec = rmd_cmd_find(RMD_PROTO_V3, 0x9A);
	assert_non_null(spec);
	rmd_text_init(&t, buf, sizeof(buf));
	rmd_describe_fields(&t, RMD_DESCRIBE_TEXT, RMD_PROTO_V3,
			    rmd_cmd_layout(spec, RMD_DIR_REPLY), &msg);
	assert_string_equal(buf, ": temperature 25 °C, brake locked, voltage 48 V, errors 0x0000");
	rmd_text_init(&t, buf, sizeof(buf));
	rmd_describe_fields(&t, RMD_DESCRIBE_JSON, RMD_PROTO_V3,
			    rmd_cmd_layout(spec, RMD_DIR_REPLY), &msg);
	assert_string_equal(buf, ",\"temperature_c\":25,\"brake_released\":false,\"voltage_v\":48,"
				 "\"error_code\":0,\"errors\":[]");
}

static void test_text(void **state)
{
	struct rmd_text t;
	char buf[8], json[64], num[16];

	(void)state;
	rmd_text_init(&t, buf, sizeof(buf));
	rmd_text_add(&t, "%s", "0123456789");
	rmd_text_add(&t, "more");
	assert_string_equal(buf, "0123456");
	rmd_text_init(&t, json, sizeof(json));
	rmd_text_json_str(&t, "a\"b\\\x01\xc3", 6);
	assert_string_equal(json, "\"a\\\"b\\\\\\u0001\\u00c3\"");
	rmd_fmt_real(num, sizeof(num), -0.0, 6);
	assert_string_equal(num, "0");
	rmd_fmt_real(num, sizeof(num), NAN, 6);
	assert_string_equal(num, "null");
}

static void test_field_conversion(void **state)
{
	const struct rmd_field_spec i16 = { .size = 2, .is_signed = true, .scale = 1.0 };
	const struct rmd_field_spec u8 = { .size = 1, .scale = 0.01 };
	const struct rmd_field_spec u56 = { .size = 7, .scale = 1.0 };
	int64_t lo, hi, raw;

	(void)state;
	rmd_field_range(&i16, &lo, &hi);
	assert_true(lo == -32768 && hi == 32767);
	rmd_field_range(&u8, &lo, &hi);
	assert_true(lo == 0 && hi == 255);
	/* Rounded first, then saturated: the half LSB below the end still fits. */
	assert_int_equal(rmd_field_from_native(&i16, 32767.4, &raw), 0);
	assert_true(raw == 32767);
	assert_int_equal(rmd_field_from_native(&i16, 32767.6, &raw), -ERANGE);
	assert_true(raw == 32767);
	assert_int_equal(rmd_field_from_native(&i16, -32768.0, &raw), 0);
	assert_true(raw == -32768);
	assert_int_equal(rmd_field_from_native(&i16, -1e9, &raw), -ERANGE);
	assert_true(raw == -32768);
	assert_int_equal(rmd_field_from_native(&i16, NAN, &raw), -ERANGE);
	assert_true(raw == 0);
	assert_int_equal(rmd_field_from_native(&i16, -2.5, &raw), 0);
	assert_true(raw == -3); /* halves away from zero */
	assert_int_equal(rmd_field_from_native(&u8, 1.234, &raw), 0);
	assert_true(raw == 123);
	assert_true(fabs(rmd_field_to_native(&u8, 123) - 1.23) < 1e-12);
	assert_int_equal(rmd_field_from_native(&u8, -0.01, &raw), -ERANGE);
	assert_true(raw == 0);
	/* 2^56 - 1 is no double: its nearest one is the end, not past it. */
	assert_int_equal(rmd_field_from_native(&u56, 72057594037927935.0, &raw), 0);
	assert_true(raw == INT64_C(72057594037927935));
}

static void test_msg_native(void **state)
{
	const struct rmd_cmd_spec *spec = rmd_cmd_find(RMD_PROTO_V3, 0xA4);
	struct rmd_msg msg = { .cmd = 0xA4 };

	(void)state;
	assert_non_null(spec);
	/* V3 §2.20: angle int32 in 0.01 deg, speed uint16 in 1 dps. */
	assert_int_equal(rmd_msg_set_native(&msg, spec, RMD_DIR_REQUEST, RMD_FLD_ANGLE, 12.345), 0);
	assert_true(msg.v[RMD_FLD_ANGLE] == 1235 && rmd_msg_has(&msg, RMD_FLD_ANGLE));
	assert_int_equal(rmd_msg_set_native(&msg, spec, RMD_DIR_REQUEST, RMD_FLD_MAX_SPEED, 1e6),
			 -ERANGE);
	assert_true(msg.v[RMD_FLD_MAX_SPEED] == 65535);
	assert_int_equal(rmd_msg_set_native(&msg, spec, RMD_DIR_REQUEST, RMD_FLD_VOLTAGE, 1.0),
			 -ENOENT);
	assert_false(rmd_msg_has(&msg, RMD_FLD_VOLTAGE));
	assert_true(fabs(rmd_msg_get_native(&msg, spec, RMD_DIR_REQUEST, RMD_FLD_ANGLE, -1.0) -
			 12.35) < 1e-9);
	assert_true(rmd_msg_get_native(&msg, spec, RMD_DIR_REQUEST, RMD_FLD_VOLTAGE, -1.0) == -1.0);
}

static void test_proto_names(void **state)
{
	static const struct {
		const char *s;
		int r;
		enum rmd_proto proto;
	} cases[] = {
		{ "v3", 0, RMD_PROTO_V3 },   { "V3", 0, RMD_PROTO_V3 },	  { "v2", 0, RMD_PROTO_V2 },
		{ "MIT", 0, RMD_PROTO_MIT }, { "Mit", 0, RMD_PROTO_MIT }, { "v4", 0, RMD_PROTO_V4 },
		{ "V4", 0, RMD_PROTO_V4 },   { "v5", -EINVAL, 0 },	  { "", -EINVAL, 0 },
		{ "mitt", -EINVAL, 0 },	     { "v", -EINVAL, 0 },
	};

	(void)state;
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		enum rmd_proto p = RMD_PROTO_V2;
		int r = rmd_proto_parse(cases[i].s, &p);

		if (r != cases[i].r || (r == 0 && p != cases[i].proto))
			fail_msg("rmd_proto_parse(\"%s\") = %d, proto %d", cases[i].s, r, (int)p);
	}
	assert_string_equal(rmd_proto_name(RMD_PROTO_MIT), "MIT");
	assert_string_equal(rmd_proto_key(RMD_PROTO_V2), "v2");
	assert_string_equal(rmd_proto_name(RMD_PROTO_V4), "V4");
	assert_string_equal(rmd_proto_key((enum rmd_proto)7), "?");
	assert_null(rmd_proto_keys[RMD_PROTO_COUNT]);
}

static void test_rs485_bauds(void **state)
{
	speed_t s = B0;

	(void)state;
	assert_int_equal(rmd_rs485_baud_speed(115200, &s), 0);
	assert_true(s == B115200);
	assert_int_equal(rmd_rs485_baud_speed(2000000, &s), 0);
	assert_true(s == B2000000);
	assert_int_equal(rmd_rs485_baud_speed(9600, &s), -EINVAL);
	assert_int_equal(rmd_rs485_baud_speed(1000000, NULL), 0);
	for (size_t i = 0; i < RMD_RS485_N_BAUDS; i++)
		assert_int_equal(rmd_rs485_baud_speed(RMD_RS485_BAUDS[i].baud, NULL), 0);
}

SUITE_MAIN("describe", NULL, NULL,
	   {
		   cmocka_unit_test(test_frame_keys),
		   cmocka_unit_test(test_frame_undecoded),
		   cmocka_unit_test(test_frame_v4_reports),
		   cmocka_unit_test(test_frame_mit),
		   cmocka_unit_test(test_styles),
		   cmocka_unit_test(test_text),
		   cmocka_unit_test(test_field_conversion),
		   cmocka_unit_test(test_msg_native),
		   cmocka_unit_test(test_proto_names),
		   cmocka_unit_test(test_rs485_bauds),
	   })

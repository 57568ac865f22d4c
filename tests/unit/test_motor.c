// SPDX-License-Identifier: MIT
/*
 * motor tests: SI at the output shaft <-> native units for every protocol,
 * both ways, with direction -1, zero offsets, torque constants, rotor
 * units and MIT ranges; the manuals' worked examples as vectors (V3 §2.17,
 * §2.18, §2.20, §2.12, §5.4); clamping; NaN and Inf refused before
 * anything is encoded; the V2 0x280 frame; safe-action frames; reply keys;
 * and the V2 encoder unwrapped into a multi-turn position.
 */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "rmd/config.h"
#include "rmd/mit.h"
#include "rmd/motor.h"

#include "harness/hex.h"
#include "harness/suite.h"

#define DEG (M_PI / 180.0)

static void assert_frame(const char *name, const struct rmd_frame *got, const char *want)
{
	char g[HEX_FRAME_LEN];

	frame_hex(got, g);
	if (strcmp(g, want))
		fail_msg("%s: got %s, want %s", name, g, want);
}

/* A config entry with the defaults the loader gives, then the test's values. */
static struct rmd_config_motor cfg_motor(uint8_t id, enum rmd_proto proto, enum rmd_mode mode)
{
	struct rmd_config_motor c;

	rmd_config_motor_defaults(&c);
	snprintf(c.name, sizeof(c.name), "m%u", id);
	c.id = id;
	c.proto = proto;
	c.mode = mode;
	c.torque_constant_nm_a = 2.0;
	return c;
}

static struct rmd_motor motor_of(const struct rmd_config_motor *c)
{
	struct rmd_motor m;

	assert_int_equal(rmd_motor_init(&m, c), 0);
	return m;
}

/* c mounted the other way round, zero at zero_rad, kt_nm_a N·m per A: its motor. */
static struct rmd_motor motor_reversed(struct rmd_config_motor *c, double zero_rad, double kt_nm_a)
{
	c->direction = -1;
	c->zero_offset_rad = zero_rad;
	c->torque_constant_nm_a = kt_nm_a;
	return motor_of(c);
}

static struct rmd_setpoint sp_mode(enum rmd_mode mode)
{
	struct rmd_setpoint sp = { .enable = true, .mode = (uint8_t)mode };

	return sp;
}

static void test_init_refuses(void **state)
{
	struct rmd_config_motor c = cfg_motor(1, RMD_PROTO_V3, RMD_MODE_TORQUE);
	struct rmd_motor m;

	(void)state;
	c.direction = 0;
	assert_int_equal(rmd_motor_init(&m, &c), -EINVAL);
	c = cfg_motor(1, RMD_PROTO_V3, RMD_MODE_TORQUE);
	c.torque_constant_nm_a = 0;
	assert_int_equal(rmd_motor_init(&m, &c), -EINVAL);
	c = cfg_motor(1, RMD_PROTO_MIT, RMD_MODE_MIT);
	c.torque_constant_nm_a = 0; /* fine for MIT: its frames carry torque */
	assert_int_equal(rmd_motor_init(&m, &c), 0);
	c.mit.kd_min = c.mit.kd_max;
	assert_int_equal(rmd_motor_init(&m, &c), -EINVAL);
	c = cfg_motor(33, RMD_PROTO_V3, RMD_MODE_TORQUE);
	assert_int_equal(rmd_motor_init(&m, &c), -EINVAL);
	c = cfg_motor(1, RMD_PROTO_V3, RMD_MODE_TORQUE);
	c.gear_ratio = 0;
	assert_int_equal(rmd_motor_init(&m, &c), -EINVAL);
}

struct enc_vec {
	const char *name;
	struct {
		enum rmd_proto proto;
		int dir;
		double gear;
		enum rmd_units units;
		double zero;
		double kt;
	} m; /* how the motor is mounted */
	struct rmd_setpoint sp;
	const char *hex;
};

static const struct enc_vec enc_vecs[] = {
	/* V3 §2.17.4: iq -1 A = 0xFF9C */
	{ "V3 §2.17.4 torque",
	  { RMD_PROTO_V3, 1, 1.0, RMD_UNITS_OUTPUT, 0.0, 2.0 },
	  { .enable = true, .mode = RMD_MODE_TORQUE, .torque_nm = -2.0 },
	  "141#A10000009CFF0000" },
	/* direction -1 turns the sign: +2 N·m is -1 A on the wire */
	{ "V3 torque, direction -1",
	  { RMD_PROTO_V3, -1, 1.0, RMD_UNITS_OUTPUT, 0.0, 2.0 },
	  { .enable = true, .mode = RMD_MODE_TORQUE, .torque_nm = 2.0 },
	  "141#A10000009CFF0000" },
	/* Kt: 1 N·m at 0.5 N·m/A is 2 A = 200 */
	{ "V3 torque, Kt 0.5",
	  { RMD_PROTO_V3, 1, 1.0, RMD_UNITS_OUTPUT, 0.0, 0.5 },
	  { .enable = true, .mode = RMD_MODE_TORQUE, .torque_nm = 1.0 },
	  "141#A1000000C8000000" },
	/* V3 §2.18.4 example 1: 100 dps = 10000 */
	{ "V3 §2.18.4 speed",
	  { RMD_PROTO_V3, 1, 1.0, RMD_UNITS_OUTPUT, 0.0, 2.0 },
	  { .enable = true, .mode = RMD_MODE_SPEED, .vel_rad_s = 100.0 * DEG },
	  "141#A200000010270000" },
	/* V3 §2.18.4 example 2: -100 dps, here from +100 dps and direction -1 */
	{ "V3 speed, direction -1",
	  { RMD_PROTO_V3, -1, 1.0, RMD_UNITS_OUTPUT, 0.0, 2.0 },
	  { .enable = true, .mode = RMD_MODE_SPEED, .vel_rad_s = 100.0 * DEG },
	  "141#A2000000F0D8FFFF" },
	/* rotor units: 100/6 dps at the output is 100 dps at the rotor */
	{ "V3 speed, rotor units",
	  { RMD_PROTO_V3, 1, 6.0, RMD_UNITS_ROTOR, 0.0, 2.0 },
	  { .enable = true, .mode = RMD_MODE_SPEED, .vel_rad_s = 100.0 / 6.0 * DEG },
	  "141#A200000010270000" },
	/* V3 §2.20.4 example 1: 360 deg at up to 500 dps */
	{ "V3 §2.20.4 position",
	  { RMD_PROTO_V3, 1, 1.0, RMD_UNITS_OUTPUT, 0.0, 2.0 },
	  { .enable = true,
	    .mode = RMD_MODE_POSITION,
	    .pos_rad = 2.0 * M_PI,
	    .max_vel_rad_s = 500.0 * DEG },
	  "141#A400F401A08C0000" },
	/* zero offset and direction: native = -pos + 0.5 rad; -2 pi + 0.5 -> 2 pi */
	{ "V3 position, zero offset, direction -1",
	  { RMD_PROTO_V3, -1, 1.0, RMD_UNITS_OUTPUT, 2.0 * M_PI - 1.0, 2.0 },
	  { .enable = true,
	    .mode = RMD_MODE_POSITION,
	    .pos_rad = -1.0,
	    .max_vel_rad_s = 500.0 * DEG },
	  "141#A400F401A08C0000" },
	/* V2 §3.37: iq -2000..2000 is -32..32 A; 0.8 A = 50 */
	{ "V2 torque",
	  { RMD_PROTO_V2, 1, 1.0, RMD_UNITS_OUTPUT, 0.0, 0.5 },
	  { .enable = true, .mode = RMD_MODE_TORQUE, .torque_nm = 0.4 },
	  "141#A100000032000000" },
	/* V2 §3.38: 0.01 dps like V3 */
	{ "V2 speed",
	  { RMD_PROTO_V2, 1, 1.0, RMD_UNITS_OUTPUT, 0.0, 0.5 },
	  { .enable = true, .mode = RMD_MODE_SPEED, .vel_rad_s = 100.0 * DEG },
	  "141#A200000010270000" },
	/* V2 §3.40 with rotor units: 60 deg at the output is 360 at the rotor */
	{ "V2 position, rotor units",
	  { RMD_PROTO_V2, 1, 6.0, RMD_UNITS_ROTOR, 0.0, 0.5 },
	  { .enable = true,
	    .mode = RMD_MODE_POSITION,
	    .pos_rad = 60.0 * DEG,
	    .max_vel_rad_s = 500.0 / 6.0 * DEG },
	  "142#A400F401A08C0000" },
	/* V3 §5.4 example 1 (p 10, v 1.02, kp 10, kd 1, t 10) through direction -1
	 * and a zero offset of 0.5 rad: native p = -(-9.5) + 0.5 = 10 */
	{ "MIT §5.4, direction -1, zero offset",
	  { RMD_PROTO_MIT, -1, 1.0, RMD_UNITS_OUTPUT, 0.5, 0.0 },
	  { .enable = true,
	    .mode = RMD_MODE_MIT,
	    .pos_rad = -9.5,
	    .vel_rad_s = -1.02,
	    .kp = 10.0,
	    .kd = 1.0,
	    .torque_nm = -10.0 },
	  "401#E66682E052333B55" },
};

static void test_encode_vectors(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(enc_vecs) / sizeof(enc_vecs[0]); i++) {
		const struct enc_vec *v = &enc_vecs[i];
		uint8_t id = strstr(v->hex, "142#") ? 2 : 1;
		struct rmd_config_motor c = cfg_motor(id, v->m.proto, RMD_MODE_TORQUE);
		struct rmd_motor m;
		struct rmd_frame f;
		unsigned fl = 99;
		int r;

		c.direction = v->m.dir;
		c.gear_ratio = v->m.gear;
		c.units = v->m.units;
		c.zero_offset_rad = v->m.zero;
		c.torque_constant_nm_a = v->m.kt;
		m = motor_of(&c);
		r = rmd_motor_encode(&m, &v->sp, &f, &fl);
		if (r)
			fail_msg("%s: encode returned %d", v->name, r);
		assert_frame(v->name, &f, v->hex);
		if (fl)
			fail_msg("%s: flagged as clamped", v->name);
	}
}

static void test_clamp(void **state)
{
	struct rmd_config_motor c = cfg_motor(1, RMD_PROTO_V3, RMD_MODE_POSITION);
	struct rmd_setpoint sp = sp_mode(RMD_MODE_POSITION);
	struct rmd_motor m;
	struct rmd_frame f;
	unsigned fl;

	(void)state;
	c.limits.position_min_rad = -1.0;
	c.limits.position_max_rad = 2.0 * M_PI;
	c.limits.velocity_rad_s = 500.0 * DEG;
	c.limits.torque_nm = 2.0;
	m = motor_of(&c);

	/* beyond the window and the speed limit: clamped to 360 deg at 500 dps */
	sp.pos_rad = 100.0;
	sp.max_vel_rad_s = 1000.0;
	assert_int_equal(rmd_motor_encode(&m, &sp, &f, &fl), 0);
	assert_true(fl & RMD_MOTOR_CLAMPED);
	assert_frame("position clamped", &f, "141#A400F401A08C0000");

	/* max velocity 0: the configured limit */
	sp.pos_rad = 2.0 * M_PI;
	sp.max_vel_rad_s = 0.0;
	assert_int_equal(rmd_motor_encode(&m, &sp, &f, &fl), 0);
	assert_int_equal(fl, 0);
	assert_frame("max speed from the limit", &f, "141#A400F401A08C0000");

	/* torque: |t| <= 2 N·m, Kt 2: -1 A */
	sp = sp_mode(RMD_MODE_TORQUE);
	sp.torque_nm = -50.0;
	assert_int_equal(rmd_motor_encode(&m, &sp, &f, &fl), 0);
	assert_true(fl & RMD_MOTOR_CLAMPED);
	assert_frame("torque clamped", &f, "141#A10000009CFF0000");

	/* speed: |v| <= 500 dps */
	sp = sp_mode(RMD_MODE_SPEED);
	sp.vel_rad_s = -1e6;
	assert_int_equal(rmd_motor_encode(&m, &sp, &f, &fl), 0);
	assert_true(fl & RMD_MOTOR_CLAMPED);
	assert_frame("speed clamped", &f, "141#A2000000B03CFFFF");

	/* beyond the wire's own range: int16 iq saturates at 327.67 A */
	c = cfg_motor(1, RMD_PROTO_V3, RMD_MODE_TORQUE);
	c.torque_constant_nm_a = 0.001;
	m = motor_of(&c);
	sp = sp_mode(RMD_MODE_TORQUE);
	sp.torque_nm = 1.0;
	assert_int_equal(rmd_motor_encode(&m, &sp, &f, &fl), 0);
	assert_true(fl & RMD_MOTOR_CLAMPED);
	assert_frame("iq saturated", &f, "141#A1000000FF7F0000");
}

static void test_clamp_mit(void **state)
{
	struct rmd_config_motor c = cfg_motor(3, RMD_PROTO_MIT, RMD_MODE_MIT);
	struct rmd_setpoint sp = sp_mode(RMD_MODE_MIT);
	struct rmd_mit_cmd got;
	struct rmd_motor m;
	struct rmd_frame f;
	unsigned fl;
	uint8_t id;

	(void)state;
	c.mit.t_min = -18.0; /* some firmware (docs/design.md) */
	c.mit.t_max = 18.0;
	c.limits.position_max_rad = 1.0;
	c.limits.torque_nm = 30.0;
	m = motor_of(&c);
	sp.pos_rad = 5.0;
	sp.vel_rad_s = 0.0;
	sp.kp = 1000.0; /* above kp_max 500 */
	sp.kd = 2.0;
	sp.torque_nm = 25.0; /* within the limit, above the range */
	assert_int_equal(rmd_motor_encode(&m, &sp, &f, &fl), 0);
	assert_true(fl & RMD_MOTOR_CLAMPED);
	assert_int_equal(f.can_id, 0x403);
	assert_int_equal(rmd_mit_decode_cmd(&c.mit, &f, &id, &got), 0);
	assert_int_equal(id, 3);
	assert_float_equal(got.p_des_rad, 1.0, 25.0 / 65535);
	assert_float_equal(got.kp, 500.0, 1e-9);
	assert_float_equal(got.kd, 2.0, 5.0 / 4095);
	assert_float_equal(got.t_ff_nm, 18.0, 1e-9);
}

/*
 * issue 11: an MIT motor keeps its gains' codes between setpoints
 * (struct rmd_motor.mit_gains); the frames and the clamp flag must be
 * those of a motor that works every code out afresh, whether the gains
 * stay, change, come back or are clamped.
 */
static void test_mit_gain_codes_kept(void **state)
{
	static const double gains[][2] = {
		{ 5.0, 0.2 },	 { 5.0, 0.2 },	  { 7.5, 0.2 },	 { 7.5, 1.0 }, { 5.0, 0.2 },
		{ 1000.0, 0.2 }, { 1000.0, 0.2 }, { 5.0, -1.0 }, { 0.0, 0.0 }, { -0.0, 0.0 },
	};
	struct rmd_config_motor c = cfg_motor(3, RMD_PROTO_MIT, RMD_MODE_MIT);
	struct rmd_motor kept = motor_of(&c);

	(void)state;
	for (size_t k = 0; k < sizeof(gains) / sizeof(gains[0]); k++) {
		struct rmd_motor fresh = motor_of(&c);
		struct rmd_setpoint sp = sp_mode(RMD_MODE_MIT);
		struct rmd_frame got, want;
		unsigned fl_got = 0, fl_want = 0;

		sp.pos_rad = 0.1 * (double)k;
		sp.vel_rad_s = -0.2 * (double)k;
		sp.torque_nm = 0.3;
		sp.kp = gains[k][0];
		sp.kd = gains[k][1];
		assert_int_equal(rmd_motor_encode(&kept, &sp, &got, &fl_got), 0);
		assert_int_equal(rmd_motor_encode(&fresh, &sp, &want, &fl_want), 0);
		if (got.can_id != want.can_id || got.len != want.len ||
		    memcmp(got.data, want.data, sizeof(got.data)) || fl_got != fl_want)
			fail_msg("setpoint %zu (kp %g, kd %g): frame or flags differ", k, sp.kp,
				 sp.kd);
	}
}

static void test_nonfinite_refused(void **state)
{
	static const double bad[] = { NAN, INFINITY, -INFINITY };
	struct rmd_config_motor cv3 = cfg_motor(1, RMD_PROTO_V3, RMD_MODE_TORQUE);
	struct rmd_config_motor cmit = cfg_motor(1, RMD_PROTO_MIT, RMD_MODE_MIT);
	struct rmd_motor v3 = motor_of(&cv3), mit = motor_of(&cmit);

	(void)state;
	for (size_t k = 0; k < 3; k++) {
		/* every field each mode uses, one at a time */
		struct {
			struct rmd_motor *m;
			enum rmd_mode mode;
			size_t field; /* offset into struct rmd_setpoint */
		} cases[] = {
			{ &v3, RMD_MODE_TORQUE, offsetof(struct rmd_setpoint, torque_nm) },
			{ &v3, RMD_MODE_SPEED, offsetof(struct rmd_setpoint, vel_rad_s) },
			{ &v3, RMD_MODE_POSITION, offsetof(struct rmd_setpoint, pos_rad) },
			{ &v3, RMD_MODE_POSITION, offsetof(struct rmd_setpoint, max_vel_rad_s) },
			{ &mit, RMD_MODE_MIT, offsetof(struct rmd_setpoint, pos_rad) },
			{ &mit, RMD_MODE_MIT, offsetof(struct rmd_setpoint, vel_rad_s) },
			{ &mit, RMD_MODE_MIT, offsetof(struct rmd_setpoint, torque_nm) },
			{ &mit, RMD_MODE_MIT, offsetof(struct rmd_setpoint, kp) },
			{ &mit, RMD_MODE_MIT, offsetof(struct rmd_setpoint, kd) },
		};

		for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
			struct rmd_setpoint sp = sp_mode(cases[i].mode);
			struct rmd_frame f, before;
			unsigned fl = 0x55;

			memcpy((char *)&sp + cases[i].field, &bad[k], sizeof(double));
			memset(&f, 0xAA, sizeof(f));
			before = f;
			if (rmd_motor_encode(cases[i].m, &sp, &f, &fl) != -EDOM)
				fail_msg("case %zu, value %g: not refused", i, bad[k]);
			if (memcmp(&f, &before, sizeof(f)) || fl != 0x55)
				fail_msg("case %zu, value %g: output touched", i, bad[k]);
		}
	}
	/* a NaN in a field the mode does not use is no matter */
	{
		struct rmd_setpoint sp = sp_mode(RMD_MODE_TORQUE);
		struct rmd_frame f;

		sp.pos_rad = NAN;
		sp.kp = INFINITY;
		assert_int_equal(rmd_motor_encode(&v3, &sp, &f, NULL), 0);
	}
}

static void test_unsupported(void **state)
{
	struct rmd_config_motor c = cfg_motor(1, RMD_PROTO_V3, RMD_MODE_TORQUE);
	struct rmd_motor m = motor_of(&c);
	struct rmd_setpoint sp = sp_mode(RMD_MODE_MIT);
	struct rmd_frame f;

	(void)state;
	assert_int_equal(rmd_motor_encode(&m, &sp, &f, NULL), -EOPNOTSUPP);
	sp.mode = 17;
	assert_int_equal(rmd_motor_encode(&m, &sp, &f, NULL), -EOPNOTSUPP);
	/* an MIT motor takes V3 frames too: torque needs Kt, speed does not */
	c = cfg_motor(4, RMD_PROTO_MIT, RMD_MODE_MIT);
	c.torque_constant_nm_a = 0;
	m = motor_of(&c);
	sp = sp_mode(RMD_MODE_TORQUE);
	assert_int_equal(rmd_motor_encode(&m, &sp, &f, NULL), -EOPNOTSUPP);
	sp = sp_mode(RMD_MODE_SPEED);
	assert_int_equal(rmd_motor_encode(&m, &sp, &f, NULL), 0);
	assert_frame("MIT motor, V3 speed", &f, "144#A200000000000000");
}

static void test_v2_batch(void **state)
{
	struct rmd_config_motor c[4];
	struct rmd_motor m[4];
	const struct rmd_motor *ms[4];
	double t[4] = { 0.4, 0.4, NAN, 100.0 };
	struct rmd_frame f;
	unsigned fl = 0, bad = 0;

	(void)state;
	for (unsigned k = 0; k < 4; k++) {
		c[k] = cfg_motor((uint8_t)(k + 1), RMD_PROTO_V2, RMD_MODE_TORQUE);
		c[k].torque_constant_nm_a = 0.5;
		c[k].limits.torque_nm = 5.0;
	}
	c[1].direction = -1;
	for (unsigned k = 0; k < 4; k++) {
		m[k] = motor_of(&c[k]);
		ms[k] = &m[k];
	}
	/* 0.8 A = 50, -0.8 A = -50, NaN -> 0 A, 100 N·m -> 5 N·m = 10 A = 625 */
	assert_int_equal(rmd_motor_encode_v2_batch(ms, t, &f, &fl, &bad), 0);
	assert_frame("0x280", &f, "280#3200CEFF00007102");
	assert_int_equal(bad, 1);
	assert_true(fl & RMD_MOTOR_CLAMPED);
	/* a missing motor's slot is 0 A */
	ms[0] = NULL;
	assert_int_equal(rmd_motor_encode_v2_batch(ms, t, &f, NULL, NULL), 0);
	assert_frame("0x280 without motor 1", &f, "280#0000CEFF00007102");
	/* a motor in the wrong slot is refused */
	ms[0] = &m[1];
	assert_int_equal(rmd_motor_encode_v2_batch(ms, t, &f, NULL, NULL), -EINVAL);
}

static void test_safe_frames(void **state)
{
	struct rmd_config_motor cv3 = cfg_motor(2, RMD_PROTO_V3, RMD_MODE_POSITION);
	struct rmd_config_motor cmit = cfg_motor(2, RMD_PROTO_MIT, RMD_MODE_MIT);
	struct rmd_motor v3 = motor_of(&cv3), mit = motor_of(&cmit);
	struct rmd_frame f[2];
	struct rmd_mit_cmd got;
	uint8_t id;

	(void)state;
	assert_int_equal(rmd_motor_encode_safe(&v3, RMD_SAFE_STOP, f), 1);
	assert_frame("stop", &f[0], "142#8000000000000000");
	assert_int_equal(rmd_motor_encode_safe(&v3, RMD_SAFE_HOLD, f), 1);
	assert_frame("hold", &f[0], "142#8100000000000000");
	assert_int_equal(rmd_motor_encode_safe(&v3, RMD_SAFE_BRAKE, f), 2);
	assert_frame("brake 1", &f[0], "142#8000000000000000");
	assert_frame("brake 2", &f[1], "142#7800000000000000");
	assert_int_equal(rmd_motor_encode_safe(&v3, RMD_SAFE_DAMP, f), 1);
	assert_frame("damp V3", &f[0], "142#A200000000000000");
	/* MIT motors: stop etc. in V3 on 0x140 + ID, damp in MIT */
	assert_int_equal(rmd_motor_encode_safe(&mit, RMD_SAFE_STOP, f), 1);
	assert_frame("stop MIT", &f[0], "142#8000000000000000");
	assert_int_equal(rmd_motor_encode_safe(&mit, RMD_SAFE_DAMP, f), 1);
	assert_int_equal(f[0].can_id, 0x402);
	assert_int_equal(rmd_mit_decode_cmd(&cmit.mit, &f[0], &id, &got), 0);
	assert_float_equal(got.kp, 0.0, 1e-12);
	assert_float_equal(got.kd, RMD_MOTOR_DAMP_KD, 5.0 / 4095);
	assert_float_equal(got.v_des_rad_s, 0.0, 90.0 / 4095);
	assert_float_equal(got.t_ff_nm, 0.0, 48.0 / 4095);
}

static void test_commands_and_keys(void **state)
{
	struct rmd_config_motor cv2 = cfg_motor(5, RMD_PROTO_V2, RMD_MODE_TORQUE);
	struct rmd_config_motor cv3 = cfg_motor(5, RMD_PROTO_V3, RMD_MODE_TORQUE);
	struct rmd_config_motor cmit = cfg_motor(5, RMD_PROTO_MIT, RMD_MODE_MIT);
	struct rmd_motor v2 = motor_of(&cv2), v3 = motor_of(&cv3), mit = motor_of(&cmit);
	struct rmd_setpoint sp = sp_mode(RMD_MODE_MIT);
	struct rmd_frame f;
	uint32_t id;
	uint16_t cmd;

	(void)state;
	assert_int_equal(rmd_motor_encode_cmd(&v3, 0x9C, &f), 0);
	assert_frame("0x9C", &f, "145#9C00000000000000");
	rmd_motor_reply_key(&v3, &f, &id, &cmd);
	assert_int_equal(id, 0x245);
	assert_int_equal(cmd, 0x9C);
	rmd_motor_reply_key(&v2, &f, &id, &cmd);
	assert_int_equal(id, 0x145);
	assert_int_equal(cmd, 0x9C);
	rmd_motor_reply_key(&mit, &f, &id, &cmd);
	assert_int_equal(id, 0x245);
	assert_int_equal(rmd_motor_encode(&mit, &sp, &f, NULL), 0);
	rmd_motor_reply_key(&mit, &f, &id, &cmd);
	assert_int_equal(id, 0x505);
	assert_int_equal(cmd, RMD_MOTOR_CMD_MIT);
	f = frame_from("280#0000000000000000");
	rmd_motor_reply_key(&v2, &f, &id, &cmd);
	assert_int_equal(id, 0x145);
	assert_int_equal(cmd, 0xA1);
	/* V2 has neither 0xB5 nor 0xB3 */
	assert_int_equal(rmd_motor_encode_cmd(&v2, 0xB5, &f), -ENOENT);
	assert_int_equal(rmd_motor_encode_comm_timeout(&v2, 100, &f), -EOPNOTSUPP);
	assert_int_equal(rmd_motor_encode_comm_timeout(&mit, 100, &f), 0);
	assert_frame("0xB3 100 ms", &f, "145#B300000064000000");
}

static void test_decode_v3(void **state)
{
	struct rmd_config_motor c = cfg_motor(1, RMD_PROTO_V3, RMD_MODE_POSITION);
	struct rmd_motor_reply r;
	struct rmd_motor_state st = { 0 };
	struct rmd_motor m;
	struct rmd_frame f;

	(void)state;
	m = motor_reversed(&c, 0.1, 2.0);
	/* V3 §2.20.4 reply: 50 degC, 1 A, 500 dps, 45 deg */
	f = frame_from("241#A4326400F4012D00");
	assert_int_equal(rmd_motor_decode(&m, &f, &r), 0);
	assert_int_equal(r.cmd, 0xA4);
	assert_int_equal(r.have, RMD_MOTOR_HAVE_POS | RMD_MOTOR_HAVE_VEL | RMD_MOTOR_HAVE_TORQUE |
					 RMD_MOTOR_HAVE_TEMP);
	assert_float_equal(r.temp_c, 50.0, 1e-9);
	assert_float_equal(r.current_a, -1.0, 1e-9);
	assert_float_equal(r.torque_nm, -2.0, 1e-9);
	assert_float_equal(r.vel_rad_s, -500.0 * DEG, 1e-9);
	assert_float_equal(r.pos_rad, -(45.0 * DEG - 0.1), 1e-9);
	rmd_motor_apply(&r, &st);
	assert_float_equal(st.pos_rad, r.pos_rad, 0);
	assert_float_equal(st.torque_nm, -2.0, 1e-9);

	/* V3 §2.12.4: 50 degC, brake released, 48.5 V, error 0x0004 (low voltage) */
	f = frame_from("241#9A320001E5010400");
	assert_int_equal(rmd_motor_decode(&m, &f, &r), 0);
	assert_true(r.have & RMD_MOTOR_HAVE_ERROR);
	assert_float_equal(r.voltage_v, 48.5, 1e-9);
	assert_int_equal(r.error_code, 0x0004);
	assert_true(r.brake_released);
	rmd_motor_apply(&r, &st);
	assert_int_equal(st.error_code, 4);
	assert_float_equal(st.voltage_v, 48.5, 1e-9);
	assert_float_equal(st.pos_rad, -(45.0 * DEG - 0.1), 1e-9); /* kept */

	/* 0xB3 echo, 0xB5 model, 0xB2 version */
	f = frame_from("241#B300000064000000");
	assert_int_equal(rmd_motor_decode(&m, &f, &r), 0);
	assert_int_equal(r.comm_timeout_ms, 100);
	f = frame_from("241#B558385332563130");
	assert_int_equal(rmd_motor_decode(&m, &f, &r), 0);
	assert_string_equal(r.model, "X8S2V10");
	f = frame_from("241#B20000002E893401");
	assert_int_equal(rmd_motor_decode(&m, &f, &r), 0);
	assert_int_equal(r.version_date, 20220206);

	/* not this motor's, bad length, unknown command (0xF1 after a comm-loss trip) */
	f = frame_from("242#9A320001E5010400");
	assert_int_equal(rmd_motor_decode(&m, &f, &r), -EINVAL);
	f = frame_from("141#9A320001E5010400");
	assert_int_equal(rmd_motor_decode(&m, &f, &r), -EINVAL);
	f = frame_from("241#9A3200");
	assert_int_equal(rmd_motor_decode(&m, &f, &r), -EBADMSG);
	f = frame_from("241#F100000000000000");
	assert_int_equal(rmd_motor_decode(&m, &f, &r), -ENOENT);
	assert_int_equal(r.cmd, RMD_MOTOR_CMD_COMM_LOST);
}

static void test_decode_v3_rotor(void **state)
{
	struct rmd_config_motor c = cfg_motor(1, RMD_PROTO_V3, RMD_MODE_SPEED);
	struct rmd_motor_reply r;
	struct rmd_motor m;
	struct rmd_frame f;

	(void)state;
	c.gear_ratio = 6.0;
	c.units = RMD_UNITS_ROTOR;
	m = motor_of(&c);
	f = frame_from("241#9C326400F4012D00");
	assert_int_equal(rmd_motor_decode(&m, &f, &r), 0);
	assert_float_equal(r.vel_rad_s, 500.0 / 6.0 * DEG, 1e-9);
	assert_float_equal(r.pos_rad, 45.0 / 6.0 * DEG, 1e-9);
}

static void test_decode_v2_unwrap(void **state)
{
	struct rmd_config_motor c = cfg_motor(2, RMD_PROTO_V2, RMD_MODE_TORQUE);
	const struct rmd_cmd_spec *a1 = rmd_cmd_find(RMD_PROTO_V2, 0xA1);
	struct rmd_motor_reply r;
	struct rmd_motor m;
	struct rmd_msg msg;
	struct rmd_frame f;
	const double per_count = 2.0 * M_PI / 65536.0 / 6.0;

	(void)state;
	assert_non_null(a1);
	c.gear_ratio = 6.0;
	c.units = RMD_UNITS_ROTOR;
	c.torque_constant_nm_a = 0.5;
	c.direction = -1;
	m = motor_of(&c);
	memset(&msg, 0, sizeof(msg));
	msg.cmd = 0xA1;
	rmd_msg_set(&msg, RMD_FLD_TEMP, 30);
	rmd_msg_set(&msg, RMD_FLD_CURRENT, 2048); /* V2 §3.37: 33 A */
	rmd_msg_set(&msg, RMD_FLD_SPEED, 600);	  /* rotor dps */
	rmd_msg_set(&msg, RMD_FLD_ENCODER, 65000);
	assert_int_equal(rmd_encode(RMD_PROTO_V2, RMD_DIR_REPLY, 2, &msg, &f), 0);
	assert_int_equal(f.can_id, 0x142);
	/* no reference: the encoder alone is no position */
	assert_true(rmd_motor_needs_v2_reference(&m));
	assert_int_equal(rmd_motor_decode(&m, &f, &r), 0);
	assert_false(r.have & RMD_MOTOR_HAVE_POS);
	assert_true(r.have & RMD_MOTOR_HAVE_VEL);

	rmd_motor_set_v2_reference(&m, 1.0, 0); /* the 0x92 angle at bring-up */
	assert_false(rmd_motor_needs_v2_reference(&m));
	assert_int_equal(rmd_motor_decode(&m, &f, &r), 0);
	assert_float_equal(r.current_a, -33.0, 1e-9);
	assert_float_equal(r.torque_nm, -16.5, 1e-9);
	assert_float_equal(r.vel_rad_s, -100.0 * DEG, 1e-9);
	assert_float_equal(r.pos_rad, -1.0, 1e-12); /* anchored at the reference */

	/* across the wrap: 65000 -> 500 is +1036 counts */
	rmd_msg_set(&msg, RMD_FLD_ENCODER, 500);
	assert_int_equal(rmd_encode(RMD_PROTO_V2, RMD_DIR_REPLY, 2, &msg, &f), 0);
	assert_int_equal(rmd_motor_decode(&m, &f, &r), 0);
	assert_float_equal(r.pos_rad, -(1.0 + 1036 * per_count), 1e-12);
	/* and back down across it */
	rmd_msg_set(&msg, RMD_FLD_ENCODER, 65535);
	assert_int_equal(rmd_encode(RMD_PROTO_V2, RMD_DIR_REPLY, 2, &msg, &f), 0);
	assert_int_equal(rmd_motor_decode(&m, &f, &r), 0);
	assert_float_equal(r.pos_rad, -(1.0 + 535 * per_count), 1e-12);

	/* silent (LOST): the count is forgotten until a 0x92 angle, which anchors it */
	rmd_motor_forget_v2_reference(&m);
	assert_true(rmd_motor_needs_v2_reference(&m));
	assert_int_equal(rmd_motor_decode(&m, &f, &r), 0);
	assert_false(r.have & RMD_MOTOR_HAVE_POS);
	{
		struct rmd_msg a = { .cmd = 0x92 };
		struct rmd_frame g;

		/* V2 §3.29: 0.01 deg at the rotor (rotor units): 720 deg is 120 at the output */
		rmd_msg_set(&a, RMD_FLD_ANGLE, 72000);
		assert_int_equal(rmd_encode(RMD_PROTO_V2, RMD_DIR_REPLY, 2, &a, &g), 0);
		assert_int_equal(rmd_motor_decode(&m, &g, &r), 0);
		assert_true(r.have & RMD_MOTOR_HAVE_POS);
		assert_false(rmd_motor_needs_v2_reference(&m));
		/* the next encoder value is there, and counts from it */
		assert_int_equal(rmd_motor_decode(&m, &f, &r), 0);
		assert_float_equal(r.pos_rad, -(720.0 / 6.0 * DEG), 1e-9);
	}

	/* V2 replies come on 0x140 + ID, not 0x240 + ID */
	f.can_id = 0x242;
	assert_int_equal(rmd_motor_decode(&m, &f, &r), -EINVAL);
}

/* A V2 reply at t_ms: speed in rotor dps, the encoder; its position, if it has one. */
static bool v2_at(struct rmd_motor *m, double t_ms, int speed_dps, unsigned enc,
		  struct rmd_motor_state *st)
{
	struct rmd_msg msg = { .cmd = 0xA1 };
	struct rmd_frame f;
	unsigned have;
	int64_t before = st->pos_rx_ns;

	rmd_msg_set(&msg, RMD_FLD_SPEED, speed_dps);
	rmd_msg_set(&msg, RMD_FLD_ENCODER, enc);
	assert_int_equal(rmd_encode(RMD_PROTO_V2, RMD_DIR_REPLY, 2, &msg, &f), 0);
	assert_int_equal(rmd_motor_receive(m, &f, (int64_t)(t_ms * 1e6), st, &have), 0);
	assert_true((st->pos_rx_ns != before) == !!(have & RMD_MOTOR_HAVE_POS));
	return have & RMD_MOTOR_HAVE_POS;
}

/*
 * The V2 count's trust (rmd/motor.h RMD_MOTOR_V2_STEP_TURNS,
 * RMD_MOTOR_V2_ANCHOR_RAD), by the replies' rotor speeds and times: a step
 * over a quarter rotor turn, or an anchor over half a degree of output
 * motion after the 0x92 angle, gives no position and drops the reference.
 */
static void test_v2_count_trust(void **state)
{
	struct rmd_config_motor c = cfg_motor(2, RMD_PROTO_V2, RMD_MODE_TORQUE);
	struct rmd_motor_state st = { 0 };
	struct rmd_motor m;

	(void)state;
	c.gear_ratio = 6.0;
	c.units = RMD_UNITS_ROTOR;
	m = motor_of(&c);
	rmd_motor_set_v2_reference(&m, 1.0, 1000000);
	/* 10 ms later at 60 rotor dps: 0.1 deg at the output, anchored */
	assert_true(v2_at(&m, 11.0, 60, 0, &st));
	/* 10 ms at 7200 rotor dps: 0.2 rotor turns, counted */
	assert_true(v2_at(&m, 21.0, 7200, 13107, &st));
	assert_true(v2_at(&m, 31.0, 7200, 26214, &st));
	/* 10 ms at up to 10000 rotor dps: 0.28 of a turn, no longer sure */
	assert_false(v2_at(&m, 41.0, 10000, 44418, &st));
	assert_true(rmd_motor_needs_v2_reference(&m));
	assert_false(v2_at(&m, 51.0, 0, 44418, &st));
	/* anchored again: a 0x92 angle, then 10 ms at 600 rotor dps (1 deg): not anchored */
	rmd_motor_set_v2_reference(&m, 2.0, 52000000);
	assert_false(v2_at(&m, 62.0, 600, 100, &st));
	assert_true(rmd_motor_needs_v2_reference(&m));
	/* ... and at 200 rotor dps (0.33 deg): anchored, then counted at rest */
	rmd_motor_set_v2_reference(&m, 2.0, 63000000);
	assert_true(v2_at(&m, 73.0, 200, 100, &st));
	assert_true(v2_at(&m, 83.0, 0, 100, &st));
	assert_float_equal(st.pos_rad, 2.0, 1e-9);
	assert_false(rmd_motor_needs_v2_reference(&m));
}

static void test_decode_mit(void **state)
{
	struct rmd_config_motor c = cfg_motor(1, RMD_PROTO_MIT, RMD_MODE_MIT);
	struct rmd_mit_reply rep = {
		.motor_id = 1, .pos_rad = 10.0, .vel_rad_s = 1.0, .torque_nm = 5.0
	};
	struct rmd_motor_reply r;
	struct rmd_motor m;
	struct rmd_frame f;

	(void)state;
	m = motor_reversed(&c, 0.5, 2.5);
	assert_int_equal(rmd_mit_encode_reply(&c.mit, &rep, &f), 0);
	assert_int_equal(rmd_motor_decode(&m, &f, &r), 0);
	assert_int_equal(r.cmd, RMD_MOTOR_CMD_MIT);
	assert_float_equal(r.pos_rad, -9.5, 25.0 / 65535);
	assert_float_equal(r.vel_rad_s, -1.0, 90.0 / 4095);
	assert_float_equal(r.torque_nm, -5.0, 48.0 / 4095);
	assert_float_equal(r.current_a, r.torque_nm / 2.5, 1e-12);
	/* without Kt, the current is unknown */
	c.torque_constant_nm_a = 0;
	m = motor_of(&c);
	assert_int_equal(rmd_motor_decode(&m, &f, &r), 0);
	assert_true(isnan(r.current_a));
	/* the D0 id byte must agree with the identifier */
	f.data[0] = 2;
	assert_int_equal(rmd_motor_decode(&m, &f, &r), -EBADMSG);
	/* a V3 motor takes no MIT replies */
	c = cfg_motor(1, RMD_PROTO_V3, RMD_MODE_TORQUE);
	m = motor_of(&c);
	f.data[0] = 1;
	assert_int_equal(rmd_motor_decode(&m, &f, &r), -EINVAL);
}

/* Seeded round trip: encode a position, read the angle back through a 0x92-like reply. */
static void test_position_round_trip(void **state)
{
	unsigned seed = 12345;

	(void)state;
	for (int i = 0; i < 2000; i++) {
		struct rmd_config_motor c = cfg_motor(1, RMD_PROTO_V3, RMD_MODE_POSITION);
		struct rmd_setpoint sp = sp_mode(RMD_MODE_POSITION);
		struct rmd_motor_reply r;
		struct rmd_motor m;
		struct rmd_frame f;
		int32_t raw;

		c.direction = rand_r(&seed) & 1 ? 1 : -1;
		c.zero_offset_rad = (rand_r(&seed) % 2000 - 1000) / 100.0;
		c.gear_ratio = 1 + rand_r(&seed) % 50;
		c.units = rand_r(&seed) & 1 ? RMD_UNITS_ROTOR : RMD_UNITS_OUTPUT;
		m = motor_of(&c);
		sp.pos_rad = (rand_r(&seed) % 20000 - 10000) / 1000.0;
		assert_int_equal(rmd_motor_encode(&m, &sp, &f, NULL), 0);
		/* the 0xA4 angle as a V3 §2.11 0x92 reply (both 0.01 deg, int32) */
		memcpy(&raw, &f.data[4], 4);
		f.can_id = 0x241;
		memset(f.data, 0, sizeof(f.data));
		f.data[0] = 0x92;
		memcpy(&f.data[4], &raw, 4);
		assert_int_equal(rmd_motor_decode(&m, &f, &r), 0);
		if (fabs(r.pos_rad - sp.pos_rad) > 0.005 * DEG * c.gear_ratio + 1e-9)
			fail_msg("seed 12345, case %d: %g -> %g", i, sp.pos_rad, r.pos_rad);
	}
}

/* The limit rule the bridge and the encoder share (docs/lcm.md). */
static void test_clamp_rule(void **state)
{
	const struct rmd_config_limits lim = { -1.0, 2.0, 3.0, 4.0 };
	const struct rmd_config_limits none = { -INFINITY, INFINITY, INFINITY, INFINITY };
	struct rmd_motor_clamp_note note = { 0 };
	struct rmd_setpoint sp = sp_mode(RMD_MODE_MIT);

	(void)state;
	sp.pos_rad = 5.0;
	sp.vel_rad_s = -7.0;
	sp.torque_nm = 1.0;
	sp.kp = 1000.0; /* gains are not clamped: the bridge rejects them */
	assert_int_equal(rmd_motor_clamp(&lim, &sp, &note), 2);
	assert_string_equal(note.field, "position");
	assert_true(note.from == 5.0 && note.to == 2.0);
	assert_true(sp.pos_rad == 2.0 && sp.vel_rad_s == -3.0 && sp.torque_nm == 1.0);
	assert_true(sp.kp == 1000.0);
	/* a mode clamps only what it uses */
	sp = sp_mode(RMD_MODE_TORQUE);
	sp.pos_rad = 9.0;
	sp.torque_nm = -9.0;
	assert_int_equal(rmd_motor_clamp(&lim, &sp, NULL), 1);
	assert_true(sp.pos_rad == 9.0 && sp.torque_nm == -4.0);
	/* max_vel: 0 is the limit, and stays 0 without one */
	sp = sp_mode(RMD_MODE_POSITION);
	assert_int_equal(rmd_motor_clamp(&lim, &sp, NULL), 0);
	assert_true(sp.max_vel_rad_s == 3.0);
	sp = sp_mode(RMD_MODE_POSITION);
	assert_int_equal(rmd_motor_clamp(&none, &sp, NULL), 0);
	assert_true(sp.max_vel_rad_s == 0.0);
	sp.max_vel_rad_s = 9.0;
	assert_int_equal(rmd_motor_clamp(&lim, &sp, &note), 1);
	assert_string_equal(note.field, "max_velocity");
	assert_true(sp.max_vel_rad_s == 3.0);
}

/* Which modes a motor takes, and the bridge's view of it. */
static void test_modes_and_info(void **state)
{
	struct rmd_config_motor c3 = cfg_motor(3, RMD_PROTO_V3, RMD_MODE_TORQUE);
	struct rmd_config_motor cm = cfg_motor(4, RMD_PROTO_MIT, RMD_MODE_MIT);
	struct rmd_config_motor c2 = cfg_motor(1, RMD_PROTO_V2, RMD_MODE_TORQUE);
	const unsigned sp_pos = RMD_MOTOR_MODE_BIT(RMD_MODE_SPEED) |
				RMD_MOTOR_MODE_BIT(RMD_MODE_POSITION);
	struct rmd_motor m3, mm, m2;
	struct rmd_motor_info info;

	(void)state;
	cm.torque_constant_nm_a = 0; /* unknown: no torque mode */
	c3.bus = 2;
	c3.limits.torque_nm = 4.5;
	m3 = motor_of(&c3);
	mm = motor_of(&cm);
	m2 = motor_of(&c2);
	assert_int_equal(rmd_motor_modes(&m3, false), RMD_MOTOR_MODE_BIT(RMD_MODE_TORQUE) | sp_pos);
	assert_int_equal(rmd_motor_modes(&mm, false), sp_pos | RMD_MOTOR_MODE_BIT(RMD_MODE_MIT));
	assert_int_equal(rmd_motor_modes(&m2, true), RMD_MOTOR_MODE_BIT(RMD_MODE_TORQUE));
	rmd_motor_info(&m3, false, &info);
	assert_string_equal(info.name, "m3");
	assert_string_equal(info.protocol, "v3");
	assert_int_equal(info.bus, 2);
	assert_int_equal(info.id, 3);
	assert_true(info.torque_max_nm == 4.5);
	assert_true(info.kp_min == 0 && info.kp_max == 0); /* no MIT: an empty gain range */
	rmd_motor_info(&mm, false, &info);
	assert_string_equal(info.protocol, "mit");
	assert_true(info.kp_max == cm.mit.kp_max && info.kd_max == cm.mit.kd_max);
}

/*
 * issue 11: rmd_motor_encode() and rmd_motor_decode() read the rows they
 * resolved at init instead of interpreting a struct rmd_msg per frame; they
 * must give what the codec's interpreter gives.  Seeded setpoints in every
 * mode of V2 and V3 motors (direction, gear, offset), encoded both ways,
 * and seeded replies of every command decoded both ways.
 */
static double rnd(unsigned *seed, double lo, double hi)
{
	*seed = *seed * 1103515245u + 12345u;
	return lo + (hi - lo) * (double)((*seed >> 8) & 0xFFFFFF) / (double)0xFFFFFF;
}

/* The interpreter's frame: native values rounded (llround) and clamped to each field. */
static void ref_put(struct rmd_msg *msg, const struct rmd_cmd_spec *spec, enum rmd_field fld,
		    double native)
{
	const struct rmd_field_spec *fs = rmd_layout_field(spec, RMD_DIR_REQUEST, fld);
	int64_t lo, hi;
	double raw;

	if (!fs)
		return;
	rmd_field_range(fs, &lo, &hi);
	raw = native / (fs->scale > 0.0 ? fs->scale : 1.0);
	rmd_msg_set(msg, fld, raw <= (double)lo ? lo : raw >= (double)hi ? hi : llround(raw));
}

static void test_resolved_rows_match_interpreter(void **state)
{
	static const enum rmd_proto protos[] = { RMD_PROTO_V3, RMD_PROTO_V2, RMD_PROTO_V4 };
	static const enum rmd_mode modes[] = { RMD_MODE_TORQUE, RMD_MODE_SPEED, RMD_MODE_POSITION };
	unsigned seed = 11;

	(void)state;
	for (unsigned p = 0; p < sizeof(protos) / sizeof(protos[0]); p++) {
		for (unsigned k = 0; k < 300; k++) {
			enum rmd_mode mode = modes[k % 3];
			struct rmd_config_motor c = cfg_motor(2, protos[p], mode);
			struct rmd_setpoint sp = sp_mode(mode);
			const struct rmd_cmd_spec *spec;
			struct rmd_frame got, want;
			struct rmd_msg msg;
			struct rmd_motor m;
			double dpr = 180.0 / M_PI;

			c.direction = k & 1 ? -1 : 1;
			c.gear_ratio = k % 5 ? 1.0 : 9.0;
			c.units = k % 7 ? RMD_UNITS_OUTPUT : RMD_UNITS_ROTOR;
			c.zero_offset_rad = rnd(&seed, -1, 1);
			m = motor_of(&c);
			sp.torque_nm = rnd(&seed, -200, 200);
			sp.vel_rad_s = rnd(&seed, -500, 500);
			sp.pos_rad = rnd(&seed, -1e5, 1e5);
			sp.max_vel_rad_s = rnd(&seed, 0, 50);
			assert_int_equal(rmd_motor_encode(&m, &sp, &got, NULL), 0);

			memset(&msg, 0, sizeof(msg));
			msg.cmd = mode == RMD_MODE_TORQUE ? 0xA1 :
				  mode == RMD_MODE_SPEED  ? 0xA2 :
							    0xA4;
			spec = rmd_cmd_find(protos[p], msg.cmd);
			assert_non_null(spec);
			if (mode == RMD_MODE_TORQUE)
				ref_put(&msg, spec, RMD_FLD_CURRENT,
					c.direction * sp.torque_nm / 2.0);
			else if (mode == RMD_MODE_SPEED)
				ref_put(&msg, spec, RMD_FLD_SPEED,
					c.direction * sp.vel_rad_s * dpr * m.native_per_output);
			else {
				ref_put(&msg, spec, RMD_FLD_ANGLE,
					(c.direction * sp.pos_rad + c.zero_offset_rad) * dpr *
						m.native_per_output);
				ref_put(&msg, spec, RMD_FLD_MAX_SPEED,
					sp.max_vel_rad_s * dpr * m.native_per_output);
			}
			assert_int_equal(rmd_encode(protos[p], RMD_DIR_REQUEST, 2, &msg, &want), 0);
			assert_int_equal(got.can_id, want.can_id);
			assert_int_equal(got.len, want.len);
			assert_memory_equal(got.data, want.data, RMD_FRAME_LEN);
		}
		/* replies of every command byte, random data: the fields the interpreter finds */
		for (unsigned cmd = 0; cmd < 256; cmd++) {
			struct rmd_config_motor c = cfg_motor(3, protos[p], RMD_MODE_TORQUE);
			struct rmd_motor m = motor_of(&c);
			const struct rmd_cmd_spec *spec = rmd_cmd_find(protos[p], (uint8_t)cmd);
			struct rmd_motor_reply r;
			struct rmd_frame f = { .can_id = m.reply_id, .len = RMD_FRAME_LEN };
			struct rmd_msg msg;
			int ret, ref;

			f.data[0] = (uint8_t)cmd;
			for (unsigned b = 1; b < RMD_FRAME_LEN; b++)
				f.data[b] = (uint8_t)rnd(&seed, 0, 255);
			ret = rmd_motor_decode(&m, &f, &r);
			ref = rmd_decode(protos[p], RMD_DIR_REPLY, &f, &msg, NULL);
			if (ref < 0 || !spec) {
				assert_true(ret < 0);
				continue;
			}
			assert_int_equal(ret, 0);
			assert_int_equal(!!(r.have & RMD_MOTOR_HAVE_TEMP),
					 rmd_msg_has(&msg, RMD_FLD_TEMP));
			if (rmd_msg_has(&msg, RMD_FLD_TEMP))
				assert_true(r.temp_c == (double)msg.v[RMD_FLD_TEMP] *
								rmd_layout_field(spec,
										 RMD_DIR_REPLY,
										 RMD_FLD_TEMP)
									->scale);
			assert_int_equal(!!(r.have & RMD_MOTOR_HAVE_TORQUE),
					 rmd_msg_has(&msg, RMD_FLD_CURRENT));
			if (rmd_msg_has(&msg, RMD_FLD_CURRENT))
				assert_true(r.current_a == (double)msg.v[RMD_FLD_CURRENT] *
								   rmd_layout_field(spec,
										    RMD_DIR_REPLY,
										    RMD_FLD_CURRENT)
									   ->scale);
			assert_int_equal(!!(r.have & RMD_MOTOR_HAVE_ERROR),
					 rmd_msg_has(&msg, RMD_FLD_ERROR));
			if (rmd_msg_has(&msg, RMD_FLD_ERROR))
				assert_int_equal(r.error_code, (uint16_t)msg.v[RMD_FLD_ERROR]);
			assert_int_equal(!!(r.have & RMD_MOTOR_HAVE_VEL),
					 rmd_msg_has(&msg, RMD_FLD_SPEED));
			assert_int_equal(!!(r.have & RMD_MOTOR_HAVE_VOLTAGE),
					 rmd_msg_has(&msg, RMD_FLD_VOLTAGE));
		}
	}
}

/* ---- issue 13: fine position feedback ------------------------------------------ */

/* Decode hex (a reply of m) and fuse it into st at t_ns. */
static void take_hex(struct rmd_motor *m, const char *hex, int64_t t_ns, struct rmd_motor_state *st)
{
	struct rmd_frame f = frame_from(hex);
	struct rmd_motor_reply r;

	if (rmd_motor_decode(m, &f, &r) < 0)
		fail_msg("%s: not a reply of motor %u", hex, m->id);
	rmd_motor_take(m, &r, t_ns, st);
}

/*
 * rmd_motor_take(): with feedback.position multi_turn the position is the
 * newest 0x92 answer's (0.01 deg, V3 §2.11), with its receive time; a
 * control reply's whole degrees (V3 §2.13.3) never replace it, but give
 * velocity and torque their own time.  Without it every reply's angle is
 * taken, with one time for all.
 */
static void test_fine_feedback_fusion(void **state)
{
	struct rmd_config_motor c = cfg_motor(1, RMD_PROTO_V3, RMD_MODE_POSITION);
	struct rmd_motor fine, coarse;
	struct rmd_motor_state st = { 0 }, sc = { 0 };

	(void)state;
	coarse = motor_of(&c);
	c.feedback.position = RMD_FEEDBACK_MULTI_TURN;
	fine = motor_of(&c);
	assert_true(fine.fine_pos);
	assert_false(coarse.fine_pos);

	/* 0x92: 12345 = 123.45 deg */
	take_hex(&fine, "241#9200000039300000", 1000, &st);
	assert_float_equal(st.pos_rad, 123.45 * DEG, 1e-12);
	assert_int_equal(st.pos_rx_ns, 1000);
	assert_int_equal(st.rx_ns, 0); /* nothing but the position came */
	/* 0x9C: 30 degC, 1.00 A, 500 dps, 123 deg: the angle is not taken */
	take_hex(&fine, "241#9C1E6400F4017B00", 2000, &st);
	assert_float_equal(st.pos_rad, 123.45 * DEG, 1e-12);
	assert_int_equal(st.pos_rx_ns, 1000);
	assert_float_equal(st.vel_rad_s, 500 * DEG, 1e-12);
	assert_float_equal(st.current_a, 1.0, 1e-12);
	assert_int_equal(st.rx_ns, 2000);
	/* the control answer to 0xA4 alike */
	take_hex(&fine, "241#A41E6400F4017C00", 3000, &st);
	assert_float_equal(st.pos_rad, 123.45 * DEG, 1e-12);
	assert_int_equal(st.rx_ns, 3000);
	/* a newer 0x92, negative: -50.00 deg */
	take_hex(&fine, "241#9200000078ECFFFF", 4000, &st);
	assert_float_equal(st.pos_rad, -50.0 * DEG, 1e-12);
	assert_int_equal(st.pos_rx_ns, 4000);
	assert_int_equal(st.rx_ns, 3000);

	/* control feedback: the control reply's angle, one time for every value */
	take_hex(&coarse, "241#9C1E6400F4017B00", 2000, &sc);
	assert_float_equal(sc.pos_rad, 123.0 * DEG, 1e-12);
	assert_int_equal(sc.pos_rx_ns, 2000);
	assert_int_equal(sc.rx_ns, 2000);
	take_hex(&coarse, "241#9200000039300000", 2500, &sc);
	assert_float_equal(sc.pos_rad, 123.45 * DEG, 1e-12);
	assert_int_equal(sc.pos_rx_ns, 2500);
	assert_int_equal(sc.rx_ns, 2000);
}

/* rmd_motor_pos_resolution_rad() and config_t's copy, per protocol and feedback. */
static void test_position_resolution(void **state)
{
	struct rmd_config_motor c = cfg_motor(1, RMD_PROTO_V3, RMD_MODE_POSITION);
	struct rmd_motor m;
	struct rmd_motor_info info;

	(void)state;
	m = motor_of(&c);
	assert_float_equal(rmd_motor_pos_resolution_rad(&m), 1.0 * DEG, 1e-15);
	rmd_motor_info(&m, false, &info);
	assert_float_equal(info.pos_resolution_rad, 1.0 * DEG, 1e-15);
	c.feedback.position = RMD_FEEDBACK_MULTI_TURN;
	m = motor_of(&c);
	assert_float_equal(rmd_motor_pos_resolution_rad(&m), 0.01 * DEG, 1e-15);
	/* units rotor: the motor's degrees are the rotor's, gear_ratio of them an output degree */
	c.units = RMD_UNITS_ROTOR;
	c.gear_ratio = 9.0;
	m = motor_of(&c);
	assert_float_equal(rmd_motor_pos_resolution_rad(&m), 0.01 * DEG / 9.0, 1e-15);
	/* V2: one count of the rotor encoder (V2 §3.32) */
	c = cfg_motor(2, RMD_PROTO_V2, RMD_MODE_TORQUE);
	c.gear_ratio = 6.0;
	m = motor_of(&c);
	assert_float_equal(rmd_motor_pos_resolution_rad(&m), 2.0 * M_PI / 65536.0 / 6.0, 1e-15);
	/* MIT: its 16-bit code over [p_min, p_max] (V3 §5), or 0x92's 0.01 deg */
	c = cfg_motor(3, RMD_PROTO_MIT, RMD_MODE_MIT);
	m = motor_of(&c);
	assert_float_equal(rmd_motor_pos_resolution_rad(&m), (c.mit.p_max - c.mit.p_min) / 65535.0,
			   1e-15);
	c.feedback.position = RMD_FEEDBACK_MULTI_TURN;
	m = motor_of(&c);
	assert_float_equal(rmd_motor_pos_resolution_rad(&m), 0.01 * DEG, 1e-15);
}

SUITE_MAIN("motor", NULL, NULL,
	   {
		   cmocka_unit_test(test_init_refuses),
		   cmocka_unit_test(test_encode_vectors),
		   cmocka_unit_test(test_clamp),
		   cmocka_unit_test(test_clamp_mit),
		   cmocka_unit_test(test_nonfinite_refused),
		   cmocka_unit_test(test_mit_gain_codes_kept),
		   cmocka_unit_test(test_unsupported),
		   cmocka_unit_test(test_v2_batch),
		   cmocka_unit_test(test_safe_frames),
		   cmocka_unit_test(test_commands_and_keys),
		   cmocka_unit_test(test_decode_v3),
		   cmocka_unit_test(test_decode_v3_rotor),
		   cmocka_unit_test(test_decode_v2_unwrap),
		   cmocka_unit_test(test_v2_count_trust),
		   cmocka_unit_test(test_decode_mit),
		   cmocka_unit_test(test_position_round_trip),
		   cmocka_unit_test(test_clamp_rule),
		   cmocka_unit_test(test_modes_and_info),
		   cmocka_unit_test(test_resolved_rows_match_interpreter),
		   cmocka_unit_test(test_fine_feedback_fusion),
		   cmocka_unit_test(test_position_resolution),
	   })

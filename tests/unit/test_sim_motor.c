// SPDX-License-Identifier: MIT
/*
 * Simulated motor tests.  The motor is driven only through its frame
 * interface (rmd_sim_motor_receive / _poll / _step, and the power-cycle and
 * fault-injection hooks), with requests made by rmd_encode and
 * rmd_mit_encode_cmd; every result is read from reply frames decoded by
 * rmd_decode / rmd_mit_decode_reply, never from the motor's struct.
 * Expected values come from the parameters the test configures.
 *
 * The fuzz test takes its seed from RMD_TEST_SEED, else the clock; the seed
 * is printed, and a failure names it.
 */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <cmocka.h>

#include "rmd/codec.h"
#include "rmd/mit.h"
#include "rmd/sim.h"
#include "harness/suite.h"

#define MS INT64_C(1000000)
#define MAXREP 8

static uint64_t seed;

/* The test's clock: every call below happens at `now`. */
static int64_t now;

/* ---- Helpers ------------------------------------------------------------ */

struct kv {
	enum rmd_field fld;
	int64_t raw;
};

#define KV(fld, raw)                          \
	(struct kv)                           \
	{                                     \
		RMD_FLD_##fld, (int64_t)(raw) \
	}

/* A request frame for motor `id` (0: the 0x280 frame) made by the codec. */
static struct rmd_frame req_n(enum rmd_proto proto, uint8_t id, uint8_t cmd, const struct kv *kv,
			      size_t n)
{
	struct rmd_msg msg = { .cmd = cmd };
	struct rmd_frame f;

	for (size_t i = 0; i < n; i++)
		rmd_msg_set(&msg, kv[i].fld, kv[i].raw);
	assert_int_equal(rmd_encode(proto, RMD_DIR_REQUEST, id, &msg, &f), 0);
	return f;
}

#define REQ(proto, id, cmd, ...)                                                  \
	req_n(RMD_PROTO_##proto, (id), (cmd), (const struct kv[]){ __VA_ARGS__ }, \
	      sizeof((const struct kv[]){ __VA_ARGS__ }) / sizeof(struct kv))
#define REQ0(proto, id, cmd) req_n(RMD_PROTO_##proto, (id), (cmd), NULL, 0)

/* Send f at `now`; returns the replies' count, replies in out[]. */
static int send(struct rmd_sim_motor *m, const struct rmd_frame *f, struct rmd_frame *out)
{
	int n = rmd_sim_motor_receive(m, now, f, out, MAXREP);

	assert_true(n >= 0 && n <= MAXREP);
	return n;
}

/* Send f, expect exactly one reply, decode it as `proto` reply of f's command. */
static struct rmd_msg ask(struct rmd_sim_motor *m, enum rmd_proto proto, const struct rmd_frame *f,
			  struct rmd_frame *raw)
{
	struct rmd_frame out[MAXREP];
	struct rmd_msg msg;

	assert_int_equal(send(m, f, out), 1);
	assert_int_equal(rmd_decode(proto, RMD_DIR_REPLY, &out[0], &msg, NULL), 0);
	if (raw)
		*raw = out[0];
	return msg;
}

/* Send f and expect its bytes back on `reply_id` (an echo). */
static void expect_echo(struct rmd_sim_motor *m, const struct rmd_frame *f, uint32_t reply_id)
{
	struct rmd_frame out[MAXREP];

	assert_int_equal(send(m, f, out), 1);
	assert_int_equal(out[0].can_id, reply_id);
	assert_int_equal(out[0].len, RMD_FRAME_LEN);
	assert_memory_equal(out[0].data, f->data, RMD_FRAME_LEN);
}

static void expect_silence(struct rmd_sim_motor *m, const struct rmd_frame *f)
{
	struct rmd_frame out[MAXREP];

	assert_int_equal(send(m, f, out), 0);
}

/* Read field `fld` of V3 (or V2) read command `cmd`. */
static int64_t read_v(struct rmd_sim_motor *m, enum rmd_proto proto, uint8_t id, uint8_t cmd,
		      enum rmd_field fld)
{
	struct rmd_frame f = req_n(proto, id, cmd, NULL, 0);
	struct rmd_msg msg = ask(m, proto, &f, NULL);

	assert_true(rmd_msg_has(&msg, fld));
	return msg.v[fld];
}

static int64_t angle_cdeg(struct rmd_sim_motor *m, uint8_t id)
{
	return read_v(m, RMD_PROTO_V3, id, 0x92, RMD_FLD_ANGLE);
}

static int64_t speed_dps(struct rmd_sim_motor *m, uint8_t id)
{
	return read_v(m, RMD_PROTO_V3, id, 0x9C, RMD_FLD_SPEED);
}

static void advance(struct rmd_sim_motor *m, int64_t ns)
{
	now += ns;
	rmd_sim_motor_step(m, now);
}

/* Advance while talking to the motor every 10 ms (keeps comm-loss quiet). */
static void advance_talking(struct rmd_sim_motor *m, uint8_t id, int64_t ns)
{
	for (int64_t end = now + ns; now < end;) {
		advance(m, 10 * MS);
		(void)speed_dps(m, id);
	}
}

static void motor_init(struct rmd_sim_motor *m, uint8_t id, enum rmd_proto proto)
{
	struct rmd_sim_motor_params p;

	rmd_sim_motor_params_default(&p, id, proto);
	rmd_sim_motor_init(m, &p, now);
}

static void brake_release(struct rmd_sim_motor *m, enum rmd_proto proto, uint8_t id)
{
	struct rmd_frame f = req_n(proto, id, 0x77, NULL, 0);

	expect_echo(m, &f, (proto == RMD_PROTO_V2 ? RMD_CAN_REQ_BASE : RMD_CAN_V3_REPLY_BASE) + id);
}

/* A simulator default motor, its brake released: ready to move. */
static void motor_ready(struct rmd_sim_motor *m, uint8_t id, enum rmd_proto proto)
{
	motor_init(m, id, proto);
	brake_release(m, proto, id);
}

static int setup(void **state)
{
	(void)state;
	now = INT64_C(1000000000);
	return 0;
}

/* ---- (a) absolute move timing ------------------------------------------- */

/*
 * V3 §2.20 with 0x43 index 0/1 at 2000 dps/s and 500 dps max: a trapezoid
 * of 360 deg takes d/v + v/a = 0.72 + 0.25 = 0.97 s.
 */
static void test_abs_move_time(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_frame f;
	const double t_plan = 360.0 / 500.0 + 500.0 / 2000.0;
	int64_t t0, t_reach = -1;

	(void)state;
	motor_ready(&m, 1, RMD_PROTO_V3);
	for (int i = 0; i < 2; i++) {
		f = REQ(V3, 1, 0x43, KV(INDEX, i), KV(ACCEL, 2000));
		expect_echo(&m, &f, 0x241);
	}
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x42, RMD_FLD_ACCEL), 2000);

	f = REQ(V3, 1, 0xA4, KV(MAX_SPEED, 500), KV(ANGLE, 36000));
	(void)ask(&m, RMD_PROTO_V3, &f, NULL);
	t0 = now;
	for (int ms = 1; ms <= 1500; ms++) {
		int64_t a;

		advance(&m, MS);
		a = angle_cdeg(&m, 1);
		if (ms == 500) {
			/* Cruising at the max speed. */
			assert_true(llabs(speed_dps(&m, 1) - 500) <= 5);
			assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x70, RMD_FLD_MODE), 3);
		}
		if (llabs(a - 36000) <= 20) {
			if (t_reach < 0)
				t_reach = now - t0;
		} else {
			/* Once there, it stays (no overshoot beyond 0.2 deg). */
			assert_true(t_reach < 0);
		}
	}
	assert_true(t_reach > 0);
	print_message("0xA4 360 deg: reached in %.4f s, plan %.4f s\n", (double)t_reach * 1e-9,
		      t_plan);
	assert_true(fabs((double)t_reach * 1e-9 - t_plan) < 0.03);
	assert_true(llabs(angle_cdeg(&m, 1) - 36000) <= 2);
	assert_int_equal(speed_dps(&m, 1), 0);
}

/* ---- (b) torque step ---------------------------------------------------- */

/* V3 §2.17: 0.5 A gives a = (kt i - coulomb - viscous v) / J. */
static void test_torque_step_acceleration(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_sim_motor_params p;
	struct rmd_frame f;
	struct rmd_msg rep;
	double v1, v2, a_meas, a_exp;

	(void)state;
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V3);
	rmd_sim_motor_init(&m, &p, now);
	brake_release(&m, RMD_PROTO_V3, 1);

	f = REQ(V3, 1, 0xA1, KV(CURRENT, 50));
	rep = ask(&m, RMD_PROTO_V3, &f, NULL);
	assert_int_equal(rep.cmd, 0xA1);
	assert_int_equal(rep.v[RMD_FLD_CURRENT], 50);
	advance(&m, 10 * MS);
	v1 = (double)speed_dps(&m, 1) * M_PI / 180.0;
	advance(&m, 40 * MS);
	v2 = (double)speed_dps(&m, 1) * M_PI / 180.0;
	a_meas = (v2 - v1) / 0.040;
	a_exp = (p.kt_nm_a * 0.5 - p.coulomb_nm - p.viscous_nm_s_rad * 0.5 * (v1 + v2)) /
		p.inertia_kgm2;
	print_message("torque step: a = %.2f rad/s^2, expected %.2f\n", a_meas, a_exp);
	assert_true(v2 > v1);
	assert_true(fabs(a_meas - a_exp) < 0.03 * a_exp);
	/* 0x9C reports the current it runs (0.01 A). */
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x9C, RMD_FLD_CURRENT), 50);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x70, RMD_FLD_MODE), 1);
}

/* V3 §2.19, §2.21: direct tracking, 0xA5 within its speed limit (0.01 dps). */
static void test_position_tracking(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_frame f;
	int64_t a;

	(void)state;
	motor_ready(&m, 1, RMD_PROTO_V3);
	f = REQ(V3, 1, 0xA5, KV(MAX_SPEED, 5000), KV(ANGLE, 1000));
	(void)ask(&m, RMD_PROTO_V3, &f, NULL);
	advance(&m, 100 * MS);
	assert_true(llabs(speed_dps(&m, 1) - 50) <= 1);
	a = angle_cdeg(&m, 1);
	assert_true(a > 350 && a < 550);
	advance(&m, 300 * MS);
	assert_true(llabs(angle_cdeg(&m, 1) - 1000) <= 3);
	assert_int_equal(speed_dps(&m, 1), 0);
	/* 0xA3: no limit but the firmware's; a 1 kHz stream is followed closely. */
	for (int ms = 1; ms <= 500; ms++) {
		f = REQ(V3, 1, 0xA3, KV(ANGLE, 1000 + 10 * ms)); /* 100 dps ramp */
		(void)ask(&m, RMD_PROTO_V3, &f, NULL);
		advance(&m, MS);
	}
	assert_true(llabs(speed_dps(&m, 1) - 100) <= 2);
	assert_true(llabs(angle_cdeg(&m, 1) - 6000) <= 150);
	advance(&m, 200 * MS);
	assert_true(llabs(angle_cdeg(&m, 1) - 6000) <= 3);
}

/* Copper loss heats the winding: T = Ta + P Rth (1 - exp(-t / tau)). */
static void test_heating(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_sim_motor_params p;
	struct rmd_frame f;
	double pcu, want;

	(void)state;
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V3);
	p.load_nm = 20.0; /* balances 10 A: the shaft stays, no stall (< 80 %) */
	p.coulomb_nm = 1.0;
	rmd_sim_motor_init(&m, &p, now);
	brake_release(&m, RMD_PROTO_V3, 1);
	f = REQ(V3, 1, 0xA1, KV(CURRENT, 1000));
	(void)ask(&m, RMD_PROTO_V3, &f, NULL);
	advance(&m, 60000 * MS);
	pcu = 1.5 * p.phase_resistance_ohm * 10.0 * 10.0;
	want = p.ambient_c + pcu * p.thermal_resistance_c_w * (1.0 - exp(-60.0 / p.thermal_tau_s));
	assert_true(fabs((double)read_v(&m, RMD_PROTO_V3, 1, 0x9A, RMD_FLD_TEMP) - want) <= 1.0);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x9A, RMD_FLD_ERROR), 0);
	assert_int_equal(speed_dps(&m, 1), 0);
}

/* ---- (c) brake ---------------------------------------------------------- */

static void test_brake_blocks_motion(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_frame f;
	int64_t a;

	(void)state;
	motor_init(&m, 1, RMD_PROTO_V3);
	/* Locked at power-on (V3 §2.27.1, §2.12.3 data[3] = 0). */
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x9A, RMD_FLD_BRAKE), 0);
	f = REQ(V3, 1, 0xA2, KV(SPEED, 10000));
	(void)ask(&m, RMD_PROTO_V3, &f, NULL);
	advance(&m, 300 * MS);
	assert_int_equal(angle_cdeg(&m, 1), 0);
	assert_int_equal(speed_dps(&m, 1), 0);

	brake_release(&m, RMD_PROTO_V3, 1);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x9A, RMD_FLD_BRAKE), 1);
	advance(&m, 500 * MS);
	assert_true(llabs(speed_dps(&m, 1) - 100) <= 1);
	a = angle_cdeg(&m, 1);
	assert_true(a > 4000 && a < 5100); /* ~100 dps for ~0.5 s */

	/* 0x78 locks it again: the shaft stops where it is. */
	f = REQ0(V3, 1, 0x78);
	expect_echo(&m, &f, 0x241);
	a = angle_cdeg(&m, 1);
	advance(&m, 200 * MS);
	assert_int_equal(angle_cdeg(&m, 1), a);
	assert_int_equal(speed_dps(&m, 1), 0);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x9A, RMD_FLD_BRAKE), 0);
}

/* ---- (d) comm-loss protection ------------------------------------------- */

static void test_comm_loss_sequence(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_frame f, out[MAXREP];
	int64_t t_first = -1, t_last = -1, a;
	int f1 = 0;

	(void)state;
	motor_ready(&m, 1, RMD_PROTO_V3);
	f = REQ(V3, 1, 0xA2, KV(SPEED, 10000));
	(void)ask(&m, RMD_PROTO_V3, &f, NULL);
	advance_talking(&m, 1, 200 * MS);
	assert_true(speed_dps(&m, 1) > 90);
	/* V3 §2.30: 100 ms, echoed. */
	f = REQ(V3, 1, 0xB3, KV(TIMEOUT, 100));
	expect_echo(&m, &f, 0x241);

	/* Silence for 3.5 s: trip after 100 ms, then 0xF1 each second. */
	for (int i = 0; i < 350; i++) {
		int n;

		now += 10 * MS;
		n = rmd_sim_motor_poll(&m, now, out, MAXREP);
		for (int k = 0; k < n; k++) {
			static const uint8_t f1_data[8] = { 0xF1 };

			assert_int_equal(out[k].can_id, 0x241);
			assert_memory_equal(out[k].data, f1_data, 8);
			if (t_first < 0)
				t_first = now;
			else
				assert_true(llabs(now - t_last - 1000 * MS) <= 10 * MS);
			t_last = now;
			f1++;
		}
	}
	assert_int_equal(f1, 4); /* at ~0.1, 1.1, 2.1 and 3.1 s */
	assert_true(t_first - (now - 3500 * MS) <= 120 * MS);

	/* The first command after the trip is only echoed, not executed. */
	f = REQ(V3, 1, 0xA2, KV(SPEED, 10000));
	expect_echo(&m, &f, 0x241);
	/* The second executes: status shows the brake locked, no error. */
	f = REQ0(V3, 1, 0x9A);
	{
		struct rmd_msg st = ask(&m, RMD_PROTO_V3, &f, NULL);

		assert_int_equal(st.v[RMD_FLD_BRAKE], 0);
		assert_int_equal(st.v[RMD_FLD_ERROR], 0);
	}
	/* Output off: no motion, mode cleared. */
	a = angle_cdeg(&m, 1);
	advance_talking(&m, 1, 200 * MS);
	assert_int_equal(angle_cdeg(&m, 1), a);
	assert_int_equal(speed_dps(&m, 1), 0);
	assert_int_equal(rmd_sim_motor_poll(&m, now, out, MAXREP), 0);

	/* Normal operation again. */
	brake_release(&m, RMD_PROTO_V3, 1);
	f = REQ(V3, 1, 0xA2, KV(SPEED, 5000));
	(void)ask(&m, RMD_PROTO_V3, &f, NULL);
	advance_talking(&m, 1, 300 * MS);
	assert_true(llabs(speed_dps(&m, 1) - 50) <= 1);
	assert_true(angle_cdeg(&m, 1) > a + 500);
}

/* ---- (e) V2 four-torque frame ------------------------------------------- */

static void test_v2_multi_torque(void **state)
{
	struct rmd_sim_motor m[5];
	struct rmd_frame f, out[MAXREP];
	static const int64_t set[4] = { 125, -250, 375, -500 }; /* 32 A / 2000 LSB */

	(void)state;
	for (int i = 0; i < 5; i++) {
		motor_init(&m[i], (uint8_t)(i + 1), RMD_PROTO_V2);
		brake_release(&m[i], RMD_PROTO_V2, (uint8_t)(i + 1));
	}
	f = REQ(V2, 0, RMD_V2_CMD_MULTI_TORQUE, KV(CURRENT_1, set[0]), KV(CURRENT_2, set[1]),
		KV(CURRENT_3, set[2]), KV(CURRENT_4, set[3]));
	assert_int_equal(f.can_id, RMD_CAN_MULTI);
	for (int i = 0; i < 5; i++) {
		struct rmd_msg rep;
		double want_a = (double)(i < 4 ? set[i] : 0) * 32.0 / 2000.0;

		if (i == 4) {
			/* V2 §4.1: motors 1..4 only. */
			assert_int_equal(send(&m[i], &f, out), 0);
			continue;
		}
		assert_int_equal(send(&m[i], &f, out), 1);
		/* V2 §4.2: on 0x140 + ID, like the 0xA1 reply. */
		assert_int_equal(out[0].can_id, 0x141 + (uint32_t)i);
		assert_int_equal(rmd_decode(RMD_PROTO_V2, RMD_DIR_REPLY, &out[0], &rep, NULL), 0);
		assert_int_equal(rep.cmd, 0xA1);
		assert_true(fabs((double)rep.v[RMD_FLD_CURRENT] * 33.0 / 2048.0 - want_a) <
			    33.0 / 2048.0);
	}
	now += 100 * MS;
	for (int i = 0; i < 5; i++) {
		int64_t v;

		rmd_sim_motor_step(&m[i], now);
		v = read_v(&m[i], RMD_PROTO_V2, (uint8_t)(i + 1), 0x9C, RMD_FLD_SPEED);
		if (i == 4)
			assert_int_equal(v, 0);
		else
			assert_true(set[i] > 0 ? v > 100 : v < -100);
	}
}

/* ---- (f) MIT ------------------------------------------------------------ */

static void test_mit_pd_law(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_sim_motor_params p;
	const struct rmd_mit_ranges *r = &rmd_mit_default_ranges;
	struct rmd_mit_cmd cmd = {
		.p_des_rad = 1.0, .v_des_rad_s = 0.0, .kp = 20.0, .kd = 1.0, .t_ff_nm = 0.5
	};
	struct rmd_mit_cmd q;
	struct rmd_frame f, out[MAXREP];
	struct rmd_mit_reply rep;
	uint8_t id;
	double tol, lsb_t = (r->t_max - r->t_min) / 4095.0;

	(void)state;
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_MIT);
	rmd_sim_motor_init(&m, &p, now);
	brake_release(&m, RMD_PROTO_V3, 1);
	assert_int_equal(rmd_mit_encode_cmd(r, 1, &cmd, &f), 0);
	/* What the motor hears is the quantised command. */
	assert_int_equal(rmd_mit_decode_cmd(r, &f, &id, &q), 0);
	tol = lsb_t + q.kp * (r->p_max - r->p_min) / 65535.0 +
	      q.kd * (r->v_max - r->v_min) / 4095.0;
	for (int ms = 0; ms < 1000; ms++) {
		double t_law;

		assert_int_equal(send(&m, &f, out), 1);
		assert_int_equal(out[0].can_id, 0x501);
		assert_int_equal(rmd_mit_decode_reply(r, &out[0], &rep), 0);
		assert_int_equal(rep.motor_id, 1);
		t_law = q.kp * (q.p_des_rad - rep.pos_rad) +
			q.kd * (q.v_des_rad_s - rep.vel_rad_s) + q.t_ff_nm;
		if (fabs(rep.torque_nm - t_law) > tol)
			fail_msg("MIT at %d ms: torque %.4f, law %.4f (p %.4f v %.4f)", ms,
				 rep.torque_nm, t_law, rep.pos_rad, rep.vel_rad_s);
		advance(&m, MS);
	}
	/* At rest where the spring balances t_ff (within the Coulomb band). */
	assert_true(fabs(rep.pos_rad - (q.p_des_rad + q.t_ff_nm / q.kp)) <
		    p.coulomb_nm / q.kp + 0.002);
	/* MIT motors speak V3 too. */
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x70, RMD_FLD_MODE), 1);
}

/*
 * Issue 33.5: V3 and V4 firmware take MIT frames (V3 §5, V4.2 §5), scaled
 * as their firmware says: the manual's preset, and from firmware
 * 2026042402 (V4.4) the model's own (X6: p ±12.566 rad, t ±60 N·m, kd
 * 0..50; docs/protocol-v4.md).  The preset's frame of t 10 N·m is 25 N·m
 * to an X6 of V4.4.
 */
static void test_mit_scaling_by_firmware(void **state)
{
	static const struct rmd_mit_ranges x6 = { -12.566, 12.566, -45, 45, -60, 60, 0, 500, 0, 50 };
	static const struct {
		enum rmd_proto proto;
		uint32_t version;
		const char *model;
		const struct rmd_mit_ranges *scale; /* NULL: the preset (V3 §5.1) */
	} rows[] = {
		{ RMD_PROTO_V3, 20220206, "X8S2V10", NULL },
		{ RMD_PROTO_V4, 2025070202, "X6S2V3", NULL },
		{ RMD_PROTO_V4, 2026042402, "X6S2V3", &x6 },
		{ RMD_PROTO_V4, 2026042402, "X4-36", NULL }, /* a model of no V4.4 row: as set */
	};
	struct rmd_mit_cmd cmd = { .p_des_rad = 2.0, .kd = 1.0, .t_ff_nm = 10.0 };

	(void)state;
	for (size_t i = 0; i < sizeof(rows) / sizeof(rows[0]); i++) {
		const struct rmd_mit_ranges *r = rows[i].scale ? rows[i].scale :
								 &rmd_mit_default_ranges;
		struct rmd_sim_motor_params p;
		struct rmd_sim_motor m;
		struct rmd_frame f, out[MAXREP];
		struct rmd_mit_reply rep;

		rmd_sim_motor_params_default(&p, 1, rows[i].proto);
		p.version_date = rows[i].version;
		snprintf(p.model, sizeof(p.model), "%s", rows[i].model);
		rmd_sim_motor_init(&m, &p, now);
		brake_release(&m, rows[i].proto, 1);
		assert_int_equal(rmd_mit_encode_cmd(r, 1, &cmd, &f), 0);
		assert_int_equal(send(&m, &f, out), 1);
		assert_int_equal(m.ctrl, RMD_SIM_MIT);
		if (fabs(m.mit.t_ff_nm - 10.0) > (r->t_max - r->t_min) / 4095 ||
		    fabs(m.mit.p_des_rad - 2.0) > (r->p_max - r->p_min) / 65535 ||
		    fabs(m.mit.kd - 1.0) > (r->kd_max - r->kd_min) / 4095)
			fail_msg("row %zu: the motor took p %g kd %g t %g", i, m.mit.p_des_rad,
				 m.mit.kd, m.mit.t_ff_nm);
		/* its reply is on the same scale */
		assert_int_equal(out[0].can_id, 0x501);
		assert_int_equal(rmd_mit_decode_reply(r, &out[0], &rep), 0);
		assert_true(fabs(rep.torque_nm - m.p.kt_nm_a * m.iq_a) <=
			    (r->t_max - r->t_min) / 4095);
	}
}

/* ---- (g) power cycle ---------------------------------------------------- */

static void test_power_cycle_ram_rom(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_frame f, out[MAXREP];
	int64_t off = 10923; /* 10 deg: 65536 counts x 6 per output turn */
	int64_t a;
	int f1 = 0;

	(void)state;
	motor_ready(&m, 1, RMD_PROTO_V3);
	f = REQ(V3, 1, 0xA4, KV(MAX_SPEED, 720), KV(ANGLE, 100000));
	(void)ask(&m, RMD_PROTO_V3, &f, NULL);
	advance(&m, 2000 * MS);
	assert_true(llabs(angle_cdeg(&m, 1) - 100000) <= 2);
	/* 0x60 = 0x61 - 0x62, counts of the motor-side encoder. */
	assert_true(llabs(read_v(&m, RMD_PROTO_V3, 1, 0x60, RMD_FLD_ENCODER) -
			  INT64_C(100000) * 393216 / 36000) <= 3);

	/* ROM: zero offset (V3 §2.9), comm-loss time (§2.30), gains (§2.3). */
	f = REQ(V3, 1, 0x63, KV(ENCODER_OFF, off));
	expect_echo(&m, &f, 0x241);
	f = REQ(V3, 1, 0xB3, KV(TIMEOUT, 300));
	expect_echo(&m, &f, 0x241);
	f = REQ(V3, 1, 0x32, KV(CURR_KP, 90), KV(CURR_KI, 30), KV(SPD_KP, 90), KV(SPD_KI, 30),
		KV(POS_KP, 90), KV(POS_KI, 30));
	expect_echo(&m, &f, 0x241);
	/* RAM: other gains (§2.2), lost at power-off. */
	f = REQ(V3, 1, 0x31, KV(CURR_KP, 70), KV(CURR_KI, 20), KV(SPD_KP, 70), KV(SPD_KI, 20),
		KV(POS_KP, 70), KV(POS_KI, 20));
	expect_echo(&m, &f, 0x241);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x30, RMD_FLD_SPD_KP), 70);
	/* The new zero applies only after a restart (§2.9.1). */
	assert_true(llabs(angle_cdeg(&m, 1) - 100000) <= 2);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x62, RMD_FLD_ENCODER_OFF), 0);

	rmd_sim_motor_power_cycle(&m, now);
	/* 1000 deg - 10 deg wraps to -90 deg. */
	a = angle_cdeg(&m, 1);
	assert_true(llabs(a - -9000) <= 1);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x62, RMD_FLD_ENCODER_OFF), off);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x30, RMD_FLD_SPD_KP), 90);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x30, RMD_FLD_POS_KI), 30);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x9A, RMD_FLD_BRAKE), 0);
	assert_true(read_v(&m, RMD_PROTO_V3, 1, 0xB1, RMD_FLD_RUNTIME) < 5);
	/* 0xB3 survived: silence trips the protection. */
	for (int i = 0; i < 50; i++) {
		now += 10 * MS;
		f1 += rmd_sim_motor_poll(&m, now, out, MAXREP);
	}
	assert_int_equal(f1, 1);
	f = REQ0(V3, 1, 0x9C);
	expect_echo(&m, &f, 0x241);

	/* 0x20 index 4 keeps the multi-turn value over a power cycle... */
	brake_release(&m, RMD_PROTO_V3, 1);
	f = REQ(V3, 1, 0xB3, KV(TIMEOUT, 0));
	expect_echo(&m, &f, 0x241);
	f = REQ(V3, 1, 0xA4, KV(MAX_SPEED, 720), KV(ANGLE, 72000));
	(void)ask(&m, RMD_PROTO_V3, &f, NULL);
	advance(&m, 2000 * MS);
	assert_true(llabs(angle_cdeg(&m, 1) - 72000) <= 2);
	f = REQ(V3, 1, 0x20, KV(INDEX, 4), KV(VALUE, 1));
	expect_echo(&m, &f, 0x241);
	rmd_sim_motor_power_cycle(&m, now);
	assert_true(llabs(angle_cdeg(&m, 1) - 72000) <= 2);
	/* ... unless index 1 asked to clear it at the next start. */
	f = REQ(V3, 1, 0x20, KV(INDEX, 1), KV(VALUE, 0));
	expect_echo(&m, &f, 0x241);
	assert_true(llabs(angle_cdeg(&m, 1) - 72000) <= 2);
	/* 0x76 resets without a reply, and RAM goes (V3 §2.25). */
	f = REQ0(V3, 1, 0x76);
	expect_silence(&m, &f);
	assert_true(llabs(angle_cdeg(&m, 1) - 0) <= 2); /* 720 deg wraps to 0 */
	f = REQ(V3, 1, 0x31, KV(CURR_KP, 1), KV(CURR_KI, 2), KV(SPD_KP, 3), KV(SPD_KI, 4),
		KV(POS_KP, 5), KV(POS_KI, 6));
	expect_echo(&m, &f, 0x241);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x30, RMD_FLD_POS_KI), 6);
	f = REQ0(V3, 1, 0x76);
	expect_silence(&m, &f);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x30, RMD_FLD_POS_KI), 30);
}

/*
 * The firmware's boot (rmd_sim_motor_params.boot_ms): after power returns
 * or a 0x76 reset the motor hears and says nothing for boot_ms -- a motion
 * command meanwhile is not executed -- then answers, its runtime (0xB1,
 * V3 §2.28) counted from the power's return, its brake locked and its
 * multi-turn count wrapped.  With 0 it answers at once.
 */
static void test_boot_time(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_sim_motor_params p;
	struct rmd_frame f;
	int64_t t_on;

	(void)state;
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V3);
	p.boot_ms = 1100;
	p.start_angle_deg = 400.0;
	rmd_sim_motor_init(&m, &p, now);
	/* the first power-on was before: it answers at once, its runtime from now */
	assert_true(read_v(&m, RMD_PROTO_V3, 1, 0xB1, RMD_FLD_RUNTIME) < 2);
	advance(&m, 3000 * MS);
	assert_true(llabs(read_v(&m, RMD_PROTO_V3, 1, 0xB1, RMD_FLD_RUNTIME) - 3000) <= 1);
	brake_release(&m, RMD_PROTO_V3, 1);

	rmd_sim_motor_power_cycle(&m, now);
	t_on = now;
	f = REQ(V3, 1, 0xA4, KV(MAX_SPEED, 720), KV(ANGLE, 40000));
	for (int k = 0; k < 109; k++) {
		expect_silence(&m, &f);
		advance(&m, 10 * MS);
	}
	/* not executed: at rest where the boot left it */
	assert_true(fabs(m.vel_rad_s) < 1e-9);
	advance(&m, 10 * MS);
	assert_true(now - t_on >= 1100 * MS);
	/* up: 400 deg wrapped to 40, its runtime since the power returned, its brake locked */
	assert_true(llabs(angle_cdeg(&m, 1) - 4000) <= 1);
	assert_true(llabs(read_v(&m, RMD_PROTO_V3, 1, 0xB1, RMD_FLD_RUNTIME) - 1100) <= 1);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x9A, RMD_FLD_BRAKE), 0);

	/* 0x76 boots as long */
	f = REQ0(V3, 1, 0x76);
	expect_silence(&m, &f);
	t_on = now;
	advance(&m, 1000 * MS);
	f = REQ0(V3, 1, 0x9C);
	expect_silence(&m, &f);
	advance(&m, 100 * MS);
	assert_true(llabs(read_v(&m, RMD_PROTO_V3, 1, 0xB1, RMD_FLD_RUNTIME) - (now - t_on) / MS) <=
		    1);

	/* boot_ms 0: at once, its runtime from 0 again */
	m.p.boot_ms = 0;
	advance(&m, 500 * MS);
	rmd_sim_motor_power_cycle(&m, now);
	assert_true(read_v(&m, RMD_PROTO_V3, 1, 0xB1, RMD_FLD_RUNTIME) < 2);
}

/* ---- (h) CAN ID filter and 0x300 ---------------------------------------- */

static void test_can_filter(void **state)
{
	struct rmd_sim_motor m1, m2;
	struct rmd_frame f, bc, rd, out[MAXREP];
	struct rmd_msg rep;

	(void)state;
	motor_init(&m1, 1, RMD_PROTO_V3);
	motor_init(&m2, 2, RMD_PROTO_V3);
	bc = REQ0(V3, 0, 0x9A);
	assert_int_equal(bc.can_id, RMD_CAN_MULTI);
	rd = REQ(V3, 1, 0x79, KV(READ_FLAG, 1), KV(CAN_ID, 0));
	assert_int_equal(rd.can_id, RMD_CAN_SET_ID);

	/* V3 §3: each motor answers the broadcast on its own reply identifier. */
	assert_int_equal(send(&m1, &bc, out), 1);
	assert_int_equal(out[0].can_id, 0x241);
	assert_int_equal(send(&m2, &bc, out), 1);
	assert_int_equal(out[0].can_id, 0x242);
	/* V3 §4.4 example 2: the read answers 0x240 + ID on 0x300. */
	rep = ask(&m1, RMD_PROTO_V3, &rd, &out[0]);
	assert_int_equal(out[0].can_id, RMD_CAN_SET_ID);
	assert_int_equal(rep.v[RMD_FLD_CAN_ID], 0x241);

	/* V3 §2.33.4 index 2: filter on, 0x280 and 0x300 no longer reach it. */
	f = REQ(V3, 1, 0x20, KV(INDEX, 2), KV(VALUE, 1));
	expect_echo(&m1, &f, 0x241);
	expect_silence(&m1, &bc);
	expect_silence(&m1, &rd);
	assert_int_equal(send(&m2, &bc, out), 1);
	/* Saved in flash. */
	rmd_sim_motor_power_cycle(&m1, now);
	expect_silence(&m1, &bc);
	(void)read_v(&m1, RMD_PROTO_V3, 1, 0x9A, RMD_FLD_ERROR);
	f = REQ(V3, 1, 0x20, KV(INDEX, 2), KV(VALUE, 0));
	expect_echo(&m1, &f, 0x241);
	assert_int_equal(send(&m1, &bc, out), 1);

	/* V3 §4: 0x300 write sets the ID, echoed; the motor then answers as #5. */
	f = REQ(V3, 2, 0x79, KV(READ_FLAG, 0), KV(CAN_ID, 5));
	expect_echo(&m2, &f, RMD_CAN_SET_ID);
	f = REQ0(V3, 2, 0x9C);
	expect_silence(&m2, &f);
	assert_int_equal(read_v(&m2, RMD_PROTO_V3, 5, 0x9A, RMD_FLD_ERROR), 0);
	rep = ask(&m2, RMD_PROTO_V3, &rd, NULL);
	assert_int_equal(rep.v[RMD_FLD_CAN_ID], 0x245);
}

/* ---- (i) error reports and faults --------------------------------------- */

static int count_reports(struct rmd_sim_motor *m, int64_t ns, int64_t *first, uint16_t bits)
{
	struct rmd_frame out[MAXREP];
	int64_t last = -1;
	int count = 0;

	for (int64_t end = now + ns; now < end;) {
		int n;

		now += 10 * MS;
		n = rmd_sim_motor_poll(m, now, out, MAXREP);
		for (int k = 0; k < n; k++) {
			struct rmd_msg rep;

			assert_int_equal(
				rmd_decode(RMD_PROTO_V3, RMD_DIR_REPLY, &out[k], &rep, NULL), 0);
			assert_int_equal(rep.cmd, 0x9A);
			assert_int_equal(out[k].can_id, 0x241);
			assert_true((rep.v[RMD_FLD_ERROR] & bits) == bits);
			/* 100 ms apart, as seen by a 10 ms poll. */
			if (last >= 0)
				assert_true(llabs(now - last - 100 * MS) <= 10 * MS);
			else if (first)
				*first = now;
			last = now;
			count++;
		}
	}
	return count;
}

static void test_error_reports(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_sim_motor_params p;
	struct rmd_frame f;
	int64_t t_inject, first = -1;

	(void)state;
	motor_init(&m, 1, RMD_PROTO_V3);
	/* Faulted but reports not enabled: silent. */
	rmd_sim_motor_set_error(&m, RMD_SIM_ERR_OVER_TEMP);
	assert_int_equal(count_reports(&m, 500 * MS, NULL, 0), 0);
	rmd_sim_motor_set_error(&m, 0);
	/* V3 §2.33.4 index 3. */
	f = REQ(V3, 1, 0x20, KV(INDEX, 3), KV(VALUE, 1));
	expect_echo(&m, &f, 0x241);
	assert_int_equal(count_reports(&m, 500 * MS, NULL, 0), 0);
	rmd_sim_motor_set_error(&m, RMD_SIM_ERR_OVER_TEMP);
	t_inject = now;
	assert_int_equal(count_reports(&m, 950 * MS, &first, RMD_SIM_ERR_OVER_TEMP), 10);
	assert_true(first - t_inject <= 10 * MS);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x9A, RMD_FLD_ERROR), RMD_SIM_ERR_OVER_TEMP);
	/* Cleared: the reports stop. */
	rmd_sim_motor_set_error(&m, 0);
	assert_int_equal(count_reports(&m, 500 * MS, NULL, 0), 0);

	/* A real over-temperature: ambient 90 degC, above the 80 degC limit. */
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V3);
	p.ambient_c = 90.0;
	rmd_sim_motor_init(&m, &p, now);
	advance(&m, MS);
	f = REQ0(V3, 1, 0x9A);
	{
		struct rmd_msg st = ask(&m, RMD_PROTO_V3, &f, NULL);

		assert_int_equal(st.v[RMD_FLD_TEMP], 90);
		assert_int_equal(st.v[RMD_FLD_ERROR], RMD_SIM_ERR_OVER_TEMP);
	}
	/* V3 §2.17.1: no control command runs while faulted. */
	brake_release(&m, RMD_PROTO_V3, 1);
	f = REQ(V3, 1, 0xA2, KV(SPEED, 10000));
	(void)ask(&m, RMD_PROTO_V3, &f, NULL);
	advance(&m, 200 * MS);
	assert_int_equal(speed_dps(&m, 1), 0);
	f = REQ(V3, 1, 0x20, KV(INDEX, 3), KV(VALUE, 1));
	expect_echo(&m, &f, 0x241);
	assert_int_equal(count_reports(&m, 250 * MS, NULL, RMD_SIM_ERR_OVER_TEMP), 3);

	/* Low voltage (V3 §2.12.4 example: 0x0004), a level-2 fault. */
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V3);
	p.supply_v = 20.0;
	rmd_sim_motor_init(&m, &p, now);
	advance(&m, MS);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x9A, RMD_FLD_ERROR), RMD_SIM_ERR_LOW_VOLTAGE);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x9A, RMD_FLD_VOLTAGE), 200);
}

/* Stall (V3 §8.2, level 1): torque against a load it cannot move, > 1 s. */
static void test_stall_latches(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_sim_motor_params p;
	struct rmd_frame f;

	(void)state;
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V3);
	p.load_nm = 100.0;    /* beyond kt * max current: the shaft would back-drive */
	p.coulomb_nm = 200.0; /* ... but static friction holds it */
	rmd_sim_motor_init(&m, &p, now);
	brake_release(&m, RMD_PROTO_V3, 1);
	f = REQ(V3, 1, 0xA1, KV(CURRENT, 1900));
	(void)ask(&m, RMD_PROTO_V3, &f, NULL);
	advance(&m, 900 * MS);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x9A, RMD_FLD_ERROR), 0);
	advance(&m, 200 * MS);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x9A, RMD_FLD_ERROR), RMD_SIM_ERR_STALL);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x9C, RMD_FLD_CURRENT), 0);
	/* Latched: even 0x80 does not clear it; a restart does. */
	f = REQ0(V3, 1, 0x80);
	expect_echo(&m, &f, 0x241);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x9A, RMD_FLD_ERROR), RMD_SIM_ERR_STALL);
	rmd_sim_motor_power_cycle(&m, now);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x9A, RMD_FLD_ERROR), 0);
}

/* ---- (j) garbage -------------------------------------------------------- */

static uint64_t rng_state;

static uint64_t rng(void)
{
	uint64_t z = (rng_state += UINT64_C(0x9E3779B97F4A7C15));

	z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
	z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
	return z ^ (z >> 31);
}

static void test_garbage_no_reply(void **state)
{
	struct rmd_sim_motor v3, v2, mit, v4;
	struct rmd_frame f;

	(void)state;
	motor_init(&v3, 1, RMD_PROTO_V3);
	motor_init(&v2, 1, RMD_PROTO_V2);
	motor_init(&mit, 1, RMD_PROTO_MIT);
	motor_init(&v4, 1, RMD_PROTO_V4);

	/* Wrong DLC. */
	f = REQ0(V3, 1, 0x9C);
	for (uint8_t len = 0; len < 16; len++) {
		if (len == RMD_FRAME_LEN)
			continue;
		f.len = len;
		expect_silence(&v3, &f);
		expect_silence(&v2, &f);
	}
	/* Unknown command bytes (V3 has no 0x88, 0x94, 0xA6 or 0xA7). */
	static const uint8_t unknown_v3[] = { 0x00, 0x01, 0x19, 0x88, 0x94, 0xA6, 0xA7, 0xFF };
	for (size_t i = 0; i < sizeof(unknown_v3); i++) {
		f = (struct rmd_frame){ .can_id = 0x141, .len = 8, .data = { unknown_v3[i] } };
		expect_silence(&v3, &f);
		expect_silence(&mit, &f);
	}
	/* V4.2 §9: no 0xA3, 0xA5; no 0x71 */
	static const uint8_t unknown_v4[] = { 0x00, 0x71, 0x88, 0xA3, 0xA5, 0xA7, 0xFF };
	for (size_t i = 0; i < sizeof(unknown_v4); i++) {
		f = (struct rmd_frame){ .can_id = 0x141, .len = 8, .data = { unknown_v4[i] } };
		expect_silence(&v4, &f);
	}
	static const uint8_t unknown_v2[] = { 0x00, 0x20, 0xB1, 0xB3, 0xB5, 0xFF };
	for (size_t i = 0; i < sizeof(unknown_v2); i++) {
		f = (struct rmd_frame){ .can_id = 0x141, .len = 8, .data = { unknown_v2[i] } };
		expect_silence(&v2, &f);
	}
	/*
	 * Identifiers not addressed to motor 1 (or not requests); 0x401 is
	 * addressed to V3 firmware too (V3 §5: it takes MIT frames), not V2.
	 */
	static const uint32_t ids[] = { 0x140, 0x142, 0x160, 0x241, 0x501, 0x401, 0x7FF, 0 };
	for (size_t i = 0; i < sizeof(ids) / sizeof(ids[0]); i++) {
		f = (struct rmd_frame){ .can_id = ids[i], .len = 8, .data = { 0x9C } };
		expect_silence(&v2, &f);
		if (ids[i] != 0x401) {
			expect_silence(&v3, &f);
			expect_silence(&mit, &f);
		}
	}
	/* 0x300 carries 0x79 only (V3 §4); V2 has no 0x300 at all. */
	f = (struct rmd_frame){ .can_id = 0x300, .len = 8, .data = { 0x9C } };
	expect_silence(&v3, &f);
	f = (struct rmd_frame){ .can_id = 0x300, .len = 8, .data = { 0x79, 0, 1 } };
	expect_silence(&v2, &f);
	/* 0x79 on 0x141 is not how V3 sets IDs. */
	f = (struct rmd_frame){ .can_id = 0x141, .len = 8, .data = { 0x79, 0, 1 } };
	expect_silence(&v3, &f);

	/* Random frames: never a crash, replies only on the motor's own ids. */
	rng_state = seed;
	for (int i = 0; i < 200000; i++) {
		struct rmd_sim_motor *m = i % 4 == 0 ? &v3 :
					  i % 4 == 1 ? &v2 :
					  i % 4 == 2 ? &mit :
						       &v4;
		static const uint32_t pick[] = { 0x141, 0x280, 0x300, 0x401, 0x142, 0x241 };
		struct rmd_frame out[MAXREP];
		uint64_t r = rng();
		int n;

		f.can_id = (r & 7) < 6 ? pick[r & 7] : (uint32_t)(r >> 8) & 0x7FF;
		f.len = (r >> 20) & 15 ? 8 : (uint8_t)((r >> 24) & 15);
		r = rng();
		memcpy(f.data, &r, 8);
		if (i % 4 == 0)
			f.data[0] = (uint8_t)(0xA0 + (r >> 60)); /* motion commands often */
		now += (int64_t)(rng() % (2 * MS));
		n = rmd_sim_motor_receive(m, now, &f, out, MAXREP);
		if (n < 0 || n > 1)
			fail_msg("random frame #%d: %d replies (RMD_TEST_SEED=%llu)", i, n,
				 (unsigned long long)seed);
		n = rmd_sim_motor_poll(m, now, out, MAXREP);
		if (n < 0 || n > MAXREP)
			fail_msg("random frame #%d: poll %d (RMD_TEST_SEED=%llu)", i, n,
				 (unsigned long long)seed);
	}
	/* Null and zero-room calls are harmless too. */
	f = REQ0(V3, 1, 0x9C);
	assert_int_equal(rmd_sim_motor_receive(&v3, now, NULL, NULL, 0), 0);
	assert_int_equal(rmd_sim_motor_poll(NULL, now, NULL, 0), 0);
}

/* ---- more commands ------------------------------------------------------ */

static void test_reads_and_identity(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_frame f, raw;
	struct rmd_msg rep;
	char model[8];

	(void)state;
	motor_init(&m, 3, RMD_PROTO_V3);
	/* V3 §2.32.4: "X8S2V10". */
	rmd_model_string(read_v(&m, RMD_PROTO_V3, 3, 0xB5, RMD_FLD_MODEL), model);
	assert_string_equal(model, "X8S2V10");
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 3, 0xB2, RMD_FLD_VERSION), 20220206);
	advance(&m, 1234 * MS);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 3, 0xB1, RMD_FLD_RUNTIME), 1234);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 3, 0x9A, RMD_FLD_VOLTAGE), 480);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 3, 0x9A, RMD_FLD_TEMP), 25);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 3, 0x70, RMD_FLD_MODE), 0);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 3, 0x71, RMD_FLD_POWER), 0);
	rep = ask(&m, RMD_PROTO_V3,
		  &(struct rmd_frame){ .can_id = 0x143, .len = 8, .data = { 0x30 } }, &raw);
	assert_int_equal(raw.can_id, 0x243);
	assert_int_equal(rep.v[RMD_FLD_CURR_KP], 0x55); /* V3 §2.1.4 */
	/* 0x43 index 2 limits speed-mode acceleration (V3 §2.5.4). */
	brake_release(&m, RMD_PROTO_V3, 3);
	f = REQ(V3, 3, 0x43, KV(INDEX, 2), KV(ACCEL, 1000));
	expect_echo(&m, &f, 0x243);
	f = REQ(V3, 3, 0xA2, KV(SPEED, 50000));
	(void)ask(&m, RMD_PROTO_V3, &f, NULL);
	advance(&m, 200 * MS);
	assert_true(llabs(speed_dps(&m, 3) - 200) <= 10);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 3, 0x70, RMD_FLD_MODE), 2);
	assert_true(read_v(&m, RMD_PROTO_V3, 3, 0x71, RMD_FLD_POWER) > 0);
	/* 0x81 stops and holds; 0x80 turns the output off. */
	f = REQ0(V3, 3, 0x81);
	expect_echo(&m, &f, 0x243);
	advance(&m, 300 * MS);
	assert_int_equal(speed_dps(&m, 3), 0);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 3, 0x70, RMD_FLD_MODE), 3);
	f = REQ0(V3, 3, 0x80);
	expect_echo(&m, &f, 0x243);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 3, 0x70, RMD_FLD_MODE), 0);
	/* 0xB4: noise or nothing (V3 §2.31.3), never a crash. */
	f = REQ(V3, 3, 0xB4, KV(BAUD, 1));
	for (int i = 0; i < 8; i++) {
		struct rmd_frame out[MAXREP];
		int n = send(&m, &f, out);

		assert_true(n == 0 || (n == 1 && out[0].can_id == 0x243));
	}
}

static void test_v2_commands(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_frame f;
	int64_t e;

	(void)state;
	motor_ready(&m, 2, RMD_PROTO_V2);
	/* V2 §3.40: 0xA4 to 90 deg. */
	f = REQ(V2, 2, 0xA4, KV(MAX_SPEED, 360), KV(ANGLE, 9000));
	{
		struct rmd_msg rep = ask(&m, RMD_PROTO_V2, &f, NULL);

		assert_int_equal(rep.cmd, 0xA4);
		assert_true(rmd_msg_has(&rep, RMD_FLD_ENCODER));
	}
	advance(&m, 1000 * MS);
	assert_true(llabs(read_v(&m, RMD_PROTO_V2, 2, 0x92, RMD_FLD_ANGLE) - 9000) <= 2);
	assert_true(llabs(read_v(&m, RMD_PROTO_V2, 2, 0x94, RMD_FLD_ANGLE) - 9000) <= 2);
	/* V2 §3.32: the single-turn encoder counts a motor turn: 90 deg x 6 = 1.5 turns. */
	e = read_v(&m, RMD_PROTO_V2, 2, 0x9C, RMD_FLD_ENCODER);
	assert_true(llabs(e - 32768) <= 8);
	assert_int_equal(read_v(&m, RMD_PROTO_V2, 2, 0x70, RMD_FLD_MODE), 2);
	/* V2 §3.41: single-turn 0xA5, counter-clockwise to 0 deg: back down. */
	f = REQ(V2, 2, 0xA5, KV(SPIN_DIR, 1), KV(ANGLE, 0));
	(void)ask(&m, RMD_PROTO_V2, &f, NULL);
	advance(&m, 1000 * MS);
	assert_true(llabs(read_v(&m, RMD_PROTO_V2, 2, 0x92, RMD_FLD_ANGLE)) <= 2);
	/* Clockwise to 0 deg: a whole turn up. */
	f = REQ(V2, 2, 0xA6, KV(SPIN_DIR, 0), KV(MAX_SPEED, 720), KV(ANGLE, 35000));
	(void)ask(&m, RMD_PROTO_V2, &f, NULL);
	advance(&m, 1500 * MS);
	assert_true(llabs(read_v(&m, RMD_PROTO_V2, 2, 0x92, RMD_FLD_ANGLE) - 35000) <= 2);
	/* V2 §3.43: increment. */
	f = REQ(V2, 2, 0xA7, KV(ANGLE, -5000));
	(void)ask(&m, RMD_PROTO_V2, &f, NULL);
	advance(&m, 1000 * MS);
	assert_true(llabs(read_v(&m, RMD_PROTO_V2, 2, 0x92, RMD_FLD_ANGLE) - 30000) <= 2);

	/* V2 §3.35/§3.36: 0x81 stops a speed run, 0x88 resumes it. */
	f = REQ(V2, 2, 0xA2, KV(SPEED, 9000));
	(void)ask(&m, RMD_PROTO_V2, &f, NULL);
	advance(&m, 300 * MS);
	assert_true(llabs(read_v(&m, RMD_PROTO_V2, 2, 0x9C, RMD_FLD_SPEED) - 90) <= 1);
	f = REQ0(V2, 2, 0x81);
	expect_echo(&m, &f, 0x142);
	advance(&m, 300 * MS);
	assert_int_equal(read_v(&m, RMD_PROTO_V2, 2, 0x9C, RMD_FLD_SPEED), 0);
	f = REQ0(V2, 2, 0x88);
	expect_echo(&m, &f, 0x142);
	advance(&m, 300 * MS);
	assert_true(llabs(read_v(&m, RMD_PROTO_V2, 2, 0x9C, RMD_FLD_SPEED) - 90) <= 1);
	f = REQ0(V2, 2, 0x80);
	expect_echo(&m, &f, 0x142);
	assert_int_equal(read_v(&m, RMD_PROTO_V2, 2, 0x70, RMD_FLD_MODE), 0xFF);

	/* V2 §3.20: one acceleration, RAM; §3.19 reads it. */
	f = REQ(V2, 2, 0x43, KV(ACCEL, 5000));
	expect_echo(&m, &f, 0x142);
	assert_int_equal(read_v(&m, RMD_PROTO_V2, 2, 0x42, RMD_FLD_ACCEL), 5000);
	/* V2 §3.7, §3.1: Q24 gains. */
	f = REQ(V2, 2, 0x38, KV(SPD_KP, 1 << 21));
	expect_echo(&m, &f, 0x142);
	assert_int_equal(read_v(&m, RMD_PROTO_V2, 2, 0x32, RMD_FLD_SPD_KP), 1 << 21);
	/* V2 §3.52: ID read on 0x140 + ID. */
	f = REQ(V2, 2, 0x79, KV(READ_FLAG, 1), KV(CAN_ID, 0));
	{
		struct rmd_msg rep = ask(&m, RMD_PROTO_V2, &f, NULL);

		assert_int_equal(rep.v[RMD_FLD_CAN_ID], 2);
	}
	/* V2 §3.21: negative multi-turn values as 56-bit two's complement. */
	f = REQ(V2, 2, 0xA4, KV(MAX_SPEED, 720), KV(ANGLE, -9000));
	(void)ask(&m, RMD_PROTO_V2, &f, NULL);
	advance(&m, 2000 * MS);
	assert_true(llabs(read_v(&m, RMD_PROTO_V2, 2, 0x92, RMD_FLD_ANGLE) + 9000) <= 2);
	assert_true(llabs(read_v(&m, RMD_PROTO_V2, 2, 0x60, RMD_FLD_ENCODER) + 98304) <= 3);
	/* V2 §3.49: 0x76 echoes, then resets. */
	f = REQ0(V2, 2, 0x76);
	expect_echo(&m, &f, 0x142);
	assert_int_equal(read_v(&m, RMD_PROTO_V2, 2, 0x42, RMD_FLD_ACCEL), 10000);
}

/* Same seed, same jitter; the turnaround stays within mean +- jitter. */
static void test_deterministic_jitter(void **state)
{
	struct rmd_sim_motor a, b;

	(void)state;
	motor_init(&a, 4, RMD_PROTO_V3);
	motor_init(&b, 4, RMD_PROTO_V3);
	for (int i = 0; i < 1000; i++) {
		int64_t ta = rmd_sim_motor_turnaround_ns(&a);

		assert_int_equal(ta, rmd_sim_motor_turnaround_ns(&b));
		assert_true(ta >= 400000 && ta <= 600000);
	}
	rmd_sim_motor_seed(&b, 99);
	rmd_sim_motor_seed(&a, 99);
	assert_int_equal(rmd_sim_motor_rand(&a), rmd_sim_motor_rand(&b));
}

/*
 * Replies leave in the order of their requests, whatever the jitter: a
 * request every 1 ms to a motor that takes 2..10 ms.  Each reply is due a
 * turnaround after its request at the earliest, never before the previous
 * one, and the jitter really would have reordered some.
 */
static void test_replies_in_order(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_frame f = REQ0(V3, 1, 0x9A);
	int64_t prev = 0;
	unsigned held = 0;

	(void)state;
	motor_init(&m, 1, RMD_PROTO_V3);
	m.p.turnaround_ns = 6e6;
	m.p.turnaround_jitter_ns = 4e6;
	for (int k = 0; k < 200; k++) {
		int64_t t = (int64_t)k * MS, due = rmd_sim_motor_reply_due(&m, t, &f);

		assert_true(due >= t + 2 * MS && due <= t + 10 * MS);
		assert_true(due >= prev);
		held += due == prev;
		prev = due;
	}
	if (held < 10)
		fail_msg("only %u of 200 replies waited for the one before: the test shows nothing",
			 held);
}

/* The next-event hint names when the comm-loss 0xF1 falls due. */
static void test_next_event(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_frame f, out[MAXREP];
	int64_t t;

	(void)state;
	motor_init(&m, 1, RMD_PROTO_V3);
	assert_true(rmd_sim_motor_next_event_ns(&m) == INT64_MAX);
	f = REQ(V3, 1, 0xB3, KV(TIMEOUT, 50));
	expect_echo(&m, &f, 0x241);
	t = rmd_sim_motor_next_event_ns(&m);
	assert_true(t > now + 50 * MS && t <= now + 50 * MS + RMD_SIM_STEP_NS);
	assert_int_equal(rmd_sim_motor_poll(&m, t - 1, out, MAXREP), 0);
	assert_int_equal(rmd_sim_motor_poll(&m, t, out, MAXREP), 1);
	assert_int_equal(out[0].data[0], RMD_SIM_CMD_COMM_LOST);
	assert_int_equal(rmd_sim_motor_next_event_ns(&m), t + 1000 * MS);
	now = t;
}

/* ---- V4 (docs/protocol-v4.md) ------------------------------------------- */

/* Read V4 0x30's float gain of `index` (V4.2 §2.1), as its 32 bits. */
static int64_t v4_gain_bits(struct rmd_sim_motor *m, uint8_t id, uint8_t index)
{
	struct rmd_frame f = REQ(V4, id, 0x30, KV(INDEX, index));
	struct rmd_msg msg = ask(m, RMD_PROTO_V4, &f, NULL);

	assert_int_equal(msg.v[RMD_FLD_INDEX], index);
	return msg.v[RMD_FLD_GAIN];
}

/*
 * V4.2 §2.1 .. §2.3: one float gain by index; RAM lost at power off, ROM
 * kept; an index §2.1.4 does not list is not answered.  §2.4: 0x42 by
 * index.  The factory gain is the §2.1.5 example's 1.0.
 */
static void test_v4_gains_and_accel(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_frame f;
	struct rmd_msg msg;

	(void)state;
	motor_init(&m, 1, RMD_PROTO_V4);
	assert_true(v4_gain_bits(&m, 1, 1) == 0x3F800000);
	/* §2.2.5: current KP 1.5 to RAM; speed KI 0.25 to RAM; position KD 2.0 to ROM */
	f = REQ(V4, 1, 0x31, KV(INDEX, 1), KV(GAIN, 0x3FC00000));
	expect_echo(&m, &f, 0x241);
	f = REQ(V4, 1, 0x31, KV(INDEX, 5), KV(GAIN, 0x3E800000));
	expect_echo(&m, &f, 0x241);
	f = REQ(V4, 1, 0x32, KV(INDEX, 9), KV(GAIN, 0x40000000));
	expect_echo(&m, &f, 0x241);
	assert_true(v4_gain_bits(&m, 1, 1) == 0x3FC00000);
	assert_true(v4_gain_bits(&m, 1, 5) == 0x3E800000);
	assert_true(v4_gain_bits(&m, 1, 9) == 0x40000000);
	assert_true(v4_gain_bits(&m, 1, 4) == 0x3F800000);
	rmd_sim_motor_power_cycle(&m, now);
	assert_true(v4_gain_bits(&m, 1, 1) == 0x3F800000);
	assert_true(v4_gain_bits(&m, 1, 9) == 0x40000000);
	/* indexes 0, 3, 6 and 10 are no gains */
	static const uint8_t bad[] = { 0, 3, 6, 10, 255 };
	for (size_t i = 0; i < sizeof(bad); i++) {
		f = REQ(V4, 1, 0x30, KV(INDEX, bad[i]));
		expect_silence(&m, &f);
	}
	/* §2.4: 0x42 answers the index asked, with that acceleration */
	f = REQ(V4, 1, 0x43, KV(INDEX, 2), KV(ACCEL, 5000));
	expect_echo(&m, &f, 0x241);
	f = REQ(V4, 1, 0x42, KV(INDEX, 2));
	msg = ask(&m, RMD_PROTO_V4, &f, NULL);
	assert_int_equal(msg.v[RMD_FLD_INDEX], 2);
	assert_int_equal(msg.v[RMD_FLD_ACCEL], 5000);
	f = REQ(V4, 1, 0x42, KV(INDEX, 0));
	msg = ask(&m, RMD_PROTO_V4, &f, NULL);
	assert_int_equal(msg.v[RMD_FLD_INDEX], 0);
	assert_int_equal(msg.v[RMD_FLD_ACCEL], 10000);
	f = REQ(V4, 1, 0x42, KV(INDEX, 4));
	expect_silence(&m, &f);
	/* a V3 motor's 0x30 is still six uint8 gains */
	motor_init(&m, 1, RMD_PROTO_V3);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x30, RMD_FLD_CURR_KP), 85);
}

/*
 * docs/protocol-v4.md: firmware 2025070202 does not answer 0x79; 0x20
 * index 5 writes the new ID to ROM, echoed from the new 0x240 + ID at
 * once, while requests still go to the old ID until 0x76.  Index 6/7
 * (limits) are echoed.
 */
static void test_v4_set_id(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_frame f, out[MAXREP];

	(void)state;
	motor_init(&m, 1, RMD_PROTO_V4);
	f = REQ(V4, 0, 0x79, KV(READ_FLAG, 1));
	assert_int_equal(f.can_id, 0x300);
	expect_silence(&m, &f);
	f = REQ(V4, 0, 0x79, KV(READ_FLAG, 0), KV(CAN_ID, 2));
	expect_silence(&m, &f);
	assert_int_equal(read_v(&m, RMD_PROTO_V4, 1, 0x9C, RMD_FLD_TEMP), 25);

	/* an ID out of 1..32 is echoed and changes nothing */
	f = REQ(V4, 1, 0x20, KV(INDEX, 5), KV(VALUE, 33));
	expect_echo(&m, &f, 0x241);
	f = REQ(V4, 1, 0x20, KV(INDEX, 5), KV(VALUE, 7));
	expect_echo(&m, &f, 0x247);
	/* still motor 1 until the reset */
	(void)read_v(&m, RMD_PROTO_V4, 1, 0x9A, RMD_FLD_VOLTAGE);
	f = REQ0(V4, 7, 0x9A);
	expect_silence(&m, &f);
	f = REQ(V4, 1, 0x20, KV(INDEX, 6), KV(VALUE, 9000));
	expect_echo(&m, &f, 0x241);
	f = REQ(V4, 1, 0x20, KV(INDEX, 7), KV(VALUE, -9000));
	expect_echo(&m, &f, 0x241);
	f = REQ0(V4, 1, 0x76);
	assert_int_equal(send(&m, &f, out), 0);
	f = REQ0(V4, 1, 0x9A);
	expect_silence(&m, &f);
	assert_int_equal(read_v(&m, RMD_PROTO_V4, 7, 0x9C, RMD_FLD_TEMP), 25);
	rmd_sim_motor_power_cycle(&m, now);
	assert_int_equal(read_v(&m, RMD_PROTO_V4, 7, 0x9C, RMD_FLD_TEMP), 25);

	/* a V3 motor knows no index 5: echoed, its ID kept */
	motor_init(&m, 1, RMD_PROTO_V3);
	f = REQ(V3, 1, 0x20, KV(INDEX, 5), KV(VALUE, 7));
	expect_echo(&m, &f, 0x241);
	f = REQ0(V3, 1, 0x76);
	assert_int_equal(send(&m, &f, out), 0);
	assert_int_equal(read_v(&m, RMD_PROTO_V3, 1, 0x9C, RMD_FLD_TEMP), 25);
}

/*
 * V4.2 §2.34.4 index 4: the multi-turn angle kept at power off, as in V3;
 * without it a power cycle wraps it to +-180 deg.  0xA6 (§2.22) moves
 * within one turn, in the direction asked.
 */
static void test_v4_multi_turn_and_single(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_frame f;
	struct rmd_msg msg;

	(void)state;
	motor_ready(&m, 1, RMD_PROTO_V4);
	f = REQ(V4, 1, 0xA4, KV(MAX_SPEED, 720), KV(ANGLE, 72000));
	(void)ask(&m, RMD_PROTO_V4, &f, NULL);
	advance_talking(&m, 1, 2000 * MS);
	assert_true(llabs(read_v(&m, RMD_PROTO_V4, 1, 0x92, RMD_FLD_ANGLE) - 72000) <= 2);
	f = REQ(V4, 1, 0x20, KV(INDEX, 4), KV(VALUE, 1));
	expect_echo(&m, &f, 0x241);
	rmd_sim_motor_power_cycle(&m, now);
	assert_true(llabs(read_v(&m, RMD_PROTO_V4, 1, 0x92, RMD_FLD_ANGLE) - 72000) <= 2);
	f = REQ(V4, 1, 0x20, KV(INDEX, 4), KV(VALUE, 0));
	expect_echo(&m, &f, 0x241);
	rmd_sim_motor_power_cycle(&m, now);
	assert_true(llabs(read_v(&m, RMD_PROTO_V4, 1, 0x92, RMD_FLD_ANGLE)) <= 2);

	/* 0xA6: to 90 deg counterclockwise (1) from 0: the long way, -270 deg */
	brake_release(&m, RMD_PROTO_V4, 1);
	f = REQ(V4, 1, 0xA6, KV(SPIN_DIR, 1), KV(MAX_SPEED, 720), KV(ANGLE, 9000));
	msg = ask(&m, RMD_PROTO_V4, &f, NULL);
	assert_true(rmd_msg_has(&msg, RMD_FLD_ENCODER) && !rmd_msg_has(&msg, RMD_FLD_ANGLE));
	advance_talking(&m, 1, 2000 * MS);
	assert_true(llabs(read_v(&m, RMD_PROTO_V4, 1, 0x92, RMD_FLD_ANGLE) + 27000) <= 2);
	assert_true(llabs(read_v(&m, RMD_PROTO_V4, 1, 0x94, RMD_FLD_ANGLE) - 9000) <= 2);
}

/*
 * V4.2 §2.33: 0xB6 pushes a read's reply every n x 10 ms and the read is
 * no longer answered; off restores it; a reset ends it.
 */
static void test_v4_active_reply(void **state)
{
	struct rmd_sim_motor m;
	struct rmd_frame f, out[MAXREP];
	struct rmd_msg msg;
	int64_t t0;

	(void)state;
	motor_init(&m, 2, RMD_PROTO_V4);
	/* 0x9C every 2 x 10 ms: no reply to 0xB6 */
	f = REQ(V4, 2, 0xB6, KV(REPORT_CMD, 0x9C), KV(REPORT_ON, 1), KV(REPORT_MS, 2));
	assert_int_equal(send(&m, &f, out), 0);
	t0 = now;
	assert_true(rmd_sim_motor_next_event_ns(&m) == t0 + 20 * MS);
	f = REQ0(V4, 2, 0x9C);
	expect_silence(&m, &f);
	(void)read_v(&m, RMD_PROTO_V4, 2, 0x9A, RMD_FLD_VOLTAGE); /* others still answer */
	assert_int_equal(rmd_sim_motor_poll(&m, t0 + 20 * MS - 1, out, MAXREP), 0);
	assert_int_equal(rmd_sim_motor_poll(&m, t0 + 20 * MS, out, MAXREP), 1);
	assert_int_equal(out[0].can_id, 0x242);
	assert_int_equal(rmd_decode(RMD_PROTO_V4, RMD_DIR_REPLY, &out[0], &msg, NULL), 0);
	assert_int_equal(msg.cmd, 0x9C);
	assert_true(rmd_msg_has(&msg, RMD_FLD_TEMP));
	assert_true(rmd_sim_motor_next_event_ns(&m) == t0 + 40 * MS);
	/* a late poll catches up, within its room */
	assert_int_equal(rmd_sim_motor_poll(&m, t0 + 100 * MS, out, 2), 2);
	assert_int_equal(rmd_sim_motor_poll(&m, t0 + 100 * MS, out, MAXREP), 2);
	assert_int_equal(rmd_sim_motor_poll(&m, t0 + 100 * MS, out, MAXREP), 0);
	now = t0 + 100 * MS;
	/* a second command on its own period: 0x92 every 50 ms; 0x9C's at +20, +40 */
	f = REQ(V4, 2, 0xB6, KV(REPORT_CMD, 0x92), KV(REPORT_ON, 1), KV(REPORT_MS, 5));
	assert_int_equal(send(&m, &f, out), 0);
	assert_int_equal(rmd_sim_motor_poll(&m, now + 50 * MS, out, MAXREP), 3);
	/* one poll's due frames come in the order of the dialect's list (0x92 first) */
	assert_int_equal(out[0].data[0], 0x92);
	assert_int_equal(out[1].data[0], 0x9C);
	assert_int_equal(out[2].data[0], 0x9C);
	/* a command 0xB6 cannot push is ignored; 0x9C off answers again */
	f = REQ(V4, 2, 0xB6, KV(REPORT_CMD, 0xB2), KV(REPORT_ON, 1), KV(REPORT_MS, 1));
	assert_int_equal(send(&m, &f, out), 0);
	(void)read_v(&m, RMD_PROTO_V4, 2, 0xB2, RMD_FLD_VERSION);
	f = REQ(V4, 2, 0xB6, KV(REPORT_CMD, 0x9C), KV(REPORT_ON, 0), KV(REPORT_MS, 0));
	assert_int_equal(send(&m, &f, out), 0);
	(void)read_v(&m, RMD_PROTO_V4, 2, 0x9C, RMD_FLD_TEMP);
	/* a reset ends 0x92's */
	f = REQ0(V4, 2, 0x92);
	expect_silence(&m, &f);
	f = REQ0(V4, 2, 0x76);
	assert_int_equal(send(&m, &f, out), 0);
	(void)read_v(&m, RMD_PROTO_V4, 2, 0x92, RMD_FLD_ANGLE);
	assert_true(rmd_sim_motor_next_event_ns(&m) == INT64_MAX);
	assert_int_equal(rmd_sim_motor_poll(&m, now + 1000 * MS, out, MAXREP), 0);
}

int main(void)
{
	const char *env = getenv("RMD_TEST_SEED");
	const struct CMUnitTest tests[] = {
		cmocka_unit_test_setup(test_abs_move_time, setup),
		cmocka_unit_test_setup(test_torque_step_acceleration, setup),
		cmocka_unit_test_setup(test_position_tracking, setup),
		cmocka_unit_test_setup(test_heating, setup),
		cmocka_unit_test_setup(test_brake_blocks_motion, setup),
		cmocka_unit_test_setup(test_comm_loss_sequence, setup),
		cmocka_unit_test_setup(test_v2_multi_torque, setup),
		cmocka_unit_test_setup(test_mit_pd_law, setup),
		cmocka_unit_test_setup(test_mit_scaling_by_firmware, setup),
		cmocka_unit_test_setup(test_power_cycle_ram_rom, setup),
		cmocka_unit_test_setup(test_boot_time, setup),
		cmocka_unit_test_setup(test_can_filter, setup),
		cmocka_unit_test_setup(test_error_reports, setup),
		cmocka_unit_test_setup(test_stall_latches, setup),
		cmocka_unit_test_setup(test_garbage_no_reply, setup),
		cmocka_unit_test_setup(test_reads_and_identity, setup),
		cmocka_unit_test_setup(test_v2_commands, setup),
		cmocka_unit_test_setup(test_deterministic_jitter, setup),
		cmocka_unit_test_setup(test_replies_in_order, setup),
		cmocka_unit_test_setup(test_next_event, setup),
		cmocka_unit_test_setup(test_v4_gains_and_accel, setup),
		cmocka_unit_test_setup(test_v4_set_id, setup),
		cmocka_unit_test_setup(test_v4_multi_turn_and_single, setup),
		cmocka_unit_test_setup(test_v4_active_reply, setup),
	};

	seed = env ? strtoull(env, NULL, 0) : (uint64_t)time(NULL);
	printf("test_sim_motor: RMD_TEST_SEED=%llu\n", (unsigned long long)seed);
	return SUITE_RUN("sim_motor", tests, NULL, NULL);
}

// SPDX-License-Identifier: MIT
/*
 * The rt loop, the V2 0x280 frame and its batch (harness/loop_rig.h): one
 * frame for the batched motors, only while each is ENABLED in torque
 * mode; a motor of the batch LOST; a motor the file does not list that
 * would take the frame for its own command (a stray), at bring-up and
 * later, and a bus that cannot give each motor its own frames refused.
 */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "harness/loop_rig.h"
#include "harness/v2_batch.h"
#include "harness/suite.h"

/* The first frame a motor put on the wire with identifier watch_id (caller's clock; 0: none). */
static uint32_t watch_id;
static int64_t watch_first_ns;

static void watch(unsigned b, const struct rmd_sim_pending *p, int64_t start_ns)
{
	if (p->src != RMD_SIM_SRC_HOST && watch_id && p->f.can_id == watch_id && !watch_first_ns)
		watch_first_ns = start_ns + R.epoch[b];
}

static void v2_batch(struct rmd_config *cfg)
{
	for (unsigned i = 0; i < 4; i++) {
		struct rmd_config_motor *m = &cfg->motors[i];

		m->bus = 0;
		m->id = (uint8_t)(i + 1);
		m->proto = RMD_PROTO_V2;
		m->mode = RMD_MODE_TORQUE;
		m->status_poll_hz = 0; /* no room for polls beside a full 0x280 cycle */
		m->comm_loss_ms = 0;   /* V2: no 0xB3; driven only with the protection off */
	}
	cfg->n_buses = 1;
}

static void test_v2_batch(void **state)
{
	struct rmd_snapshot s;
	unsigned from, n280 = 0;

	(void)state;
	rig_up(4, v2_batch);
	assert_int_equal(R.io.plan.bus[0].batch, RMD_BATCH_ON);
	bring_up();
	/* motor 3: V2 (no model or version query), 48.0 V, 25 °C, no 0xB3 in V2 */
	assert_int_equal(R.report.motor[2].state, RMD_BRINGUP_FOUND);
	assert_string_equal(R.report.motor[2].model, "");
	assert_int_equal(R.report.motor[2].version, 0);
	assert_true(R.report.motor[2].status);
	assert_float_equal(R.report.motor[2].voltage_v, 48.0, 0.05);
	assert_float_equal(R.report.motor[2].temp_c, 25.0, 0.5);
	assert_true(R.report.motor[2].v2_angle);
	assert_int_equal(R.report.motor[2].b3, RMD_B3_NOT_APPLICABLE);
	trace_n = 0;
	run(100, false);
	for (unsigned k = 0; k < trace_n; k++)
		assert_false(moves_frame(&trace[k].f));
	cmd_clear();
	cmd_motor(0, true, RMD_MODE_TORQUE)->torque_nm = 0.5;
	cmd_motor(1, true, RMD_MODE_TORQUE)->torque_nm = -0.5;
	cmd_motor(2, true, RMD_MODE_TORQUE)->torque_nm = 0.0;
	cmd_motor(3, true, RMD_MODE_TORQUE)->torque_nm = 0.0;
	from = trace_n;
	run(200, true);
	for (unsigned k = from; k < trace_n; k++)
		n280 += trace[k].f.can_id == 0x280;
	assert_true(n280 >= 195);
	s = snap();
	/* 0.5 N·m at 2 N·m/A: 0.25 A, measured in 33/2048 A steps */
	assert_float_equal(s.m[0].current_a, 0.25, 0.02);
	assert_float_equal(s.m[1].current_a, -0.25, 0.02);
	assert_true(s.m[0].vel_rad_s > 0.5);
	assert_true(s.m[1].vel_rad_s < -0.5);
	assert_true(s.m[0].pos_rad > 0.1);
	for (unsigned i = 0; i < 4; i++) {
		assert_true(s.m[i].reply_age_cycles <= 1);
		assert_int_equal(s.m[i].missed_replies, 0);
	}
	/* the motors driven at 0 N·m stay put */
	assert_float_equal(sim_motor(2)->vel_rad_s, 0.0, 1e-6);
	rig_down();
}

/*
 * Issue 33 point 1: a 0x280 frame is a torque command to every batched
 * motor (V2 §4.1: 0 A switches the output on at 0 A), so it goes out only
 * while all of them are driven in torque mode.  Judged on the wire and on
 * the simulated motors: a motor READY, SAFE (hold, under a 1 N·m load) or
 * LOST never gets one, and keeps its own action; the driven ones get their
 * torques in frames of their own meanwhile.
 */
static void v2_batch_loaded(struct rmd_sim_setup *sim)
{
	sim->motors[1].load_nm = 1.0; /* the knee: gravity pulls it */
}

/* 0x280 frames since trace[from]. */
static unsigned batches_since(unsigned from)
{
	unsigned n = 0;

	for (unsigned k = from; k < trace_n; k++)
		n += trace[k].f.can_id == 0x280;
	return n;
}

static void test_v2_batch_only_enabled(void **state)
{
	unsigned from, most_apart, last[4], c0;

	(void)state;
	rig_sim_tweak = v2_batch_loaded;
	rig_up(4, v2_batch);
	rig_sim_tweak = NULL;
	R.io.cfg.safety.safe_action = RMD_SAFE_HOLD;
	assert_int_equal(R.io.plan.bus[0].batch, RMD_BATCH_ON);
	assert_true(R.io.plan.bus[0].batch_own >= 2);
	bring_up();
	run(50, false);

	/* two driven, two READY: no 0x280, the READY ones stay off */
	cmd_clear();
	cmd_motor(0, true, RMD_MODE_TORQUE)->torque_nm = 0.5;
	cmd_motor(2, true, RMD_MODE_TORQUE)->torque_nm = -0.5;
	from = trace_n;
	run(200, true);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_int_equal(lifecycle(1), RMD_LC_READY);
	if (batches_since(from))
		fail_msg("%u 0x280 frames while motors 2 and 4 are READY", batches_since(from));
	assert_int_equal(sim_motor(1)->ctrl, RMD_SIM_OFF);
	assert_int_equal(sim_motor(3)->ctrl, RMD_SIM_OFF);
	assert_true(sim_motor(0)->vel_rad_s > 0.5);
	assert_true(sim_motor(2)->vel_rad_s < -0.5);
	assert_true(sent_to(0, 0xA1, from) >= 200 / 4);

	/* all four driven: the 0x280 frame */
	cmd_motor(1, true, RMD_MODE_TORQUE)->torque_nm = 1.0; /* holds the knee up */
	cmd_motor(3, true, RMD_MODE_TORQUE)->torque_nm = 0.0;
	from = trace_n;
	run(200, true);
	assert_true(batches_since(from) >= 150);

	/*
	 * The controller stops commanding the knee: its watchdog holds it
	 * (0x81), under its load, while the others run on.  No 0x280 may
	 * take the hold back with a torque of 0 A.
	 */
	R.cmd.present &= ~(1u << 1);
	for (c0 = 0; c0 < 300 && lifecycle(1) != RMD_LC_SAFE; c0++)
		run(1, true);
	assert_int_equal(lifecycle(1), RMD_LC_SAFE);
	from = trace_n;
	memset(last, 0, sizeof(last));
	most_apart = 0;
	for (unsigned c = 1; c <= 500; c++) {
		unsigned before = trace_n;

		run(1, true);
		for (unsigned k = before; k < trace_n; k++) {
			unsigned id = trace[k].f.can_id - 0x140u;

			if (trace[k].f.can_id == 0x280)
				fail_msg("cycle %u after the hold: a 0x280 frame (%02X %02X ...) "
					 "while the knee is SAFE",
					 c, trace[k].f.data[0], trace[k].f.data[1]);
			if (id >= 1 && id <= 4 && trace[k].f.data[0] == 0xA1) {
				if (c - last[id - 1] > most_apart && last[id - 1])
					most_apart = c - last[id - 1];
				last[id - 1] = c;
			}
		}
		assert_int_equal(lifecycle(1), RMD_LC_SAFE);
	}
	assert_int_equal(sim_motor(1)->ctrl, RMD_SIM_HOLD);
	if (fabs(sim_motor(1)->vel_rad_s) > 0.05)
		fail_msg("the held knee turns at %g rad/s", sim_motor(1)->vel_rad_s);
	/* the driven ones: their torques in their own frames, each at least every other cycle */
	assert_int_equal(sent_to(1, 0xA1, from), 0);
	assert_true(most_apart >= 1 && most_apart <= 2);
	assert_true(sent_to(0, 0xA1, from) >= 500 / 2 - 1);
	rig_down();
}

/*
 * Issue 33 point 2: a V3 motor on the bus that the configuration does not
 * list (a spare) takes 0x280 as a command of its own (V3 §3): the frame
 * the loop builds for its V2 motors' torques.  The torques below make the
 * frame begin 77 00 (V3 §2.26: brake release).
 */
static void stray_v3(struct rmd_sim_setup *sim)
{
	struct rmd_sim_motor_params *p = &sim->buses[0].strays[0];

	rmd_sim_motor_params_default(p, 5, RMD_PROTO_V3);
	p->start_angle_deg = 90.0;
	sim->buses[0].n_strays = 1;
}

static void v2_batch_500(struct rmd_config *cfg)
{
	v2_batch(cfg);
	cfg->loop.rate_hz = 500; /* room for each motor's own frames */
}

/* The torque of motor 1 that makes a 0x280 frame begin with `cmd` 00 (the others at 0). */
static double torque_for_first_byte(uint8_t cmd)
{
	const struct rmd_motor *ms[4];

	for (unsigned i = 0; i < 4; i++)
		ms[i] = rmd_loop_motor(R.l, i);
	return v2_batch_torque_for(ms, cmd);
}

/* Every V2 motor driven in torque mode, motor 1 at t1: the 0x280 frame is allowed. */
static void drive_all(double t1)
{
	cmd_clear();
	cmd_motor(0, true, RMD_MODE_TORQUE)->torque_nm = t1;
	for (unsigned i = 1; i < 4; i++)
		cmd_motor(i, true, RMD_MODE_TORQUE)->torque_nm = 0.0;
}

static void test_v2_batch_stray(void **state)
{
	const struct rmd_sim_motor *stray;
	unsigned from;

	(void)state;
	rig_sim_tweak = stray_v3;
	rig_up(4, v2_batch_500);
	rig_sim_tweak = NULL;
	assert_int_equal(R.io.plan.bus[0].batch, RMD_BATCH_ON);
	bring_up();
	/* bring-up saw it, said so, and the bus will not batch */
	assert_int_equal(R.report.stray_ids[0], 1u << 4);
	assert_int_equal(R.report.bus[0].stray_id, 0x245);
	assert_false(R.report.bus[0].stray_refused);
	stray = rmd_sim_wire_motor(rmd_bus_sim_get(&R.io.buses[0]), 5);
	assert_non_null(stray);
	drive_all(torque_for_first_byte(0x77));
	from = trace_n;
	run(500, true);
	for (unsigned i = 0; i < 4; i++)
		assert_int_equal(lifecycle(i), RMD_LC_ENABLED);
	if (batches_since(from))
		fail_msg("%u 0x280 frames with a V3 motor on the bus", batches_since(from));
	/* the driven motors get their torques in their own frames, every cycle */
	for (unsigned i = 0; i < 4; i++)
		assert_true(sent_to(i, 0xA1, from) >= 500 - 20);
	assert_true(stray->brake_locked);
	assert_int_equal(stray->ctrl, RMD_SIM_OFF);
	assert_float_equal(stray->pos_rad, 90.0 * M_PI / 180.0, 1e-6);
	rig_down();
}

/*
 * The spare powered on only after bring-up: its first answer (to the
 * first 0x280 frame it heard and took for a command: there is no earlier
 * sign of it) stops the frame at once, for good, and is reported.  One
 * frame more may be on its way when that answer lands after the next
 * tick's receive.
 */
static void test_v2_batch_stray_later(void **state)
{
	struct rmd_sim_fault f = {
		.kind = RMD_SIM_FAULT_DISAPPEAR,
		.motor_id = 5,
		.start_ns = 0,
		.end_ns = 0, /* set below */
	};
	unsigned from;
	int64_t after;

	(void)state;
	rig_sim_tweak = stray_v3;
	rig_up(4, v2_batch_500);
	rig_sim_tweak = NULL;
	f.end_ns = 3000 * MS; /* off through bring-up, on 3 s into the sim's time */
	set_faults(0, &f, 1);
	bring_up();
	assert_int_equal(R.report.stray_ids[0], 0);
	/* a frame the spare executes and answers (one that is no V3 command it ignores) */
	drive_all(torque_for_first_byte(0x77));
	run(200, true);
	assert_true(batches_since(0) >= 150);
	rig_tap_hook = watch;
	watch_id = 0x245;
	watch_first_ns = 0;
	from = trace_n;
	for (unsigned c = 0; c < 2000 && !watch_first_ns; c++)
		run(1, true);
	assert_true(watch_first_ns > 0);
	run(500, true);
	after = 0;
	for (unsigned k = from; k < trace_n; k++)
		if (trace[k].f.can_id == 0x280 && trace[k].t_ns > watch_first_ns)
			after++;
	watch_id = 0;
	if (after > 1)
		fail_msg("%lld 0x280 frames after the V3 motor answered", (long long)after);
	assert_int_equal(count_ev(RMD_EV_STRAY, -1), 1);
	assert_int_equal(R.ev[R.nev - 1].kind == RMD_EV_STRAY ? R.ev[R.nev - 1].a : 0x245, 0x245);
	for (unsigned i = 0; i < 4; i++)
		assert_int_equal(lifecycle(i), RMD_LC_ENABLED);
	rig_down();
}

/*
 * 4 V2 motors at 1 kHz with a poll fit only with the 0x280 frame: a spare
 * V3 motor refuses the bus at bring-up (it would run slower for good);
 * with can_id_filter (its filter is on: the frame does not reach it) the
 * bus batches.
 */
static void test_v2_batch_stray_refused(void **state)
{
	(void)state;
	rig_sim_tweak = stray_v3;
	rig_up(4, v2_batch);
	assert_true(R.io.plan.bus[0].batch_own < 4);
	assert_int_equal(rmd_loop_bringup(R.l, &R.report), -EPROTO);
	assert_int_equal(R.report.strays_refused, 1);
	assert_true(R.report.bus[0].stray_refused);
	assert_int_equal(R.report.stray_ids[0], 1u << 4);
	rig_down();

	rig_up(4, v2_batch);
	rig_sim_tweak = NULL;
	R.io.cfg.buses[0].can_id_filter = true;
	bring_up();
	assert_int_equal(R.report.stray_ids[0], 0);
	assert_int_equal(R.report.strays_refused, 0);
	rig_down();
}

/* A batched motor LOST (lost_motor_action: motor): no 0x280 while it is. */
static void test_v2_batch_lost_motor(void **state)
{
	struct rmd_sim_fault f = { .kind = RMD_SIM_FAULT_DISAPPEAR, .motor_id = 3 };
	unsigned from;

	(void)state;
	rig_up(4, v2_batch);
	bring_up();
	run(20, false);
	cmd_clear();
	for (unsigned i = 0; i < 4; i++)
		cmd_motor(i, true, RMD_MODE_TORQUE)->torque_nm = 0.2;
	run(100, true);
	assert_true(batches_since(0) >= 50);
	f.start_ns = rmd_bus_sim_time_ns(&R.io.buses[0], t_now);
	f.end_ns = f.start_ns + 300 * MS;
	set_faults(0, &f, 1);
	for (unsigned c = 0; c < 100 && lifecycle(2) != RMD_LC_LOST; c++)
		run(1, true);
	assert_int_equal(lifecycle(2), RMD_LC_LOST);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	from = trace_n;
	for (unsigned c = 0; c < 200 && lifecycle(2) == RMD_LC_LOST; c++)
		run(1, true);
	if (batches_since(from))
		fail_msg("%u 0x280 frames while motor 3 is LOST", batches_since(from));
	assert_true(sent_to(0, 0xA1, from) > 0);
	rig_down();
}

SUITE_MAIN("loop_v2_batch", NULL, NULL,
	   {
		   cmocka_unit_test(test_v2_batch),
		   cmocka_unit_test(test_v2_batch_only_enabled),
		   cmocka_unit_test(test_v2_batch_lost_motor),
		   cmocka_unit_test(test_v2_batch_stray),
		   cmocka_unit_test(test_v2_batch_stray_later),
		   cmocka_unit_test(test_v2_batch_stray_refused),
	   })

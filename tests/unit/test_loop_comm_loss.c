// SPDX-License-Identifier: MIT
/*
 * The rt loop, comm-loss protection (0xB3) as a precondition of motion
 * (issue 13; harness/loop_rig.h): a trip (0xF1, the echoed first frame);
 * the rounds of 0xB3 writes, at bring-up and after it, lost, answered
 * with zeros, against a motor found late or one that trips between two
 * frames; enables refused while unarmed; the protection off by config;
 * V2 motors, which have no 0xB3.
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
#include "harness/suite.h"

static void test_comm_loss_trip(void **state)
{
	struct rmd_loop_counters c;
	bool f1 = false;

	(void)state;
	rig_up(3, NULL);
	bring_up();
	run(100, false);
	/* the loop stalls for 300 ms: the motors' 0xB3 (100 ms) trips, 0xF1 comes */
	t_now += 300 * MS;
	run(1, false);
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(lifecycle(i), RMD_LC_LOST);
	for (unsigned k = 0; k < R.nev; k++)
		f1 |= R.ev[k].kind == RMD_EV_MOTOR_ERROR && R.ev[k].b == 0xF1;
	assert_true(f1);
	assert_int_equal(count_ev(RMD_EV_OVERRUN, -1), 1);
	/* re-probed: the first frame is only echoed, the motor is back */
	run(700, false);
	rmd_loop_get_counters(R.l, &c);
	assert_true(c.echoes >= 3);
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(lifecycle(i), RMD_LC_READY);
	rig_down();
}

/*
 * Issue 32 point 3: a trip whose 0xF1 is not heard.  The loop stalls for
 * 300 ms while the motors run; their 0xB3 (100 ms) trips, and every 0xF1
 * is lost on the wire.  The first command each hears after the stall is
 * only echoed, not run: that echo is the motor saying it tripped (its
 * output off), so it is treated as the 0xF1 would be -- lost, reported,
 * and no setpoint reaches it again until the controller enables it anew.
 * Judged on the wire: before, the echo was counted and the next setpoint
 * ran the motor again, reported ENABLED all along.
 */
/* Where the host's frames stood (trace_n) when each motor's first echo of a 0xA2 went out. */
static unsigned echo_at[3];

static void note_echo(unsigned b, const struct rmd_sim_pending *p, int64_t start_ns)
{
	(void)start_ns;
	/* a speed reply carries its temperature in DATA[1]; the request, zeros */
	if (b == 0 && p->src >= 0 && p->src < 3 && p->f.data[0] == 0xA2 && !p->f.data[1] &&
	    !p->f.data[2] && !p->f.data[3] && echo_at[p->src] == UINT32_MAX)
		echo_at[p->src] = trace_n;
}

static void test_trip_seen_by_echo(void **state)
{
	struct rmd_sim_fault f = { .kind = RMD_SIM_FAULT_DROP,
				   .probability = 1.0,
				   .cmd = RMD_MOTOR_CMD_COMM_LOST };
	struct rmd_loop_counters c;
	unsigned tripped = 0;

	(void)state;
	up_at_speed(NULL, 3, 1.0, 200);
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(lifecycle(i), RMD_LC_ENABLED);
	fault_now(&f, 0);
	R.nev = 0;
	for (unsigned i = 0; i < 3; i++)
		echo_at[i] = UINT32_MAX;
	rig_tap_hook = note_echo;
	t_now += 300 * MS;
	run(1, true);
	for (unsigned i = 0; i < 3; i++)
		assert_true(sim_motor(i)->echo_next || sim_motor(i)->ctrl == RMD_SIM_OFF);
	run(30, true);
	rig_tap_hook = NULL;
	rmd_loop_get_counters(R.l, &c);
	assert_true(c.echoes >= 3);
	for (unsigned i = 0; i < 3; i++) {
		unsigned after;

		if (echo_at[i] == UINT32_MAX)
			fail_msg("motor %u echoed no 0xA2 after the stall: not tested", i + 1);
		/*
		 * After its echo went out, at most the setpoint already on its
		 * way before rmdd could take the echo (the next cycle's, sent
		 * ahead of the reply's arrival), then none: its safe action
		 */
		after = sent_to(i, 0xA2, echo_at[i]);
		if (after > 1)
			fail_msg("motor %u: %u speed setpoints after its echo (the trip)", i + 1,
				 after);
		assert_int_not_equal(sim_motor(i)->ctrl, RMD_SIM_SPEED);
		assert_int_not_equal(lifecycle(i), RMD_LC_ENABLED);
		for (unsigned k = 0; k < R.nev; k++)
			tripped += R.ev[k].kind == RMD_EV_MOTOR_ERROR && R.ev[k].motor == i &&
				   R.ev[k].b == RMD_MOTOR_CMD_COMM_LOST;
	}
	assert_int_equal(tripped, 3);
	/* enabled anew, it runs */
	run(700, true);
	cl_reenable(0);
	run(30, true);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_int_equal(sim_motor(0)->ctrl, RMD_SIM_SPEED);
	rig_down();
}

/* Motor 1's first MIT echo after the stall: where the host's frames stood (trace_n). */
static unsigned mit_echo_at;

static void note_mit_echo(unsigned b, const struct rmd_sim_pending *p, int64_t start_ns)
{
	(void)start_ns;
	if (b != 0 || p->src != 0 || p->f.can_id != 0x501 || mit_echo_at != UINT32_MAX)
		return;
	/* the echo: the bytes of the newest MIT frame the host sent it */
	for (unsigned k = trace_n; k-- > 0;)
		if (trace[k].f.can_id == 0x401) {
			if (!memcmp(trace[k].f.data, p->f.data, 8))
				mit_echo_at = trace_n;
			return;
		}
}

static void mit_first(struct rmd_config *cfg)
{
	cfg->motors[0].proto = RMD_PROTO_MIT;
	cfg->motors[0].mode = RMD_MODE_MIT;
}

/*
 * The same in MIT mode: the echo of an MIT frame (on 0x500 + ID, its
 * request's bytes) is the trip; after it at most the frame already on its
 * way, then no MIT frame until the controller enables it anew.
 */
static void test_trip_seen_by_mit_echo(void **state)
{
	struct rmd_sim_fault f = { .kind = RMD_SIM_FAULT_DROP,
				   .probability = 1.0,
				   .cmd = RMD_MOTOR_CMD_COMM_LOST };
	struct rmd_setpoint *sp;
	unsigned after;

	(void)state;
	rig_up(1, mit_first);
	bring_up();
	cmd_clear();
	sp = cmd_motor(0, true, RMD_MODE_MIT);
	sp->kd = 0.5;
	sp->vel_rad_s = 1.0;
	run(200, true);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_true(sent_to(0, 0x400, 0) > 150);
	fault_now(&f, 0);
	R.nev = 0;
	mit_echo_at = UINT32_MAX;
	rig_tap_hook = note_mit_echo;
	t_now += 300 * MS;
	run(30, true);
	rig_tap_hook = NULL;
	if (mit_echo_at == UINT32_MAX)
		fail_msg("motor 1 echoed no MIT frame after the stall: not tested");
	after = sent_to(0, 0x400, mit_echo_at);
	if (after > 1)
		fail_msg("motor 1: %u MIT frames after its echo (the trip)", after);
	assert_int_not_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_int_equal(count_ev(RMD_EV_MOTOR_ERROR, 0), 1);
	rig_down();
}

/* ---- issue 13: comm-loss protection is a precondition of motion ------------------- */

/* The loop's and the health's view of motor i's protection. */
static uint8_t cl_of(unsigned i)
{
	return rmd_loop_comm_loss(R.l, i);
}

/* Events RMD_EV_COMM_LOSS of motor i with state a (-1: any) and refusal flag b (-1: any). */
static unsigned cl_events(unsigned i, int a, int b)
{
	unsigned n = 0;

	events_pump();
	for (unsigned k = 0; k < R.nev; k++)
		if (R.ev[k].kind == RMD_EV_COMM_LOSS && R.ev[k].motor == i &&
		    (a < 0 || R.ev[k].a == a) && (b < 0 || R.ev[k].b == b))
			n++;
	return n;
}

/* A frame that moves motor i went out since trace[from]. */
static bool moved_since(unsigned i, unsigned from)
{
	const struct rmd_config_motor *m = &R.io.cfg.motors[i];

	for (unsigned k = from; k < trace_n; k++)
		if (trace[k].bus == m->bus && (trace[k].f.can_id & 0xFF) == m->id &&
		    trace[k].f.can_id != 0x280 && moves_frame(&trace[k].f))
			return true;
	return false;
}

/*
 * Three motors, probe.on_missing start, fault f on bus 0 (its times from
 * now on the sim bus's clock), bring-up; R.cmd enables every motor at
 * 1 rad/s.  Returns where the trace stands.
 */
static unsigned cl_rig(struct rmd_sim_fault f)
{
	rig_up(3, missing_start);
	if (f.start_ns)
		f.start_ns += sim_time(0);
	if (f.end_ns)
		f.end_ns += sim_time(0);
	set_faults(0, &f, 1);
	bring_up();
	cmd_clear();
	for (unsigned i = 0; i < 3; i++)
		cmd_motor(i, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	return trace_n;
}

/*
 * The reproducer: motor 1's frames are dropped from 5 ms to 300 ms
 * of the sim bus, so its 0xB3 answer at bring-up is lost.  With
 * probe.on_missing refuse, bring-up refuses to start; with start, motor 1
 * is never enabled before it is armed, and is armed once it answers.
 */
static void test_cl_reproducer(void **state)
{
	struct rmd_sim_fault drop = { .kind = RMD_SIM_FAULT_DROP,
				      .motor_id = 1,
				      .probability = 1.0 };
	unsigned from;
	bool armed_seen = false;

	(void)state;
	/* refuse: motor 1 counts as missing; the report says why */
	rig_up(3, NULL);
	drop.start_ns = sim_time(0) + 5 * MS;
	drop.end_ns = sim_time(0) + 300 * MS;
	set_faults(0, &drop, 1);
	assert_int_equal(rmd_loop_bringup(R.l, &R.report), -ENODEV);
	assert_int_equal(R.report.missing, 0);
	assert_int_equal(R.report.unarmed, 1);
	assert_int_equal(R.report.motor[0].b3, RMD_B3_NO_ANSWER);
	assert_int_equal(R.report.motor[0].comm_loss, RMD_CL_NO_ANSWER);
	assert_int_equal(R.report.motor[1].comm_loss, RMD_CL_ARMED);
	rig_down();

	/* start: nothing moves motor 1 until it is armed */
	drop.start_ns = 5 * MS;
	drop.end_ns = 300 * MS;
	from = cl_rig(drop);
	assert_int_equal(R.report.unarmed, 1);
	assert_int_equal(cl_of(0), RMD_CL_NO_ANSWER);
	for (unsigned k = 0; k < 1500; k++) {
		run(1, true);
		if (lifecycle(0) == RMD_LC_ENABLED && !rmd_comm_loss_set(cl_of(0)))
			fail_msg("cycle %u: motor 1 enabled without its protection (%u)", k,
				 cl_of(0));
		armed_seen |= rmd_comm_loss_set(cl_of(0));
		if (!armed_seen && moved_since(0, from))
			fail_msg("cycle %u: a frame that moves motor 1 before it was armed", k);
	}
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
	assert_int_equal(lifecycle(2), RMD_LC_ENABLED);
	/* it was lost meanwhile, came back and was armed, echo-verified */
	assert_int_equal(cl_of(0), RMD_CL_ARMED);
	assert_true(sent_to(0, 0xB3, from) >= 1);
	assert_int_equal(cl_events(0, RMD_CL_ARMED, 0), 1);
	assert_int_equal(sim_motor(0)->ram.comm_timeout_ms, R.io.cfg.safety.comm_loss_ms);
	/* back from LOST it wants enable 0 then 1, and then it runs */
	assert_int_equal(lifecycle(0), RMD_LC_READY);
	cl_reenable(0);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	rig_down();
}

/*
 * A motor that answers everything but 0xB3 cannot be enabled: each enable
 * is refused and counted, a warning goes out once, new rounds of writes
 * come at most once a second; once it answers, the waiting enable applies.
 */
static void test_cl_refused(void **state)
{
	struct rmd_sim_fault drop = {
		.kind = RMD_SIM_FAULT_DROP, .motor_id = 2, .probability = 1.0, .cmd = 0xB3
	};
	static struct rmd_health h;
	unsigned from, writes;

	(void)state;
	from = cl_rig(drop);
	assert_int_equal(R.report.motor[1].b3, RMD_B3_NO_ANSWER);
	assert_int_equal(R.report.unarmed, 1);
	run(3000, true);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_int_equal(lifecycle(1), RMD_LC_READY);
	assert_false(moved_since(1, from));
	assert_int_equal(cl_of(1), RMD_CL_NO_ANSWER);
	/* refused, counted, said once */
	assert_true(rmd_loop_get_health(R.l, &h));
	assert_int_equal(h.nmotors, 3);
	assert_int_equal(h.comm_loss[0], RMD_CL_ARMED);
	assert_int_equal(h.comm_loss[1], RMD_CL_NO_ANSWER);
	assert_int_equal(h.comm_loss_ms[1], R.io.cfg.safety.comm_loss_ms);
	assert_true(h.unarmed_rejects[1] > 2000);
	assert_int_equal(h.unarmed_rejects[0], 0);
	assert_int_equal(cl_events(1, RMD_CL_NO_ANSWER, 1), 1);
	/* bounded: a round of 3 writes per second at most (ROM) */
	writes = sent_to(1, 0xB3, from);
	if (writes < 3 || writes > 3 * 4)
		fail_msg("%u 0xB3 writes in 3 s", writes);
	/* it answers: the next round arms it, and the enable that waited applies */
	set_faults(0, NULL, 0);
	run(1100, true);
	assert_int_equal(cl_of(1), RMD_CL_ARMED);
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
	assert_int_equal(sim_motor(1)->ctrl, RMD_SIM_SPEED);
	rig_down();
}

/* A motor that first answers 10 s after start gets 0xB3 (echo-verified) before it can move. */
static void test_cl_late_motor(void **state)
{
	struct rmd_sim_fault gone = { .kind = RMD_SIM_FAULT_DISAPPEAR, .motor_id = 3, .param = 1 };
	unsigned from, first_b3 = 0, first_move = 0;

	(void)state;
	gone.end_ns = 10000 * MS;
	from = cl_rig(gone);
	assert_int_equal(R.report.motor[2].state, RMD_BRINGUP_MISSING);
	assert_int_equal(cl_of(2), RMD_CL_PENDING);
	run(10600, true);
	assert_int_equal(lifecycle(2), RMD_LC_READY);
	assert_int_equal(cl_of(2), RMD_CL_ARMED);
	assert_int_equal(sim_motor(2)->rom.comm_timeout_ms, R.io.cfg.safety.comm_loss_ms);
	/* the controller re-enables it (enable 0, then 1) */
	cl_reenable(2);
	assert_int_equal(lifecycle(2), RMD_LC_ENABLED);
	for (unsigned k = from; k < trace_n; k++) {
		const struct sent *t = &trace[k];

		if (t->f.can_id != 0x143)
			continue;
		if (!first_b3 && t->f.data[0] == 0xB3)
			first_b3 = k;
		if (!first_move && moves_frame(&t->f))
			first_move = k;
	}
	assert_true(first_b3 > 0 && first_move > first_b3);
	rig_down();
}

static void cl_off_motor2(struct rmd_config *cfg)
{
	cfg->probe.on_missing = RMD_MISSING_START;
	cfg->motors[1].comm_loss_ms = 0;
}

/* A motor whose protection the config turns off may move without an answer to 0xB3. */
static void test_cl_off_by_config(void **state)
{
	struct rmd_sim_fault drop = {
		.kind = RMD_SIM_FAULT_DROP, .motor_id = 2, .probability = 1.0, .cmd = 0xB3
	};
	static struct rmd_health h;

	(void)state;
	rig_up(3, cl_off_motor2);
	assert_int_equal(rmd_config_comm_loss_ms(&R.io.cfg, 1), 0);
	assert_int_equal(rmd_config_comm_loss_ms(&R.io.cfg, 0), R.io.cfg.safety.comm_loss_ms);
	set_faults(0, &drop, 1);
	assert_int_equal(rmd_loop_bringup(R.l, &R.report), 0); /* refuse would not refuse it */
	t_now = (t_now / MS + 1) * MS;
	assert_int_equal(R.report.unarmed, 0);
	assert_int_equal(R.report.motor[1].comm_loss_ms, 0);
	assert_int_equal(cl_of(1), RMD_CL_OFF);
	/* bring-up wrote 0 (off) to it, and the time to the others */
	assert_int_equal(sim_motor(1)->ram.comm_timeout_ms, 0);
	assert_int_equal(sim_motor(0)->ram.comm_timeout_ms, R.io.cfg.safety.comm_loss_ms);
	cmd_clear();
	cmd_motor(1, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	run(200, true);
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
	assert_true(rmd_loop_get_health(R.l, &h));
	assert_int_equal(h.comm_loss[1], RMD_CL_OFF);
	assert_int_equal(h.comm_loss_ms[1], 0);
	assert_int_equal(h.unarmed_rejects[1], 0);
	rig_down();
}

static void v2_two(struct rmd_config *cfg)
{
	for (unsigned i = 0; i < 2; i++) {
		cfg->motors[i].proto = RMD_PROTO_V2;
		cfg->motors[i].mode = RMD_MODE_TORQUE;
		cfg->motors[i].comm_loss_ms = 0; /* V2: no 0xB3, off by config */
	}
}

/*
 * V2 §3.29: motors whose multi-turn angle is -50 deg (in both of the
 * manual's readings), +100 deg or ten turns and more report it; V2 motors
 * have no 0xB3: with comm_loss_ms 0 (as a loaded config must say) they are
 * OFF by config, never held back.
 */
static void test_v2_start_angle(void **state)
{
	static const struct {
		double deg;
		bool magnitude;
	} c[] = { { -50.0, false },  { -50.0, true },	{ 100.0, false },
		  { 3637.5, false }, { -3637.5, true }, { -3637.5, false } };

	(void)state;
	for (size_t k = 0; k < sizeof(c) / sizeof(c[0]); k++) {
		struct rmd_snapshot s;

		memset(&R, 0, sizeof(R));
		rig_up(2, v2_two);
		/* the motors power on at the angle; the sim answers 0x92 in the form */
		rig_down();
		R.io.sim.motors[0].start_angle_deg = c[k].deg;
		R.io.sim.motors[0].v2_angle_magnitude = c[k].magnitude;
		R.io.sim.motors[0].gear_ratio = R.io.cfg.motors[0].gear_ratio;
		open_buses();
		R.l = NULL;
		{
			struct rmd_loop_opts o = { .cfg = &R.io.cfg,
						   .plan = &R.io.plan,
						   .buses = R.io.buses,
						   .snapshot_fd = -1,
						   .now_ns = fake_now,
						   .sleep_ns = fake_sleep };
			char err[256];

			R.l = rmd_loop_new(&o, err, sizeof(err));
			assert_non_null(R.l);
		}
		bring_up();
		assert_true(R.report.motor[0].v2_angle);
		assert_int_equal(cl_of(0), RMD_CL_OFF);
		run(50, false);
		s = snap();
		if (fabs(s.m[0].pos_rad - c[k].deg * M_PI / 180.0) > 0.01)
			fail_msg("%g deg (%s): %.5f rad, want %.5f", c[k].deg,
				 c[k].magnitude ? "magnitude" : "two's complement", s.m[0].pos_rad,
				 c[k].deg * M_PI / 180.0);
		rig_down();
	}
}

/*
 * V3 §2.30 example 2: a motor that answers 0xB3 with zeros is armed (the
 * form recorded), at bring-up and when the loop writes it again.
 */
static void test_cl_zeros_answer(void **state)
{
	struct rmd_sim_fault drop = { .kind = RMD_SIM_FAULT_DROP,
				      .motor_id = 1,
				      .probability = 1.0 };

	(void)state;
	rig_up(3, NULL);
	sim_motor(0)->p.b3_answer_zeros = true;
	bring_up();
	assert_int_equal(R.report.motor[0].b3, RMD_B3_ZEROS);
	assert_int_equal(R.report.unarmed, 0);
	assert_int_equal(cl_of(0), RMD_CL_ARMED_ZEROS);
	assert_int_equal(cl_of(1), RMD_CL_ARMED);
	cmd_clear();
	cmd_motor(0, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	run(20, true);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	/* lost and back: the loop's own write is answered with zeros too */
	drop.start_ns = sim_time(0);
	set_faults(0, &drop, 1);
	run(30, true);
	assert_int_equal(lifecycle(0), RMD_LC_LOST);
	assert_int_equal(cl_of(0), RMD_CL_PENDING);
	set_faults(0, NULL, 0);
	run(700, true);
	assert_int_equal(cl_of(0), RMD_CL_ARMED_ZEROS);
	assert_int_equal(cl_events(0, RMD_CL_ARMED_ZEROS, 0), 1);
	cl_reenable(0);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	rig_down();
}

/* 100 Hz, probe.on_missing start */
static void slow_missing_start(struct rmd_config *cfg)
{
	cfg->probe.on_missing = RMD_MISSING_START;
	cfg->loop.rate_hz = 100;
}

/* Motor 3 was left by an earlier run with a 3 ms protection in ROM, tripped since. */
static void rom_3ms_tripped_motor3(struct rmd_sim_setup *sim)
{
	sim->motors[2].comm_loss_rom_ms = 3;
	sim->motors[2].comm_loss_tripped = true;
}

/*
 * The loop's own round after PROBE/LOST -> READY against a motor that
 * trips between two of the loop's frames: motor 3 keeps 3 ms in ROM from
 * an earlier run (tripped: it echoes the first command), its cable is cut
 * through bring-up, and at 100 Hz its first answer (an echo) and the
 * round's 0xB3 a cycle later are 10 ms apart: it trips in between and
 * only echoes the 0xB3, which is its answer.  The status read queued
 * ahead of the 0xB3 takes that echo, so the write is done: the motor's ROM
 * holds the configured time, and once enabled it moves (with 3 ms it
 * would trip between every two frames and only echo them).
 */
static void test_cl_round_after_trip(void **state)
{
	/* its cable cut through bring-up; firmware that sends no 0xF1 when it trips */
	struct rmd_sim_fault f[2] = {
		{ .kind = RMD_SIM_FAULT_DISAPPEAR, .motor_id = 3 },
		{ .kind = RMD_SIM_FAULT_DROP, .motor_id = 3, .probability = 1.0, .cmd = 0xF1 },
	};
	struct rmd_loop_counters c;
	unsigned from;

	(void)state;
	rig_sim_tweak = rom_3ms_tripped_motor3;
	rig_up(3, slow_missing_start);
	rig_sim_tweak = NULL;
	assert_true(sim_motor(2)->comm_lost && sim_motor(2)->echo_next);
	assert_int_equal(sim_motor(2)->rom.comm_timeout_ms, 3);
	f[0].end_ns = sim_time(0) + 500 * MS;
	set_faults(0, f, 2);
	bring_up();
	assert_int_equal(R.report.motor[2].state, RMD_BRINGUP_MISSING);
	cmd_clear();
	from = trace_n;
	run(150, false);
	assert_true(sent_to(2, 0xB3, from) >= 1);
	if (sim_motor(2)->rom.comm_timeout_ms != R.io.cfg.safety.comm_loss_ms)
		fail_msg("motor 3: ROM keeps %u ms, configured %u: its echo passed for the write",
			 sim_motor(2)->rom.comm_timeout_ms, R.io.cfg.safety.comm_loss_ms);
	assert_int_equal(lifecycle(2), RMD_LC_READY);
	assert_int_equal(cl_of(2), RMD_CL_ARMED);
	rmd_loop_get_counters(R.l, &c);
	assert_true(c.echoes >= 2); /* its first answer, and the read ahead of the 0xB3 */
	/* armed for real: the controller enables it and it moves */
	cl_reenable(2);
	run(30, true);
	assert_int_equal(lifecycle(2), RMD_LC_ENABLED);
	assert_int_equal(sim_motor(2)->ctrl, RMD_SIM_SPEED);
	assert_false(sim_motor(2)->comm_lost);
	rig_down();
}

/* motors 1 and 2 V2 in torque mode: 1 without comm_loss_ms 0 (as no loaded config has it), 2 with */
static void v2_one_unprotected(struct rmd_config *cfg)
{
	v2_two(cfg);
	cfg->motors[0].comm_loss_ms = RMD_CONFIG_COMM_LOSS_INHERIT;
}

static void v2_one_unprotected_start(struct rmd_config *cfg)
{
	v2_one_unprotected(cfg);
	cfg->probe.on_missing = RMD_MISSING_START;
}

/*
 * Issue 13 for V2 motors, which have no 0xB3: one whose config turns the
 * protection off (comm_loss_ms 0) is OFF by config, as a V3 motor would
 * be, and runs; one whose config does not (the loader refuses that file,
 * a program may still build it) is UNSUPPORTED: bring-up counts it as
 * not armed (probe.on_missing refuse refuses to start), every enable is
 * refused, counted and reported once, and nothing moves it or writes 0xB3.
 */
static void test_v2_protection_off_by_config(void **state)
{
	static struct rmd_health h;
	unsigned from;

	(void)state;
	rig_up(3, v2_one_unprotected);
	assert_int_equal(rmd_loop_bringup(R.l, &R.report), -ENODEV);
	assert_int_equal(R.report.unarmed, 1);
	assert_int_equal(R.report.motor[0].comm_loss, RMD_CL_UNSUPPORTED);
	assert_int_equal(R.report.motor[1].comm_loss, RMD_CL_OFF);
	rig_down();

	rig_up(3, v2_one_unprotected_start);
	bring_up();
	assert_int_equal(cl_of(0), RMD_CL_UNSUPPORTED);
	assert_int_equal(cl_of(1), RMD_CL_OFF);
	cmd_clear();
	for (unsigned i = 0; i < 2; i++)
		cmd_motor(i, true, RMD_MODE_TORQUE)->torque_nm = 0.5;
	from = trace_n;
	run(300, true);
	assert_int_equal(lifecycle(0), RMD_LC_READY);
	assert_false(moved_since(0, from));
	assert_int_equal(sent_to(0, 0xB3, from), 0);
	assert_int_equal(sim_motor(0)->ctrl, RMD_SIM_OFF);
	assert_int_equal(cl_events(0, RMD_CL_UNSUPPORTED, 1), 1);
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
	assert_int_equal(sim_motor(1)->ctrl, RMD_SIM_TORQUE);
	assert_true(rmd_loop_get_health(R.l, &h));
	assert_int_equal(h.comm_loss[0], RMD_CL_UNSUPPORTED);
	assert_true(h.unarmed_rejects[0] >= 100); /* health is a snapshot of some cycles ago */
	assert_int_equal(h.comm_loss[1], RMD_CL_OFF);
	assert_int_equal(h.comm_loss_ms[1], 0);
	assert_int_equal(h.unarmed_rejects[1], 0);
	rig_down();
}

SUITE_MAIN("loop_comm_loss", NULL, NULL,
	   {
		   cmocka_unit_test(test_comm_loss_trip),
		   cmocka_unit_test(test_trip_seen_by_echo),
		   cmocka_unit_test(test_trip_seen_by_mit_echo),
		   cmocka_unit_test(test_cl_reproducer),
		   cmocka_unit_test(test_cl_refused),
		   cmocka_unit_test(test_cl_late_motor),
		   cmocka_unit_test(test_cl_off_by_config),
		   cmocka_unit_test(test_v2_start_angle),
		   cmocka_unit_test(test_cl_zeros_answer),
		   cmocka_unit_test(test_cl_round_after_trip),
		   cmocka_unit_test(test_v2_protection_off_by_config),
	   })

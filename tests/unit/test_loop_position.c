// SPDX-License-Identifier: MIT
/*
 * The rt loop, position after a power cycle and homing (rmd/multiturn.h;
 * harness/loop_rig.h): a travel band narrower than a rotor turn gives the
 * true position, one bad reading does not decide it, an ambiguous one is
 * uncertain and refuses position mode and MIT with kp > 0; V2 motors'
 * multi-turn count (recounted after a silent turn, firmware without 0x92,
 * counted at speed); homing, and a home outside the joint's travel.
 */
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

/*
 * A forged reply (test_pos_settle_one_bad_reading): once motor 1 on bus 0
 * (a V3 entry) has echoed 0x80 and 0x78, the next status 2 reply it sends
 * reads a rotor turn more (V3 §2.13.3: int16 whole degrees at DATA[6..7]),
 * as a frame garbled into another valid one, or another node's, would.
 */
static struct {
	bool armed;
	bool saw_80, saw_78;
	bool done;
} forge;

static void forge_reply(unsigned b, const struct rmd_sim_pending *p, int64_t start_ns)
{
	struct rmd_frame *f = (struct rmd_frame *)&p->f; /* the wire's own frame, not const */
	int16_t deg;

	(void)start_ns;
	if (!forge.armed || forge.done || b != 0 || p->src == RMD_SIM_SRC_HOST ||
	    f->can_id != 0x241)
		return;
	forge.saw_80 |= f->data[0] == 0x80;
	forge.saw_78 |= f->data[0] == 0x78;
	if (!forge.saw_80 || !forge.saw_78 || f->data[0] != 0x9C)
		return;
	deg = (int16_t)(uint16_t)(f->data[6] | f->data[7] << 8);
	deg = (int16_t)(deg + 360);
	f->data[6] = (uint8_t)((uint16_t)deg & 0xFF);
	f->data[7] = (uint8_t)((uint16_t)deg >> 8);
	forge.done = true;
}

/* ---- position after a power cycle (rmd/multiturn.h) --------------------------- */

/* Motor 1's case: where its joint is and what rmdd is told about it. */
static struct pc_case {
	const char *name;
	double gear;
	int dir;
	double zero_rad;
	double start_deg;    /* the simulated output angle at first power-on (native) */
	double below, above; /* travel band around the truth, deg; below -1: none */
	bool v2;	     /* a V2 motor (else V3) */
	bool mit;	     /* an MIT motor */
	bool wrap_rotor;     /* the simulated motor wraps within one rotor turn */
} pc;

/* > 0: the motor's position limits, this far either side of its truth (else none) */
static double pc_limits_rad;

static double pc_truth_rad(void)
{
	return pc.dir * (pc.start_deg * M_PI / 180.0 - pc.zero_rad);
}

static void pc_tweak(struct rmd_config *cfg)
{
	struct rmd_config_motor *m = &cfg->motors[0];
	double t = pc_truth_rad();

	m->gear_ratio = pc.gear;
	m->direction = pc.dir;
	if (pc.v2) {
		m->proto = RMD_PROTO_V2;
		m->comm_loss_ms = 0; /* V2 has no 0xB3 (the loader insists) */
	}
	if (pc.mit) {
		m->proto = RMD_PROTO_MIT;
		m->mode = RMD_MODE_MIT;
	}
	m->zero_offset_rad = pc.zero_rad;
	m->multi_turn_saved = false;
	/* no position limits: the joint turns past rmdd --sim's one turn */
	m->limits.position_min_rad = pc_limits_rad ? t - pc_limits_rad : -INFINITY;
	m->limits.position_max_rad = pc_limits_rad ? t + pc_limits_rad : INFINITY;
	m->n_travel = 0;
	if (pc.below != -1) {
		m->n_travel = 2;
		m->travel_rad[0] = t - pc.below * M_PI / 180.0;
		m->travel_rad[1] = t + pc.above * M_PI / 180.0;
	}
}

static void pc_sim(struct rmd_sim_setup *sim)
{
	sim->motors[0].multi_turn_save = false;
	sim->motors[0].start_angle_deg = pc.start_deg;
	sim->motors[0].wrap_rotor = pc.wrap_rotor;
}

static void pc_rig(void)
{
	rig_sim_tweak = pc_sim;
	rig_up(3, pc_tweak);
	rig_sim_tweak = NULL;
	bring_up();
	run(50, false);
}

/* Motor 1's power fails for 300 ms; the loop runs until it is READY again. */
static void pc_power_cycle(void)
{
	struct rmd_sim_fault off = { .kind = RMD_SIM_FAULT_DISAPPEAR, .motor_id = 1, .param = 1 };

	fault_now(&off, 300 * MS);
	run(200, true);
	assert_int_equal(lifecycle(0), RMD_LC_LOST);
	assert_false(snap().m[0].pos_certain);
	run(1300, true);
	set_faults(0, NULL, 0);
	assert_int_equal(lifecycle(0), RMD_LC_READY);
}

/* V3 control replies carry whole degrees (V3 §2.13.3) */
#define PC_TOL (0.5 * M_PI / 180.0 + 1e-6)

/* The in-band cases (test_pos_cycle_in_band()): at several angles, gear ratios, directions. */
static const struct pc_case in_band[] = {
	{ "direct drive, 400 deg", 1.0, 1, 0.0, 400.0, 100.0, 100.0, false, false, false },
	{ "direct drive reversed, -500 deg, zero 0.3", 1.0, -1, 0.3, -500.0, 20.0, 300.0, false,
	  false, false },
	{ "1:6, -100 deg, band 40 deg", 6.0, 1, 0.0, -100.0, 20.0, 20.0, false, false, false },
	{ "1:9 reversed, 725 deg, zero -0.5, band 30 deg", 9.0, -1, -0.5, 725.0, 5.0, 25.0, false,
	  false, false },
	{ "1:9, 10 deg (no wrap), band at its edge", 9.0, 1, 0.0, 10.0, 0.0, 30.0, false, false,
	  false },
	{ "V2 1:6, 250 deg (rmdd unwraps the encoder)", 6.0, 1, 0.0, 250.0, 10.0, 20.0, true, false,
	  false },
	{ "MIT direct drive reversed, 300 deg", 1.0, -1, 0.1, 300.0, 90.0, 90.0, false, true,
	  false },
	/* firmware that keeps only the rotor's angle: 727 deg comes back as 7 deg */
	{ "1:9 rotor wrap, 727 deg, band 30 deg", 9.0, 1, 0.0, 727.0, 10.0, 20.0, false, false,
	  true },
	{ "1:6 rotor wrap reversed, -95 deg, zero 0.2", 6.0, -1, 0.2, -95.0, 25.0, 25.0, false,
	  false, true },
};

/*
 * A joint whose travel band is narrower than one rotor turn at the output
 * (2 pi / gear_ratio) reports its true position after a power cycle, which
 * wrapped the motor's angle (include/rmd/sim.h): at several angles, gear
 * ratios, both directions and zero offsets.
 */
static void test_pos_cycle_in_band(void **state)
{
	(void)state;
	for (size_t k = 0; k < SUITE_N(in_band); k++) {
		struct rmd_snapshot s;

		pc = in_band[k];
		pc_rig();
		s = snap();
		if (!s.m[0].pos_certain || s.m[0].pos_trust != RMD_POS_IN_BAND ||
		    fabs(s.m[0].pos_rad - pc_truth_rad()) > PC_TOL)
			fail_msg("%s: at bring-up: certain %d trust %d pos %g, truth %g", pc.name,
				 s.m[0].pos_certain, s.m[0].pos_trust, s.m[0].pos_rad,
				 pc_truth_rad());
		cmd_clear();
		cmd_motor(1, false, RMD_MODE_TORQUE);
		pc_power_cycle();
		run(20, true);
		/* the motor's own count wrapped: it says something else now */
		if (fabs(pc.start_deg) > 180.0)
			assert_true(fabs(sim_motor(0)->pos_rad * 180.0 / M_PI - pc.start_deg) >
				    90.0);
		s = snap();
		if (!s.m[0].pos_certain || s.m[0].pos_trust != RMD_POS_IN_BAND ||
		    fabs(s.m[0].pos_rad - pc_truth_rad()) > PC_TOL)
			fail_msg("%s: after the power cycle: certain %d trust %d pos %g, truth %g "
				 "(the simulated shaft at %g deg)",
				 pc.name, s.m[0].pos_certain, s.m[0].pos_trust, s.m[0].pos_rad,
				 pc_truth_rad(), sim_motor(0)->pos_rad * 180.0 / M_PI);
		/* the others kept their count (the rig's motors save it) */
		assert_true(s.m[1].pos_certain);
		assert_int_equal(s.m[1].pos_trust, RMD_POS_SAVED);
		rig_down();
	}
}

/*
 * The first position of a motor back from a power cycle is a reply that
 * reads a turn off (forge above): one reading alone would shift the frame
 * its commands are sent in by a turn for good; two that agree decide.
 */
static void test_pos_settle_one_bad_reading(void **state)
{
	struct rmd_snapshot s;

	(void)state;
	pc = in_band[0]; /* direct drive, 400 deg, band 200 deg */
	pc_rig();
	assert_true(snap().m[0].pos_certain);
	cmd_clear();
	cmd_motor(0, false, RMD_MODE_TORQUE);
	memset(&forge, 0, sizeof(forge));
	rig_tap_hook = forge_reply;
	forge.armed = true;
	pc_power_cycle();
	run(20, true);
	forge.armed = false;
	assert_true(forge.done);
	s = snap();
	if (!s.m[0].pos_certain || s.m[0].pos_trust != RMD_POS_IN_BAND ||
	    fabs(s.m[0].pos_rad - pc_truth_rad()) > PC_TOL)
		fail_msg("after the power cycle and one forged reply: certain %d trust %d pos %g, "
			 "truth %g",
			 s.m[0].pos_certain, s.m[0].pos_trust, s.m[0].pos_rad, pc_truth_rad());
	rig_down();
}

/*
 * A joint without a band narrower than one turn: uncertain after the power
 * cycle; a position-mode enable is refused on the wire (no 0xA4 reaches
 * the bus), counted and reported once; torque mode still runs; switching
 * to position while enabled stops it (safe action).
 */
static void test_pos_ambiguous_refused(void **state)
{
	static const struct pc_case cases[] = {
		{ "1:6, no band, 100 deg", 6.0, 1, 0.0, 100.0, -1, 0, false, false, false },
		{ "1:9, band 45 deg", 9.0, -1, 0.2, 300.0, 20.0, 25.0, false, false, false },
		{ "direct drive, no band, 700 deg", 1.0, 1, 0.0, 700.0, -1, 0, false, false,
		  false },
		/* a band beside the joint, [truth + 5, truth + 25] deg: no turn fits it */
		{ "1:9, band beside the truth", 9.0, 1, 0.0, 200.0, -5.0, 25.0, false, false,
		  false },
	};

	(void)state;
	for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
		struct rmd_setpoint *sp;
		unsigned from;
		uint64_t n;

		pc = cases[k];
		pc_rig();
		assert_false(snap().m[0].pos_certain);
		assert_int_equal(snap().m[0].pos_trust, pc.below < 0 && pc.below != -1 ?
								RMD_POS_OUTSIDE :
								RMD_POS_AMBIGUOUS);
		cmd_clear();
		cmd_motor(1, false, RMD_MODE_TORQUE);
		pc_power_cycle();
		cmd_motor(0, false, RMD_MODE_TORQUE); /* back from LOST: enable = 0 first */
		run(20, true);
		assert_false(snap().m[0].pos_certain);
		/* position mode: refused, never on the wire */
		from = trace_n;
		R.nev = 0;
		sp = cmd_motor(0, true, RMD_MODE_POSITION);
		sp->pos_rad = pc_truth_rad();
		n = ignored_over(300, RMD_IGN_POS_UNCERTAIN);
		if (n != 300)
			fail_msg("%s: %llu of 300 position enables counted as refused", pc.name,
				 (unsigned long long)n);
		assert_int_equal(lifecycle(0), RMD_LC_READY);
		assert_int_equal(sent_to(0, 0xA4, from), 0);
		assert_int_equal(sent_to(0, 0x77, from), 0);
		assert_int_equal(count_ev(RMD_EV_POS_REFUSED, 0), 1);
		/* torque mode runs */
		from = trace_n;
		sp = cmd_motor(0, true, RMD_MODE_TORQUE);
		sp->torque_nm = 0.1;
		run(50, true);
		assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
		assert_true(sent_to(0, 0xA1, from) > 40);
		/* switching to position while enabled: the safe action, no 0xA4 */
		from = trace_n;
		sp = cmd_motor(0, true, RMD_MODE_POSITION);
		sp->pos_rad = pc_truth_rad();
		run(50, true);
		assert_int_equal(lifecycle(0), RMD_LC_SAFE);
		assert_int_equal(sent_to(0, 0xA4, from), 0);
		assert_int_equal(sent_to(0, 0x80, from), 1);
		rig_down();
	}
}

/*
 * An MIT motor whose position is uncertain: MIT with kp > 0 is refused (no
 * 0x400 + ID frame), MIT with kp = 0 (damping only) runs, and switching to
 * kp > 0 while it runs stops it.
 */
static void test_pos_uncertain_mit_kp(void **state)
{
	struct rmd_setpoint *sp;
	unsigned from;

	(void)state;
	pc = (struct pc_case){ "MIT, no band", 1.0, 1, 0.0, 500.0, -1, 0, false, true, false };
	pc_rig();
	assert_false(snap().m[0].pos_certain);
	cmd_clear();
	from = trace_n;
	sp = cmd_motor(0, true, RMD_MODE_MIT);
	sp->pos_rad = snap().m[0].pos_rad;
	sp->kp = 5.0;
	sp->kd = 0.5;
	assert_int_equal(ignored_over(100, RMD_IGN_POS_UNCERTAIN), 100);
	assert_int_equal(lifecycle(0), RMD_LC_READY);
	assert_int_equal(sent_to(0, 0x400, from), 0);
	sp->kp = 0.0;
	run(50, true);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_true(sent_to(0, 0x400, from) > 40);
	sp->kp = 5.0;
	run(5, true);
	assert_int_equal(lifecycle(0), RMD_LC_SAFE);
	rig_down();
}

/*
 * A V2 motor reports its rotor's encoder, one rotor turn of it (V2 §3.32);
 * rmdd counts the turns from the 0x92 angle.  Silent (LOST) while it runs
 * to its last target more than half a turn away, it cannot be counted:
 * back, its position is the motor's 0x92 angle again, and a position
 * command puts the shaft where the controller means, not a turn off.
 * Judged on the simulated shaft and on the 0xA4 frames on the wire.
 */
static void v2_pos_tweak(struct rmd_config *cfg)
{
	struct rmd_config_motor *m = &cfg->motors[0];

	m->proto = RMD_PROTO_V2;
	m->mode = RMD_MODE_POSITION;
	m->comm_loss_ms = 0; /* V2 has no 0xB3 (the loader insists) */
	m->gear_ratio = 1.0;
	m->multi_turn_saved = false;
	m->n_travel = 0;
	m->limits.velocity_rad_s = 5.0;
	m->limits.position_min_rad = -2.5;
	m->limits.position_max_rad = 2.5;
}

static void test_v2_silent_turn_recounted(void **state)
{
	struct rmd_sim_fault gone = { .kind = RMD_SIM_FAULT_DISAPPEAR, .motor_id = 1 };
	struct rmd_setpoint *sp;
	struct rmd_snapshot s;
	unsigned from;

	(void)state;
	rig_up(3, v2_pos_tweak);
	bring_up();
	run(50, false);
	cmd_clear();
	sp = cmd_motor(0, true, RMD_MODE_POSITION);
	sp->pos_rad = -2.0;
	sp->max_vel_rad_s = 5.0;
	run(1000, true);
	assert_float_equal(sim_motor(0)->pos_rad, -2.0, 0.01);
	/* the last target, 4.3 rad on: the motor runs there while it is silent */
	sp->pos_rad = 2.3;
	run(2, true);
	fault_now(&gone, 1500 * MS);
	run(1400, true);
	assert_int_equal(lifecycle(0), RMD_LC_LOST);
	assert_float_equal(sim_motor(0)->pos_rad, 2.3, 0.01);
	run(1500, true);
	set_faults(0, NULL, 0);
	s = snap();
	assert_int_equal(s.m[0].lifecycle, RMD_LC_READY);
	if (!s.m[0].pos_certain || fabs(s.m[0].pos_rad - 2.3) > 0.01)
		fail_msg("back: certain %d, position %.4f rad (trust %d); the shaft is at 2.3",
			 s.m[0].pos_certain, s.m[0].pos_rad, s.m[0].pos_trust);
	/* enable = 0, then 1, to a target near where it is */
	cmd_motor(0, false, RMD_MODE_POSITION);
	run(2, true);
	from = trace_n;
	sp = cmd_motor(0, true, RMD_MODE_POSITION);
	sp->pos_rad = 2.0;
	sp->max_vel_rad_s = 5.0;
	run(500, true);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_true(sent_to(0, 0xA4, from) > 400);
	for (unsigned k = from; k < trace_n; k++) {
		const struct rmd_frame *f = &trace[k].f;
		int32_t centideg;

		if (f->can_id != 0x141 || f->data[0] != 0xA4)
			continue;
		/* V2 §3.40: the angle, int32 0.01 deg at bytes 4..7 */
		centideg = (int32_t)((uint32_t)f->data[4] | (uint32_t)f->data[5] << 8 |
				     (uint32_t)f->data[6] << 16 | (uint32_t)f->data[7] << 24);
		if (fabs(centideg / 100.0 - 2.0 * 180.0 / M_PI) > 0.02)
			fail_msg("frame %u: 0xA4 to %.2f deg, want %.2f", k, centideg / 100.0,
				 2.0 * 180.0 / M_PI);
	}
	assert_float_equal(sim_motor(0)->pos_rad, 2.0, 0.01);
	rig_down();
}

/*
 * V2 firmware that does not know 0x92 (rmd/sim.h ignores_cmd): the
 * encoder has no reference, so the motor reports no position, and every
 * other read asks 0x92 again.  The reads in between keep it fed: never
 * LOST, a speed command streams on the wire; a position command, which
 * needs the position, is refused and no 0xA4 goes out.
 */
static void test_v2_without_angle_command(void **state)
{
	struct rmd_snapshot s;
	unsigned from, asks, reads, a2;

	(void)state;
	rig_up(3, v2_pos_tweak);
	sim_motor(0)->p.ignores_cmd = 0x92;
	bring_up();
	assert_false(R.report.motor[0].v2_angle);
	from = trace_n;
	run(400, false);
	s = snap();
	assert_int_equal(s.m[0].lifecycle, RMD_LC_READY);
	assert_false(s.m[0].pos_certain);
	assert_int_equal(s.m[0].pos_rx_ns, 0);
	asks = sent_to(0, 0x92, from);
	reads = sent_to(0, 0x9C, from) + sent_to(0, 0x9A, from) + asks;
	if (asks < reads / 3 || asks > reads * 2 / 3)
		fail_msg("READY: %u of %u reads ask 0x92, want about half", asks, reads);
	/* enabled in speed mode: fed by the reads that answer */
	cmd_clear();
	cmd_motor(0, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	from = trace_n;
	for (unsigned k = 0; k < 10; k++) {
		run(100, true);
		assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	}
	a2 = sent_to(0, 0xA2, from);
	asks = sent_to(0, 0x92, from);
	/* one frame a cycle: the setpoint, or now and then the status read in its place */
	reads = sent_to(0, 0x9A, from) + sent_to(0, 0x9C, from);
	if (a2 + reads + asks < 995 || a2 < 950 || !asks || asks > reads + 1)
		fail_msg("ENABLED: %u 0xA2, %u status reads and %u 0x92 in 1000 cycles", a2, reads,
			 asks);
	assert_float_equal(sim_motor(0)->vel_rad_s, 1.0, 0.05);
	assert_false(snap().m[0].pos_certain);
	/* a position command needs a position: refused, nothing moves the shaft there */
	cmd_motor(0, false, RMD_MODE_SPEED);
	run(20, true);
	from = trace_n;
	cmd_motor(0, true, RMD_MODE_POSITION)->pos_rad = 1.0;
	run(200, true);
	assert_int_not_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_int_equal(sent_to(0, 0xA4, from), 0);
	assert_int_equal(sent_to(0, 0xA3, from), 0);
	rig_down();
}

/*
 * V2 §3.32: each reply carries one rotor turn of encoder, so the count
 * holds only while the rotor turns less than half a turn between two.  At
 * 100 Hz a rotor at 60 turns/s turns 0.6 of one: the step is ambiguous.
 * The reported position is then absent, never a count that aliased
 * backwards: during the spin every position reported is where the shaft
 * was (within the motion of one cycle), and stopped again the position is
 * the shaft's, counted from a fresh 0x92 angle.
 */
static void v2_fast_tweak(struct rmd_config *cfg)
{
	v2_pos_tweak(cfg);
	cfg->loop.rate_hz = 100;
	cfg->motors[0].mode = RMD_MODE_SPEED;
	cfg->motors[0].limits.velocity_rad_s = 500.0;
	cfg->motors[0].limits.position_min_rad = -1e5;
	cfg->motors[0].limits.position_max_rad = 1e5;
}

static void v2_fast_sim(struct rmd_sim_setup *sim)
{
	sim->motors[0].max_speed_dps = 1e5;
	sim->motors[0].fw_max_speed_dps = 1e5;
	/* the no-load speed grows with the supply (back EMF) */
	sim->motors[0].supply_v = 900.0;
	sim->motors[0].over_voltage_v = 1000.0;
}

static void test_v2_count_at_speed(void **state)
{
	const double vel = 60.0 * 2.0 * M_PI; /* 60 rotor turns a second, gear 1 */
	unsigned shown = 0, fast = 0;
	struct rmd_snapshot s;
	int64_t last_rx = 0;

	(void)state;
	rig_sim_tweak = v2_fast_sim;
	rig_up(3, v2_fast_tweak);
	rig_sim_tweak = NULL;
	bring_up();
	run(20, false);
	cmd_clear();
	cmd_motor(0, true, RMD_MODE_SPEED)->vel_rad_s = vel;
	for (unsigned k = 0; k < 400; k++) {
		double v, err;

		run(1, true);
		s = snap();
		v = sim_motor(0)->vel_rad_s;
		if (fabs(v) > M_PI * 100.0) /* over half a rotor turn a cycle */
			fast++;
		if (!s.m[0].pos_rx_ns || s.m[0].pos_rx_ns == last_rx)
			continue;
		last_rx = s.m[0].pos_rx_ns;
		shown++;
		err = fabs(s.m[0].pos_rad - sim_motor(0)->pos_rad);
		if (err > fabs(v) * 0.01 + 0.05)
			fail_msg("cycle %u at %.0f rad/s: position %.3f rad, the shaft at %.3f", k,
				 v, s.m[0].pos_rad, sim_motor(0)->pos_rad);
	}
	if (fast < 100)
		fail_msg("the rotor ran over half a turn a cycle in only %u of 400 cycles", fast);
	cmd_motor(0, true, RMD_MODE_SPEED)->vel_rad_s = 0.0;
	run(300, true);
	s = snap();
	assert_int_equal(s.m[0].lifecycle, RMD_LC_ENABLED);
	if (fabs(s.m[0].pos_rad - sim_motor(0)->pos_rad) > 0.01)
		fail_msg("stopped: position %.4f rad, the shaft at %.4f (%u positions in the spin)",
			 s.m[0].pos_rad, sim_motor(0)->pos_rad, shown);
	rig_down();
}

static struct rmd_home homes;

/* Motor i homed: at pos_rad now, or as reported. */
static void home(unsigned i, bool as_reported, double pos_rad)
{
	homes.seq[i]++;
	homes.as_reported[i] = as_reported;
	homes.pos_rad[i] = pos_rad;
	rmd_latest_put(&R.io.homes, &homes);
}

/*
 * Homing (rmd.home_t through the bridge) makes an uncertain position
 * certain without moving the motor: refused while the motor is enabled;
 * applied as a shift of the reported frame; then a position command goes
 * where the controller means, in both directions and with a zero offset.
 */
static void test_pos_homed(void **state)
{
	static const struct pc_case cases[] = {
		{ "1:6, 460 deg", 6.0, 1, 0.0, 460.0, -1, 0, false, false, false },
		{ "1:9 reversed, -400 deg, zero 0.4", 9.0, -1, 0.4, -400.0, -1, 0, false, false,
		  false },
	};

	(void)state;
	for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
		struct rmd_setpoint *sp;
		struct rmd_snapshot s;
		unsigned from;
		double native0;

		pc = cases[k];
		memset(&homes, 0, sizeof(homes));
		pc_rig();
		cmd_clear();
		cmd_motor(1, false, RMD_MODE_TORQUE);
		pc_power_cycle();
		cmd_motor(0, false, RMD_MODE_TORQUE);
		run(20, true);
		s = snap();
		assert_false(s.m[0].pos_certain);
		/* the motor wrapped: rmdd reports where it says it is, off by turns */
		assert_true(fabs(s.m[0].pos_rad - pc_truth_rad()) > 0.5);
		/* enabled (torque): homing refused */
		R.nev = 0;
		sp = cmd_motor(0, true, RMD_MODE_TORQUE);
		run(20, true);
		assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
		home(0, false, pc_truth_rad());
		run(5, true);
		assert_false(snap().m[0].pos_certain);
		assert_int_equal(count_ev(RMD_EV_HOME_REFUSED, 0), 1);
		/* disabled: homed, nothing moves, the position is the truth */
		cmd_motor(0, false, RMD_MODE_TORQUE);
		run(20, true);
		native0 = sim_motor(0)->pos_rad;
		from = trace_n;
		home(0, false, pc_truth_rad());
		run(20, true);
		s = snap();
		assert_true(s.m[0].pos_certain);
		assert_int_equal(s.m[0].pos_trust, RMD_POS_HOMED);
		assert_float_equal(s.m[0].pos_rad, pc_truth_rad(), PC_TOL);
		for (unsigned t = from; t < trace_n; t++)
			if (trace[t].f.can_id == 0x141 && moves_frame(&trace[t].f))
				fail_msg("%s: homing sent 0x%02X", pc.name, trace[t].f.data[0]);
		/* position mode now runs: 0.2 rad further, and the motor goes there */
		from = trace_n;
		sp = cmd_motor(0, true, RMD_MODE_POSITION);
		sp->pos_rad = pc_truth_rad() + 0.2;
		sp->max_vel_rad_s = 2.0;
		run(1000, true);
		assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
		assert_true(sent_to(0, 0xA4, from) > 900);
		assert_float_equal(snap().m[0].pos_rad, pc_truth_rad() + 0.2, PC_TOL + 0.01);
		assert_float_equal(sim_motor(0)->pos_rad - native0, pc.dir * 0.2, 0.02);
		rig_down();
	}
}

/*
 * Issue 33 point 6: a home outside the joint's travel (90 sent for 1.57
 * rad, degrees for radians) would move the frame so that setpoints within
 * the limits drive the joint past them.  Refused, reported and counted,
 * with a travel band and with position limits alone; a position command
 * afterwards goes where the controller means (the simulated shaft).
 */
static void test_home_outside_travel(void **state)
{
	/* 1:6 (a 60 deg period at the output), its band 100 deg: homing decides it */
	static const struct pc_case cases[] = {
		{ "travel band", 6.0, 1, 0.0, 460.0, 50.0, 50.0, false, false, false },
		{ "limits only", 6.0, 1, 0.0, 460.0, -1, 0, false, false, false },
	};

	(void)state;
	for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
		struct rmd_setpoint *sp;
		struct rmd_health h;
		unsigned from;
		double native0;

		pc = cases[k];
		memset(&homes, 0, sizeof(homes));
		pc_limits_rad = pc.below == -1 ? 0.9 : 0.0; /* the limits are the band */
		pc_rig();
		pc_limits_rad = 0.0;
		cmd_clear();
		cmd_motor(0, false, RMD_MODE_POSITION);
		cmd_motor(1, false, RMD_MODE_TORQUE);
		run(20, true);
		/* homed where it is: certain */
		home(0, false, pc_truth_rad());
		run(5, true);
		assert_int_equal(snap().m[0].pos_trust, RMD_POS_HOMED);
		/* degrees for radians: refused, the frame stays */
		R.nev = 0;
		home(0, false, pc_truth_rad() * 180.0 / M_PI);
		run(5, true);
		assert_int_equal(count_ev(RMD_EV_HOME_REFUSED, 0), 1);
		for (unsigned e = 0; e < R.nev; e++)
			if (R.ev[e].kind == RMD_EV_HOME_REFUSED)
				assert_int_equal(R.ev[e].a, RMD_HOME_OUTSIDE);
		assert_float_equal(snap().m[0].pos_rad, pc_truth_rad(), PC_TOL);
		assert_true(rmd_loop_get_health(R.l, &h));
		run((unsigned)(R.io.cfg.lcm.health_period_ms + 10), true);
		assert_true(rmd_loop_get_health(R.l, &h));
		assert_int_equal(h.homes_refused, 1);
		/* as reported: the same rule, on what it reports (here: inside) */
		home(0, true, 0.0);
		run(5, true);
		assert_int_equal(count_ev(RMD_EV_HOME_REFUSED, 0), 1);
		/* a position 0.2 rad on goes 0.2 rad on */
		native0 = sim_motor(0)->pos_rad;
		from = trace_n;
		sp = cmd_motor(0, true, RMD_MODE_POSITION);
		sp->pos_rad = pc_truth_rad() + 0.2;
		sp->max_vel_rad_s = 2.0;
		run(1000, true);
		assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
		assert_true(sent_to(0, 0xA4, from) > 900);
		if (fabs(sim_motor(0)->pos_rad - native0 - 0.2) > 0.02)
			fail_msg("%s: the shaft turned %g rad, not 0.2", pc.name,
				 sim_motor(0)->pos_rad - native0);
		rig_down();
	}
}

SUITE_MAIN("loop_position", NULL, NULL,
	   {
		   cmocka_unit_test(test_pos_cycle_in_band),
		   cmocka_unit_test(test_v2_silent_turn_recounted),
		   cmocka_unit_test(test_v2_without_angle_command),
		   cmocka_unit_test(test_v2_count_at_speed),
		   cmocka_unit_test(test_pos_settle_one_bad_reading),
		   cmocka_unit_test(test_pos_ambiguous_refused),
		   cmocka_unit_test(test_pos_homed),
		   cmocka_unit_test(test_home_outside_travel),
		   cmocka_unit_test(test_pos_uncertain_mit_kp),
	   })

// SPDX-License-Identifier: MIT
/*
 * rt loop tests: rmd_loop_cycle() driven with an injected clock over
 * in-process simulated buses (rmd_bus_sim_open(); the sim's time follows
 * the now_ns each call passes).  A tap on every sim bus records the frames
 * the host put on the wire, so a test checks what actually went out.
 *
 * Covered: bring-up and its report; READY motors are read, never moved;
 * an enabled position command moves a motor to its target; reply latency
 * and age; frames per cycle as planned; missed replies -> LOST -> safe
 * action, re-probe -> READY and not ENABLED; lost_motor_action all; error
 * flags -> FAULT -> READY; a comm-loss trip (0xF1, the echoed first frame);
 * the host watchdog trips after command_timeout_ms + 1 cycle and a new
 * enable lifts it; NaN never reaches the wire; stop_motors; overruns; the
 * V2 0x280 frame; MIT motors; health.
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
#include <time.h>

#include <cmocka.h>

#include "rmd/bus_sim.h"
#include "rmd/config.h"
#include "rmd/config_yaml.h"
#include "rmd/bringup.h"
#include "rmd/bus_open.h"
#include "rmd/loop.h"
#include "rmd/multiturn.h"
#include "rmd/plan.h"
#include "rmd/sim.h"
#include "rmd/sim_wire.h"
#include "rmd/spsc.h"
#include "rmd/state.h"

#include "harness/clock.h"
#include "harness/loop_io.h"
#include "harness/rig.h"
#include "harness/v2_batch.h"

#define MS INT64_C(1000000)
#define US INT64_C(1000)
#define TRACE_MAX 65536
#define EVENTS_MAX 8192

/* ---- frames the host put on the wire --------------------------------------- */

struct sent {
	unsigned bus;
	struct rmd_frame f;
	int64_t t_ns; /* caller's clock, start of frame */
};

static struct sent trace[TRACE_MAX];
static unsigned trace_n;

/* ---- the rig ---------------------------------------------------------------- */

struct rig {
	int64_t epoch[RMD_MAX_BUSES]; /* caller time at sim time 0 */
	struct rig_loop io;	      /* configuration, plan, buses, channels */
	struct rmd_loop *l;
	struct rmd_command cmd;	   /* the command the test builds */
	struct rmd_bringup report; /* of the last bring-up */
};

static struct rig R;
/* when set, rig_up() hands it the simulated motors' setup before it opens the buses */
static void (*rig_sim_tweak)(struct rmd_sim_setup *sim);
static struct rmd_event evs[EVENTS_MAX];
static unsigned nev;

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

static void forge_reply(unsigned b, const struct rmd_sim_pending *p)
{
	struct rmd_frame *f = (struct rmd_frame *)&p->f; /* the wire's own frame, not const */
	int16_t deg;

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

/* The first frame a motor put on the wire with identifier watch_id (caller's clock; 0: none). */
static uint32_t watch_id;
static int64_t watch_first_ns;

static void tap(void *ctx, const struct rmd_sim_pending *p, int64_t start_ns, int64_t eof_ns)
{
	unsigned b = (unsigned)(uintptr_t)ctx;

	(void)eof_ns;
	forge_reply(b, p);
	if (p->src != RMD_SIM_SRC_HOST && watch_id && p->f.can_id == watch_id && !watch_first_ns)
		watch_first_ns = start_ns + R.epoch[b];
	if (p->src != RMD_SIM_SRC_HOST || trace_n >= TRACE_MAX)
		return;
	trace[trace_n++] = (struct sent){ .bus = b, .f = p->f, .t_ns = start_ns + R.epoch[b] };
}

static void events_pump(void)
{
	struct rmd_event e;

	while (rmd_ring_pop(&R.io.events, &e))
		if (nev < EVENTS_MAX)
			evs[nev++] = e;
}

static unsigned count_ev(unsigned kind, int motor)
{
	unsigned n = 0;

	events_pump();
	for (unsigned k = 0; k < nev; k++)
		if (evs[k].kind == kind && (motor < 0 || evs[k].motor == motor))
			n++;
	return n;
}

typedef void tweak_fn(struct rmd_config *cfg);

/* Every sim motor follows its config entry (after a tweak changed it). */
static void sync_sim(struct rmd_config *cfg)
{
	for (unsigned i = 0; i < cfg->n_motors; i++) {
		struct rmd_config_motor *m = &cfg->motors[i];
		struct rmd_sim_motor_params *p = &R.io.sim.motors[i];

		p->id = m->id;
		p->proto = m->proto;
		p->mit = m->mit;
		p->gear_ratio = m->gear_ratio;
		if (m->torque_constant_nm_a > 0)
			p->kt_nm_a = m->torque_constant_nm_a;
	}
}

static void open_buses(void)
{
	rig_open_buses(&R.io.cfg, &R.io.sim, R.io.buses);
	for (unsigned b = 0; b < R.io.cfg.n_buses; b++)
		rmd_sim_wire_set_tap(rmd_bus_sim_get(&R.io.buses[b]), tap, (void *)(uintptr_t)b);
}

/*
 * n V3 motors three to a sim bus (rmd_config_sim_default()), tweaked, and a
 * loop on them, on the injected clock or (real) on CLOCK_MONOTONIC.
 */
static void rig_up_clock(unsigned n, tweak_fn *tweak, bool real)
{
	struct rmd_loop_opts o;
	char err[1024];
	int r;

	memset(&R, 0, sizeof(R));
	trace_n = 0;
	nev = 0;
	t_now = 1000 * MS;
	assert_int_equal(rmd_config_sim_default(&R.io.cfg, &R.io.sim, n), 0);
	R.io.cfg.safety.safe_action = RMD_SAFE_STOP;
	R.io.cfg.safety.lost_motor_action = RMD_LOST_MOTOR;
	if (tweak)
		tweak(&R.io.cfg);
	sync_sim(&R.io.cfg);
	if (rig_sim_tweak)
		rig_sim_tweak(&R.io.sim);
	r = rmd_plan_build(&R.io.cfg, &R.io.plan, err, sizeof(err));
	if (r)
		fail_msg("plan: %s", err);
	open_buses();
	assert_int_equal(rig_loop_opts(&R.io, &o), 0);
	if (real) { /* the loop's own clock */
		o.now_ns = NULL;
		o.sleep_ns = NULL;
	}
	R.l = rmd_loop_new(&o, err, sizeof(err));
	if (!R.l)
		fail_msg("rmd_loop_new: %s", err);
}

static void rig_up(unsigned n, tweak_fn *tweak)
{
	rig_up_clock(n, tweak, false);
}

static void rig_down(void)
{
	rmd_loop_free(R.l);
	R.l = NULL;
	for (unsigned b = 0; b < R.io.cfg.n_buses; b++)
		rmd_bus_close(&R.io.buses[b]);
}

/* Bring-up, then the clock on a whole millisecond; the epochs for the tap. */
static void bring_up(void)
{
	int r = rmd_loop_bringup(R.l, &R.report);

	if (r)
		fail_msg("bring-up: %d", r);
	t_now = (t_now / MS + 1) * MS;
	for (unsigned b = 0; b < R.io.cfg.n_buses; b++)
		R.epoch[b] = t_now - rmd_bus_sim_time_ns(&R.io.buses[b], t_now);
}

static int64_t period(void)
{
	return R.io.plan.period_ns;
}

/* n cycles, one period apart; with_cmd: publish R.cmd before each. */
static void run(unsigned n, bool with_cmd)
{
	for (unsigned k = 0; k < n; k++) {
		if (with_cmd) {
			R.cmd.rx_ns = t_now;
			R.cmd.seq++;
			rmd_latest_put(&R.io.cmds, &R.cmd);
		}
		rmd_loop_cycle(R.l, t_now);
		t_now += period();
	}
	events_pump();
}

/* How many commands the loop ignored for `why` over n cycles run with R.cmd. */
static uint64_t ignored_over(unsigned n, enum rmd_ignore why)
{
	struct rmd_loop_counters c0, c1;

	rmd_loop_get_counters(R.l, &c0);
	run(n, true);
	rmd_loop_get_counters(R.l, &c1);
	return c1.ignored[why] - c0.ignored[why];
}

static void cmd_clear(void)
{
	memset(&R.cmd, 0, sizeof(R.cmd));
}

static struct rmd_setpoint *cmd_motor(unsigned i, bool enable, enum rmd_mode mode)
{
	struct rmd_setpoint *sp = &R.cmd.m[i];

	R.cmd.present |= 1u << i;
	memset(sp, 0, sizeof(*sp));
	sp->enable = enable;
	sp->mode = (uint8_t)mode;
	return sp;
}

static struct rmd_snapshot snap(void)
{
	struct rmd_snapshot s;

	rmd_loop_get_snapshot(R.l, &s);
	return s;
}

static struct rmd_sim_motor *sim_motor(unsigned i)
{
	const struct rmd_config_motor *m = &R.io.cfg.motors[i];

	return rmd_sim_wire_motor(rmd_bus_sim_get(&R.io.buses[m->bus]), m->id);
}

static unsigned lifecycle(unsigned i)
{
	return snap().m[i].lifecycle;
}

/* Host frames to motor i (its 0x140 + ID or 0x400 + ID) with command byte cmd since trace[from]. */
static unsigned sent_to(unsigned i, int cmd, unsigned from)
{
	const struct rmd_config_motor *m = &R.io.cfg.motors[i];
	unsigned n = 0;

	for (unsigned k = from; k < trace_n; k++) {
		const struct sent *s = &trace[k];

		if (s->bus != m->bus)
			continue;
		if (cmd == 0x400 && s->f.can_id == 0x400u + m->id)
			n++;
		else if (cmd != 0x400 && s->f.can_id == 0x140u + m->id && s->f.data[0] == cmd)
			n++;
	}
	return n;
}

static bool moves_frame(const struct rmd_frame *f)
{
	uint8_t c = f->data[0];

	if (f->can_id >= 0x400 || f->can_id == 0x280)
		return true;
	return (c >= 0xA1 && c <= 0xA8) || c == 0x77 || c == 0x88;
}

/* n 0 clears the table (f then points at a dummy: rmd_sim_wire_set_faults() memcpy()s it) */
static void set_faults(unsigned bus, const struct rmd_sim_fault *f, size_t n)
{
	static const struct rmd_sim_fault none;

	assert_int_equal(
		rmd_sim_wire_set_faults(rmd_bus_sim_get(&R.io.buses[bus]), f ? f : &none, n), 0);
}

static int64_t sim_time(unsigned bus)
{
	return rmd_bus_sim_time_ns(&R.io.buses[bus], t_now);
}

/*
 * Fault f on bus 0 from the sim's time now, for for_ns (0: until cleared);
 * returns trace_n, where its effects begin.
 */
static unsigned fault_now(struct rmd_sim_fault *f, int64_t for_ns)
{
	f->start_ns = sim_time(0);
	if (for_ns)
		f->end_ns = f->start_ns + for_ns;
	set_faults(0, f, 1);
	return trace_n;
}

/* Three motors brought up, the first n running in speed mode at vel_rad_s for `cycles`. */
static void up_at_speed(tweak_fn *tweak, unsigned n, double vel_rad_s, unsigned cycles)
{
	rig_up(3, tweak);
	bring_up();
	cmd_clear();
	for (unsigned i = 0; i < n; i++)
		cmd_motor(i, true, RMD_MODE_SPEED)->vel_rad_s = vel_rad_s;
	run(cycles, true);
}

/* ---- tests ------------------------------------------------------------------- */

static void test_bringup_ready_not_moved(void **state)
{
	struct rmd_loop_counters c;
	struct rmd_snapshot s;
	uint64_t tx0, want = 0;
	unsigned n = 0;

	(void)state;
	rig_up(3, NULL);
	bring_up();
	/* each found: X8S2V10, firmware 20220206, 48.0 V, 25 °C, no errors */
	assert_int_equal(R.report.n_motors, 3);
	assert_int_equal(R.report.missing, 0);
	for (unsigned i = 0; i < 3; i++) {
		/* 0xB3 is written last, to every motor, after all probes */
		rig_assert_default_motor(&R.report.motor[i]);
		n++;
	}
	assert_int_equal(n, 3);
	assert_int_equal(R.report.comm_loss_ms, 100);
	assert_int_equal(R.report.unexpected_ids[0], 0);
	for (unsigned i = 0; i < 3; i++) {
		assert_int_equal(lifecycle(i), RMD_LC_READY);
		assert_int_equal(sim_motor(i)->ram.comm_timeout_ms, 100);
	}

	/* no command: polled for 2 s, never moved, frames exactly as planned */
	tx0 = R.io.buses[0].stats.tx_frames;
	for (unsigned k = 0; k < 2000; k++) {
		struct rmd_plan_slot slots[RMD_PLAN_MAX_SLOTS];

		want += rmd_plan_cycle(&R.io.plan, 0, k, slots);
	}
	trace_n = 0;
	run(2000, false);
	assert_int_equal(R.io.buses[0].stats.tx_frames - tx0, want);
	for (unsigned k = 0; k < trace_n; k++)
		if (moves_frame(&trace[k].f))
			fail_msg("frame %03X#%02X sent to a READY motor", trace[k].f.can_id,
				 trace[k].f.data[0]);
	s = snap();
	for (unsigned i = 0; i < 3; i++) {
		struct rmd_sim_motor *m = sim_motor(i);

		assert_int_equal(s.m[i].lifecycle, RMD_LC_READY);
		assert_int_equal(m->ctrl, RMD_SIM_OFF);
		assert_true(m->brake_locked);
		assert_false(m->comm_lost); /* the reads keep 0xB3 from tripping */
		assert_true(s.m[i].reply_age_cycles <= 1);
		assert_int_equal(s.m[i].missed_replies, 0);
		assert_float_equal(s.m[i].temp_c, 25.0, 1.0);
		assert_float_equal(s.m[i].voltage_v, 48.0, 0.05);
		assert_true(isfinite(s.m[i].pos_rad));
		assert_int_equal(s.m[i].error_code, 0);
	}
	rmd_loop_get_counters(R.l, &c);
	assert_int_equal(c.missed, 0);
	assert_int_equal(c.unexpected, 0);
	assert_true(c.replies >= want - 6);
	rig_down();
}

static void test_bringup_unexpected(void **state)
{
	struct rmd_sim_motor_params p;

	(void)state;
	rig_up(3, NULL);
	/* a motor on the wire that the configuration does not know */
	p = R.io.sim.motors[0];
	p.id = 7;
	p.seed = 0;
	assert_true(rmd_sim_wire_add_motor(rmd_bus_sim_get(&R.io.buses[0]), &p, 0) >= 0);
	bring_up();
	/* sim0: motor 7 answers, but is not configured */
	assert_int_equal(R.report.unexpected_ids[0], 1u << (7 - 1));
	/* and it is never spoken to again */
	trace_n = 0;
	run(500, false);
	for (unsigned k = 0; k < trace_n; k++)
		assert_int_not_equal(trace[k].f.can_id, 0x147);
	rig_down();
}

static void missing_start(struct rmd_config *cfg)
{
	cfg->probe.on_missing = RMD_MISSING_START;
}

static void test_bringup_missing(void **state)
{
	struct rmd_sim_fault gone = {
		.kind = RMD_SIM_FAULT_DISAPPEAR, .motor_id = 2, .start_ns = 0, .end_ns = 0
	};

	(void)state;
	/* refuse: -ENODEV, and the report says which and how it was asked */
	rig_up(3, NULL);
	set_faults(0, &gone, 1);
	assert_int_equal(rmd_loop_bringup(R.l, &R.report), -ENODEV);
	assert_int_equal(R.report.missing, 1);
	assert_int_equal(R.report.motor[1].state, RMD_BRINGUP_MISSING);
	assert_int_equal(R.report.motor[1].probe_cmd, 0xB5);
	assert_int_equal(R.report.motor[1].tries, 3);
	assert_int_equal(R.report.motor[1].timeout_ns, 5 * MS);
	assert_int_equal(R.report.motor[1].b3, RMD_B3_NOT_APPLICABLE);
	assert_int_equal(R.report.motor[0].state, RMD_BRINGUP_FOUND);
	assert_int_equal(R.report.motor[2].state, RMD_BRINGUP_FOUND);
	assert_string_equal(R.report.motor[2].model, "X8S2V10");
	rig_down();

	/* start: the others run, the missing one is LOST and re-probed at 2 Hz */
	rig_up(3, missing_start);
	set_faults(0, &gone, 1);
	assert_int_equal(rmd_loop_bringup(R.l, &R.report), 0);
	t_now = (t_now / MS + 1) * MS;
	assert_int_equal(lifecycle(1), RMD_LC_LOST);
	assert_int_equal(lifecycle(0), RMD_LC_READY);
	trace_n = 0;
	run(2000, false);
	{
		unsigned probes = sent_to(1, 0x9A, 0);

		if (probes < 4 || probes > 5)
			fail_msg("%u re-probes in 2 s", probes);
	}
	set_faults(0, NULL, 0); /* it comes back */
	run(600, false);
	assert_int_equal(lifecycle(1), RMD_LC_READY);
	rig_down();
}

static void position_tweak(struct rmd_config *cfg)
{
	cfg->motors[0].mode = RMD_MODE_POSITION;
	cfg->motors[0].limits.velocity_rad_s = 5.0;
	cfg->motors[0].limits.position_min_rad = -2.0;
	cfg->motors[0].limits.position_max_rad = 2.0;
}

static void test_enable_position_moves(void **state)
{
	struct rmd_setpoint *sp;
	struct rmd_snapshot s;
	struct rmd_sim_motor *m;

	(void)state;
	rig_up(3, position_tweak);
	bring_up();
	run(100, false);
	cmd_clear();
	sp = cmd_motor(0, true, RMD_MODE_POSITION);
	sp->pos_rad = 1.0;
	sp->max_vel_rad_s = 3.0;
	run(1500, true);
	s = snap();
	m = sim_motor(0);
	assert_int_equal(s.m[0].lifecycle, RMD_LC_ENABLED);
	assert_int_equal(s.m[0].mode, RMD_MODE_POSITION);
	/* V3 control replies carry whole degrees (V3 §2.13.3) */
	assert_float_equal(s.m[0].pos_rad, 1.0, 0.6 * M_PI / 180.0 + 0.001);
	assert_float_equal(m->pos_rad, 1.0, 0.01);
	assert_float_equal(s.m[0].vel_rad_s, 0.0, 0.05);
	/* the others were not enabled and did not move */
	assert_int_equal(s.m[1].lifecycle, RMD_LC_READY);
	assert_int_equal(sim_motor(1)->ctrl, RMD_SIM_OFF);
	/* docs/design.md: answers 0.5-0.8 ms after the request, plus wire time */
	for (unsigned i = 0; i < 3; i++) {
		if (s.m[i].reply_latency_ns < 500 * US || s.m[i].reply_latency_ns > 1200 * US)
			fail_msg("motor %u: latency %lld ns", i,
				 (long long)s.m[i].reply_latency_ns);
		assert_true(s.m[i].reply_age_cycles <= 1);
		assert_int_equal(s.m[i].missed_replies, 0);
	}
	assert_true(s.m[0].reply_latency_ns <= 900 * US);
	if (getenv("RMD_TEST_VERBOSE"))
		for (unsigned i = 0; i < 3; i++)
			print_message("motor %u: latency %lld us, age %u\n", i,
				      (long long)(s.m[i].reply_latency_ns / US),
				      s.m[i].reply_age_cycles);
	/* a target beyond the window is clamped to it */
	sp->pos_rad = 10.0;
	run(1500, true);
	assert_float_equal(sim_motor(0)->pos_rad, 2.0, 0.01);
	rig_down();
}

/* Three motors on one bus, enabled in speed mode at 1 rad/s for 200 cycles. */
static void three_at_speed(void)
{
	rig_up(3, NULL);
	bring_up();
	cmd_clear();
	for (unsigned i = 0; i < 3; i++)
		cmd_motor(i, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	run(200, true);
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
}

/*
 * Motor 2 alone got the safe action: one event, its stop (0x80) on the wire
 * since trace[from] and its output off; motors 1 and 3 still ENABLED.
 * Runs 5 cycles.
 */
static void assert_motor2_alone_stopped(unsigned from)
{
	assert_int_equal(count_ev(RMD_EV_SAFE_ACTION, 1), 1);
	assert_int_equal(count_ev(RMD_EV_SAFE_ACTION, 0), 0);
	run(5, true);
	assert_int_equal(sent_to(1, 0x80, from), 1);
	assert_int_equal(sim_motor(1)->ctrl, RMD_SIM_OFF);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_int_equal(lifecycle(2), RMD_LC_ENABLED);
}

static void test_lost_and_recovery(void **state)
{
	struct rmd_sim_fault drop = { .kind = RMD_SIM_FAULT_DROP,
				      .motor_id = 2,
				      .probability = 1.0 };
	unsigned n_lost = 0, from;
	struct rmd_snapshot s;

	(void)state;
	three_at_speed();
	assert_int_equal(sim_motor(1)->ctrl, RMD_SIM_SPEED);

	from = fault_now(&drop, 0);
	/* each cycle one more missed reply, N = 10 in a row: LOST */
	for (unsigned k = 0; k < 30 && !n_lost; k++) {
		run(1, true);
		if (lifecycle(1) == RMD_LC_LOST)
			n_lost = k + 1;
	}
	s = snap();
	if (n_lost < R.io.cfg.safety.missed_replies_lost ||
	    n_lost > R.io.cfg.safety.missed_replies_lost + 3)
		fail_msg("lost after %u cycles", n_lost);
	assert_true(s.m[1].missed_replies >= R.io.cfg.safety.missed_replies_lost);
	/* the safe action (stop) went out to it; the others keep running */
	assert_motor2_alone_stopped(from);
	assert_int_equal(sim_motor(0)->ctrl, RMD_SIM_SPEED);

	/* it answers again: READY, not ENABLED, though enable = 1 keeps coming */
	set_faults(0, NULL, 0);
	run(1200, true);
	assert_int_equal(lifecycle(1), RMD_LC_READY);
	assert_int_equal(sim_motor(1)->ctrl, RMD_SIM_OFF);
	/* enable = 0, then 1: the controller means it */
	cmd_motor(1, false, RMD_MODE_SPEED);
	run(2, true);
	cmd_motor(1, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	run(20, true);
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
	assert_int_equal(sim_motor(1)->ctrl, RMD_SIM_SPEED);
	rig_down();
}

static void lost_all(struct rmd_config *cfg)
{
	cfg->safety.lost_motor_action = RMD_LOST_ALL;
	cfg->safety.safe_action = RMD_SAFE_HOLD;
}

static void test_lost_all(void **state)
{
	struct rmd_sim_fault gone = { .kind = RMD_SIM_FAULT_DISAPPEAR, .motor_id = 3 };
	unsigned from;

	(void)state;
	up_at_speed(lost_all, 3, 2.0, 100);
	from = fault_now(&gone, 0);
	run(30, true);
	assert_int_equal(lifecycle(2), RMD_LC_LOST);
	assert_int_equal(lifecycle(0), RMD_LC_SAFE);
	assert_int_equal(lifecycle(1), RMD_LC_SAFE);
	assert_int_equal(count_ev(RMD_EV_SAFE_ACTION, -1), 3);
	/* hold: 0x81 to each */
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(sent_to(i, 0x81, from), 1);
	assert_int_equal(sim_motor(0)->ctrl, RMD_SIM_HOLD);
	/* the streaming enable does not restart them ... */
	run(50, true);
	assert_int_equal(lifecycle(0), RMD_LC_SAFE);
	/* ... an enable = 0 first does */
	cmd_motor(0, false, RMD_MODE_SPEED);
	run(2, true);
	cmd_motor(0, true, RMD_MODE_SPEED)->vel_rad_s = 2.0;
	run(5, true);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_int_equal(lifecycle(1), RMD_LC_SAFE);
	rig_down();
}

static void test_fault_flags(void **state)
{
	struct rmd_sim_fault hot = { .kind = RMD_SIM_FAULT_ERROR_FLAG,
				     .motor_id = 1,
				     .param = RMD_SIM_ERR_OVER_TEMP };
	struct rmd_snapshot s;

	(void)state;
	rig_up(3, NULL);
	bring_up();
	cmd_clear();
	cmd_motor(0, true, RMD_MODE_TORQUE)->torque_nm = 0.0;
	run(50, true);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	fault_now(&hot, 500 * MS);
	run(300, true); /* 0x9A polls at 10 Hz */
	s = snap();
	assert_int_equal(s.m[0].lifecycle, RMD_LC_FAULT);
	assert_int_equal(s.m[0].error_code, RMD_SIM_ERR_OVER_TEMP);
	assert_int_equal(count_ev(RMD_EV_MOTOR_ERROR, 0), 1);
	/* no safe action: a faulted motor runs none (V3 §2.17.1); output off instead */
	assert_int_equal(count_ev(RMD_EV_SAFE_ACTION, 0), 0);
	assert_int_equal(sim_motor(0)->ctrl, RMD_SIM_OFF);
	assert_int_equal(lifecycle(1), RMD_LC_READY);
	run(500, true);
	s = snap();
	assert_int_equal(s.m[0].lifecycle, RMD_LC_READY);
	assert_int_equal(s.m[0].error_code, 0);
	rig_down();
}

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
	for (unsigned k = 0; k < nev; k++)
		f1 |= evs[k].kind == RMD_EV_MOTOR_ERROR && evs[k].b == 0xF1;
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

static void test_watchdog(void **state)
{
	const struct rmd_health *h;
	const void *p;
	int64_t last_cmd, first80 = INT64_MAX;
	unsigned from;

	(void)state;
	up_at_speed(NULL, 2, 1.0, 150);
	assert_true(rmd_latest_get(&R.io.health, &p));
	h = p;
	assert_int_equal(h->watchdog, RMD_WD_OK);
	last_cmd = t_now - period();
	from = trace_n;
	/* the controller goes quiet */
	run(200, false);
	for (unsigned k = from; k < trace_n; k++)
		if (trace[k].f.data[0] == 0x80 && trace[k].t_ns < first80)
			first80 = trace[k].t_ns;
	/* sent in the first cycle past command_timeout_ms, on the wire right after */
	if (first80 < last_cmd + 100 * MS || first80 > last_cmd + 101 * MS + 300 * US)
		fail_msg("0x80 at +%lld us", (long long)((first80 - last_cmd) / US));
	assert_int_equal(sent_to(0, 0x80, from), 1);
	assert_int_equal(sent_to(1, 0x80, from), 1);
	assert_int_equal(sent_to(2, 0x80, from), 0); /* never enabled */
	assert_int_equal(lifecycle(0), RMD_LC_SAFE);
	assert_int_equal(lifecycle(2), RMD_LC_READY);
	assert_int_equal(sim_motor(0)->ctrl, RMD_SIM_OFF);
	assert_int_equal(count_ev(RMD_EV_SAFE_ACTION, -1), 2);
	assert_true(rmd_latest_get(&R.io.health, &p));
	h = p;
	assert_int_equal(h->watchdog, RMD_WD_TRIPPED);
	assert_int_equal(h->safe_action_events, 2);
	/* latched: nothing changes without a command */
	run(300, false);
	assert_int_equal(lifecycle(0), RMD_LC_SAFE);
	/*
	 * Issue 20.3: nor with enable = 1 alone, newer than the trip as it is
	 * (before, the first one restarted the motors): nothing on the wire moves
	 */
	from = trace_n;
	assert_int_equal(ignored_over(150, RMD_IGN_EDGE), 2 * 150);
	for (unsigned k = from; k < trace_n; k++)
		if (moves_frame(&trace[k].f))
			fail_msg("a frame that moves, %03x %02x, from enable = 1 after the trip",
				 trace[k].f.can_id, trace[k].f.data[0]);
	assert_int_equal(lifecycle(0), RMD_LC_SAFE);
	assert_int_equal(lifecycle(1), RMD_LC_SAFE);
	assert_true(rmd_latest_get(&R.io.health, &p));
	assert_int_equal(((const struct rmd_health *)p)->watchdog, RMD_WD_TRIPPED);
	/* enable = 0, then enable = 1, lifts it */
	R.cmd.disables[0]++;
	R.cmd.disables[1]++;
	run(150, true);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_int_equal(sim_motor(0)->ctrl, RMD_SIM_SPEED);
	assert_true(rmd_latest_get(&R.io.health, &p));
	h = p;
	assert_int_equal(h->watchdog, RMD_WD_OK);
	rig_down();
}

/* Index in evs[] of the first event of `kind` for motor m from evs[from] on, or nev. */
static unsigned ev_at(unsigned from, unsigned kind, unsigned m)
{
	for (unsigned k = from; k < nev; k++)
		if (evs[k].kind == kind && evs[k].motor == m)
			return k;
	return nev;
}

/*
 * Issue 20.11: the loop reports in the order things happened, which the
 * incident summary keeps: the state change before the safe action it
 * sends, the error flags before the FAULT they cause.
 */
static void test_events_cause_before_effect(void **state)
{
	struct rmd_sim_fault flag = { .kind = RMD_SIM_FAULT_ERROR_FLAG,
				      .motor_id = 2,
				      .param = RMD_SIM_ERR_LOW_VOLTAGE };
	unsigned from, st, sa, er;

	(void)state;
	up_at_speed(NULL, 2, 1.0, 150);
	events_pump();
	from = nev;
	run(200, false); /* the watchdog trips: ENABLED -> SAFE, the safe action */
	events_pump();
	st = ev_at(from, RMD_EV_MOTOR_STATE, 0);
	sa = ev_at(from, RMD_EV_SAFE_ACTION, 0);
	if (st == nev || sa == nev || st > sa)
		fail_msg("watchdog: state change at event %u, its safe action at %u", st, sa);
	from = nev;
	fault_now(&flag, 0);
	run(300, false);
	events_pump();
	er = ev_at(from, RMD_EV_MOTOR_ERROR, 1);
	st = ev_at(from, RMD_EV_MOTOR_STATE, 1);
	if (er == nev || st == nev || er > st)
		fail_msg("fault: error flags at event %u, the state change at %u", er, st);
	rig_down();
}

/*
 * Issue 20.8: three motors at 1 kHz fill their bus, so a status poll takes
 * a motor's control slot now and then.  Whichever cycle the controller
 * goes quiet in, every enabled motor's safe frame is on the wire within
 * command_timeout_ms and one cycle: a poll never holds it back a cycle.
 */
static void test_safe_frames_take_polls_place(void **state)
{
	(void)state;
	for (unsigned off = 0; off < 40; off++) {
		int64_t last_cmd, first80[3] = { INT64_MAX, INT64_MAX, INT64_MAX };
		unsigned from;

		up_at_speed(NULL, 3, 1.0, 150 + off);
		last_cmd = t_now - period();
		from = trace_n;
		run(200, false);
		for (unsigned k = from; k < trace_n; k++)
			for (unsigned i = 0; i < 3; i++)
				if (trace[k].f.can_id == RMD_CAN_REQ_BASE + i + 1 &&
				    trace[k].f.data[0] == 0x80 && trace[k].t_ns < first80[i])
					first80[i] = trace[k].t_ns;
		for (unsigned i = 0; i < 3; i++)
			/* sent in the trip's cycle: on the wire before the next one starts */
			if (first80[i] < last_cmd + 100 * MS ||
			    first80[i] >= last_cmd + 101 * MS + period())
				fail_msg("quiet after %u cycles: motor %u's 0x80 at +%lld us",
					 150 + off, i + 1,
					 (long long)((first80[i] - last_cmd) / US));
		rig_down();
	}
}

/* The first frame to motor i with command byte cmd since trace[from]: its time, or INT64_MAX. */
static int64_t first_to(unsigned i, int cmd, unsigned from)
{
	const struct rmd_config_motor *m = &R.io.cfg.motors[i];

	for (unsigned k = from; k < trace_n; k++)
		if (trace[k].bus == m->bus && trace[k].f.can_id == 0x140u + m->id &&
		    trace[k].f.data[0] == cmd)
			return trace[k].t_ns;
	return INT64_MAX;
}

/*
 * Motor i's safe action (0x80) since trace[from], sent 100..101 ms (+ a
 * frame's time) after its last command at last_ns, in 300 ms of `what`;
 * its time.
 */
static int64_t safe_action_at(unsigned i, int64_t last_ns, unsigned from, const char *what)
{
	int64_t t80 = first_to(i, 0x80, from);

	if (t80 == INT64_MAX)
		fail_msg("motor %u: no safe action (0x80) in 300 ms of %s", i, what);
	if (t80 < last_ns + 100 * MS || t80 > last_ns + 101 * MS + 300 * US)
		fail_msg("motor %u: 0x80 at +%lld us after its last command (want +100..101 ms)", i,
			 (long long)((t80 - last_ns) / US));
	return t80;
}

/*
 * Issue 20.2: the host watchdog is per motor.  A controller that keeps
 * streaming commands which carry only motor 0 (its arms loop died) keeps
 * motor 0 driven, but motor 1 gets the safe action command_timeout_ms
 * after the last command that carried it, and no setpoint reaches it after
 * that; commands that carry no motor (count = 0) then trip motor 0 too.
 * Judged on the wire.
 */
static void test_watchdog_per_motor(void **state)
{
	int64_t last1, last0, t80;
	unsigned from;

	(void)state;
	up_at_speed(NULL, 2, 1.0, 150);
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
	last1 = t_now - period();
	/* the commands carry motor 0 only */
	R.cmd.present = 1u << 0;
	from = trace_n;
	run(300, true);
	t80 = safe_action_at(1, last1, from, "commands without it");
	for (unsigned k = from; k < trace_n; k++)
		if (trace[k].t_ns > t80 && trace[k].f.can_id == 0x140u + R.io.cfg.motors[1].id &&
		    trace[k].f.data[0] == 0xA2)
			fail_msg("motor 1: 0xA2 at +%lld us, after its safe action",
				 (long long)((trace[k].t_ns - t80) / US));
	assert_int_equal(lifecycle(1), RMD_LC_SAFE);
	assert_int_equal(sim_motor(1)->ctrl, RMD_SIM_OFF);
	/* motor 0 kept its setpoint all along */
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_int_equal(sim_motor(0)->ctrl, RMD_SIM_SPEED);
	assert_int_equal(sent_to(0, 0x80, from), 0);
	assert_true(sent_to(0, 0xA2, from) >= 250);

	/* commands that carry no motor keep nothing enabled */
	last0 = t_now - period();
	R.cmd.present = 0;
	from = trace_n;
	run(300, true);
	t80 = safe_action_at(0, last0, from, "commands with no motor");
	for (unsigned k = from; k < trace_n; k++)
		if (trace[k].t_ns > t80 && moves_frame(&trace[k].f))
			fail_msg(
				"a frame that moves (0x%03x %02x) at +%lld us, after the safe action",
				trace[k].f.can_id, trace[k].f.data[0],
				(long long)((trace[k].t_ns - t80) / US));
	assert_int_equal(lifecycle(0), RMD_LC_SAFE);
	assert_int_equal(sim_motor(0)->ctrl, RMD_SIM_OFF);
	rig_down();
}

static void brake_100ms(struct rmd_config *cfg)
{
	cfg->motors[0].brake_release_ms = 100;
}

/*
 * Issue 20.13: brake release takes time.  Motor 0 (brake_release_ms 100)
 * gets its brake release (0x77), then status reads only -- no setpoint --
 * for 100 ms from the 0x77, while its snapshot says the brake is opening
 * (state_t.brake_releasing); then its setpoints.  Motor 1 (no brake time)
 * gets its setpoints from the next slot.  Judged on the wire.
 */
static void test_brake_release_holds_setpoints(void **state)
{
	int64_t t77, ta2, t77b, ta2b;
	unsigned from;

	(void)state;
	rig_up(3, brake_100ms);
	bring_up();
	cmd_clear();
	from = trace_n;
	cmd_motor(0, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	cmd_motor(1, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	run(50, true);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	t77 = first_to(0, 0x77, from);
	if (t77 == INT64_MAX)
		fail_msg("motor 0: no brake release (0x77) after enable");
	if (first_to(0, 0xA2, from) != INT64_MAX)
		fail_msg("motor 0: a speed setpoint %lld us after its brake release",
			 (long long)((first_to(0, 0xA2, from) - t77) / US));
	assert_true(snap().m[0].release_until_ns > t_now);
	assert_int_not_equal(sim_motor(0)->ctrl, RMD_SIM_SPEED);
	/* the other motor, without a brake time, runs at once */
	t77b = first_to(1, 0x77, from);
	ta2b = first_to(1, 0xA2, from);
	if (t77b == INT64_MAX || ta2b == INT64_MAX || ta2b - t77b > 3 * MS)
		fail_msg("motor 1: 0x77 at %lld, first 0xA2 at %lld (want within 3 ms)",
			 (long long)t77b, (long long)ta2b);
	run(100, true);
	ta2 = first_to(0, 0xA2, from);
	if (ta2 < t77 + 100 * MS || ta2 > t77 + 100 * MS + 2 * period())
		fail_msg("motor 0: first setpoint %lld us after its brake release (want 100 ms)",
			 (long long)((ta2 - t77) / US));
	assert_true(sent_to(0, 0x9C, from) >= 90); /* fed by status reads meanwhile */
	assert_int_equal(snap().m[0].release_until_ns > t_now, false);
	assert_int_equal(sim_motor(0)->ctrl, RMD_SIM_SPEED);
	rig_down();
}

/* R.cmd handed over stamped rx_ns (when it arrived), then one cycle. */
static void cycle_with_cmd_at(int64_t rx_ns)
{
	R.cmd.rx_ns = rx_ns;
	R.cmd.seq++;
	rmd_latest_put(&R.io.cmds, &R.cmd);
	rmd_loop_cycle(R.l, t_now);
	t_now += period();
}

/*
 * Issue 10: rx_ns is when a command arrived, so after rmdd was held off the
 * bridge hands over what queued meanwhile with old stamps.  One from before
 * a trip does not lift it, but its enable = 0 is acted on (SAFE -> READY);
 * one from after the trip that is older than the command timeout when the
 * loop takes it moves nothing (before, it enabled the motor, released its
 * brake and tripped again in the same cycle); a fresh one enables.
 */
static void test_commands_queued_in_a_stall(void **state)
{
	struct rmd_loop_counters c0, c1;
	int64_t last_cmd, trip;
	unsigned from;

	(void)state;
	up_at_speed(NULL, 1, 1.0, 150);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_int_equal(lifecycle(1), RMD_LC_READY);
	last_cmd = t_now - period();
	/* the controller's commands stop reaching the loop: it trips */
	run(300, false);
	trip = last_cmd + 101 * MS;
	assert_int_equal(lifecycle(0), RMD_LC_SAFE);

	/* from before the trip: motor 0 enable = 0 (acted on), motor 1 enable = 1 (not) */
	rmd_loop_get_counters(R.l, &c0);
	from = trace_n;
	cmd_clear();
	cmd_motor(0, false, RMD_MODE_SPEED);
	R.cmd.disables[0]++;
	cmd_motor(1, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	cycle_with_cmd_at(trip - 50 * MS);
	rmd_loop_get_counters(R.l, &c1);
	assert_int_equal(lifecycle(0), RMD_LC_STOPPING); /* READY once 0x80, 0x78 are echoed */
	assert_int_equal(lifecycle(1), RMD_LC_READY);
	assert_int_equal(c1.ignored[RMD_IGN_TRIPPED] - c0.ignored[RMD_IGN_TRIPPED], 1);

	/* from after the trip, 150 ms old when taken (timeout 100 ms): nothing moves */
	cmd_clear();
	cmd_motor(1, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	cycle_with_cmd_at(t_now - 150 * MS);
	run(20, false);
	assert_true(t_now - 170 * MS > trip);
	rmd_loop_get_counters(R.l, &c1);
	assert_int_equal(lifecycle(0), RMD_LC_READY);
	assert_int_equal(lifecycle(1), RMD_LC_READY);
	assert_int_equal(c1.ignored[RMD_IGN_TRIPPED] - c0.ignored[RMD_IGN_TRIPPED], 2);
	for (unsigned k = from; k < trace_n; k++)
		if (moves_frame(&trace[k].f))
			fail_msg("a frame that moves, %03x %02x, from a command of the stall",
				 trace[k].f.can_id, trace[k].f.data[0]);

	/* a fresh command enables */
	run(20, true);
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
	rig_down();
}

static void mit_third(struct rmd_config *cfg)
{
	cfg->motors[2].proto = RMD_PROTO_MIT;
	cfg->motors[2].mode = RMD_MODE_MIT;
}

static void test_nan_never_on_wire(void **state)
{
	struct rmd_loop_counters c;
	struct rmd_setpoint *sp;
	unsigned from;

	(void)state;
	rig_up(3, mit_third);
	bring_up();
	/* a READY MIT motor is read with V3 0x9C, never sent an MIT frame */
	run(100, false);
	assert_int_equal(sent_to(2, 0x400, 0), 0);
	assert_true(sent_to(2, 0x9C, 0) > 50);
	cmd_clear();
	cmd_motor(0, true, RMD_MODE_TORQUE)->torque_nm = NAN;
	cmd_motor(1, true, RMD_MODE_SPEED)->vel_rad_s = INFINITY;
	sp = cmd_motor(2, true, RMD_MODE_MIT);
	sp->kp = NAN;
	sp->kd = 1.0;
	from = trace_n;
	run(100, true);
	/* the safe action's frame (stop) instead, every control slot */
	assert_int_equal(sent_to(0, 0xA1, from), 0);
	assert_int_equal(sent_to(1, 0xA2, from), 0);
	assert_int_equal(sent_to(2, 0x400, from), 0);
	assert_true(sent_to(0, 0x80, from) >= 90);
	assert_true(sent_to(2, 0x80, from) >= 90);
	rmd_loop_get_counters(R.l, &c);
	assert_true(c.nonfinite >= 270);
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(sim_motor(i)->ctrl, RMD_SIM_OFF);
	/* finite again: the frames go out */
	cmd_motor(0, true, RMD_MODE_TORQUE)->torque_nm = 0.1;
	sp = cmd_motor(2, true, RMD_MODE_MIT);
	sp->kd = 0.5;
	from = trace_n;
	run(50, true);
	assert_true(sent_to(0, 0xA1, from) >= 45);
	assert_true(sent_to(2, 0x400, from) >= 45);
	assert_int_equal(sim_motor(2)->ctrl, RMD_SIM_MIT);
	assert_int_equal(lifecycle(2), RMD_LC_ENABLED);
	/* MIT replies: position, speed, torque */
	assert_true(isfinite(snap().m[2].torque_nm));
	rig_down();
}

static void brake_safe(struct rmd_config *cfg)
{
	cfg->safety.safe_action = RMD_SAFE_BRAKE;
}

/*
 * Six motors on two buses, 0..driven-1 driven at 2 rad/s, the others READY;
 * then rmd_loop_stop_motors().  Every motor READY after it, but the driven
 * ones of a shutdown without the brake (stop, hold: SAFE, brake open),
 * its 0xB3 in place.  Returns trace_n before it.
 */
static unsigned drive_then_stop(tweak_fn *tweak, unsigned driven)
{
	const struct rmd_config_safety *s = &R.io.cfg.safety;
	unsigned from;
	bool brakes;

	rig_up(6, tweak); /* two buses */
	bring_up();
	cmd_clear();
	for (unsigned i = 0; i < driven; i++)
		cmd_motor(i, true, RMD_MODE_SPEED)->vel_rad_s = 2.0;
	run(300, true);
	assert_float_equal(sim_motor(driven - 1)->vel_rad_s, 2.0, 0.2);
	from = trace_n;
	rmd_loop_stop_motors(R.l, t_now);
	run(5, false); /* the wire delivers them */
	brakes = s->shutdown_action == RMD_SHUTDOWN_BRAKE ||
		 s->shutdown_action == RMD_SHUTDOWN_DAMP ||
		 (s->shutdown_action == RMD_SHUTDOWN_DEFAULT && s->safe_action == RMD_SAFE_BRAKE);
	for (unsigned i = 0; i < 6; i++) {
		assert_int_equal(lifecycle(i), i < driven && !brakes ? RMD_LC_SAFE : RMD_LC_READY);
		assert_int_equal(sim_motor(i)->ram.comm_timeout_ms, 100); /* 0xB3 stays */
	}
	return from;
}

/* Motor i got 0x80 and 0x78 once each since trace[from]: output off, brake locked. */
static void assert_braked(unsigned i, unsigned from)
{
	assert_int_equal(sent_to(i, 0x80, from), 1);
	assert_int_equal(sent_to(i, 0x78, from), 1);
	assert_int_equal(sim_motor(i)->ctrl, RMD_SIM_OFF);
	assert_true(sim_motor(i)->brake_locked);
}

static void test_stop_motors(void **state)
{
	unsigned from;

	(void)state;
	from = drive_then_stop(brake_safe, 6);
	for (unsigned i = 0; i < 6; i++)
		assert_braked(i, from);
	rig_down();
}

/*
 * After rmd_loop_stop_motors() the published health counts every frame the
 * buses sent, the final stops included (issue 13: rmdd's exit statistics
 * read it after the loop's thread ended), and the published state is what
 * the default shutdown (stop) left: SAFE, output off with the brake open.
 */
static void test_health_after_stop_counts_the_stops(void **state)
{
	static struct rmd_health h;
	struct rmd_snapshot *snap = malloc(sizeof(*snap));

	(void)state;
	assert_non_null(snap);
	rig_up(6, NULL); /* two buses */
	bring_up();
	cmd_clear();
	for (unsigned i = 0; i < 6; i++)
		cmd_motor(i, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	run(300, true);
	rmd_loop_stop_motors(R.l, t_now);
	assert_true(rmd_loop_get_health(R.l, &h));
	for (unsigned b = 0; b < R.io.cfg.n_buses; b++) {
		const struct rmd_bus_stats *bs = rmd_bus_stats(&R.io.buses[b]);

		assert_int_equal(h.bus[b].stats.tx_frames, bs->tx_frames);
		assert_int_equal(h.bus[b].stats.rx_frames, bs->rx_frames);
	}
	rmd_loop_get_snapshot(R.l, snap);
	for (unsigned i = 0; i < 6; i++)
		assert_int_equal(snap->m[i].lifecycle, RMD_LC_SAFE);
	free(snap);
	rig_down();
}

static void test_overrun(void **state)
{
	struct rmd_loop_stats st;

	(void)state;
	rig_up(3, NULL);
	bring_up();
	rmd_loop_cycle(R.l, t_now);
	rmd_loop_cycle(R.l, t_now + period());
	rmd_loop_cycle(R.l, t_now + 3 * period()); /* the tick at +2 never ran */
	rmd_loop_cycle(R.l, t_now + 4 * period() + 20 * US);
	rmd_loop_cycle(R.l, t_now + 8 * period());
	rmd_loop_get_stats(R.l, &st);
	assert_int_equal(st.cycles, 5);
	assert_int_equal(st.overruns, 1 + 3);
	/* the first overrun is reported at once, the next within a second later */
	assert_int_equal(count_ev(RMD_EV_OVERRUN, -1), 1);
	assert_int_equal(evs[nev - 1].a, 1);
	/*
	 * issue 11: true lateness, skipped periods included: the wake-ups were
	 * 0, one period, 20 us and three periods late (not folded into the period)
	 */
	assert_int_equal(st.wake_min_ns, 0);
	assert_int_equal(st.wake_max_ns, 3 * period());
	assert_int_equal(st.wake_p99_ns, 3 * period());
	assert_int_equal(st.wake_avg_ns, (period() + 20 * US + 3 * period()) / 4);
	assert_int_equal(rmd_loop_heartbeat(R.l), 5);
	t_now += 9 * period();
	run(1000, false);
	assert_int_equal(count_ev(RMD_EV_OVERRUN, -1), 2);
	for (unsigned k = 0, n = 0; k < nev; k++)
		if (evs[k].kind == RMD_EV_OVERRUN && ++n == 2)
			assert_int_equal(evs[k].a, 3);
	rig_down();
}

/*
 * incidents.overrun_burst (10 here) is one late wake-up's skip: twelve
 * scattered one-tick overruns within a second wait for the once-a-second
 * report (which says 12, at most 1 at once); one wake-up 10 periods late
 * is reported at once.
 */
static void test_overrun_burst_is_one_skip(void **state)
{
	(void)state;
	rig_up(3, NULL);
	assert_int_equal(R.io.cfg.incidents.overrun_burst, 10);
	bring_up();
	run(1, false);
	t_now += period(); /* the first overrun: reported at once */
	run(1, false);
	assert_int_equal(count_ev(RMD_EV_OVERRUN, -1), 1);
	for (int k = 0; k < 12; k++) {
		t_now += period();
		run(2, false);
	}
	assert_int_equal(count_ev(RMD_EV_OVERRUN, -1), 1);
	t_now += 10 * period();
	run(1, false);
	assert_int_equal(count_ev(RMD_EV_OVERRUN, -1), 2);
	assert_int_equal(evs[nev - 1].a, 12 + 10);
	assert_int_equal(evs[nev - 1].b, 10);
	rig_down();
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
	assert_int_equal(evs[nev - 1].kind == RMD_EV_STRAY ? evs[nev - 1].a : 0x245, 0x245);
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

static void test_bus_off(void **state)
{
	struct rmd_sim_fault off = { .kind = RMD_SIM_FAULT_BUS_OFF };
	struct rmd_loop_stats st;
	struct rmd_loop_counters c;

	(void)state;
	up_at_speed(NULL, 1, 1.0, 100);
	fault_now(&off, 50 * MS);
	run(30, true);
	/* nothing leaves: each request unsent is a missed reply, N in a row: LOST */
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(lifecycle(i), RMD_LC_LOST);
	assert_int_equal(count_ev(RMD_EV_BUS_STATE, -1), 1);
	assert_true(count_ev(RMD_EV_SEND_FAILED, -1) >= 1);
	assert_int_equal(count_ev(RMD_EV_SAFE_ACTION, 0), 1);
	/* the cause before what it caused: an incident's summary keeps this order */
	for (unsigned k = 0; k < nev; k++) {
		if (evs[k].kind == RMD_EV_SEND_FAILED)
			fail_msg("a send failure (event %u) before the bus-off that caused it", k);
		if (evs[k].kind == RMD_EV_BUS_STATE)
			break;
	}
	rmd_loop_get_stats(R.l, &st);
	rmd_loop_get_counters(R.l, &c);
	assert_true(st.plan_misses >= 25);
	assert_true(c.frames_not_sent >= 30);
	/* the bus comes back: the stop still waiting goes out, the motors are found again */
	run(1000, true);
	assert_int_equal(count_ev(RMD_EV_BUS_STATE, -1), 2);
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(lifecycle(i), RMD_LC_READY);
	assert_int_equal(sim_motor(0)->ctrl, RMD_SIM_OFF);
	rig_down();
}

/*
 * Issue 20.9: shutdown while one bus is off: the motors of the other bus
 * are stopped and say so; those of the bus that is off are not reached,
 * and rmd_loop_stop_reached() says so (the exit line names them).
 */
static void test_stop_motors_bus_off(void **state)
{
	struct rmd_sim_fault off = { .kind = RMD_SIM_FAULT_BUS_OFF };

	(void)state;
	rig_up(6, NULL); /* two buses: motors 0..2 on sim0, 3..5 on sim1 */
	bring_up();
	cmd_clear();
	for (unsigned i = 0; i < 6; i++)
		cmd_motor(i, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	run(200, true);
	fault_now(&off, 500 * MS); /* sim0 only */
	run(2, true);
	rmd_loop_stop_motors(R.l, t_now);
	for (unsigned i = 0; i < 6; i++)
		if (rmd_loop_stop_reached(R.l, i) != (i >= 3))
			fail_msg("motor %u: stop %s, on a bus %s", i,
				 rmd_loop_stop_reached(R.l, i) ? "reached" : "not reached",
				 i < 3 ? "that is off" : "that works");
	for (unsigned i = 3; i < 6; i++)
		assert_int_equal(sim_motor(i)->ctrl, RMD_SIM_OFF);
	rig_down();
}

static void test_health(void **state)
{
	const struct rmd_health *h;
	const void *p;

	(void)state;
	rig_up(6, NULL);
	bring_up();
	run(250, false);
	assert_true(rmd_latest_get(&R.io.health, &p));
	h = p;
	assert_int_equal(h->nbuses, 2);
	assert_string_equal(h->bus[1].name, "sim1");
	assert_int_equal(h->bus[0].state, RMD_BUS_ACTIVE);
	assert_true(h->bus[0].load > 0.2 && h->bus[0].load < 1.0);
	assert_int_equal(h->loop.cycles, 201);
	assert_int_equal(h->watchdog, RMD_WD_IDLE);
	assert_true(h->bus[0].stats.tx_frames > 600);
	rig_down();
}

static void test_thread(void **state)
{
	struct timespec ms = { .tv_nsec = 1000000 };
	struct rmd_loop_stats st;
	int r;

	(void)state;
	/* the thread keeps CLOCK_MONOTONIC: not with an injected clock */
	rig_up(3, NULL);
	assert_int_equal(rmd_loop_start(R.l), -EINVAL);
	rig_down();

	rig_up_clock(3, NULL, true);
	r = rmd_loop_bringup(R.l, &R.report);
	if (r)
		fail_msg("bring-up: %d", r);
	r = rmd_loop_start(R.l);
	if (r)
		fail_msg("rmd_loop_start: %s", strerror(-r));
	assert_int_equal(rmd_loop_start(R.l), -EBUSY);
	/* wait for 300 cycles, 5 s at most */
	for (unsigned k = 0; k < 5000 && rmd_loop_heartbeat(R.l) < 300; k++)
		nanosleep(&ms, NULL);
	rmd_loop_request_stop(R.l);
	assert_int_equal(rmd_loop_join(R.l), 0);
	rmd_loop_get_stats(R.l, &st);
	assert_true(st.cycles >= 300);
	assert_true(st.wake_max_ns >= st.wake_p99_ns && st.wake_p99_ns >= st.wake_min_ns);
	for (unsigned i = 0; i < 3; i++) {
		assert_int_equal(lifecycle(i), RMD_LC_READY);
		/* bring-up's output off, and on the way out the thread's */
		assert_int_equal(sent_to(i, 0x80, 0), 2);
	}
	events_pump();
	for (unsigned k = 0; k < nev; k++)
		if (evs[k].kind == RMD_EV_RT && getenv("RMD_TEST_VERBOSE"))
			print_message("no real time: %s (%lld)\n",
				      evs[k].b == RMD_LOOP_RT_MLOCK ? "mlockall" :
				      evs[k].b == RMD_LOOP_RT_FIFO  ? "SCHED_FIFO" :
								      "affinity",
				      (long long)evs[k].a);
	if (getenv("RMD_TEST_VERBOSE"))
		print_message("%llu cycles, %llu overruns, wake-up %lld/%lld/%lld/%lld us\n",
			      (unsigned long long)st.cycles, (unsigned long long)st.overruns,
			      (long long)st.wake_min_ns / 1000, (long long)st.wake_avg_ns / 1000,
			      (long long)st.wake_p99_ns / 1000, (long long)st.wake_max_ns / 1000);
	rig_down();
}

/*
 * Issue 23: the thread's cycle in parts.  After rmd_loop_tick() nothing is
 * published; rmd_loop_collect() says when the replies to the tick's
 * requests are in, and rmd_loop_publish() then puts out a state that holds
 * them (age 0, received after the tick), before the next tick, once.  A
 * motor that stopped answering is waited for until it missed once, never
 * again while it stays silent.  Over the cycles the wait for the last reply
 * stays inside the period on the sim bus (its motors answer 0.5 +- 0.1 ms).
 */
static int64_t collect_until_in(int64_t tick)
{
	int64_t t = tick;

	while (!rmd_loop_collect(R.l, t) && t < tick + period())
		t += 10 * US;
	return t;
}

static void test_state_when_replies_are_in(void **state)
{
	struct rmd_sim_fault gone = { .kind = RMD_SIM_FAULT_DISAPPEAR, .motor_id = 2 };
	struct rmd_snapshot s0, s1;
	int64_t tick, t, worst = 0;

	(void)state;
	rig_up(2, NULL);
	bring_up();
	cmd_clear();
	for (unsigned i = 0; i < 2; i++)
		cmd_motor(i, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	run(50, true);
	s0 = snap();
	tick = t_now;
	rmd_loop_tick(R.l, tick);
	assert_int_equal(snap().cycle, s0.cycle); /* nothing out yet */
	assert_false(rmd_loop_collect(R.l, tick + 100 * US));
	t = collect_until_in(tick);
	if (t <= tick + 300 * US || t >= tick + period())
		fail_msg("the replies in %lld us after the tick", (long long)((t - tick) / US));
	assert_int_equal(snap().cycle, s0.cycle);
	rmd_loop_publish(R.l, t);
	s1 = snap();
	assert_int_equal(s1.cycle, s0.cycle + 1);
	assert_int_equal(s1.t_ns, t);
	for (unsigned i = 0; i < 2; i++) {
		assert_int_equal(s1.m[i].reply_age_cycles, 0);
		assert_true(s1.m[i].rx_ns > tick && s1.m[i].rx_ns <= t);
	}
	rmd_loop_publish(R.l, t + 10 * US); /* once a cycle */
	assert_int_equal(snap().cycle, s1.cycle);
	assert_int_equal(snap().t_ns, t);

	/* many cycles: every one's replies in before its next tick */
	for (unsigned k = 0; k < 200; k++) {
		tick += period();
		R.cmd.rx_ns = tick;
		R.cmd.seq++;
		rmd_latest_put(&R.io.cmds, &R.cmd);
		rmd_loop_tick(R.l, tick);
		t = collect_until_in(tick);
		assert_true(t < tick + period());
		if (t - tick > worst)
			worst = t - tick;
		rmd_loop_publish(R.l, t);
	}
	print_message("last reply of a cycle in at most %lld us after its tick\n",
		      (long long)(worst / US));

	/* motor 3 gone: waited for in the cycle it first misses, not after */
	t_now = tick + period();
	fault_now(&gone, 0);
	for (unsigned k = 0; k < 10; k++) {
		tick += period();
		rmd_loop_tick(R.l, tick);
		t = collect_until_in(tick);
		if (k >= 4)
			assert_true(t < tick + period());
		rmd_loop_publish(R.l, t);
	}
	assert_true(snap().m[1].reply_age_cycles > 0);
	rig_down();
}

/* The seqlock getter gives the health the triple buffer got, and the motor records. */
static void test_health_getter(void **state)
{
	static struct rmd_health got;
	const struct rmd_health *h;
	const struct rmd_motor *m;
	const void *p;

	(void)state;
	rig_up(6, NULL);
	assert_false(rmd_loop_get_health(R.l, &got)); /* none before the first cycle */
	bring_up();
	run(250, false);
	assert_true(rmd_latest_get(&R.io.health, &p));
	h = p;
	assert_true(rmd_loop_get_health(R.l, &got));
	assert_memory_equal(&got, h, sizeof(got));
	assert_int_equal(got.loop.cycles, 201);
	m = rmd_loop_motor(R.l, 5);
	assert_non_null(m);
	assert_string_equal(m->name, R.io.cfg.motors[5].name);
	assert_int_equal(m->bus, R.io.cfg.motors[5].bus);
	assert_int_equal(m->id, R.io.cfg.motors[5].id);
	assert_null(rmd_loop_motor(R.l, 6));
	rig_down();
}

/*
 * Issue 13: an enable = 0 the loop never saw as a command of its own (the
 * bridge handed enable = 1 over before the next cycle) still counts: its
 * trace is rmd_command.disables[].  What the loop does not act on is
 * counted by reason.
 */
static void test_enable_edge_latched(void **state)
{
	struct rmd_sim_fault drop = { .kind = RMD_SIM_FAULT_DROP,
				      .motor_id = 2,
				      .probability = 1.0 };
	struct rmd_snapshot s;
	struct rmd_health h;

	(void)state;
	three_at_speed();
	/* measurement times: the reply each value came from, at most a cycle old */
	s = snap();
	for (unsigned i = 0; i < 3; i++) {
		assert_true(s.m[i].rx_ns > s.t_ns - 2 * period());
		assert_true(s.m[i].rx_ns <= t_now);
	}

	drop.start_ns = sim_time(0);
	set_faults(0, &drop, 1);
	for (unsigned k = 0; k < 30 && lifecycle(1) != RMD_LC_LOST; k++)
		run(1, true);
	assert_int_equal(lifecycle(1), RMD_LC_LOST);
	assert_int_equal(ignored_over(10, RMD_IGN_NOT_READY), 10);
	/* its values stay those of its last reply, and say so */
	s = snap();
	assert_true(s.m[1].rx_ns < s.t_ns - 10 * period());

	/* back: READY; enable = 1 alone is ignored, and counted */
	set_faults(0, NULL, 0);
	run(1200, true);
	assert_int_equal(lifecycle(1), RMD_LC_READY);
	assert_int_equal(ignored_over(5, RMD_IGN_EDGE), 5);
	assert_int_equal(lifecycle(1), RMD_LC_READY);

	/* enable = 0 then enable = 1 within one cycle: the loop sees only the second */
	R.cmd.disables[1]++;
	run(20, true);
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
	assert_int_equal(sim_motor(1)->ctrl, RMD_SIM_SPEED);
	/* the others never left ENABLED: an enable = 0 they did not get is not theirs */
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_int_equal(lifecycle(2), RMD_LC_ENABLED);
	/* health carries the counts (the bridge puts them in health_t) */
	run(200, true);
	assert_true(rmd_loop_get_health(R.l, &h));
	assert_true(h.ignored[RMD_IGN_EDGE] >= 5);
	assert_true(h.ignored[RMD_IGN_NOT_READY] >= 10);
	rig_down();
}

static void shutdown_stop(struct rmd_config *cfg)
{
	cfg->safety.shutdown_action = RMD_SHUTDOWN_STOP;
}

static void shutdown_hold(struct rmd_config *cfg)
{
	cfg->safety.shutdown_action = RMD_SHUTDOWN_HOLD;
}

static void shutdown_brake(struct rmd_config *cfg)
{
	cfg->safety.shutdown_action = RMD_SHUTDOWN_BRAKE;
}

static void shutdown_damp(struct rmd_config *cfg)
{
	cfg->safety.shutdown_action = RMD_SHUTDOWN_DAMP;
	cfg->safety.shutdown_damp_ms = 50;
}

/* damp for longer than the motors' comm-loss protection (the default's 500 ms against 100) */
static void shutdown_damp_long(struct rmd_config *cfg)
{
	cfg->safety.shutdown_action = RMD_SHUTDOWN_DAMP;
	cfg->safety.shutdown_damp_ms = 500;
	cfg->safety.comm_loss_ms = 100;
}

/*
 * Issue 20.5: during a damp phase longer than their protection, the
 * motors not damped are fed (a status read every period), so their
 * protection never trips and the final stop and brake are executed, not
 * swallowed as a trip's echo.
 */
static void test_shutdown_damp_feeds_the_others(void **state)
{
	unsigned from;

	(void)state;
	from = drive_then_stop(shutdown_damp_long, 4);
	for (unsigned i = 0; i < 6; i++) {
		if (sim_motor(i)->comm_lost)
			fail_msg("motor %u: its comm-loss protection tripped during the damp phase",
				 i);
		assert_braked(i, from);
		assert_true(rmd_comm_loss_set(rmd_loop_comm_loss(R.l, i)));
	}
	rig_down();
}

/* Issue 13: each safety.shutdown_action, on the wire. */
static void test_shutdown_actions(void **state)
{
	unsigned from;

	(void)state;
	/* stop: 0x80 to every motor, nothing else; the shafts turn freely */
	from = drive_then_stop(shutdown_stop, 4);
	for (unsigned i = 0; i < 6; i++) {
		assert_int_equal(sent_to(i, 0x80, from), 1);
		assert_int_equal(sent_to(i, 0x78, from) + sent_to(i, 0x81, from), 0);
		assert_int_equal(sim_motor(i)->ctrl, RMD_SIM_OFF);
		/* the driven ones' brakes stay open (0x77 at enable); the others never opened */
		assert_int_equal(sim_motor(i)->brake_locked, i >= 4);
	}
	rig_down();

	/* hold: 0x81 to the driven motors (they hold), 0x80 to the others */
	from = drive_then_stop(shutdown_hold, 4);
	for (unsigned i = 0; i < 6; i++) {
		assert_int_equal(sent_to(i, 0x81, from), i < 4);
		assert_int_equal(sent_to(i, 0x80, from), i >= 4);
		assert_int_equal(sent_to(i, 0x78, from), 0);
		assert_int_equal(sim_motor(i)->ctrl, i < 4 ? RMD_SIM_HOLD : RMD_SIM_OFF);
	}
	rig_down();

	/* brake: 0x80 and 0x78 to every motor */
	from = drive_then_stop(shutdown_brake, 4);
	for (unsigned i = 0; i < 6; i++)
		assert_braked(i, from);
	rig_down();

	/* damp: zero speed to the driven motors every period for 50 ms, then brake all */
	from = drive_then_stop(shutdown_damp, 4);
	for (unsigned i = 0; i < 6; i++) {
		unsigned n = sent_to(i, 0xA2, from);

		if (i < 4 && (n < 45 || n > 55))
			fail_msg("motor %u: %u zero-speed frames in 50 ms at 1 kHz", i, n);
		if (i >= 4)
			assert_int_equal(n, 0);
		assert_braked(i, from);
		/* it had stopped before the brake closed */
		assert_float_equal(sim_motor(i)->vel_rad_s, 0.0, 0.2);
	}
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
	for (unsigned k = 0; k < nev; k++)
		if (evs[k].kind == RMD_EV_COMM_LOSS && evs[k].motor == i &&
		    (a < 0 || evs[k].a == a) && (b < 0 || evs[k].b == b))
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

/* What a controller does for motor i back from LOST: enable = 0, then 1 (1 rad/s); 22 cycles. */
static void cl_reenable(unsigned i)
{
	cmd_motor(i, false, RMD_MODE_SPEED);
	run(2, true);
	cmd_motor(i, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	run(20, true);
}

/*
 * The issue's reproducer: motor 1's frames are dropped from 5 ms to 300 ms
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

/*
 * issue 11: the loop's own statistics.  Wake-ups land in 1 us buckets as
 * cyclictest's (a 2.5 ms stall is one wake-up 2500 us late, an overflow;
 * 7 us late lands in bucket 7), and every matched reply's latency is kept
 * per motor, from the loop's stamps.
 */
static void test_wake_hist_and_reply_latency(void **state)
{
	struct rmd_loop_wake_hist wh;
	struct rmd_latency lat;
	struct rmd_loop_counters c;
	uint64_t sum = 0;

	(void)state;
	rig_up(3, NULL);
	bring_up();
	run(100, false);
	rmd_loop_cycle(R.l, t_now + 7 * US);
	t_now += period();
	rmd_loop_cycle(R.l, t_now + 2500 * US); /* two ticks skipped: the next is 3 periods on */
	t_now += 3 * period();
	run(100, false);
	rmd_loop_get_wake_hist(R.l, &wh);
	for (unsigned k = 0; k < RMD_LOOP_WAKE_US_BUCKETS; k++)
		sum += wh.us[k];
	assert_int_equal(wh.over, 1);
	assert_int_equal(wh.us[7], 1);
	assert_int_equal(sum + wh.over, wh.n);
	rmd_loop_get_counters(R.l, &c);
	sum = 0;
	for (unsigned i = 0; i < 3; i++) {
		assert_true(rmd_loop_get_reply_latency(R.l, i, &lat));
		assert_true(lat.n > 150);
		assert_true(lat.min_ns > 0 && lat.min_ns <= lat.max_ns);
		assert_true(rmd_latency_p99(&lat) <= lat.max_ns);
		assert_true(rmd_latency_p99(&lat) >= lat.sum_ns / (int64_t)lat.n * 3 / 4);
		sum += lat.n;
	}
	/* every matched reply, bring-up's too */
	assert_true(sum <= c.replies);
	assert_false(rmd_loop_get_reply_latency(R.l, 3, &lat));
	rig_down();
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

/*
 * A joint whose travel band is narrower than one rotor turn at the output
 * (2 pi / gear_ratio) reports its true position after a power cycle, which
 * wrapped the motor's angle (include/rmd/sim.h): at several angles, gear
 * ratios, both directions and zero offsets.
 */
static void test_pos_cycle_in_band(void **state)
{
	static const struct pc_case cases[] = {
		{ "direct drive, 400 deg", 1.0, 1, 0.0, 400.0, 100.0, 100.0, false, false, false },
		{ "direct drive reversed, -500 deg, zero 0.3", 1.0, -1, 0.3, -500.0, 20.0, 300.0,
		  false, false, false },
		{ "1:6, -100 deg, band 40 deg", 6.0, 1, 0.0, -100.0, 20.0, 20.0, false, false,
		  false },
		{ "1:9 reversed, 725 deg, zero -0.5, band 30 deg", 9.0, -1, -0.5, 725.0, 5.0, 25.0,
		  false, false, false },
		{ "1:9, 10 deg (no wrap), band at its edge", 9.0, 1, 0.0, 10.0, 0.0, 30.0, false,
		  false, false },
		{ "V2 1:6, 250 deg (rmdd unwraps the encoder)", 6.0, 1, 0.0, 250.0, 10.0, 20.0,
		  true, false, false },
		{ "MIT direct drive reversed, 300 deg", 1.0, -1, 0.1, 300.0, 90.0, 90.0, false,
		  true, false },
		/* firmware that keeps only the rotor's angle: 727 deg comes back as 7 deg */
		{ "1:9 rotor wrap, 727 deg, band 30 deg", 9.0, 1, 0.0, 727.0, 10.0, 20.0, false,
		  false, true },
		{ "1:6 rotor wrap reversed, -95 deg, zero 0.2", 6.0, -1, 0.2, -95.0, 25.0, 25.0,
		  false, false, true },
	};

	(void)state;
	for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
		struct rmd_snapshot s;

		pc = cases[k];
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
	static const struct pc_case c = { .name = "direct drive, 400 deg, band 200 deg",
					  .gear = 1.0,
					  .dir = 1,
					  .start_deg = 400.0,
					  .below = 100.0,
					  .above = 100.0 };
	struct rmd_snapshot s;

	(void)state;
	pc = c;
	pc_rig();
	assert_true(snap().m[0].pos_certain);
	cmd_clear();
	cmd_motor(0, false, RMD_MODE_TORQUE);
	memset(&forge, 0, sizeof(forge));
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
		nev = 0;
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
	static const struct pc_case c = { .name = "MIT, no band",
					  .gear = 1.0,
					  .dir = 1,
					  .start_deg = 500.0,
					  .below = -1,
					  .mit = true };
	struct rmd_setpoint *sp;
	unsigned from;

	(void)state;
	pc = c;
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
		nev = 0;
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
		nev = 0;
		home(0, false, pc_truth_rad() * 180.0 / M_PI);
		run(5, true);
		assert_int_equal(count_ev(RMD_EV_HOME_REFUSED, 0), 1);
		for (unsigned e = 0; e < nev; e++)
			if (evs[e].kind == RMD_EV_HOME_REFUSED)
				assert_int_equal(evs[e].a, RMD_HOME_OUTSIDE);
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

/* ---- issue 10 point 5: the fault matrix (docs/faults.md), one fault kind per test -------- */

/* Loop counters since c0. */
static struct rmd_loop_counters counters_since(const struct rmd_loop_counters *c0)
{
	struct rmd_loop_counters c;

	rmd_loop_get_counters(R.l, &c);
	c.missed -= c0->missed;
	c.unexpected -= c0->unexpected;
	c.bad_replies -= c0->bad_replies;
	c.replies -= c0->replies;
	return c;
}

/*
 * Cycles from now until motor i is LOST (at most `max`), with R.cmd; the
 * bound of the matrix: missed_replies_lost requests in a row, each missed
 * at its deadline (a few cycles after it went out).
 */
static unsigned cycles_to_lost(unsigned i, unsigned max)
{
	for (unsigned k = 1; k <= max; k++) {
		run(1, true);
		if (lifecycle(i) == RMD_LC_LOST)
			return k;
	}
	fail_msg("motor %u not lost in %u cycles", i + 1, max);
	return 0;
}

/*
 * A per-frame fault on all of motor 2's frames that leaves its requests
 * unanswered (the reply is unreadable as its answer): LOST within
 * missed_replies_lost + 3 cycles, with the safe action for it alone; the
 * frames counted unexpected and reported at most once a second; READY
 * once the fault ends, ENABLED again after enable 0 then 1.
 */
static void lost_by_frame_fault(struct rmd_sim_fault f)
{
	unsigned n = R.io.cfg.safety.missed_replies_lost, from;
	struct rmd_loop_counters c0, c;

	three_at_speed();
	rmd_loop_get_counters(R.l, &c0);
	nev = 0;
	from = fault_now(&f, 0);
	if (cycles_to_lost(1, n + 3) < n)
		fail_msg("lost before %u missed replies", n);
	c = counters_since(&c0);
	assert_true(c.missed >= n);
	assert_true(c.unexpected >= n - 1);
	assert_motor2_alone_stopped(from);
	run(1000, true);
	assert_true(count_ev(RMD_EV_UNEXPECTED, -1) <= 2); /* at most once a second per bus */
	set_faults(0, NULL, 0);
	run(700, true);
	assert_int_equal(lifecycle(1), RMD_LC_READY);
	cl_reenable(1);
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
	assert_int_equal(sim_motor(1)->ctrl, RMD_SIM_SPEED);
	rig_down();
}

/* garbage: random data bytes, so no answer matches its request. */
static void test_fault_garbage(void **state)
{
	(void)state;
	lost_by_frame_fault((struct rmd_sim_fault){
		.kind = RMD_SIM_FAULT_GARBAGE, .motor_id = 2, .probability = 1.0 });
}

/* bad_dlc 0: an empty frame is no answer. */
static void test_fault_bad_dlc_empty(void **state)
{
	(void)state;
	lost_by_frame_fault((struct rmd_sim_fault){
		.kind = RMD_SIM_FAULT_BAD_DLC, .motor_id = 2, .probability = 1.0, .param = 0 });
}

/* wrong_id: motor 2 answers on motor 1's identifier; motor 2's requests go unanswered. */
static void test_fault_wrong_id(void **state)
{
	(void)state;
	lost_by_frame_fault((struct rmd_sim_fault){
		.kind = RMD_SIM_FAULT_WRONG_ID, .motor_id = 2, .probability = 1.0, .param = 1 });
}

/*
 * bad_dlc 1..7: the answer carries its command byte, so it matches its
 * request (the motor is there) but cannot be decoded: each is counted
 * (bad_replies) and the motor's values stay those of its last good reply.
 * It is not lost: a gap the matrix names (its state's rx time stops).
 */
static void test_fault_bad_dlc_short(void **state)
{
	struct rmd_sim_fault f = {
		.kind = RMD_SIM_FAULT_BAD_DLC, .motor_id = 2, .probability = 1.0, .param = 4
	};
	struct rmd_loop_counters c0, c;
	struct rmd_snapshot s0, s;

	(void)state;
	three_at_speed();
	rmd_loop_get_counters(R.l, &c0);
	fault_now(&f, 0);
	run(2, true);
	s0 = snap();
	run(100, true);
	c = counters_since(&c0);
	s = snap();
	assert_true(c.bad_replies >= 95);
	assert_int_equal(c.missed, 0);
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
	assert_true(s.m[1].pos_rad == s0.m[1].pos_rad); /* frozen */
	assert_true(s.m[0].pos_rad > s0.m[0].pos_rad + 0.05);
	assert_int_equal(s.m[1].rx_ns, s0.m[1].rx_ns);
	set_faults(0, NULL, 0);
	run(5, true);
	assert_true(snap().m[1].pos_rad > s.m[1].pos_rad + 0.05);
	rig_down();
}

/*
 * delay: an answer within the reply deadline (1 ms at 1 kHz) changes
 * nothing; one past it (10 ms) makes the first requests missed (counted),
 * then the late answers match newer requests of the same command: the
 * motor is not lost (a gap the matrix names: its values are the delay
 * old, and reply_latency_ns does not show it).
 */
static void test_fault_delay(void **state)
{
	struct rmd_sim_fault f = { .kind = RMD_SIM_FAULT_DELAY, .motor_id = 2, .probability = 1.0 };
	struct rmd_loop_counters c0, c;

	(void)state;
	three_at_speed();
	f.param = 1 * MS;
	rmd_loop_get_counters(R.l, &c0);
	fault_now(&f, 0);
	run(300, true);
	c = counters_since(&c0);
	assert_int_equal(c.missed, 0);
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
	f.param = 10 * MS;
	fault_now(&f, 0);
	rmd_loop_get_counters(R.l, &c0);
	run(300, true);
	c = counters_since(&c0);
	/*
	 * Beyond the deadline: the first misses open a reboot check
	 * (rmd/reboot.h), whose reads are as late as every answer, and the
	 * setpoints' answers match newer setpoints again after it: a
	 * transient of a few times the delay's cycles ...
	 */
	if (c.missed < 1 || c.missed > 80)
		fail_msg("%llu missed with a 10 ms delay", (unsigned long long)c.missed);
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
	/* ... then only the status reads, with no newer one to match (10 a second) */
	rmd_loop_get_counters(R.l, &c0);
	run(1000, true);
	c = counters_since(&c0);
	if (c.missed > 12)
		fail_msg("%llu missed in a second with a 10 ms delay",
			 (unsigned long long)c.missed);
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
	/* a late answer is no reboot */
	assert_int_equal(count_ev(RMD_EV_REBOOT, 1), 0);
	rig_down();
}

/*
 * flood: a foreign node's frames on an identifier no motor uses are counted
 * (unexpected) and reported at most once a second, and change nothing else;
 * one on identifier 0x001 every 100 us wins every arbitration, so nothing
 * of rmdd's leaves: every motor LOST (safe action, plan misses), READY once
 * the flood ends.
 */
static void test_fault_flood(void **state)
{
	struct rmd_sim_fault f = { .kind = RMD_SIM_FAULT_FLOOD,
				   .param = 200 * US,
				   .can_id = 0x7FF };
	struct rmd_loop_counters c0, c;
	struct rmd_loop_stats st;

	(void)state;
	three_at_speed();
	rmd_loop_get_counters(R.l, &c0);
	nev = 0;
	fault_now(&f, 0);
	run(1500, true);
	c = counters_since(&c0);
	assert_true(c.unexpected >= 1500); /* at least one a cycle: it yields to rmdd's frames */
	assert_int_equal(c.missed, 0);
	assert_true(count_ev(RMD_EV_UNEXPECTED, -1) <= 2);
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(lifecycle(i), RMD_LC_ENABLED);
	f.can_id = 0x001;
	f.param = 100 * US;
	fault_now(&f, 0);
	run(30, true);
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(lifecycle(i), RMD_LC_LOST);
	rmd_loop_get_stats(R.l, &st);
	assert_true(st.plan_misses > 0);
	assert_int_equal(count_ev(RMD_EV_SAFE_ACTION, -1), 3);
	set_faults(0, NULL, 0);
	run(700, true);
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(lifecycle(i), RMD_LC_READY);
	rig_down();
}

/*
 * Over-temperature, from the motor's own physics rather than an injected
 * flag: motor 1 heats past its over_temp_c (the sim's ambient raised, its
 * thermal time constant shortened); the 0x9A poll (10 Hz) reads error
 * 0x1000: FAULT with the safe action and the error in state and event,
 * within one poll period; it cools below over_temp_clear_c: READY.
 */
static void test_fault_over_temperature(void **state)
{
	struct rmd_sim_motor *m;
	struct rmd_snapshot s;
	unsigned k;

	(void)state;
	up_at_speed(NULL, 1, 1.0, 50);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	m = sim_motor(0);
	m->p.thermal_tau_s = 0.05;
	m->p.ambient_c = m->p.over_temp_c + 20.0;
	nev = 0;
	for (k = 0; k < 500 && !(m->errors & RMD_SIM_ERR_OVER_TEMP); k++)
		run(1, true);
	assert_true(m->errors & RMD_SIM_ERR_OVER_TEMP);
	run(110, true); /* the next 0x9A poll (10 Hz), and its answer */
	s = snap();
	assert_int_equal(s.m[0].lifecycle, RMD_LC_FAULT);
	assert_true(s.m[0].error_code & RMD_SIM_ERR_OVER_TEMP);
	assert_true(s.m[0].temp_c > m->p.over_temp_c);
	assert_int_equal(count_ev(RMD_EV_MOTOR_ERROR, 0), 1);
	assert_int_equal(count_ev(RMD_EV_SAFE_ACTION, 0), 0); /* output off (0x80) instead */
	assert_int_equal(m->ctrl, RMD_SIM_OFF);
	m->p.ambient_c = 25.0;
	run(1000, true);
	s = snap();
	assert_int_equal(s.m[0].lifecycle, RMD_LC_READY);
	assert_int_equal(s.m[0].error_code, 0);
	rig_down();
}

/* ---- issue 13: fine position feedback ------------------------------------------ */

/*
 * 500 Hz; motor 0 in position mode with 0x92 reads every cycle
 * (feedback.position multi_turn), motor 1 in position mode without.
 */
static void fine_tweak(struct rmd_config *cfg)
{
	cfg->loop.rate_hz = 500;
	for (unsigned i = 0; i < 2; i++) {
		cfg->motors[i].mode = RMD_MODE_POSITION;
		cfg->motors[i].limits.velocity_rad_s = 5.0;
	}
	cfg->motors[0].feedback.position = RMD_FEEDBACK_MULTI_TURN;
}

/* pos_rad in units of 0.01 deg, and how far it is from a whole one. */
static double centideg_off(double pos_rad, double *cd)
{
	*cd = pos_rad * 18000.0 / M_PI;
	return fabs(*cd - round(*cd));
}

/*
 * Issue 13 acceptance on the sim bus: a V3 position-mode motor tracking a
 * slow sine reports its position in 0.01 deg steps (0x92), each with the
 * receive time of the 0x92 answer it came from, at the planned read rate;
 * the motor without fine feedback reports whole degrees (V3 §2.13.3), and
 * the bus stays within its planned frames.
 */
static void test_fine_position_sine(void **state)
{
	const struct rmd_plan_motor *pm;
	const unsigned cycles = 2000; /* 4 s at 500 Hz: two periods of the sine */
	unsigned from, fine_steps = 0, whole_1 = 0, new_pos_t = 0;
	int64_t last_pos_t = 0, worst_age = 0;
	double worst_err = 0, err;
	struct rmd_snapshot s;

	(void)state;
	rig_up(3, fine_tweak);
	pm = &R.io.plan.motor[0];
	assert_int_equal(pm->fine_divisor, 1);
	assert_float_equal(pm->pos_hz, 500.0, 1e-9);
	assert_int_equal(R.io.plan.motor[1].fine_divisor, 0);
	assert_true(R.io.plan.bus[0].worst_ns <= period());
	bring_up();
	run(50, false);
	cmd_clear();
	from = trace_n;
	for (unsigned k = 0; k < cycles; k++) {
		double t = (double)k / 500.0, cd;
		struct rmd_sim_motor *m = sim_motor(0);

		for (unsigned i = 0; i < 2; i++) {
			struct rmd_setpoint *sp = cmd_motor(i, true, RMD_MODE_POSITION);

			sp->pos_rad = 0.5 * sin(2.0 * M_PI * 0.5 * t);
			sp->max_vel_rad_s = 5.0;
		}
		run(1, true);
		s = snap();
		if (k < 100 || s.m[0].lifecycle != RMD_LC_ENABLED)
			continue;
		/* 0.01 deg steps, and mostly not whole degrees while moving */
		if (centideg_off(s.m[0].pos_rad, &cd) > 1e-6)
			fail_msg("cycle %u: position %.9f rad is %.6f centidegrees: not 0.01 deg "
				 "steps",
				 k, s.m[0].pos_rad, cd);
		fine_steps += fabs(cd / 100.0 - round(cd / 100.0)) > 0.004;
		whole_1 += centideg_off(s.m[1].pos_rad, &cd) < 1e-6 &&
			   fabs(cd / 100.0 - round(cd / 100.0)) < 1e-6;
		/* the position's time is its 0x92 answer's; a new one each cycle */
		assert_true(s.m[0].pos_rx_ns > 0 && s.m[0].pos_rx_ns <= t_now);
		if (s.m[0].pos_rx_ns != last_pos_t)
			new_pos_t++;
		last_pos_t = s.m[0].pos_rx_ns;
		/* its age at the state's time (the cycle's tick) */
		if (s.t_ns - s.m[0].pos_rx_ns > worst_age)
			worst_age = s.t_ns - s.m[0].pos_rx_ns;
		/*
		 * What the motor said: its true angle, but for its motion since
		 * the answer (its age, and a period for the sim's own clock, which
		 * runs up to the last frame it carried) at the sine's top speed.
		 */
		err = fabs(s.m[0].pos_rad - m->pos_rad) -
		      0.5 * M_PI * (double)(t_now - s.m[0].pos_rx_ns + period()) / 1e9;
		if (err > worst_err)
			worst_err = err;
	}
	print_message("fine: %u of %u states off whole degrees, %u new position times, oldest "
		      "%.2f ms, error beyond motion %.5f deg\n",
		      fine_steps, cycles - 100, new_pos_t, (double)worst_age / 1e6,
		      worst_err * 180.0 / M_PI);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_true(fine_steps > (cycles - 100) * 9 / 10);
	/* the motor without fine feedback: whole degrees, as V3 control replies carry */
	assert_int_equal(whole_1, cycles - 100);
	/* a new 0x92 answer every cycle (pos_hz 500 at 500 Hz), none older than a cycle */
	assert_true(new_pos_t >= (cycles - 100) * 98 / 100);
	assert_true(worst_age > 0 && worst_age <= period());
	assert_true(worst_err <= 0);
	/* velocity and torque keep the control replies' time */
	assert_true(s.m[0].rx_ns > 0 && s.m[0].rx_ns != s.m[0].pos_rx_ns);
	assert_int_equal(s.m[1].rx_ns, s.m[1].pos_rx_ns);
	/* the wire: one 0x92 a cycle to motor 0, none to motor 1, every setpoint still sent */
	assert_true(sent_to(0, 0x92, from) >= cycles - 1 && sent_to(0, 0x92, from) <= cycles);
	assert_int_equal(sent_to(1, 0x92, from), 0);
	assert_true(sent_to(0, 0xA4, from) + sent_to(0, 0x9A, from) >= cycles - 100);
	/* at rest, exactly what the motor measures, to half the LSB */
	cmd_motor(0, true, RMD_MODE_POSITION)->pos_rad = 0.123456;
	run(1000, true);
	s = snap();
	assert_float_equal(s.m[0].pos_rad * 180.0 / M_PI, sim_motor(0)->pos_rad * 180.0 / M_PI,
			   0.005 + 1e-9);
	assert_float_equal(s.m[0].pos_rad, 0.123456, 0.0002);
	assert_int_equal(snap().m[0].missed_replies, 0);
	rig_down();
}

/*
 * V3 §2.11: at exactly 0.00 deg the 0x92 answer repeats its request byte
 * for byte.  Right behind the motor's answered setpoint it is the answer,
 * not a tripped motor's echo: the position stays fresh (a new 0x92 time
 * each cycle) and no echo is counted.
 */
static void test_fine_position_at_zero(void **state)
{
	struct rmd_loop_counters c0, c1;
	struct rmd_snapshot s;
	int64_t last_pos_t;

	(void)state;
	rig_up(3, fine_tweak);
	bring_up();
	run(50, false);
	cmd_clear();
	cmd_motor(0, true, RMD_MODE_POSITION)->pos_rad = 0.0;
	cmd_motor(0, true, RMD_MODE_POSITION)->max_vel_rad_s = 5.0;
	run(1000, true);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	/* the motor is at 0.00 deg to the 0x92 LSB: its answer repeats the request */
	assert_true(fabs(sim_motor(0)->pos_rad * 18000.0 / M_PI) < 0.5);
	rmd_loop_get_counters(R.l, &c0);
	last_pos_t = snap().m[0].pos_rx_ns;
	for (unsigned k = 0; k < 100; k++) {
		run(1, true);
		s = snap();
		if (s.m[0].pos_rx_ns == last_pos_t)
			fail_msg("cycle %u: position time not renewed: the 0x92 answer at 0.00 deg "
				 "was taken for an echo",
				 k);
		last_pos_t = s.m[0].pos_rx_ns;
		assert_float_equal(s.m[0].pos_rad, 0.0, 1e-12);
	}
	rmd_loop_get_counters(R.l, &c1);
	assert_int_equal(c1.echoes, c0.echoes);
	rig_down();
}

/* Issue 13's 25 Hz bus: 3 V3 position motors, the default status_poll_hz. */
static void r25_tweak(struct rmd_config *cfg)
{
	cfg->loop.rate_hz = 25;
	cfg->safety.comm_loss_ms = 400;
	for (unsigned i = 0; i < cfg->n_motors; i++) {
		cfg->motors[i].mode = RMD_MODE_POSITION;
		cfg->motors[i].rate_divisor = 1;
		cfg->motors[i].status_poll_hz = RMD_CONFIG_DEFAULT_STATUS_POLL_HZ;
	}
}

/*
 * Issue 13: 30 status polls a second on a 25 Hz loop go two a cycle
 * (rmd/plan.h), and the loop sends and matches them all: over 2 simulated
 * seconds every motor gets >= 20 0x9A polls on the wire, every frame of
 * the plan goes out, and no reply is missed, ENABLED (setpoint and poll in
 * one cycle) or READY.
 */
static void test_polls_two_a_cycle(void **state)
{
	const unsigned cycles = 50; /* 2 s at 25 Hz */
	struct rmd_loop_counters c0, c1;
	uint64_t want = 0, tx0, n = 0; /* n: the loop's cycle (0 after bring-up) */
	unsigned from;
	struct rmd_snapshot s;

	(void)state;
	rig_up(3, r25_tweak);
	assert_int_equal(R.io.plan.bus[0].poll_burst, 2);
	bring_up();
	for (int enabled = 0; enabled <= 1; enabled++) {
		cmd_clear();
		for (unsigned i = 0; enabled && i < 3; i++)
			cmd_motor(i, true, RMD_MODE_POSITION)->pos_rad = 0.1 * i;
		run(3, enabled); /* into ENABLED */
		n += 3;
		want = 0;
		for (uint64_t k = 0; k < cycles; k++) {
			struct rmd_plan_slot slots[RMD_PLAN_MAX_SLOTS];

			want += rmd_plan_cycle(&R.io.plan, 0, n + k, slots);
		}
		n += cycles;
		rmd_loop_get_counters(R.l, &c0);
		tx0 = R.io.buses[0].stats.tx_frames;
		from = trace_n;
		run(cycles, enabled);
		rmd_loop_get_counters(R.l, &c1);
		s = snap();
		for (unsigned i = 0; i < 3; i++) {
			print_message("%s motor %u: %u 0x9A polls in %u cycles\n",
				      enabled ? "enabled" : "ready", i, sent_to(i, 0x9A, from),
				      cycles);
			assert_true(sent_to(i, 0x9A, from) >= 20);
			assert_int_equal(s.m[i].lifecycle, enabled ? RMD_LC_ENABLED : RMD_LC_READY);
			assert_int_equal(s.m[i].missed_replies, 0);
			/* the setpoints still go every cycle */
			if (enabled)
				assert_int_equal(sent_to(i, 0xA4, from), cycles);
		}
		assert_int_equal(R.io.buses[0].stats.tx_frames - tx0, want);
		assert_int_equal(c1.missed - c0.missed, 0);
		assert_int_equal(c1.frames_not_sent - c0.frames_not_sent, 0);
		assert_int_equal(c1.unexpected - c0.unexpected, 0);
		assert_int_equal(c1.replies - c0.replies, want);
	}
	rig_down();
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_bringup_ready_not_moved),
		cmocka_unit_test(test_bringup_missing),
		cmocka_unit_test(test_bringup_unexpected),
		cmocka_unit_test(test_enable_position_moves),
		cmocka_unit_test(test_lost_and_recovery),
		cmocka_unit_test(test_lost_all),
		cmocka_unit_test(test_fault_flags),
		cmocka_unit_test(test_comm_loss_trip),
		cmocka_unit_test(test_watchdog),
		cmocka_unit_test(test_shutdown_damp_feeds_the_others),
		cmocka_unit_test(test_safe_frames_take_polls_place),
		cmocka_unit_test(test_events_cause_before_effect),
		cmocka_unit_test(test_watchdog_per_motor),
		cmocka_unit_test(test_brake_release_holds_setpoints),
		cmocka_unit_test(test_commands_queued_in_a_stall),
		cmocka_unit_test(test_nan_never_on_wire),
		cmocka_unit_test(test_stop_motors),
		cmocka_unit_test(test_health_after_stop_counts_the_stops),
		cmocka_unit_test(test_overrun),
		cmocka_unit_test(test_overrun_burst_is_one_skip),
		cmocka_unit_test(test_v2_batch),
		cmocka_unit_test(test_v2_batch_only_enabled),
		cmocka_unit_test(test_v2_batch_lost_motor),
		cmocka_unit_test(test_v2_batch_stray),
		cmocka_unit_test(test_v2_batch_stray_later),
		cmocka_unit_test(test_v2_batch_stray_refused),
		cmocka_unit_test(test_bus_off),
		cmocka_unit_test(test_stop_motors_bus_off),
		cmocka_unit_test(test_health),
		cmocka_unit_test(test_thread),
		cmocka_unit_test(test_state_when_replies_are_in),
		cmocka_unit_test(test_health_getter),
		cmocka_unit_test(test_enable_edge_latched),
		cmocka_unit_test(test_shutdown_actions),
		cmocka_unit_test(test_cl_reproducer),
		cmocka_unit_test(test_cl_refused),
		cmocka_unit_test(test_cl_late_motor),
		cmocka_unit_test(test_cl_off_by_config),
		cmocka_unit_test(test_v2_start_angle),
		cmocka_unit_test(test_cl_zeros_answer),
		cmocka_unit_test(test_wake_hist_and_reply_latency),
		cmocka_unit_test(test_cl_round_after_trip),
		cmocka_unit_test(test_v2_protection_off_by_config),
		cmocka_unit_test(test_fault_garbage),
		cmocka_unit_test(test_fault_bad_dlc_empty),
		cmocka_unit_test(test_fault_wrong_id),
		cmocka_unit_test(test_fault_bad_dlc_short),
		cmocka_unit_test(test_fault_delay),
		cmocka_unit_test(test_fault_flood),
		cmocka_unit_test(test_fault_over_temperature),
		cmocka_unit_test(test_fine_position_sine),
		cmocka_unit_test(test_fine_position_at_zero),
		cmocka_unit_test(test_polls_two_a_cycle),
		cmocka_unit_test(test_pos_cycle_in_band),
		cmocka_unit_test(test_v2_silent_turn_recounted),
		cmocka_unit_test(test_v2_without_angle_command),
		cmocka_unit_test(test_v2_count_at_speed),
		cmocka_unit_test(test_pos_settle_one_bad_reading),
		cmocka_unit_test(test_pos_ambiguous_refused),
		cmocka_unit_test(test_pos_homed),
		cmocka_unit_test(test_home_outside_travel),
		cmocka_unit_test(test_pos_uncertain_mit_kp),
	};

	cmocka_set_test_filter(getenv("RMD_TEST_FILTER"));
	return cmocka_run_group_tests_name("loop", tests, NULL, NULL);
}

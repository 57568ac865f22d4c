// SPDX-License-Identifier: MIT
/*
 * Lifecycle truth (issue 20 point 1): the state state_t shows is a promise
 * about the motor's output and brake (docs/design.md "The life of a
 * motor"), checked after every cycle against the simulated motor itself
 * (its mode, its brake, its errors: rmd_sim_wire_motor()) and the frames
 * the sim bus carried, for every transition (bring-up of a motor a
 * previous owner left running; READY, ENABLED, then enable = 0, error
 * flags, loss, the host watchdog, shutdown; and back), for V2, V3, MIT and V4
 * motors, with every safe action and shutdown action: a table of rows.
 *
 * What each state promises, as the table says:
 *   READY    output off (the sim's mode is off), brake locked, and
 *            0x80 and 0x78 on the wire since it last left READY;
 *   ENABLED  brake released, the commanded mode (once its frames arrived);
 *   SAFE     the action's: stop off; hold holding (0x81); damp damping
 *            (MIT frames, else speed 0); brake off and locked; the brake
 *            open but for brake;
 *   FAULT    no output (the fault, or the mode off), no frame that moves;
 *            once its frames arrived the mode is off (nothing resumes when
 *            the flags clear), the brake locked unless the config asks
 *            for a free shaft (stop, and a shutdown without the brake);
 *   PROBE, LOST, STOPPING: no promise; STOPPING is short.
 * A promise that rests on frames in flight is checked GRACE cycles after
 * the state was entered; READY rests on echoes, so from its first cycle.
 * One cmocka test per row, so that each row's verdict shows on its own.
 * On the lifecycle before issue 20 (9f2b9b8) 62 of these 76 tests fail.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "rmd/bus_sim.h"
#include "rmd/config.h"
#include "rmd/config_yaml.h"
#include "rmd/bringup.h"
#include "rmd/loop.h"
#include "rmd/plan.h"
#include "rmd/sim.h"
#include "rmd/sim_wire.h"
#include "rmd/spsc.h"
#include "rmd/state.h"

#include "harness/clock.h"
#include "harness/loop_io.h"
#include "harness/rig.h"
#include "harness/suite.h"

#define MS INT64_C(1000000)
#define GRACE 10	/* cycles for frames in flight to arrive and act */
#define STOPPING_MAX 20 /* cycles a motor may take to be READY from STOPPING */

enum transition {
	T_FOUND,    /* bring-up finds it running for a previous owner, brake open */
	T_DISABLE,  /* enable = 0 */
	T_FAULT,    /* error flags for 300 ms, enable = 1 streaming all along */
	T_LOST,	    /* the motor hears nothing for 300 ms (cable cut) */
	T_WATCHDOG, /* the controller goes quiet */
	T_SHUTDOWN, /* rmd_loop_stop_motors() */
};

static const char *const transition_name[] = { "found running", "disable",  "fault",
					       "lost",		"watchdog", "shutdown" };
static const char *const proto_name[] = { [RMD_PROTO_V2] = "V2",
					  [RMD_PROTO_V3] = "V3",
					  [RMD_PROTO_MIT] = "MIT",
					  [RMD_PROTO_V4] = "V4" };
static const char *const action_name[] = { "stop", "hold", "damp", "brake" };

struct row {
	enum rmd_proto proto;
	enum rmd_safe_action action;	   /* safety.safe_action */
	enum rmd_shutdown_action shutdown; /* T_SHUTDOWN: safety.shutdown_action */
	enum transition t;
};

/* ---- the rig: one motor on one sim bus, the frames it carried ---------------- */

static struct rig R; /* the loop, its configuration and bus, the controller's command */

/* What the wire and the states showed so far, against what the state in force promises. */
static struct {
	const struct row *row;
	/* the promise in force: the SAFE action (a shutdown's stop and hold are SAFE too) */
	enum rmd_safe_action in_force;
	unsigned lc, in_state; /* lifecycle after the last cycle, cycles in it */
	unsigned cycles;
	uint64_t moving_in_fault, moving_in_ready; /* frames that move, sent in those states */
	unsigned stopping_longest;
	unsigned off_sent, brake_sent; /* 0x80, 0x78 on the wire since it last left READY */
	bool seen[RMD_LC_COUNT];
	unsigned tx_from; /* frames of the wire not yet judged */
} T;

static struct rmd_sim_motor *sim(void)
{
	return rmd_sim_wire_motor(rmd_bus_sim_get(&R.io.buses[0]), R.io.cfg.motors[0].id);
}

static unsigned lifecycle(void)
{
	struct rmd_snapshot s;

	rmd_loop_get_snapshot(R.l, &s);
	return s.m[0].lifecycle;
}

/* A frame that makes a motor move: control commands, 0x77, 0x88, MIT, 0x280. */
static bool moves(const struct rmd_frame *f)
{
	uint8_t c = f->data[0];

	if (f->can_id >= 0x400 || f->can_id == 0x280)
		return true;
	return (c >= 0xA1 && c <= 0xA8) || c == 0x77 || c == 0x81 || c == 0x88;
}

#define TRUTH(cond, ...)                                                                          \
	do {                                                                                      \
		if (!(cond))                                                                      \
			fail_msg("%s %s (shutdown %d) %s, cycle %u, state %u for %u cycles: %s",  \
				 proto_name[T.row->proto], action_name[T.row->action],            \
				 (int)T.row->shutdown, transition_name[T.row->t], T.cycles, T.lc, \
				 T.in_state, #cond);                                              \
	} while (0)

/* What the state shown promises, against the simulated motor.  After each cycle. */
static void check_truth(void)
{
	const struct rmd_sim_motor *m = sim();
	bool mit = T.row->proto == RMD_PROTO_MIT;
	unsigned lc = lifecycle(), prev = T.lc;

	T.cycles++;
	if (lc != T.lc) {
		T.lc = lc;
		T.in_state = 0;
	}
	T.in_state++;
	if (lc < RMD_LC_COUNT)
		T.seen[lc] = true;
	/*
	 * The frames on the wire since the last check: decided in this cycle
	 * or, queued behind others, in the one before: judged when both ended
	 * in the same state.
	 */
	if (prev == RMD_LC_READY && lc != RMD_LC_READY)
		T.off_sent = T.brake_sent = 0;
	for (; T.tx_from < rig_host_n; T.tx_from++) {
		T.off_sent += rig_host[T.tx_from].data[0] == 0x80 &&
			      rig_host[T.tx_from].can_id < 0x400;
		T.brake_sent += rig_host[T.tx_from].data[0] == 0x78 &&
				rig_host[T.tx_from].can_id < 0x400;
		if (!moves(&rig_host[T.tx_from]) || lc != prev)
			continue;
		T.moving_in_fault += lc == RMD_LC_FAULT;
		T.moving_in_ready += lc == RMD_LC_READY;
	}
	if (lc == RMD_LC_READY) {
		/* V3 §2.15, §2.27: READY is output off and brake locked, on the wire first */
		TRUTH(T.off_sent && T.brake_sent);
		TRUTH(m->ctrl == RMD_SIM_OFF);
		TRUTH(m->brake_locked);
		TRUTH(T.moving_in_ready == 0);
	} else if (lc == RMD_LC_ENABLED) {
		if (T.in_state < GRACE)
			return;
		TRUTH(!m->brake_locked);
		TRUTH(m->ctrl == (mit ? RMD_SIM_MIT : RMD_SIM_SPEED));
	} else if (lc == RMD_LC_SAFE) {
		if (T.in_state < GRACE)
			return;
		/* V3 §2.16 / V2 §3.35: 0x81 holds; stop and brake: output off */
		TRUTH(m->ctrl == (T.in_force == RMD_SAFE_HOLD ? RMD_SIM_HOLD :
				  T.in_force != RMD_SAFE_DAMP ? RMD_SIM_OFF :
				  mit			      ? RMD_SIM_MIT :
								RMD_SIM_SPEED));
		if (T.in_force == RMD_SAFE_DAMP)
			TRUTH(mit ? m->mit.kp == 0.0 && m->mit.kd > 0.0 : m->sp_speed_rad_s == 0.0);
		/* the brake: locked by the brake action only; ENABLED had opened it */
		TRUTH(m->brake_locked == (T.in_force == RMD_SAFE_BRAKE));
	} else if (lc == RMD_LC_FAULT) {
		TRUTH(m->errors || m->ctrl == RMD_SIM_OFF);
		TRUTH(T.moving_in_fault == 0);
		if (T.in_state < GRACE)
			return;
		TRUTH(m->ctrl == RMD_SIM_OFF);
		if (T.row->action != RMD_SAFE_STOP || T.row->shutdown == RMD_SHUTDOWN_BRAKE ||
		    T.row->shutdown == RMD_SHUTDOWN_DAMP)
			TRUTH(m->brake_locked);
	} else if (lc != RMD_LC_PROBE && lc != RMD_LC_LOST) {
		/* on the way to READY */
		if (T.in_state > T.stopping_longest)
			T.stopping_longest = T.in_state;
		TRUTH(T.in_state <= STOPPING_MAX);
	}
}

static void tweak_row(const struct row *row)
{
	struct rmd_config_motor *mc = &R.io.cfg.motors[0];
	struct rmd_sim_motor_params *p = &R.io.sim.motors[0];

	R.io.cfg.safety.safe_action = row->action;
	R.io.cfg.safety.shutdown_action = row->shutdown;
	R.io.cfg.safety.shutdown_damp_ms = 50;
	mc->proto = row->proto;
	mc->mode = row->proto == RMD_PROTO_MIT ? RMD_MODE_MIT : RMD_MODE_SPEED;
	if (row->proto == RMD_PROTO_V2)
		mc->comm_loss_ms = 0; /* V2: no 0xB3, off by config */
	p->id = mc->id;
	p->proto = mc->proto;
	p->mit = mc->mit;
}

static void rig_up(const struct row *row)
{
	rig_reset(&R);
	memset(&T, 0, sizeof(T));
	T.row = row;
	T.in_force = row->action;
	T.lc = RMD_LC_PROBE;
	assert_int_equal(rmd_config_sim_default(&R.io.cfg, &R.io.sim, 1), 0);
	R.io.cfg.safety.lost_motor_action = RMD_LOST_MOTOR;
	tweak_row(row);
	R.each = check_truth; /* after every cycle */
	rig_start(&R, rig_wire_tap);
}

/* Run until the state is lc (at most max cycles, each checked). */
static void run_until(unsigned lc, unsigned max, bool with_cmd)
{
	for (unsigned k = 0; k < max && lifecycle() != lc; k++)
		rig_run(&R, 1, with_cmd);
	if (lifecycle() != lc)
		fail_msg("%s %s %s: state %u, not %u, after %u cycles", proto_name[T.row->proto],
			 action_name[T.row->action], transition_name[T.row->t], lifecycle(), lc,
			 max);
}

/* The controller's setpoint for the motor: enable, 1 rad/s (MIT: kd 1 towards it). */
static void command(bool enable)
{
	struct rmd_setpoint *sp = &R.cmd.m[0];

	R.cmd.present = 1;
	memset(sp, 0, sizeof(*sp));
	sp->enable = enable;
	if (T.row->proto == RMD_PROTO_MIT) {
		sp->mode = RMD_MODE_MIT;
		sp->vel_rad_s = 1.0;
		sp->kd = 1.0;
	} else {
		sp->mode = RMD_MODE_SPEED;
		sp->vel_rad_s = 1.0;
	}
}

/* enable = 0, READY; enable = 1, ENABLED and running. */
static void reenable(void)
{
	command(false);
	R.cmd.disables[0]++;
	run_until(RMD_LC_READY, 200, true);
	command(true);
	run_until(RMD_LC_ENABLED, 200, true);
	rig_run(&R, 100, true);
}

static void fault_window(enum rmd_sim_fault_kind kind, int64_t param, int64_t for_ns)
{
	struct rmd_sim_fault f = { .kind = kind, .motor_id = R.io.cfg.motors[0].id };
	int64_t now = rmd_bus_sim_time_ns(&R.io.buses[0], t_now);

	f.param = param;
	f.start_ns = now;
	f.end_ns = now + for_ns;
	assert_int_equal(rmd_sim_wire_set_faults(rmd_bus_sim_get(&R.io.buses[0]), &f, 1), 0);
}

static void walk(const struct row *row)
{
	struct rmd_sim_motor *m;

	rig_up(row);
	if (row->t == T_FOUND) {
		/* a previous owner left it running, brake open */
		m = sim();
		m->ctrl = RMD_SIM_SPEED;
		m->sp_speed_rad_s = 2.0;
		m->brake_locked = false;
	} else {
		/* a motor at rest: how bring-up gets it to READY is the T_FOUND rows' to judge */
		T.off_sent = T.brake_sent = 1;
	}
	if (rmd_loop_bringup(R.l, &R.report))
		fail_msg("bring-up failed");
	t_now = (t_now / MS + 1) * MS;
	check_truth();
	run_until(RMD_LC_READY, STOPPING_MAX, false);
	rig_run(&R, 50, false);
	command(true);
	run_until(RMD_LC_ENABLED, 200, true);
	rig_run(&R, 200, true);

	switch (row->t) {
	case T_FOUND:
	case T_DISABLE:
		break; /* reenable() below does it */
	case T_FAULT:
		/* V3 §2.12 table 1: over-temperature, a level-2 error: the output stops while it lasts */
		fault_window(RMD_SIM_FAULT_ERROR_FLAG, RMD_SIM_ERR_OVER_TEMP, 300 * MS);
		run_until(RMD_LC_FAULT, 200, true);
		rig_run(&R, 500, true); /* the flags clear; enable = 1 streams on */
		assert_true(T.seen[RMD_LC_FAULT]);
		run_until(RMD_LC_READY, 200, true);
		rig_run(&R, 50, true);
		break;
	case T_LOST:
		fault_window(RMD_SIM_FAULT_DISAPPEAR, 0, 300 * MS);
		run_until(RMD_LC_LOST, 200, true);
		run_until(RMD_LC_READY, 1500, true);
		rig_run(&R, 50, true);
		break;
	case T_WATCHDOG:
		run_until(RMD_LC_SAFE, 300, false);
		rig_run(&R, 200, false);
		break;
	case T_SHUTDOWN:
		if (row->shutdown == RMD_SHUTDOWN_STOP)
			T.in_force = RMD_SAFE_STOP;
		else if (row->shutdown == RMD_SHUTDOWN_HOLD)
			T.in_force = RMD_SAFE_HOLD;
		rmd_loop_stop_motors(R.l, t_now);
		/* the shutdown's own frames: test_loop_stop's test_shutdown_actions checks them */
		for (; T.tx_from < rig_host_n; T.tx_from++) {
			T.off_sent += rig_host[T.tx_from].data[0] == 0x80;
			T.brake_sent += rig_host[T.tx_from].data[0] == 0x78;
		}
		T.in_state = GRACE; /* its frames are out: the promise holds at once */
		check_truth();
		rig_run(&R, 50, false);
		assert_int_equal(lifecycle(), row->shutdown == RMD_SHUTDOWN_STOP ||
							      row->shutdown == RMD_SHUTDOWN_HOLD ?
						      RMD_LC_SAFE :
						      RMD_LC_READY);
		rig_stop(&R);
		return;
	}
	reenable();
	assert_true(T.seen[RMD_LC_READY] && T.seen[RMD_LC_ENABLED]);
	if (getenv("RMD_TEST_VERBOSE"))
		print_message("%s %s %s: %u cycles, STOPPING at most %u\n", proto_name[row->proto],
			      action_name[row->action], transition_name[row->t], T.cycles,
			      T.stopping_longest);
	rig_stop(&R);
}

/*
 * A motor whose answers cannot be read (bad_dlc 4: matched, so it is
 * there, but no echo repeats its request) never shows READY after
 * enable = 0: it stays STOPPING while 0x80 and 0x78 go out again
 * (counted), and after 16 sends it is LOST; readable again, it comes back
 * through STOPPING to a READY it proved.
 */
static void test_unechoed_is_lost(void **state)
{
	static const struct row row = { .proto = RMD_PROTO_V3,
					.action = RMD_SAFE_DAMP,
					.t = T_DISABLE };
	struct rmd_sim_fault f = {
		.kind = RMD_SIM_FAULT_BAD_DLC, .motor_id = 1, .probability = 1.0, .param = 4
	};
	struct rmd_bus *bus;
	struct rmd_loop_counters c;

	(void)state;
	rig_up(&row);
	T.off_sent = T.brake_sent = 1;
	if (rmd_loop_bringup(R.l, &R.report))
		fail_msg("bring-up failed");
	run_until(RMD_LC_READY, STOPPING_MAX, false);
	command(true);
	run_until(RMD_LC_ENABLED, 200, true);
	rig_run(&R, 100, true);
	bus = &R.io.buses[0];
	f.start_ns = rmd_bus_sim_time_ns(bus, t_now);
	assert_int_equal(rmd_sim_wire_set_faults(rmd_bus_sim_get(bus), &f, 1), 0);
	command(false);
	R.cmd.disables[0]++;
	memset(T.seen, 0, sizeof(T.seen));
	run_until(RMD_LC_LOST, STOPPING_MAX, true);
	assert_false(T.seen[RMD_LC_READY]); /* the sim did stop: rmdd could not know it */
	rmd_loop_get_counters(R.l, &c);
	assert_true(c.owed_resends >= 14);
	assert_int_equal(rmd_sim_wire_set_faults(rmd_bus_sim_get(bus), &f, 0), 0);
	run_until(RMD_LC_READY, 1500, true);
	rig_run(&R, 50, true);
	rig_stop(&R);
}

/* ---- the table ------------------------------------------------------------- */

#define N_PROTOS 4 /* V2, V3, MIT, V4 */
#define N_ROWS (N_PROTOS * 4 * 5 + N_PROTOS * 4 + N_PROTOS)

static struct row rows[N_ROWS];
static char names[N_ROWS][64];

static void test_row(void **state)
{
	walk(*state);
}

int main(void)
{
	static const enum rmd_proto protos[N_PROTOS] = { RMD_PROTO_V2, RMD_PROTO_V3, RMD_PROTO_MIT,
							 RMD_PROTO_V4 };
	static const enum rmd_shutdown_action shutdowns[] = { RMD_SHUTDOWN_STOP, RMD_SHUTDOWN_HOLD,
							      RMD_SHUTDOWN_DAMP,
							      RMD_SHUTDOWN_BRAKE };
	static const char *const shutdown_name[] = { "stop", "hold", "damp", "brake" };
	struct CMUnitTest tests[N_ROWS + 1];
	unsigned n = 0;

	/* {dialect, safe action, transition}, then {dialect, shutdown action} */
	for (unsigned p = 0; p < N_PROTOS; p++) {
		for (unsigned a = RMD_SAFE_STOP; a <= RMD_SAFE_BRAKE; a++)
			for (unsigned t = T_FOUND; t <= T_WATCHDOG; t++) {
				rows[n] = (struct row){ .proto = protos[p],
							.action = (enum rmd_safe_action)a,
							.t = (enum transition)t };
				snprintf(names[n], sizeof(names[n]), "%s %s %s",
					 proto_name[protos[p]], action_name[a], transition_name[t]);
				n++;
			}
		/* stop, but brakes by config (shutdown brake): a fault locks the brake */
		rows[n] = (struct row){ .proto = protos[p],
					.action = RMD_SAFE_STOP,
					.shutdown = RMD_SHUTDOWN_BRAKE,
					.t = T_FAULT };
		snprintf(names[n], sizeof(names[n]), "%s stop fault, shutdown brake",
			 proto_name[protos[p]]);
		n++;
		for (unsigned a = 0; a < 4; a++) {
			rows[n] = (struct row){ .proto = protos[p],
						.action = RMD_SAFE_DAMP,
						.shutdown = shutdowns[a],
						.t = T_SHUTDOWN };
			snprintf(names[n], sizeof(names[n]), "%s shutdown %s",
				 proto_name[protos[p]], shutdown_name[a]);
			n++;
		}
	}
	for (unsigned k = 0; k < n; k++)
		tests[k] = (struct CMUnitTest){ .name = names[k],
						.test_func = test_row,
						.initial_state = &rows[k] };
	tests[n++] = (struct CMUnitTest)cmocka_unit_test(test_unechoed_is_lost);
	return suite_run("lifecycle truth", tests, n, NULL, NULL);
}

// SPDX-License-Identifier: MIT
/*
 * The rt loop, stopping (harness/loop_rig.h): rmd_loop_stop_motors() and
 * each safety.shutdown_action on the wire, the others fed through a long
 * damp phase, the health after it, and a shutdown while a bus is off.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include <cmocka.h>

#include "harness/loop_rig.h"
#include "harness/suite.h"

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

SUITE_MAIN("loop_stop", NULL, NULL,
	   {
		   cmocka_unit_test(test_shutdown_damp_feeds_the_others),
		   cmocka_unit_test(test_stop_motors),
		   cmocka_unit_test(test_health_after_stop_counts_the_stops),
		   cmocka_unit_test(test_stop_motors_bus_off),
		   cmocka_unit_test(test_shutdown_actions),
	   })

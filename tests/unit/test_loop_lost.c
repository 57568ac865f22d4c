// SPDX-License-Identifier: MIT
/*
 * The rt loop, loss and recovery (harness/loop_rig.h): missed replies ->
 * LOST -> the safe action, the re-probe -> READY and not ENABLED;
 * lost_motor_action all; a bus-off.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include <cmocka.h>

#include "harness/loop_rig.h"
#include "harness/suite.h"

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
	for (unsigned k = 0; k < R.nev; k++) {
		if (R.ev[k].kind == RMD_EV_SEND_FAILED)
			fail_msg("a send failure (event %u) before the bus-off that caused it", k);
		if (R.ev[k].kind == RMD_EV_BUS_STATE)
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

SUITE_MAIN("loop_lost", NULL, NULL,
	   {
		   cmocka_unit_test(test_lost_and_recovery),
		   cmocka_unit_test(test_lost_all),
		   cmocka_unit_test(test_bus_off),
	   })
